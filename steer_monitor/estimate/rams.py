"""How the two rams share the driving force, from their pressures alone. Pure.

The declared model (design doc section 4) has each ram carry the same axial force: the
gear's chambers are cross-connected, so both rams see the same pressure difference. A ram
whose chambers are joined (a bypass or isolating valve open, a pipe broken) carries less and
the other ram more; the tiller torque they make together is unchanged, which is why the
clearance fit, working on the rams' mean force per angle bin, hardly moves, and why the
model's residual alone does not say what is wrong.

With the rams' forces f1, f2 at instants of steady motion, m = (f1 + f2) / 2 is what each
carries on an even share and d = f1 - f2 their difference. A ram carrying the share s1 of
the force (ram 2: 1 - s1) makes d = (4 s1 - 2) m, so the slope b of d on m gives
s1 = 1/2 + b/4. The slope is fitted with an intercept (centred moments), so a transducer
that reads a constant high or low (an offset between the rams, not a share) does not move
it; and the noise of m and of d are uncorrelated for transducers of equal noise, so it does
not bias it either (m's noise only widens the interval).
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

__all__ = ['EVEN', 'IDLE', 'IDLE_RAM_SHARE', 'JOINED_SHARE', 'MIN_SHARE_INSTANTS', 'MIN_SHARE_SPREAD_PA', 'OPPOSED',
           'OPPOSED_CORRELATION', 'STUCK_SHARE', 'UNEVEN', 'UNEVEN_CAUSE', 'UNJUDGED', 'WINDOW_INSTANTS', 'RamShare',
           'UnevenSpan', 'describe', 'enough', 'judge', 'opposed_cause', 'ram_share', 'ram_share_of_pressures',
           'uneven_spans', 'weak_ram_cause', 'within', 'working_against']

#: a share is judged from this many instants of steady motion (seconds of it)...
MIN_SHARE_INSTANTS = 300
#: ... with the rams' mean force varying by at least this much over them [Pa of ram pressure]
#: (what carries which share shows only as the load changes: at berth the friction alone,
#: 2-5 bar, still does)
MIN_SHARE_SPREAD_PA = 1e5
#: a ram carrying less than this share of the driving force does next to no work
IDLE_RAM_SHARE = 0.1
#: the share's interval, in standard errors each side (the instants are correlated)
MARGIN_SE = 4.0
UNJUDGED, EVEN, UNEVEN, IDLE, OPPOSED = 'unjudged', 'even', 'uneven', 'idle', 'opposed'
#: the two rams' forces correlating at or below this push against each other: on one tiller
#: they cannot for long, so one ram's starboard and port pressures are swapped in the map (a
#: ram idle or uneven correlates near 0 or above; two rams of one gear near +1)
OPPOSED_CORRELATION = -0.5
#: instants of steady motion a log's stretches and the live rams status judge over (30 s of
#: it on the 50 ms grid)
WINDOW_INSTANTS = 600
#: instants a stretch's end moves by at a time (3 s of steady motion on the 50 ms grid)
EDGE_STEP = 60
#: what uneven sharing may mean, for messages (``ram``: the weaker, 1 or 2)
UNEVEN_CAUSE = ('a bypass or isolating valve open on ram {ram}, or a pressure transducer of either ram not reading '
                'its chamber')
#: the weaker ram's chambers are joined when their difference varies by less than this share
#: of the other ram's (its mean included): the load makes the other's tens of bar at sea,
#: the noise of two transducers half a bar
JOINED_SHARE = 0.05
#: a chamber's transducer does not read when its pressure varies by less than this share of
#: the other ram's difference while its own ram's other chamber varies ten times as much
STUCK_SHARE = 0.05


@dataclass(frozen=True)
class RamShare:
    """The rams' shares of the driving force over some instants.

    Attributes:
        share: the share of ram 1 and of ram 2 (they add to 1; 0.5 each when even).
        se: the standard error of either share, from the fit's residual as if the instants
            were independent (consecutive instants that share pressure samples are not: read
            it as a lower bound).
        spread: the standard deviation of the mean ram force m over the instants [N]: what
            the share is seen against (a load that does not vary says nothing about it).
        offset: the intercept of d, f1 - f2 where m = 0 [N]: a transducer of ram 1 reading c
            high puts c (2 - 2 s1) here and none into the share.
        instants: how many instants.
        correlation: of the two rams' forces over the instants (NaN when either does not
            vary): near +1 on a sound gear, at or below :data:`OPPOSED_CORRELATION` when one
            ram's pressures are read the wrong way round.
    """

    share: tuple[float, float]
    se: float
    spread: float
    offset: float
    instants: int
    correlation: float = math.nan

    @property
    def weaker(self) -> int:
        """The ram (0 or 1) that carries less."""
        return 0 if self.share[0] <= self.share[1] else 1


def ram_share(force: NDArray[np.float64]) -> RamShare | None:
    """The shares of ``force`` (n, 2), each ram's A_r (p_stbd - p_port) [N] at instants of
    steady motion; rows with a non-finite force are left out. None with fewer than three
    rows or a mean force that does not vary.

    Centred moments in three passes over the rows (the means; the centred sums of squares
    and products and the slope; the fit's residual), compiled (:func:`_share_sums`): each
    sum of n terms is within about n machine epsilons of its terms' magnitudes, and no
    moment is a difference of large sums (the live rams status works one out every second
    of motion over 2,400 instants, where numpy's dozen calls took 0.15 ms)."""
    f = np.ascontiguousarray(force, dtype=float).reshape(-1, 2)
    return _share(_share_sums(f, math.nan))


def ram_share_of_pressures(pressures: NDArray[np.float64], ram_area: float) -> RamShare | None:
    """:func:`ram_share` of the forces ``ram_area * (p0 - p1)`` and ``ram_area * (p2 - p3)``
    of the four pressures ``pressures`` (n, 4) [Pa] (ram 1 starboard and port, ram 2 the same;
    ``ram_area`` [m^2]), each force worked out as that expression, element by element, in
    the compiled passes (the live rams status: no arrays of forces made every second)."""
    p = np.ascontiguousarray(pressures, dtype=float).reshape(-1, 4)
    return _share(_share_sums(p, float(ram_area)))


def _share(sums: tuple[int, float, float, float, float, float, float, float, float]) -> RamShare | None:
    """The share from :func:`_share_sums`' moments (None: fewer than three rows, or m does not vary)."""
    n, m_mean, d_mean, smm, smd, see, s11, s22, s12 = sums
    if n < 3 or not smm > 0:
        return None
    b = smd / smm
    se_b = math.sqrt(see / (n - 2) / smm)
    s1 = 0.5 + 0.25 * b
    corr = s12 / math.sqrt(s11 * s22) if s11 > 0 and s22 > 0 else math.nan
    return RamShare((s1, 1.0 - s1), 0.25 * se_b, math.sqrt(smm / n), d_mean - b * m_mean, int(n), corr)


@njit(cache=True, nogil=True, inline='always')
def _forces(x: NDArray[np.float64], i: int, area: float) -> tuple[float, float]:
    """Row ``i``'s two forces: the row itself (``area`` NaN: ``x`` holds forces (n, 2)), or
    ``area * (p0 - p1)``, ``area * (p2 - p3)`` of its four pressures (``x`` (n, 4))."""
    if np.isnan(area):
        return x[i, 0], x[i, 1]
    return area * (x[i, 0] - x[i, 1]), area * (x[i, 2] - x[i, 3])


@njit(cache=True, nogil=True)
def _share_sums(x: NDArray[np.float64], area: float) -> tuple[int, float, float, float, float, float, float, float,
                                                              float]:
    """Over the rows whose two forces (:func:`_forces` of ``x`` and ``area``) are finite,
    with m = (f1 + f2) / 2 and d = f1 - f2: (rows, mean m, mean d, S_mm, S_md, the
    residual's sum of squares of d on m about the slope S_md / S_mm, S_11, S_22, S_12), the
    S centred sums of products."""
    n = 0
    s_m = s_d = s_1 = s_2 = 0.0
    for i in range(x.shape[0]):
        a, c = _forces(x, i, area)
        if np.isfinite(a) and np.isfinite(c):
            n += 1
            s_m += 0.5 * (a + c)
            s_d += a - c
            s_1 += a
            s_2 += c
    if n == 0:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    m_mean, d_mean, f1_mean, f2_mean = s_m / n, s_d / n, s_1 / n, s_2 / n
    smm = smd = s11 = s22 = s12 = 0.0
    for i in range(x.shape[0]):
        a, c = _forces(x, i, area)
        if np.isfinite(a) and np.isfinite(c):
            mc, dc = 0.5 * (a + c) - m_mean, (a - c) - d_mean
            smm += mc * mc
            smd += mc * dc
            u, v = a - f1_mean, c - f2_mean
            s11 += u * u
            s22 += v * v
            s12 += u * v
    see = 0.0
    if smm > 0:
        b = smd / smm
        for i in range(x.shape[0]):
            a, c = _forces(x, i, area)
            if np.isfinite(a) and np.isfinite(c):
                e = ((a - c) - d_mean) - b * (0.5 * (a + c) - m_mean)
                see += e * e
    return n, m_mean, d_mean, smm, smd, see, s11, s22, s12


def enough(sh: RamShare, ram_area: float) -> bool:
    """The share is over ``MIN_SHARE_INSTANTS`` instants at least, with the rams' mean force
    varying by ``MIN_SHARE_SPREAD_PA`` of ram pressure (``ram_area`` [m^2]) at least."""
    return sh.instants >= MIN_SHARE_INSTANTS and sh.spread >= MIN_SHARE_SPREAD_PA * ram_area


def judge(sh: RamShare | None, warn: float, ram_area: float) -> str:
    """What a share says: ``OPPOSED`` when the rams' forces correlate at or below
    :data:`OPPOSED_CORRELATION` over ``MIN_SHARE_INSTANTS`` instants at least (one ram's
    pressures swapped in the map: no share means anything then); else judged on its interval
    (``MARGIN_SE`` standard errors each side):
    ``IDLE`` when the weaker ram carries less than ``IDLE_RAM_SHARE`` even at the top of it,
    ``UNEVEN`` when the share departs from an even half by more than ``warn`` even at its
    near end, ``EVEN`` otherwise; ``UNJUDGED`` with too few instants, too little variation of
    the load (``ram_area`` [m^2] turns the spread into pressure), or an interval wider than
    ``warn``."""
    if sh is not None and sh.instants >= MIN_SHARE_INSTANTS and sh.correlation <= OPPOSED_CORRELATION:
        return OPPOSED
    if sh is None or not enough(sh, ram_area):
        return UNJUDGED
    margin = MARGIN_SE * sh.se
    if margin > 0.5 * warn:
        return UNJUDGED
    low = sh.share[sh.weaker]
    if low + margin < IDLE_RAM_SHARE:
        return IDLE
    if 0.5 - low - margin > warn:
        return UNEVEN
    return EVEN


@dataclass(frozen=True)
class UnevenSpan:
    """A stretch of a log where the rams did not share the force evenly.

    Attributes:
        start_ns, end_ns: its first and last instant of steady motion [ns].
        ram: the weaker ram, 0 or 1.
        share: the weaker ram's share over the stretch.
        instants: instants of steady motion in it.
        idle: the weaker ram did next to no work (``IDLE``).
    """

    start_ns: int
    end_ns: int
    ram: int
    share: float
    instants: int
    idle: bool


def uneven_spans(t_ns: NDArray[np.int64], force: NDArray[np.float64], warn: float, ram_area: float,
                 window: int = WINDOW_INSTANTS) -> list[UnevenSpan]:
    """Stretches of uneven sharing in a log: the instants of steady motion ``t_ns`` (n,) [ns]
    with the rams' forces ``force`` (n, 2) [N] (rows with a non-finite force are left out)
    are cut into consecutive windows of ``window`` instants (the last one takes the rest),
    each judged by :func:`judge`; neighbouring windows judged uneven or idle make one
    stretch. Its ends are then moved, ``EDGE_STEP`` instants at a time, in while the instants
    at an end share evenly, and out into the windows beside it while those share unevenly the
    stretch's way (a fault rarely starts or ends where a window does); its share is fitted
    over the instants it then holds."""
    f = np.asarray(force, dtype=float).reshape(-1, 2)
    ok = np.isfinite(f).all(axis=1)
    t, f = np.asarray(t_ns, dtype=np.int64)[ok], f[ok]
    n = t.size
    cuts = list(range(0, n - window + 1, window)) if n >= window else [0]
    bounds = [(a, b) for a, b in zip(cuts, cuts[1:] + [n])]
    bad = [judge(ram_share(f[a:b]), warn, ram_area) in (UNEVEN, IDLE) for a, b in bounds]
    spans: list[UnevenSpan] = []
    k = 0
    while k < len(bounds):
        if not bad[k]:
            k += 1
            continue
        j = k
        while j + 1 < len(bounds) and bad[j + 1]:
            j += 1
        a, b = bounds[k][0], bounds[j][1]
        a, b = _edges(f, a, b, bounds[k - 1][0] if k > 0 else 0, bounds[j + 1][1] if j + 1 < len(bounds) else n, warn)
        sh = ram_share(f[a:b])
        if sh is not None:
            spans.append(UnevenSpan(int(t[a]), int(t[b - 1]), sh.weaker, sh.share[sh.weaker], b - a,
                                    judge(sh, warn, ram_area) == IDLE))
        k = j + 1
    return spans


def _edges(f: NDArray[np.float64], a: int, b: int, lo: int, hi: int, warn: float) -> tuple[int, int]:
    """The stretch f[a:b] moved in and out at its ends (see :func:`uneven_spans`), within
    f[lo:hi]: in while the ``EDGE_STEP`` instants at an end share evenly, out while those
    beside it share unevenly the stretch's way, each judged on its own share's interval as
    :func:`judge` does (a part whose load hardly varies has a wide one, and says neither)."""
    whole = ram_share(f[a:b])
    if whole is None:
        return a, b
    side = 1.0 if whole.share[0] > 0.5 else -1.0

    def says(part: NDArray[np.float64]) -> str | None:
        sh = ram_share(part)
        if sh is None:
            return None
        off, margin = sh.share[0] - 0.5, MARGIN_SE * sh.se
        if side * off - margin > warn:
            return UNEVEN
        if abs(off) + margin < warn:
            return EVEN
        return None

    while b - a > 2 * EDGE_STEP and says(f[a:a + EDGE_STEP]) == EVEN:
        a += EDGE_STEP
    while b - a > 2 * EDGE_STEP and says(f[b - EDGE_STEP:b]) == EVEN:
        b -= EDGE_STEP
    while a - lo >= 3 and says(f[max(a - EDGE_STEP, lo):a]) == UNEVEN:
        a = max(a - EDGE_STEP, lo)
    while hi - b >= 3 and says(f[b:min(b + EDGE_STEP, hi)]) == UNEVEN:
        b = min(b + EDGE_STEP, hi)
    return a, b


def within(t_ns: NDArray[np.int64], spans: Sequence[UnevenSpan]) -> NDArray[np.bool_]:
    """Which of the times ``t_ns`` (n,) [ns] lie in one of ``spans`` (ends included)."""
    t = np.asarray(t_ns, dtype=np.int64)
    out = np.zeros(t.shape, bool)
    for sp in spans:
        out |= (t >= sp.start_ns) & (t <= sp.end_ns)
    return out


def describe(sp: UnevenSpan) -> str:
    """One stretch in words, its times in UTC."""
    def clock(t_ns: int) -> str:
        return datetime.datetime.fromtimestamp(t_ns / 1e9, datetime.UTC).strftime('%Y-%m-%d %H:%M:%S')
    return (f'ram {sp.ram + 1} carried {100 * sp.share:.0f} % of the driving force from {clock(sp.start_ns)} to '
            f'{clock(sp.end_ns)} UTC ({sp.instants} instants of steady motion'
            f'{", next to no work" if sp.idle else ""}: {UNEVEN_CAUSE.format(ram=sp.ram + 1)})')


def working_against(force: NDArray[np.float64], rate: NDArray[np.float64]) -> int | None:
    """The ram (0 or 1) whose force works against the rudder's motion over a log while the
    other's drives it, or None when that does not single one out: the sign of each ram's
    work, the sum of its force ``force`` (n, 2) [N] times the rudder rate ``rate`` (n,)
    [rad/s] over instants of steady motion. Over motion to and fro the hydrodynamic torque's
    work nearly cancels and the friction's does not, so a ram read the right way round does
    positive work."""
    f = np.asarray(force, dtype=float).reshape(-1, 2)
    r = np.asarray(rate, dtype=float).reshape(-1)
    ok = np.isfinite(f).all(axis=1) & np.isfinite(r)
    w = (f[ok] * r[ok, None]).sum(axis=0)
    if w[0] < 0 < w[1]:
        return 0
    if w[1] < 0 < w[0]:
        return 1
    return None


def opposed_cause(sh: RamShare, ram: int | None, names: Sequence[str]) -> str:
    """Why two rams push against each other, in words: the starboard and port inputs of
    ``ram`` (0 or 1; None: either) among the four pressure input ``names``, swapped."""
    rams = [ram] if ram is not None else [0, 1]
    which = ' or '.join(f'{names[2 * k]} and {names[2 * k + 1]}' for k in rams)
    whose = f'ram {ram + 1}' if ram is not None else 'one ram'
    return (f'the rams push against each other (their forces correlate at {sh.correlation:+.2f} over '
            f'{sh.instants} instants of motion): the starboard and port pressures of {whose} are read the wrong way '
            f'round: {which} swapped in the signals map (or the transducers swapped on the gear)')


def weak_ram_cause(pressure: NDArray[np.float64], ram: int, names: Sequence[str]) -> str:
    """What the weaker ram's own chambers say of why it carries too little, from the four
    pressures ``pressure`` (k, 4) [Pa] at the instants its share was judged over, in the
    order of ``names`` (ram 1 starboard-, port-driving, ram 2 the same): its two chambers
    read the same pressure (joined: a bypass or isolating valve open), or one of them does
    not follow the load while the other does (that transducer, or its wiring, not reading);
    else :data:`UNEVEN_CAUSE`."""
    p = np.asarray(pressure, dtype=float)
    generic = UNEVEN_CAUSE.format(ram=ram + 1)
    if p.shape[0] < 3:
        return generic
    a, b = p[:, 2 * ram], p[:, 2 * ram + 1]
    other = p[:, 2 - 2 * ram] - p[:, 3 - 2 * ram]
    scale = float(np.std(other))
    if not scale > 0:
        return generic
    d = a - b
    if abs(float(d.mean())) + float(d.std()) < JOINED_SHARE * scale:
        return (f'its two chambers read the same pressure ({float(a.mean()) / 1e5:.1f} and {float(b.mean()) / 1e5:.1f} '
                f'bar): joined, a bypass or isolating valve open on ram {ram + 1}')
    for this, that, name in ((a, b, names[2 * ram]), (b, a, names[2 * ram + 1])):
        quiet = float(np.std(this))
        if quiet < STUCK_SHARE * scale and float(np.std(that)) >= 10.0 * quiet:
            return (f'{name} stays at {float(this.mean()) / 1e5:.1f} bar while the load moves the other chamber: '
                    'that transducer, or its wiring, not reading')
    return generic
