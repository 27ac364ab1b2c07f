"""How the two rams share the driving force, from their pressures alone. Pure.

The declared model (docs/physics.md, docs/estimation.md) has each ram carry the same axial force: the
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

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit

__all__ = ['AT_EDGE', 'EVEN', 'IDLE', 'IDLE_RAM_SHARE', 'JOINED_SHARE', 'MARGIN_SE', 'MIN_SHARE_INSTANTS',
           'MIN_SHARE_SPREAD_PA', 'OPPOSED', 'OPPOSED_CORRELATION', 'STUCK_SHARE', 'UNEVEN', 'UNEVEN_CAUSE',
           'UNJUDGED', 'enough', 'judge', 'opposed_cause', 'ram_share', 'RamShare',
           'share_moments', 'share_of_moments', 'ShareMoments', 'weak_ram_cause', 'working_against']

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
#: a share whose interval straddles the band's edge: it says neither (:class:`RamsCheck` keeps
#: the level it had: the hysteresis)
AT_EDGE = 'at the edge'
#: the two rams' forces correlating at or below this push against each other: on one tiller
#: they cannot for long, so one ram's starboard and port pressures are swapped in the map (a
#: ram idle or uneven correlates near 0 or above; two rams of one gear near +1)
OPPOSED_CORRELATION = -0.5
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


@dataclass(frozen=True)
class ShareMoments:
    """Moments of the rams' forces over some instants, m = (f1 + f2) / 2 and d = f1 - f2:
    their count, the means of m, d, f1 and f2, and the centred sums of products S_mm, S_md,
    S_dd, S_11, S_22, S_12. Two sets of instants merge by Chan, Golub and LeVeque's pairwise
    update (each centred sum plus the product of the means' difference times n_a n_b / n),
    as accurate as the sums of either part: no difference of large raw sums."""

    n: int
    m: float
    d: float
    f1: float
    f2: float
    smm: float
    smd: float
    sdd: float
    s11: float
    s22: float
    s12: float

    @classmethod
    def empty(cls) -> ShareMoments:
        """No instants."""
        return cls(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __add__(self, o: ShareMoments) -> ShareMoments:
        if o.n == 0:
            return self
        if self.n == 0:
            return o
        n = self.n + o.n
        w = self.n * o.n / n
        dm, dd, d1, d2 = o.m - self.m, o.d - self.d, o.f1 - self.f1, o.f2 - self.f2
        return ShareMoments(n, self.m + dm * o.n / n, self.d + dd * o.n / n, self.f1 + d1 * o.n / n,
                        self.f2 + d2 * o.n / n, self.smm + o.smm + w * dm * dm, self.smd + o.smd + w * dm * dd,
                        self.sdd + o.sdd + w * dd * dd, self.s11 + o.s11 + w * d1 * d1,
                        self.s22 + o.s22 + w * d2 * d2, self.s12 + o.s12 + w * d1 * d2)


def ram_share(force: NDArray[np.float64]) -> RamShare | None:
    """The shares of ``force`` (n, 2), each ram's A_r (p_stbd - p_port) [N] at instants of
    steady motion; rows with a non-finite force are left out. None with fewer than three
    rows or a mean force that does not vary.

    Centred moments in two passes over the rows (the means; the centred sums of squares and
    products), compiled (:func:`_share_sums`): each sum of n terms is within about n machine
    epsilons of its terms' magnitudes, and no moment is a difference of large sums. The
    slope's residual sum of squares is S_dd - S_md^2 / S_mm, a difference of centred sums
    (good to about n epsilons of S_dd: its standard error is a rough quantity, read with
    ``MARGIN_SE`` of them)."""
    return share_of_moments(share_moments(force))


def share_moments(force: NDArray[np.float64]) -> ShareMoments:
    """The moments of ``force`` (n, 2) [N] (rows with a non-finite force left out)."""
    f = np.ascontiguousarray(force, dtype=float).reshape(-1, 2)
    return ShareMoments(*_share_sums(f))


def share_of_moments(mo: ShareMoments) -> RamShare | None:
    """The share from the moments (None: fewer than three rows, or m does not vary)."""
    if mo.n < 3 or not mo.smm > 0:
        return None
    b = mo.smd / mo.smm
    see = max(mo.sdd - b * mo.smd, 0.0)
    se_b = math.sqrt(see / (mo.n - 2) / mo.smm)
    s1 = 0.5 + 0.25 * b
    corr = mo.s12 / math.sqrt(mo.s11 * mo.s22) if mo.s11 > 0 and mo.s22 > 0 else math.nan
    return RamShare((s1, 1.0 - s1), 0.25 * se_b, math.sqrt(mo.smm / mo.n), mo.d - b * mo.m, int(mo.n), corr)


@njit(cache=True, nogil=True)
def _share_sums(x: NDArray[np.float64]) -> tuple[int, float, float, float, float, float, float, float, float, float,
                                                  float]:
    """Over the rows of the forces ``x`` (n, 2) whose two forces are finite,
    with m = (f1 + f2) / 2 and d = f1 - f2: the fields of :class:`ShareMoments` (rows, means of
    m, d, f1, f2; centred S_mm, S_md, S_dd, S_11, S_22, S_12)."""
    n = 0
    s_m = s_d = s_1 = s_2 = 0.0
    for i in range(x.shape[0]):
        a, c = x[i, 0], x[i, 1]
        if np.isfinite(a) and np.isfinite(c):
            n += 1
            s_m += 0.5 * (a + c)
            s_d += a - c
            s_1 += a
            s_2 += c
    if n == 0:
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    m_mean, d_mean, f1_mean, f2_mean = s_m / n, s_d / n, s_1 / n, s_2 / n
    smm = smd = sdd = s11 = s22 = s12 = 0.0
    for i in range(x.shape[0]):
        a, c = x[i, 0], x[i, 1]
        if np.isfinite(a) and np.isfinite(c):
            mc, dc = 0.5 * (a + c) - m_mean, (a - c) - d_mean
            smm += mc * mc
            smd += mc * dc
            sdd += dc * dc
            u, v = a - f1_mean, c - f2_mean
            s11 += u * u
            s22 += v * v
            s12 += u * v
    return n, m_mean, d_mean, f1_mean, f2_mean, smm, smd, sdd, s11, s22, s12


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
    near end, ``EVEN`` when it departs by less even at its far end (the interval wholly
    inside the band ``0.5 +- warn``), ``AT_EDGE`` when the interval straddles the band's
    edge; ``UNJUDGED`` with too few instants, too little variation of the load (``ram_area``
    [m^2] turns the spread into pressure), or an interval wider than ``warn``."""
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
    if 0.5 - low + margin < warn:
        return EVEN
    return AT_EDGE


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
