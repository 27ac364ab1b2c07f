"""The one rams check: whether the two rams share the driving force, over a log or live. Pure.

The node's ``rams`` status, ``analyze``, ``report`` and ``fleet`` all judge by
:class:`RamsCheck`: instants of steady motion cut into windows of ``WINDOW_INSTANTS``, each
window's share (:func:`~steer_monitor.estimate.rams.ram_share`) judged on its interval
(:func:`~steer_monitor.estimate.rams.judge`), a level with hysteresis, and the stretches of
uneven sharing with their ends found to ``EDGE_STEP`` instants, named by ram and UTC times.
"""

from __future__ import annotations

import datetime
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from steer_monitor.estimate.rams import (
    EVEN,
    IDLE,
    MARGIN_SE,
    MIN_SHARE_INSTANTS,
    MIN_SHARE_SPREAD_PA,
    OPPOSED,
    UNEVEN,
    UNEVEN_CAUSE,
    UNJUDGED,
    RamShare,
    ShareMoments,
    judge,
    ram_share,
    share_moments,
    share_of_moments,
)
from steer_monitor.utc import utc_json

__all__ = ['EDGE_STEP', 'WINDOW_INSTANTS', 'RamsCheck', 'RamsWindow', 'UnevenSpan', 'describe', 'rams_verdict',
           'uneven_json', 'uneven_spans', 'within']

#: instants of steady motion a window of the check holds (30 s of it on the 50 ms grid)
WINDOW_INSTANTS = 600
#: instants a stretch's end moves by at a time (3 s of steady motion on the 50 ms grid)
EDGE_STEP = 60


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
    of the instants it then holds (``idle`` when a window of it was judged ``IDLE``, as the level
    then was, or its own share is) (moments merged window by window: memory stays bounded
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
        sh = share_of_moments(o.moments())
        if sh is None:
            return None
        return UnevenSpan(o.start_ns, int(o.tail[0][-1]), sh.weaker, sh.share[sh.weaker], sh.instants,
                          o.idle or judge(sh, self.warn, self.ram_area) == IDLE)

    def unsettled_from(self) -> int | None:
        """The time [ns] from which instants taken may still join or leave a stretch (None:
        every instant taken is settled): the start of the open stretch's last window judged
        uneven (its end may move in there); else the start of the last window judged (a stretch
        opening next may reach back into it); else the first instant not yet judged."""
        if self._open is not None:
            return int(self._open.tail[0][0])
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
        mo = share_moments(f)
        sh = share_of_moments(mo)
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
                self._open = _OpenStretch.starting(self._prev, (t, f), mo, sh, self.warn)
                self._open.idle = said == IDLE
                self._prev = None
            else:
                self._prev = (t, f)
            return
        if bad:
            o.extend((t, f), mo)
            o.idle |= said == IDLE
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
    when it opens; the moments of its instants before its last window judged uneven; that
    window's instants (the first window's from the start) and moments, and the windows after
    it that could not say."""

    def __init__(self, start_ns: int, tail: _Rows, tail_moments: ShareMoments) -> None:
        self.start_ns = start_ns
        self.head = ShareMoments.empty()   # from the start to the last bad window, that one left out
        self.tail = tail                   # the last bad window's rows
        self.tail_moments = tail_moments
        self.waiting: list[tuple[_Rows, ShareMoments]] = []
        self.idle = False                  # a window of it was judged IDLE: the stretch is, as the level was

    @classmethod
    def starting(cls, before: _Rows | None, first: _Rows, first_moments: ShareMoments, sh: RamShare | None,
                 warn: float) -> _OpenStretch:
        """Open on the window ``first`` (its moments, its share ``sh``), its start moved in
        within it, or out into ``before``."""
        t = first[0] if before is None else np.concatenate([before[0], first[0]])
        f = first[1] if before is None else np.concatenate([before[1], first[1]])
        a0 = 0 if before is None else before[0].size
        side = 1.0 if sh is None or sh.share[0] > 0.5 else -1.0
        a = _move_start(f, a0, f.shape[0], side, warn)
        return cls(int(t[a]), (t[a:], f[a:]), first_moments if a == a0 else share_moments(f[a:]))

    def extend(self, rows: _Rows, mo: ShareMoments) -> None:
        """A further window judged uneven or idle (its rows and moments): the last one and what
        waited join the stretch's head."""
        self.head = self.head + self.tail_moments
        for _, m in self.waiting:
            self.head = self.head + m
        self.waiting.clear()
        self.tail, self.tail_moments = rows, mo

    def wait(self, rows: _Rows, mo: ShareMoments) -> None:
        """A window that could not say: joins the stretch only if a later one is uneven."""
        self.waiting.append((rows, mo))

    def moments(self) -> ShareMoments:
        """The moments from the start to the end of the last bad window."""
        return self.head + self.tail_moments

    def closed(self, nxt: _Rows | None, warn: float, ram_area: float) -> UnevenSpan | None:
        """The stretch, its end moved in within its last bad window or out into the window
        after it (the first that waited, else ``nxt``)."""
        whole = share_of_moments(self.moments())
        if whole is None:
            return None
        side = 1.0 if whole.share[0] > 0.5 else -1.0
        tail = self.tail
        after = self.waiting[0][0] if self.waiting else nxt
        t = tail[0] if after is None else np.concatenate([tail[0], after[0]])
        f = tail[1] if after is None else np.concatenate([tail[1], after[1]])
        b = _move_end(f, tail[0].size, f.shape[0], side, warn)
        sh = share_of_moments(self.head + (self.tail_moments if b == tail[0].size else share_moments(f[:b])))
        if sh is None:
            return None
        return UnevenSpan(self.start_ns, int(t[b - 1]), sh.weaker, sh.share[sh.weaker], sh.instants,
                          self.idle or judge(sh, warn, ram_area) == IDLE)


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
