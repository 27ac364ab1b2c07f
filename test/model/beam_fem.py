"""An independent numerical beam solver for the tests: Euler-Bernoulli finite elements.

Cubic Hermite elements (deflection w and slope w' per node) are exact at the nodes for
point loads, so the closed forms of :mod:`steer_monitor.model.beams` must match to round-off.
Supports and contacts are Lagrange-multiplier constraints; the two unilateral contacts of the
load-sharing model (the ram's slope stop at bushing A, the slipper gap at the guide beam)
are solved as a convex quadratic programme by enumerating active sets and checking KKT
conditions. Nothing here uses the closed forms or the event-driven solver.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

__all__ = ['Beam', 'buckling_force', 'contact_solution']


def _element_stiffness(ei: float, h: float) -> np.ndarray:
    return ei / h**3 * np.array([
        [12.0, 6 * h, -12.0, 6 * h],
        [6 * h, 4 * h * h, -6 * h, 2 * h * h],
        [-12.0, -6 * h, 12.0, -6 * h],
        [6 * h, 2 * h * h, -6 * h, 4 * h * h],
    ])


def _element_geometric(h: float) -> np.ndarray:
    return 1.0 / (30.0 * h) * np.array([
        [36.0, 3 * h, -36.0, 3 * h],
        [3 * h, 4 * h * h, -3 * h, -h * h],
        [-36.0, -3 * h, 36.0, -3 * h],
        [3 * h, -h * h, -3 * h, 4 * h * h],
    ])


@dataclass
class Beam:
    """A beam on [0, span] meshed with a node at ``load_at``; 2 dofs per node (w, w')."""

    span: float
    ei: float
    load_at: float
    elements: int = 24

    def __post_init__(self) -> None:
        n_left = max(1, round(self.elements * self.load_at / self.span))
        n_right = max(1, self.elements - n_left)
        self.x = np.concatenate([np.linspace(0, self.load_at, n_left + 1),
                                 np.linspace(self.load_at, self.span, n_right + 1)[1:]])
        self.load_node = n_left
        self.ndof = 2 * len(self.x)

    def stiffness(self) -> np.ndarray:
        k = np.zeros((self.ndof, self.ndof))
        for e in range(len(self.x) - 1):
            idx = slice(2 * e, 2 * e + 4)
            k[idx, idx] += _element_stiffness(self.ei, self.x[e + 1] - self.x[e])
        return k

    def geometric(self) -> np.ndarray:
        kg = np.zeros((self.ndof, self.ndof))
        for e in range(len(self.x) - 1):
            idx = slice(2 * e, 2 * e + 4)
            kg[idx, idx] += _element_geometric(self.x[e + 1] - self.x[e])
        return kg

    def w_dof(self, node: int) -> int:
        return 2 * node

    def slope_dof(self, node: int) -> int:
        return 2 * node + 1

    @property
    def last(self) -> int:
        return len(self.x) - 1

    def support_rows(self, kind_a: str, kind_e: str) -> list[int]:
        """Constrained dofs for supports at x = 0 ('A') and x = span ('E')."""
        rows = [self.w_dof(0), self.w_dof(self.last)]
        if kind_a == 'clamped':
            rows.append(self.slope_dof(0))
        if kind_e == 'clamped':
            rows.append(self.slope_dof(self.last))
        return rows

    def solve(self, load: float, kind_a: str, kind_e: str,
              axial: float = 0.0) -> tuple[np.ndarray, dict[int, float]]:
        """Displacements under a lateral point load at ``load_at`` (and an axial compression),
        with the reactions at the constrained dofs (opposing the load)."""
        k = self.stiffness() - axial * self.geometric()
        f = np.zeros(self.ndof)
        f[self.w_dof(self.load_node)] = load
        rows = self.support_rows(kind_a, kind_e)
        c = np.zeros((len(rows), self.ndof))
        for i, r in enumerate(rows):
            c[i, r] = 1.0
        kkt = np.block([[k, c.T], [c, np.zeros((len(rows), len(rows)))]])
        sol = np.linalg.solve(kkt, np.concatenate([f, np.zeros(len(rows))]))
        u, lam = sol[:self.ndof], sol[self.ndof:]
        # K u + C^T lam = f: the support acts on the beam with -lam, so lam is the reaction
        # that opposes a positive load (positive for a force, clamp moment for a slope dof).
        return u, {r: float(lam[i]) for i, r in enumerate(rows)}


def buckling_force(span: float, ei: float, elements: int = 40) -> float:
    """Lowest buckling force of a pinned-pinned column from the FE eigenproblem [N]."""
    beam = Beam(span, ei, span / 2, elements)
    k, kg = beam.stiffness(), beam.geometric()
    free = [i for i in range(beam.ndof) if i not in beam.support_rows('pinned', 'pinned')]
    kf, kgf = k[np.ix_(free, free)], kg[np.ix_(free, free)]
    eig = np.linalg.eigvals(np.linalg.solve(kgf, kf))
    eig = np.real(eig[np.isreal(eig)])
    return float(np.min(eig[eig > 0]))


@dataclass
class ContactResult:
    ram_force: float
    guide_force: float
    deflection: float
    r_a: float
    r_e: float
    m_a: float
    slope_stop: bool
    guide_contact: bool


def contact_solution(span: float, ei_r: float, near: float, guide_span: float, ei_g: float,
                     guide_near: float, lateral: float, theta_max: float,
                     z_gb: float) -> ContactResult:
    """Ram pinned at A and E with a slope stop |w'(0)| <= theta_max at A, loaded by
    ``lateral`` at ``near`` from A; a clamped-clamped guide beam below the load point with a
    gap ``z_gb``. Solved as a QP by active-set enumeration."""
    ram = Beam(span, ei_r, near)
    guide = Beam(guide_span, ei_g, guide_near)
    n_r, n_g = ram.ndof, guide.ndof
    k = np.zeros((n_r + n_g, n_r + n_g))
    k[:n_r, :n_r] = ram.stiffness()
    k[n_r:, n_r:] = guide.stiffness()
    f = np.zeros(n_r + n_g)
    f[ram.w_dof(ram.load_node)] = lateral

    eq_rows = []
    for r in ram.support_rows('pinned', 'pinned'):
        row = np.zeros(n_r + n_g)
        row[r] = 1.0
        eq_rows.append(row)
    for r in guide.support_rows('clamped', 'clamped'):
        row = np.zeros(n_r + n_g)
        row[n_r + r] = 1.0
        eq_rows.append(row)
    slope_row = np.zeros(n_r + n_g)
    slope_row[ram.slope_dof(0)] = 1.0
    gap_row = np.zeros(n_r + n_g)
    gap_row[ram.w_dof(ram.load_node)] = 1.0
    gap_row[n_r + guide.w_dof(guide.load_node)] = -1.0
    ineq = [(slope_row, theta_max), (gap_row, z_gb)]

    for active in itertools.product([False, True], repeat=2):
        rows = list(eq_rows) + [ineq[i][0] for i in range(2) if active[i]]
        rhs = [0.0] * len(eq_rows) + [ineq[i][1] for i in range(2) if active[i]]
        c = np.array(rows)
        m = len(rows)
        kkt = np.block([[k, c.T], [c, np.zeros((m, m))]])
        sol = np.linalg.solve(kkt, np.concatenate([f, rhs]))
        u, lam = sol[:n_r + n_g], sol[n_r + n_g:]
        lam_ineq = lam[len(eq_rows):]
        if np.any(lam_ineq < -1e-9 * max(lateral, 1.0)):
            continue
        feasible = all(active[i] or ineq[i][0] @ u <= ineq[i][1] * (1 + 1e-12) + 1e-15
                       for i in range(2))
        if not feasible:
            continue
        guide_force = float(lam_ineq[-1]) if active[1] else 0.0
        m_a = float(lam_ineq[0]) if active[0] else 0.0
        # Reactions of the ram's supports: equality multipliers on w(0), w(L).
        r_a, r_e = float(lam[0]), float(lam[1])
        return ContactResult(
            ram_force=lateral - guide_force,
            guide_force=guide_force,
            deflection=float(u[ram.w_dof(ram.load_node)]),
            r_a=r_a, r_e=r_e, m_a=m_a,
            slope_stop=bool(active[0]), guide_contact=bool(active[1]),
        )
    raise AssertionError('no active set satisfies the KKT conditions')
