"""The declared plant (docs/physics.md) for a Rapson-slide gear, plus optional
undeclared effects. Pure numpy: no CAN here (see :mod:`steer_monitor.sim.encode`).

Per step of ``dt``: the helm programme gives an order; the rudder follows at a rate set by
the running pumps (ram speed v = pumps * v_ram, rudder rate v cos^2(alpha) / H) and a
proportional valve with a small dead band; the ship's heading follows a first-order
(Nomoto) yaw model. Then, vectorized over all steps: tiller torque from the curve scaled with
speed squared, load sharing with the true gaps, the friction law

    F_fr = F_s + mu_b (N_A + N_E) + mu_g |F_gb|,  N_A = max(|R_A|, 2 |M_A| / l_s), N_E = |R_E|

and the cylinder pressures A_r (p_stbd - p_port) = sign(alpha) Fa + sign(dalpha/dt) F_fr
(the friction term is zero while the rudder is still), on top of the return-line pressure.

Times in s inside the plant; :class:`SimResult` carries an integer-ns clock for the frames.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from steer_monitor.errors import ParameterError
from steer_monitor.model.friction import FrictionParams, friction_force
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.loadshare import load_sharing
from steer_monitor.sim.plant_effects import Effect
from steer_monitor.sim.programs import SPEED_TAU_S, HelmProgram, parse_program

__all__ = ['DEFAULT_START_NS', 'SimConfig', 'SimResult', 'simulate']

# 2026-01-01T00:00:00Z: a fixed start, so a seed reproduces a file byte for byte.
DEFAULT_START_NS = 1_767_225_600_000_000_000
KNOT = 1852.0 / 3600.0


@dataclass(frozen=True)
class SimConfig:
    """What to simulate. SI units unless the name says otherwise.

    Attributes:
        program: helm programme text (see :mod:`steer_monitor.sim.programs`).
        gaps: true clearances.
        seal_friction: F_s [N]; mu_bushing, mu_guide: friction coefficients.
        return_pressure: return-line pressure [Pa].
        angle_noise: one-sigma noise of the angle sensor [rad].
        pressure_noise: one-sigma noise of each pressure transducer [Pa].
        speed_profile: ((t [s], speed [kn]), ...) piecewise linear; one point = constant.
        oil_temp_start_c, oil_temp_end_c, oil_temp_tau_s: oil warms from start to end.
        effects: undeclared effects to add.
        dt: plant step [s].
        max_duration_s: stop the programme after this long.
        start_ns: clock of t = 0 [ns since epoch].
        noise: False for a noise-free run (quantisation stays).
    """

    program: str = 'hard_over_2'
    gaps: Clearances = field(default_factory=lambda: Clearances.from_mm(0.6, 0.25))
    seal_friction: float = 9e3
    mu_bushing: float = 0.13
    mu_guide: float = 0.05
    return_pressure: float = 2e5
    angle_noise: float = 1.5e-4
    pressure_noise: float = 0.25e5
    speed_profile: tuple[tuple[float, float], ...] = ((0.0, 16.0),)
    oil_temp_start_c: float = 35.0
    oil_temp_end_c: float = 55.0
    oil_temp_tau_s: float = 1800.0
    effects: tuple[Effect, ...] = ()
    dt: float = 0.01
    max_duration_s: float = 7200.0
    start_ns: int = DEFAULT_START_NS
    noise: bool = True

    def __post_init__(self) -> None:
        for name in ('seal_friction', 'mu_bushing', 'mu_guide', 'angle_noise', 'pressure_noise'):
            v = getattr(self, name)
            if not (math.isfinite(v) and v >= 0):
                msg = f'simulator {name} must be a finite number >= 0, got {v!r}'
                raise ParameterError(msg)
        if not (0 < self.dt <= 0.05):
            msg = f'simulator dt must lie in (0, 0.05] s, got {self.dt!r}'
            raise ParameterError(msg)
        if not self.speed_profile or any(not (math.isfinite(v) and 0 <= v <= 40) for _, v in self.speed_profile):
            msg = 'simulator speed profile needs at least one point with a speed in 0..40 kn'
            raise ParameterError(msg)
        times = [t for t, _ in self.speed_profile]
        if times != sorted(times):
            msg = 'simulator speed profile times must increase'
            raise ParameterError(msg)
        names = [e.name for e in self.effects]
        if len(set(names)) != len(names):
            msg = f'an effect is given twice: {names}'
            raise ParameterError(msg)

    def effect(self, name: str) -> Effect | None:
        return next((e for e in self.effects if e.name == name), None)


@dataclass(frozen=True)
class SimResult:
    """Plant history, one row per step; arrays of shape (n,), SI units.

    ``pressures`` maps input names (``pressure_r1_stbd`` ...) to true chamber pressures
    [Pa] before sensor effects; ``ram_force`` / ``guide_force`` / ``k_gl`` per ram.
    """

    t: NDArray[np.float64]
    order: NDArray[np.float64]
    alpha: NDArray[np.float64]
    rate: NDArray[np.float64]
    heading: NDArray[np.float64]
    pumps: NDArray[np.int8]
    speed: NDArray[np.float64]
    oil_temp: NDArray[np.float64]
    torque: NDArray[np.float64]
    axial: NDArray[np.float64]
    lateral: NDArray[np.float64]
    ram_force: NDArray[np.float64]
    guide_force: NDArray[np.float64]
    k_gl: NDArray[np.float64]
    friction: NDArray[np.float64]
    pressures: dict[str, NDArray[np.float64]]
    start_ns: int
    cut: bool = False       # the programme was cut at max_duration_s, not run to its end

    @property
    def duration(self) -> float:
        return float(self.t[-1]) if self.t.size else 0.0


def _speed_at(profile: Sequence[tuple[float, float]], t: NDArray[np.float64]) -> NDArray[np.float64]:
    times = np.array([p[0] for p in profile], float)
    knots = np.array([p[1] for p in profile], float)
    return np.interp(t, times, knots) * KNOT


def simulate(gear: GearParams, cfg: SimConfig, ram_speed_per_pump: float, pumps_available: int,
             rng: np.random.Generator) -> SimResult:
    """Run the plant over the whole programme."""
    steps = parse_program(cfg.program, pumps_available, rng)
    program = HelmProgram(steps, rng)
    dt = cfg.dt
    n_max = int(cfg.max_duration_s / dt) + 1
    h = gear.stock_to_ram
    kp_valve = 1.5            # 1/s: rate per unit error of the floating-lever valve
    dead_band = 0.1 * math.pi / 180
    nomoto_k, nomoto_t = 0.07, 20.0  # 1/s and s at service speed
    vs = gear.torque.service_speed
    speed_fn = cfg.speed_profile
    v_ship = float(_speed_at(speed_fn, np.array([0.0]))[0])
    # the histories grow with the programme (doubling), not to max_duration_s at once: a
    # generous cap on a short programme must not take the memory of the cap
    cap = min(n_max, 1 << 16)
    speed_hist, order, alpha, rate, heading = (np.zeros(cap) for _ in range(5))
    pumps = np.zeros(cap, np.int8)
    a = psi = r = 0.0
    # with a moving mass, the ram's speed follows the valve's through a first-order lag
    inertia = cfg.effect('ram_inertia')
    lag = float(inertia['rate_lag_s']) if inertia is not None else 0.0
    follow = min(1.0, dt / lag) if lag > 0 else 0.0
    w_ram = 0.0
    n = n_max
    for i in range(n_max):
        t = i * dt
        if program.done and i > 0:
            n = i
            break
        if i == cap:
            cap = min(n_max, 2 * cap)
            speed_hist, order, alpha, rate, heading, pumps = (
                np.concatenate([h_, np.zeros(cap - h_.size, h_.dtype)])
                for h_ in (speed_hist, order, alpha, rate, heading, pumps))
        o, p = program(t, a, psi, r)
        err = o - a
        w_max = p * ram_speed_per_pump * math.cos(a) ** 2 / h
        if abs(err) < dead_band:
            w = 0.0
        elif program.solenoid:      # on/off valves: full rate until inside the dead band
            w = math.copysign(min(w_max, abs(err) / dt), err)
        else:
            w = max(-w_max, min(w_max, kp_valve * err))
        if follow:
            w = w_ram = w_ram + (w - w_ram) * follow
        if program.speed_target is None:
            v_ship = float(_speed_at(speed_fn, np.array([t]))[0])
        else:                       # an engine order: the hull follows with its lag
            v_ship += (program.speed_target * KNOT - v_ship) * dt / SPEED_TAU_S
        order[i], alpha[i], rate[i], heading[i], pumps[i], speed_hist[i] = o, a, w, psi, p, v_ship
        r += (nomoto_k * (v_ship / vs) * a - r) * dt / nomoto_t
        psi += r * dt
        a += w * dt
    t = np.arange(n) * dt
    order, alpha, rate, heading, pumps = order[:n], alpha[:n], rate[:n], heading[:n], pumps[:n]
    speed = speed_hist[:n]
    oil = (cfg.oil_temp_end_c - (cfg.oil_temp_end_c - cfg.oil_temp_start_c)
           * np.exp(-t / cfg.oil_temp_tau_s)) + 273.15

    torque = gear.torque(alpha, speed)
    ls = load_sharing(gear, alpha, torque, cfg.gaps.two_z, cfg.gaps.z_gb)
    declared = FrictionParams(cfg.seal_friction, cfg.mu_bushing, cfg.mu_guide)
    friction = friction_force(declared, ls.r_a, ls.r_e, ls.m_a, ls.guide_force, gear.bushing_length)
    v_ram = h / np.cos(alpha) ** 2 * np.abs(rate)
    e = cfg.effect('viscous')
    if e is not None:
        friction = friction + float(e['c_ns_per_m']) * v_ram
    e = cfg.effect('stribeck')
    if e is not None:
        v_s = float(e['v_s_mm_s']) * 1e-3
        friction = friction + float(e['f_st_n']) * np.exp(-(v_ram / v_s) ** 2)
    e = cfg.effect('band_friction')
    if e is not None:
        deg = np.degrees(np.abs(alpha))
        friction = friction + float(e['f_n']) * ((deg >= float(e['lo_deg'])) & (deg <= float(e['hi_deg'])))
    e = cfg.effect('temp_friction')
    if e is not None:
        friction = friction * (1.0 + float(e['k_per_k']) * (oil - 273.15 - float(e['t_ref_c'])))
    moving = rate != 0.0
    load = np.sign(alpha) * ls.axial
    e = cfg.effect('pressure_friction')
    if e is not None:
        # Seal friction k A_r p_high, with A_r p_high = |load + s F_fr| (s = sign of motion):
        # F = base + k |u + F| where u = s load. Branch u + F >= 0 or < 0, exactly.
        k = float(e['k'])
        u = np.sign(rate) * load
        f_pos = (friction + k * u) / (1.0 - k)
        f_neg = (friction - k * u) / (1.0 + k)
        friction = np.where(moving, np.where(u + f_pos >= 0, f_pos, f_neg), friction)
    force = load + np.where(moving, np.sign(rate) * friction, 0.0)
    if inertia is not None and n > 1:
        # the ram's speed along its axis, H / cos^2(alpha) dalpha/dt, differentiated
        force = force + float(inertia['mass_kg']) * np.gradient(h / np.cos(alpha) ** 2 * rate, dt)
    dp = force / gear.ram_area
    dps = [dp, dp]                  # per ram
    e = cfg.effect('ram_bypass')
    if e is not None:
        span = (t >= float(e['start_s'])) & (t < float(e['end_s']))
        weak = int(float(e['ram'])) - 1
        carries = float(e['carries'])
        dps[weak] = np.where(span, carries * dp, dp)
        dps[1 - weak] = np.where(span, (2.0 - carries) * dp, dp)
    pressures = {}
    for ram, d in enumerate(dps, start=1):
        pressures[f'pressure_r{ram}_stbd'] = cfg.return_pressure + np.maximum(d, 0.0)
        pressures[f'pressure_r{ram}_port'] = cfg.return_pressure + np.maximum(-d, 0.0)
    return SimResult(t=t, order=order, alpha=alpha, rate=rate, heading=heading, pumps=pumps,
                     speed=speed, oil_temp=oil, torque=torque, axial=ls.axial, lateral=ls.lateral,
                     ram_force=ls.ram_force, guide_force=ls.guide_force, k_gl=ls.k_gl,
                     friction=np.where(moving, friction, 0.0), pressures=pressures,
                     start_ns=cfg.start_ns, cut=n == n_max and not program.done)
