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

from steer_monitor.utc import utc_json

__all__ = ['AT_EDGE', 'EDGE_STEP', 'EVEN', 'IDLE', 'IDLE_RAM_SHARE', 'JOINED_SHARE', 'MARGIN_SE',
           'MIN_SHARE_INSTANTS', 'MIN_SHARE_SPREAD_PA', 'OPPOSED', 'OPPOSED_CORRELATION', 'STUCK_SHARE', 'UNEVEN',
           'UNEVEN_CAUSE', 'UNJUDGED', 'WINDOW_INSTANTS', 'RamShare', 'RamsCheck', 'RamsWindow', 'UnevenSpan',
           'describe', 'enough', 'judge', 'opposed_cause', 'rams_verdict', 'uneven_json', 'ram_share',
           'ram_share_of_pressures', 'uneven_spans', 'weak_ram_cause', 'within', 'working_against']

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


@dataclass(frozen=True)
class _Moments:
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
    def empty(cls) -> _Moments:
        return cls(0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)

    def __add__(self, o: _Moments) -> _Moments:
        if o.n == 0:
            return self
        if self.n == 0:
            return o
        n = self.n + o.n
        w = self.n * o.n / n
        dm, dd, d1, d2 = o.m - self.m, o.d - self.d, o.f1 - self.f1, o.f2 - self.f2
        return _Moments(n, self.m + dm * o.n / n, self.d + dd * o.n / n, self.f1 + d1 * o.n / n,
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
    return _share(_moments_of(force))


def ram_share_of_pressures(pressures: NDArray[np.float64], ram_area: float) -> RamShare | None:
    """:func:`ram_share` of the forces ``ram_area * (p0 - p1)`` and ``ram_area * (p2 - p3)``
    of the four pressures ``pressures`` (n, 4) [Pa] (ram 1 starboard and port, ram 2 the same;
    ``ram_area`` [m^2]), each force worked out as that expression, element by element, in
    the compiled passes."""
    p = np.ascontiguousarray(pressures, dtype=float).reshape(-1, 4)
    return _share(_Moments(*_share_sums(p, float(ram_area))))


def _moments_of(force: NDArray[np.float64]) -> _Moments:
    f = np.ascontiguousarray(force, dtype=float).reshape(-1, 2)
    return _Moments(*_share_sums(f, math.nan))


def _share(mo: _Moments) -> RamShare | None:
    """The share from the moments (None: fewer than three rows, or m does not vary)."""
    if mo.n < 3 or not mo.smm > 0:
        return None
    b = mo.smd / mo.smm
    see = max(mo.sdd - b * mo.smd, 0.0)
    se_b = math.sqrt(see / (mo.n - 2) / mo.smm)
    s1 = 0.5 + 0.25 * b
    corr = mo.s12 / math.sqrt(mo.s11 * mo.s22) if mo.s11 > 0 and mo.s22 > 0 else math.nan
    return RamShare((s1, 1.0 - s1), 0.25 * se_b, math.sqrt(mo.smm / mo.n), mo.d - b * mo.m, int(mo.n), corr)


@njit(cache=True, nogil=True, inline='always')
def _forces(x: NDArray[np.float64], i: int, area: float) -> tuple[float, float]:
    """Row ``i``'s two forces: the row itself (``area`` NaN: ``x`` holds forces (n, 2)), or
    ``area * (p0 - p1)``, ``area * (p2 - p3)`` of its four pressures (``x`` (n, 4))."""
    if np.isnan(area):
        return x[i, 0], x[i, 1]
    return area * (x[i, 0] - x[i, 1]), area * (x[i, 2] - x[i, 3])


@njit(cache=True, nogil=True)
def _share_sums(x: NDArray[np.float64], area: float) -> tuple[int, float, float, float, float, float, float, float,
                                                              float, float, float]:
    """Over the rows whose two forces (:func:`_forces` of ``x`` and ``area``) are finite,
    with m = (f1 + f2) / 2 and d = f1 - f2: the fields of :class:`_Moments` (rows, means of
    m, d, f1, f2; centred S_mm, S_md, S_dd, S_11, S_22, S_12)."""
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
        return 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    m_mean, d_mean, f1_mean, f2_mean = s_m / n, s_d / n, s_1 / n, s_2 / n
    smm = smd = sdd = s11 = s22 = s12 = 0.0
    for i in range(x.shape[0]):
        a, c = _forces(x, i, area)
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


@dataclass(frozen=True)
class RamsWindow:
    """One window of :class:`RamsCheck`: its first and last instant [ns], its share (None:
    fewer than three instants), what :func:`judge` said of it, and the level the check holds
    after it (``said`` where that is ``EVEN``, ``UNEVEN``, ``IDLE`` or ``OPPOSED``; the level
    before it where the window could not say: ``AT_EDGE`` or ``UNJUDGED``)."""

    start_ns: int
    end_ns: int
    share: RamShare | None
    said: str
    level: str


_Rows = tuple[NDArray[np.int64], NDArray[np.float64]]


class RamsCheck:
    """The rams check: one definition of whether the two rams share the driving force, used
    by the node, ``analyze``, ``report`` and ``fleet`` alike.

    Instants of steady motion (their times and the rams' forces, in time order, in pieces of
    any size) are cut into consecutive windows of ``window`` instants (30 s of steady motion
    on the 50 ms grid), each judged by :func:`judge` on its share's interval against the band
    ``0.5 +- warn``. The level follows the windows with hysteresis: ``UNEVEN`` (or ``IDLE``)
    once a window's interval lies wholly outside the band, ``EVEN`` again only once one lies
    wholly inside it; a window whose interval straddles the band's edge (``AT_EDGE``) or that
    cannot be judged (``UNJUDGED``: too few instants, a load that hardly varied, too wide an
    interval) keeps the level it found. ``OPPOSED`` (a ram read the wrong way round) once two
    windows in a row say so: a window across a fault's start, one ram's force falling as the
    other's rises, can say it once. A stretch of uneven sharing runs from the first window
    judged uneven or idle to the last one before a window judged even (or the end); its ends
    then move in while the ``EDGE_STEP`` instants at an end share evenly (within its first
    and last window) and out into the windows beside it while those share unevenly the
    stretch's way (a fault rarely starts or ends where a window does), and its share is that
    of the instants it then holds (moments merged window by window: memory stays bounded
    however long it lasts). Rows with a non-finite force are left out. :meth:`finish` judges
    the instants after the last whole window as a window of their own and closes the stretch
    still open. Pure; not thread-safe."""

    def __init__(self, warn: float, ram_area: float, window: int = WINDOW_INSTANTS) -> None:
        self.warn, self.ram_area, self.window = float(warn), float(ram_area), int(window)
        #: the stretches closed so far, in time order
        self.spans: list[UnevenSpan] = []
        #: the last window judged (None before the first)
        self.last: RamsWindow | None = None
        #: the level the windows left: ``UNJUDGED`` until one says ``EVEN``, ``UNEVEN``,
        #: ``IDLE`` or ``OPPOSED``
        self.level = UNJUDGED
        #: the instants taken (finite forces)
        self.instants = 0
        #: the extra columns given with the last window's instants (``feed``'s ``aux``)
        self.last_aux: NDArray[np.float64] | None = None
        #: a window said ``EVEN``, ``UNEVEN`` or ``IDLE``: the sharing was judged
        self.assessed = False
        #: the share of the second of the first two windows in a row judged ``OPPOSED`` (None: none)
        self.opposed: RamShare | None = None
        self._t: list[NDArray[np.int64]] = []
        self._f: list[NDArray[np.float64]] = []
        self._x: list[NDArray[np.float64]] = []
        self._pending = 0
        self._prev: _Rows | None = None          # the last window judged, when no stretch is open
        self._open: _OpenStretch | None = None
        self._finished = False

    @property
    def pending(self) -> int:
        """Instants taken that no window has judged yet."""
        return self._pending

    def feed(self, t_ns: NDArray[np.int64], force: NDArray[np.float64], aux: NDArray[np.float64] | None = None
             ) -> int:
        """Take instants of steady motion at ``t_ns`` (n,) [ns] with the rams' forces ``force``
        (n, 2) [N] (``aux`` (n, k): columns kept for the last window, e.g. the chambers'
        pressures) and judge every window they complete; how many were judged."""
        if self._finished:
            raise ValueError('the rams check is finished: it takes no more instants')
        f = np.asarray(force, dtype=float).reshape(-1, 2)
        ok = np.isfinite(f).all(axis=1)
        t = np.asarray(t_ns, dtype=np.int64).reshape(-1)[ok]
        if not t.size:
            return 0
        self._t.append(t)
        self._f.append(f[ok])
        if aux is not None:
            self._x.append(np.asarray(aux, dtype=float).reshape(f.shape[0], -1)[ok])
        self._pending += t.size
        self.instants += t.size
        judged = 0
        if self._pending >= self.window:
            t_all, f_all = np.concatenate(self._t), np.concatenate(self._f)
            x_all = np.concatenate(self._x) if self._x else None
            k = 0
            while t_all.size - k >= self.window:
                self._judge(t_all[k:k + self.window], f_all[k:k + self.window],
                            None if x_all is None else x_all[k:k + self.window])
                k += self.window
                judged += 1
            self._t, self._f = [t_all[k:]], [f_all[k:]]
            self._x = [] if x_all is None else [x_all[k:]]
            self._pending = t_all.size - k
        return judged

    def finish(self) -> list[UnevenSpan]:
        """Judge the instants after the last whole window (as a window of their own), close
        the stretch still open, and give every stretch. Idempotent."""
        if not self._finished:
            if self._pending:
                t, f = np.concatenate(self._t), np.concatenate(self._f)
                self._judge(t, f, np.concatenate(self._x) if self._x else None)
                self._t, self._f, self._x, self._pending = [], [], [], 0
            if self._open is not None:
                self._close(None)
            self._finished = True
        return list(self.spans)

    def open_span(self) -> UnevenSpan | None:
        """The stretch still open, so far: from its start to the end of its last window judged
        uneven or idle, its share over those (None when none is open)."""
        o = self._open
        if o is None:
            return None
        sh = _share(o.moments())
        if sh is None:
            return None
        return UnevenSpan(o.start_ns, int(o.last[0][-1]) if o.last is not None else o.first_end_ns, sh.weaker,
                          sh.share[sh.weaker], sh.instants, judge(sh, self.warn, self.ram_area) == IDLE)

    def unsettled_from(self) -> int | None:
        """The time [ns] from which instants taken may still join or leave a stretch (None:
        every instant taken is settled): the start of the open stretch's last window judged
        uneven (its end may move in there); else the start of the last window judged (a stretch
        opening next may reach back into it); else the first instant not yet judged."""
        if self._open is not None:
            o = self._open
            return int(o.last[0][0]) if o.last is not None else o.start_ns
        if self._prev is not None:
            return int(self._prev[0][0])
        if self._t:
            return int(self._t[0][0])
        return None

    def excluded(self, t_ns: NDArray[np.int64]) -> NDArray[np.bool_]:
        """Which of the times ``t_ns`` lie in a closed stretch or in the open one so far."""
        spans = list(self.spans)
        o = self.open_span()
        if o is not None:
            spans.append(o)
        return within(t_ns, spans)

    # --- inside ---------------------------------------------------------------------------
    def _judge(self, t: NDArray[np.int64], f: NDArray[np.float64], x: NDArray[np.float64] | None) -> None:
        mo = _moments_of(f)
        sh = _share(mo)
        said = judge(sh, self.warn, self.ram_area)
        # a map that reads a ram the wrong way round does so in every window; a window across
        # the start of a fault (one ram's force falling as the other's rises) can look so once
        twice = said == OPPOSED and self.last is not None and self.last.said == OPPOSED
        if said in (EVEN, UNEVEN, IDLE) or twice:
            self.level = said
        self.assessed |= said in (EVEN, UNEVEN, IDLE)
        self.last = RamsWindow(int(t[0]), int(t[-1]), sh, said, self.level)
        if twice and self.opposed is None:
            self.opposed = sh
        self.last_aux = x
        bad = said in (UNEVEN, IDLE)
        o = self._open
        if o is None:
            if bad:
                self._open = _OpenStretch.starting(self._prev, (t, f), self.warn)
                self._prev = None
            else:
                self._prev = (t, f)
            return
        if bad:
            o.extend((t, f), mo)
        elif said == EVEN or twice:
            self._close((t, f))
            self._prev = (t, f)
        else:
            o.wait((t, f), mo)

    def _close(self, nxt: _Rows | None) -> None:
        o = self._open
        assert o is not None
        self._open = None
        span = o.closed(nxt, self.warn, self.ram_area)
        if span is not None:
            self.spans.append(span)


class _OpenStretch:
    """A stretch of uneven sharing not yet closed (see :class:`RamsCheck`): its start, fixed
    when it opens; the moments of its instants up to its last window judged uneven; that
    window's instants, and the windows after it that could not say."""

    def __init__(self, start_ns: int, head: _Moments, first_end_ns: int, last_rows: _Rows) -> None:
        self.start_ns = start_ns
        self.first_end_ns = first_end_ns
        self.head = head                 # from the start to the last bad window, that one left out
        self.last: _Rows | None = None   # the last bad window after the first
        self.first_rows: _Rows | None = last_rows   # the first bad window's rows from the start
        self.waiting: list[tuple[_Rows, _Moments]] = []

    @classmethod
    def starting(cls, before: _Rows | None, first: _Rows, warn: float) -> _OpenStretch:
        """Open on the window ``first``, its start moved in within it, or out into ``before``."""
        t = first[0] if before is None else np.concatenate([before[0], first[0]])
        f = first[1] if before is None else np.concatenate([before[1], first[1]])
        a0 = 0 if before is None else before[0].size
        sh = ram_share(first[1])
        side = 1.0 if sh is None or sh.share[0] > 0.5 else -1.0
        a = _move_start(f, a0, f.shape[0], side, warn)
        return cls(int(t[a]), _Moments.empty(), int(first[0][-1]), (t[a:], f[a:]))

    def extend(self, rows: _Rows, mo: _Moments) -> None:
        """A further window judged uneven or idle: what waited joins the stretch."""
        if self.first_rows is not None:
            self.head = self.head + _moments_of(self.first_rows[1])
            self.first_rows = None
        elif self.last is not None:
            self.head = self.head + _moments_of(self.last[1])
        for _, m in self.waiting:
            self.head = self.head + m
        self.waiting.clear()
        self.last = rows

    def wait(self, rows: _Rows, mo: _Moments) -> None:
        """A window that could not say: joins the stretch only if a later one is uneven."""
        self.waiting.append((rows, mo))

    def moments(self) -> _Moments:
        """The moments from the start to the end of the last bad window."""
        tail = self.first_rows if self.first_rows is not None else self.last
        return self.head + _moments_of(tail[1]) if tail is not None else self.head

    def closed(self, nxt: _Rows | None, warn: float, ram_area: float) -> UnevenSpan | None:
        """The stretch, its end moved in within its last bad window or out into the window
        after it (the first that waited, else ``nxt``)."""
        tail = self.first_rows if self.first_rows is not None else self.last
        assert tail is not None
        whole = _share(self.moments())
        if whole is None:
            return None
        side = 1.0 if whole.share[0] > 0.5 else -1.0
        after = self.waiting[0][0] if self.waiting else nxt
        t = tail[0] if after is None else np.concatenate([tail[0], after[0]])
        f = tail[1] if after is None else np.concatenate([tail[1], after[1]])
        b = _move_end(f, tail[0].size, f.shape[0], side, warn)
        sh = _share(self.head + _moments_of(f[:b]))
        if sh is None:
            return None
        return UnevenSpan(self.start_ns, int(t[b - 1]), sh.weaker, sh.share[sh.weaker], sh.instants,
                          judge(sh, warn, ram_area) == IDLE)


def _says(part: NDArray[np.float64], side: float, warn: float) -> str | None:
    """What a few instants at a stretch's end say, on their own share's interval as
    :func:`judge` judges (a part whose load hardly varies has a wide one, and says neither):
    ``UNEVEN`` the stretch's way (``side``: +1 ram 1 carries more), ``EVEN``, or None."""
    sh = ram_share(part)
    if sh is None:
        return None
    off, margin = sh.share[0] - 0.5, MARGIN_SE * sh.se
    if side * off - margin > warn:
        return UNEVEN
    if abs(off) + margin < warn:
        return EVEN
    return None


def _move_start(f: NDArray[np.float64], a: int, stop: int, side: float, warn: float) -> int:
    """A stretch's start ``a`` in ``f``, moved in (keeping ``2 EDGE_STEP`` instants before
    ``stop``) while the instants at it share evenly, else out while those before share
    unevenly the stretch's way."""
    a0 = a
    while stop - a > 2 * EDGE_STEP and _says(f[a:a + EDGE_STEP], side, warn) == EVEN:
        a += EDGE_STEP
    if a == a0:
        while a >= 3 and _says(f[max(a - EDGE_STEP, 0):a], side, warn) == UNEVEN:
            a = max(a - EDGE_STEP, 0)
    return a


def _move_end(f: NDArray[np.float64], b: int, hi: int, side: float, warn: float) -> int:
    """A stretch's end ``b`` (exclusive) in ``f``, moved in (keeping ``2 EDGE_STEP`` instants)
    while the instants before it share evenly, else out up to ``hi`` while those after share
    unevenly the stretch's way."""
    b0 = b
    while b > 2 * EDGE_STEP and _says(f[b - EDGE_STEP:b], side, warn) == EVEN:
        b -= EDGE_STEP
    if b == b0:
        while hi - b >= 3 and _says(f[b:min(b + EDGE_STEP, hi)], side, warn) == UNEVEN:
            b = min(b + EDGE_STEP, hi)
    return b


def uneven_spans(t_ns: NDArray[np.int64], force: NDArray[np.float64], warn: float, ram_area: float,
                 window: int = WINDOW_INSTANTS) -> list[UnevenSpan]:
    """The stretches of uneven sharing in a log's instants of steady motion ``t_ns`` (n,) [ns]
    with the rams' forces ``force`` (n, 2) [N]: :class:`RamsCheck` fed them at once."""
    check = RamsCheck(warn, ram_area, window)
    check.feed(t_ns, force)
    return check.finish()


def within(t_ns: NDArray[np.int64], spans: Sequence[UnevenSpan]) -> NDArray[np.bool_]:
    """Which of the times ``t_ns`` (n,) [ns] lie in one of ``spans`` (ends included)."""
    t = np.asarray(t_ns, dtype=np.int64)
    out = np.zeros(t.shape, bool)
    for sp in spans:
        out |= (t >= sp.start_ns) & (t <= sp.end_ns)
    return out


def rams_verdict(spans: Sequence[UnevenSpan], assessed: bool) -> str:
    """The rams check of a log in one line, as ``analyze`` and ``report`` end with it: its
    level (ERROR where a ram did next to no work, WARN where the sharing was uneven, OK when
    judged even throughout, NOT ASSESSED when no window could be judged) and each stretch
    with its ram and UTC times."""
    if spans:
        level = 'ERROR' if any(sp.idle for sp in spans) else 'WARN'
        return f'rams    {level}: ' + '; '.join(describe(sp) for sp in spans)
    if not assessed:
        return ('rams    NOT ASSESSED: no window of steady motion could be judged (each needs '
                f'{MIN_SHARE_INSTANTS} instants with the load varying by {MIN_SHARE_SPREAD_PA / 1e5:g} bar)')
    return 'rams    OK: the rams shared the driving force evenly wherever it was judged'


def uneven_json(sp: UnevenSpan) -> dict[str, object]:
    """A stretch in the JSON vocabulary (docs/json.md): its ends as ``*_utc`` and ``*_ns``, the
    weaker ram (1 or 2), its share [%], instants and whether it did next to no work."""
    return {'start_utc': utc_json(sp.start_ns), 'start_ns': sp.start_ns, 'end_utc': utc_json(sp.end_ns),
            'end_ns': sp.end_ns, 'ram': sp.ram + 1, 'share_pct': round(100 * sp.share, 2),
            'instants': sp.instants, 'idle': sp.idle}


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
