"""The residual's instants of steady motion, taken from the held pressure samples, compiled. Pure.

The live model holds each pressure sample (with all four pressures known) until the rudder's
angle is known 0.3 s past it (and the model's angle delay): then it judges whether the rudder
moved steadily through it (the slopes of the angle over 0.3 s before and after the angle
sample that opens its bracket both past the motion threshold, same sign) and, if so, keeps it
as an instant of steady motion with the angle interpolated to its time
(:class:`~steer_monitor.monitor.live.LiveMonitor`). Which samples an angle sample releases,
and the history of angles it judges them against, are what they were when that angle sample
came; :func:`take_instants` works the judgements out later, for many angle samples at once,
from a log of what each one saw (its release time, the delay then, the first and last angle of
its history, how many pressure samples had been held) and the angles themselves: the same
instants, in the same order, with the same numbers, as judging them as each angle sample
came. The slopes are :mod:`~steer_monitor.monitor.slopes`' (correctly rounded sums); a window
holding a non-finite angle is left to the caller (``state[5]``, then ``given``).

Times are integer ns; values SI.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from steer_monitor.compiled import njit
from steer_monitor.model.ramforce import ram_force_compiled
from steer_monitor.monitor.exactsum import MAX_PARTIALS
from steer_monitor.monitor.slopes import NONE, SLOPE, SPECIAL, slope_of

__all__ = ['CALL_FIELDS', 'OUT_FIELDS', 'take_instants']

#: the log's columns per angle sample: the time up to which it releases held samples [ns], the
#: angle delay then [ns], the global indices of the first and last angle of its history, and
#: how many pressure samples had been held when it came
CALL_FIELDS = ('t_end', 'delay', 'first', 'last', 'held')
#: an instant's columns: the angle [rad], ship speed [m/s] (NaN: not known), direction
#: (+1/-1), the rams' forces [N], rate [rad/s], oil temperature [K], the four pressures [Pa]
OUT_FIELDS = ('alpha', 'speed', 'direction', 'force_1', 'force_2', 'rate', 'oil', 'p0', 'p1', 'p2', 'p3', 'held')


@njit(cache=True, nogil=True)
def _bisect_right(a: NDArray[np.int64], x: int, lo: int, hi: int) -> int:
    """Python's ``bisect.bisect_right`` (the same index on any data, sorted or not)."""
    while lo < hi:
        mid = (lo + hi) // 2
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo


@njit(cache=True, nogil=True)
def _bisect_left(a: NDArray[np.int64], x: int, lo: int, hi: int) -> int:
    """Python's ``bisect.bisect_left``."""
    while lo < hi:
        mid = (lo + hi) // 2
        if a[mid] < x:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True)
def take_instants(pend_t: NDArray[np.int64], pend_p: NDArray[np.float64], pend_first: int,
                  calls: NDArray[np.int64], env: NDArray[np.float64], angle_t: NDArray[np.int64],
                  angle_a: NDArray[np.float64], angle_first: int, half_ns: int, moving: float, step_ns: int,
                  area: float, state: NDArray[np.int64], given: NDArray[np.float64], out: NDArray[np.float64],
                  n: int) -> int:
    """Judge held pressure samples as the angle samples of ``calls`` release them.

    Args:
        pend_t, pend_p: the held samples not yet released, in the order held: times (J,) [ns]
            and the four pressures (J, 4) [Pa]; ``pend_first`` the global count of the first.
        calls: per angle sample, in the order they came (K, 5): :data:`CALL_FIELDS`; ``env``
            the ship's speed [m/s] (NaN: not known) and oil temperature [K] then (K, 2).
        angle_t, angle_a: the angle samples (M,) [ns, rad] from global index ``angle_first``
            on, holding every history in ``calls``.
        half_ns: each side of an angle sample its steady-motion slopes are taken over [ns];
            ``moving``: the motion threshold [rad/s]; ``step_ns``: the most motion a bracket
            counts [ns]; ``area``: a ram's area [m^2].
        state: in and out (6,): the next call, the next held sample (both from 0), the time of
            the last bracket counted [ns], whether there is one (0/1), the motion counted
            since [ns], and (out) the index into ``angle_t`` of a bracket whose slopes are left
            to the caller, or -1.
        given: (6,): a call, an index into ``angle_t``, and that bracket's slopes before and
            after worked out by the caller, each as (known 1/0, slope [rad/s]) (call -1: none).
        out, n: the instants of steady motion, written from row ``n`` (0, or the return of
            the previous call of this batch) (J, 12): :data:`OUT_FIELDS` (``held``: the
            instant's index into ``pend_t``, exact in a float).

    Returns: the rows of ``out`` filled. ``state[5]`` >= 0: stopped at a bracket holding a
    non-finite angle: work it out, put it in ``given`` and call again with this return.
    """
    p = np.empty(MAX_PARTIALS)
    ts = np.empty(max(angle_t.shape[0], 1))
    k, j = state[0], state[1]
    memo_i, memo_lo, memo_hi = -1, -1, -1          # the last bracket judged, in the history it was judged in
    s1, v1, s2, v2 = NONE, 0.0, NONE, 0.0
    counted, has_counted, motion = state[2], state[3], state[4]
    state[5] = -1
    while k < calls.shape[0]:
        t_end, delay, held = calls[k, 0], calls[k, 1], calls[k, 4]
        lo, hi = calls[k, 2] - angle_first, calls[k, 3] - angle_first + 1   # the history: angle_t[lo:hi]
        while j < pend_t.shape[0] and pend_first + j < held and pend_t[j] <= t_end:
            t = pend_t[j]
            i = _bisect_right(angle_t, t + delay, lo, hi) - 1
            if i < lo or i + 1 >= hi:
                j += 1
                continue
            if given[0] == k and given[1] == i:
                s1, v1 = (SLOPE if given[2] else NONE), given[3]
                s2, v2 = (SLOPE if given[4] else NONE), given[5]
                memo_i, memo_lo, memo_hi = i, lo, hi
            elif i != memo_i or lo != memo_lo or hi != memo_hi:
                t_i = angle_t[i]
                s1, v1 = slope_of(angle_t, angle_a, _bisect_left(angle_t, t_i - half_ns, lo, hi), i + 1, p, ts)
                s2, v2 = slope_of(angle_t, angle_a, i, _bisect_right(angle_t, t_i + half_ns, lo, hi), p, ts)
                if s1 == SPECIAL or s2 == SPECIAL:
                    state[0], state[1], state[2], state[3], state[4], state[5] = k, j, counted, has_counted, motion, i
                    return n
                memo_i, memo_lo, memo_hi = i, lo, hi
            # steady: both slopes past the threshold, same sign; the rate their mean (the
            # smaller as Python's min picks it, the first unless the second is less)
            least = abs(v2) if abs(v2) < abs(v1) else abs(v1)
            if s1 == NONE or s2 == NONE or least <= moving or (v1 > 0) != (v2 > 0):
                direction, rate = 0.0, 0.0
            else:
                direction, rate = (1.0 if v1 > 0 else -1.0), 0.5 * (v1 + v2)
            if direction != 0.0 and (has_counted == 0 or angle_t[i] > counted):
                motion += min(angle_t[i + 1] - angle_t[i], step_ns)
                counted, has_counted = angle_t[i], 1
            j += 1
            if direction == 0.0:
                continue
            t_a, a_a, t_b, a_b = angle_t[i], angle_a[i], angle_t[i + 1], angle_a[i + 1]
            c0, c1, c2, c3 = pend_p[j - 1, 0], pend_p[j - 1, 1], pend_p[j - 1, 2], pend_p[j - 1, 3]
            out[n, 0] = a_a + (a_b - a_a) * float(t + delay - t_a) / float(t_b - t_a)
            out[n, 1], out[n, 2] = env[k, 0], direction
            out[n, 3], out[n, 4] = ram_force_compiled(area, c0, c1), ram_force_compiled(area, c2, c3)
            out[n, 5], out[n, 6] = rate, env[k, 1]
            out[n, 7], out[n, 8], out[n, 9], out[n, 10] = c0, c1, c2, c3
            out[n, 11] = j - 1
            n += 1
        k += 1
    state[0], state[1], state[2], state[3], state[4] = k, j, counted, has_counted, motion
    return n
