"""Diagnostic statuses of the monitor, one per concern (REP-107 names), built from the live
state. Pure: the node turns them into ``diagnostic_msgs/DiagnosticArray``.

Values are (key, text) pairs with the unit in the key (``clearance_zgb_mm``), so
diagnostic_aggregator and rqt_robot_monitor show them as they are.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from operator import is_
from typing import Any

import numpy as np

from steer_monitor.can.rejects import RejectSnapshot
from steer_monitor.can.signals import SignalMap
from steer_monitor.estimate.rams import (
    AT_EDGE,
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
    enough,
    opposed_cause,
    weak_ram_cause,
)
from steer_monitor.estimate.ramscheck import RamsCheck, describe
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.hardover import hard_over_time, pumps_running
from steer_monitor.model.inputs import PRESSURE_INPUTS, REQUIRED
from steer_monitor.model.landmarks import landmarks
from steer_monitor.model.loadshare import load_sharing_at
from steer_monitor.monitor.arrivals import ARRIVALS_KEPT_NS, RATE_WINDOW_NS
from steer_monitor.monitor.live import LiveMonitor
from steer_monitor.monitor.performance import hard_over_words, solas_judgement
from steer_monitor.monitor.verdict import ERROR, NOT_ASSESSED, OK, WARN, Verdict, clearance_verdict, worst
from steer_monitor.params import NODE_NAME, ram_share_warn_from_params
from steer_monitor.utc import utc_json, utc_text

__all__ = ['ASSESSMENT_KEY', 'ERROR', 'LEVEL_NAMES', 'NOT_ASSESSED_TEXT', 'OK', 'SILENT_PERIODS',
           'SLOW_DEFAULT_INTERVAL_NS', 'STALE', 'WARN', 'DiagnosticsBuilder', 'DiagnosticsConfig', 'Status',
           'status_name']

#: NMEA 2000's default transmission interval for slow data (Actual Pressure, PGN 130314, among
#: them): an input heard once is judged silent after three of these, until its own period is known
SLOW_DEFAULT_INTERVAL_NS = 2_000_000_000
#: a silence this much longer than an input's own period is a gap, counted with its UTC time
#: (as ``inspect`` counts them)
GAP_NS = 1_000_000_000
#: an input is silent once this many of its own periods passed without it (and
#: ``diagnostics.stale_after_s``): four lost in a row is not silence
SILENT_PERIODS = 5
STALE = 3          # REP-107 levels: OK, WARN and ERROR (0, 1, 2) are the verdict's own
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR', STALE: 'STALE'}
#: the value that says whether a status that judges the gear (clearances, guide beam, rams) has
#: judged it: ``assessed`` or :data:`NOT_ASSESSED_TEXT`
ASSESSMENT_KEY = 'assessment'
NOT_ASSESSED_TEXT = 'NOT ASSESSED'


def status_name(node_name: str, item: str) -> str:
    """A status's name, ``node: item`` as diagnostic_updater names a node's tasks: two monitors
    on one ship (``port_gear``, ``stbd_gear``) publish statuses of their own."""
    return f'{node_name}: {item}'


@dataclass(frozen=True)
class Status:
    """One diagnostic status."""

    name: str
    level: int
    message: str
    hardware_id: str
    values: tuple[tuple[str, str], ...]

    def value(self, key: str) -> str:
        return dict(self.values)[key]

    @property
    def assessed(self) -> bool:
        """False where the status says the data do not tell yet (:data:`NOT_ASSESSED_TEXT`)."""
        return dict(self.values).get(ASSESSMENT_KEY) != NOT_ASSESSED_TEXT

    @property
    def label(self) -> str:
        """The level in words, NOT ASSESSED where the status is not (published at level OK)."""
        return LEVEL_NAMES[self.level] if self.assessed else NOT_ASSESSED_TEXT


@dataclass(frozen=True)
class DiagnosticsConfig:
    """Thresholds of the statuses (SI except where named)."""

    hardware_id: str
    #: the node's name, which each status's name begins with (:func:`status_name`)
    node_name: str = NODE_NAME
    stale_after_s: float = 2.0
    clearance_warn_share: float = 0.8
    limit_2z: float = 0.6e-3
    limit_zgb: float = 0.25e-3
    guide_idle_warn_deg: float = 10.0
    solas_hard_over_s: float = 28.0
    #: WARN when a ram's share of the driving force departs from an even half by more than this
    ram_share_warn: float = 0.15
    #: the gear's main pumps (SOLAS's hard-over time is judged with all of them running)
    pumps: int = 2
    #: ram speed one pump gives [m/s]
    ram_speed_per_pump: float = 15e-3

    @classmethod
    def from_params(cls, p: Mapping[str, Any], node_name: str = NODE_NAME) -> DiagnosticsConfig:
        return cls(hardware_id=p['node.hardware_id'], node_name=node_name, stale_after_s=p['diagnostics.stale_after_s'],
                   clearance_warn_share=p['diagnostics.clearance_warn_share'],
                   limit_2z=p['clearances.limit_2z_mm'] * 1e-3, limit_zgb=p['clearances.limit_zgb_mm'] * 1e-3,
                   guide_idle_warn_deg=p['diagnostics.guide_idle_warn_deg'],
                   solas_hard_over_s=p['diagnostics.solas_hard_over_s'],
                   ram_share_warn=ram_share_warn_from_params(p),
                   pumps=p['hydraulics.pumps'], ram_speed_per_pump=p['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3)


def _f(x: float | None, fmt: str = '.3f') -> str:
    return 'n/a' if x is None or (isinstance(x, float) and not math.isfinite(x)) else format(x, fmt)


def _share_words(sh: RamShare | None) -> str:
    """A window's shares in words, ram 1's with its interval (``MARGIN_SE`` standard errors)."""
    if sh is None:
        return 'no share (fewer than three instants)'
    def pct(x: float) -> str:           # whole percent, never '-0'
        return f'{x:.0f}' if abs(x) >= 0.5 else '0'
    m = 100 * MARGIN_SE * sh.se
    p = 100 * sh.share[0]
    return f'ram 1 {pct(p)} % [{pct(max(p - m, 0.0))} .. {pct(min(p + m, 100.0))}], ram 2 {pct(100 * sh.share[1])} %'


class DiagnosticsBuilder:
    """Builds the statuses; caches the guide-beam onset angle per clearance pair."""

    def __init__(self, cfg: DiagnosticsConfig, smap: SignalMap, gear: GearParams) -> None:
        self.cfg = cfg
        self.smap = smap
        self.gear = gear
        self._onset_cache: dict[Clearances, float | None] = {}
        # per status, the last one built with what it was built from (:meth:`_memo`)
        self._memos: dict[str, tuple[tuple[Any, ...], tuple[object, ...], Status]] = {}
        # per input: its name, how long it may be silent [s], the window its rate is judged
        # over [ns], its expected rate [Hz], the keys of its rate and silence, and its expected
        # rate as a (key, text) value
        # per input: its name, its configured rate [Hz], how long it may be silent [s] and the
        # window its rate is judged over [ns] before its own period is known, and the keys of
        # its values
        self._inputs = [(spec.name, spec.rate_hz, max(cfg.stale_after_s, 3.0 / spec.rate_hz),
                         # over five of its periods at least: a 0.5 Hz input has two in 5 s, and one
                         # late frame would read as rate 0
                         min(ARRIVALS_KEPT_NS, max(RATE_WINDOW_NS, int(5e9 / spec.rate_hz))),
                         (f'{spec.name}_rate_hz', f'{spec.name}_expected_hz', f'{spec.name}_interval_s',
                          f'{spec.name}_silent_s')) for spec in smap.specs]

    def _status(self, item: str, level: int, message: str, values: list[tuple[str, str]]) -> Status:
        return Status(status_name(self.cfg.node_name, item), level, message, self.cfg.hardware_id, tuple(values))

    def _judged(self, item: str, verdict: int, message: str, values: list[tuple[str, str]]) -> Status:
        """A status that judges the gear, from its ``verdict`` (OK, WARN, ERROR or NOT_ASSESSED).
        NOT ASSESSED is published at level OK with ``assessment: NOT ASSESSED`` and the message
        saying why and what would assess it: a level is what diagnostic_aggregator rolls up, and
        it reads a STALE item beside fresh ones as ERROR, so a gear not yet assessed after a
        normal start would read as a fault; the level says a fault seen, the assessment what
        is known."""
        values = [*values, (ASSESSMENT_KEY, NOT_ASSESSED_TEXT if verdict == NOT_ASSESSED else 'assessed')]
        return self._status(item, OK if verdict == NOT_ASSESSED else verdict, message, values)

    def _memo(self, item: str, key: tuple[Any, ...], objects: tuple[object, ...], make: Callable[[], Status]
              ) -> Status:
        """The status ``make()`` builds, built again only when what it is built from changed:
        ``key`` plain values (compared by value), ``objects`` immutable ones (compared by
        identity; held here, so an identity is not reused while compared). Most seconds the
        clearances, the performance, the model's health and the rams are what they were a
        second before (at rest for hours), and their text costs tens of microseconds."""
        hit = self._memos.get(item)
        if hit is not None and hit[0] == key and all(map(is_, hit[1], objects)):
            return hit[2]
        status = make()
        self._memos[item] = (key, objects, status)
        return status

    def guide_onset_deg(self, gaps: Clearances) -> float | None:
        """Angle from which the guide beam carries load at service speed (None: never)."""
        if gaps.z_gb <= 0:
            return 0.0              # in contact from the start: carries load at any angle
        if gaps not in self._onset_cache:
            alpha = np.radians(np.arange(0.0, math.degrees(self.gear.max_rudder) + 1e-9, 0.1))
            marks = landmarks(alpha, load_sharing_at(self.gear, alpha, gaps))
            if len(self._onset_cache) >= 8:
                self._onset_cache.pop(next(iter(self._onset_cache)))
            self._onset_cache[gaps] = None if marks.guide_onset is None else math.degrees(marks.guide_onset)
        return self._onset_cache[gaps]

    def build(self, mon: LiveMonitor, rejects: RejectSnapshot, now_ns: int,
              recording: Status | None = None, why: str | None = None, off: str | None = None) -> list[Status]:
        """The statuses at ``now_ns``; ``why``: why the last analysis gave no finding (None: it
        did, or none ran yet); ``off``: why no analysis runs at all (None: they run)."""
        out = [self.can_input(mon, rejects, now_ns), self.clearances(mon), self.guide_beam(mon),
               self.performance(mon), self.model_health(mon, why, off), self.rams(mon)]
        if recording is not None:
            out.append(recording)
        return out

    def can_input(self, mon: LiveMonitor, rejects: RejectSnapshot, now_ns: int) -> Status:
        """Each input judged against its own period (the median interval of its arrivals kept),
        whatever the parameters say it comes at: a gateway forwarding the angle at 2 Hz is at
        its rate, not slow. Silent (STALE for a required input, WARN for another) past
        ``diagnostics.stale_after_s`` or :data:`SILENT_PERIODS` of its own periods, whichever
        is longer, so a burst of lost frames of a slow input is not silence (an input heard
        only once: that many of NMEA 2000's default interval for slow data,
        :data:`SLOW_DEFAULT_INTERVAL_NS`); WARN when over the arrivals kept (the last 30 s: an
        outage of a few seconds is not half of them) fewer than half the frames its period
        promises came (frames lost). An input coming steadily slower than the parameters say is said in
        the message, at level OK."""
        values: list[tuple[str, str]] = []
        stale, slow, slower = [], [], []
        signals = mon.inputs.signals
        for name, configured_hz, limit, window_ns, keys in self._inputs:
            sig = signals[name]
            period = sig.timing().period_ns
            if period is None and sig.kept() == 2:
                period = sig.times[-1] - sig.times[-2]
            if period is not None and period > 0:
                window_ns = ARRIVALS_KEPT_NS
                limit = max(limit, SILENT_PERIODS * period / 1e9)
            elif sig.kept() == 1:
                limit = max(limit, SILENT_PERIODS * SLOW_DEFAULT_INTERVAL_NS / 1e9)
            rate = sig.rate_hz(now_ns, window_ns)
            silent = sig.silent_for(now_ns)            # finite where heard: a difference of stamps
            if period is not None and period > 0:
                sig.count_gaps(period, int(GAP_NS + period))
            values += ((keys[0], f'{rate:.2f}'), (keys[1], f'{configured_hz:g}'),
                       (keys[2], 'n/a' if period is None else f'{period / 1e9:.3f}'),
                       (keys[3], 'n/a' if silent is None else f'{silent:.2f}'),
                       (f'{name}_frames_lost', str(sig.lost)), (f'{name}_gaps', str(sig.gaps)),
                       (f'{name}_last_gap_utc', 'none' if sig.last_gap is None else utc_json(sig.last_gap[0]) or ''),
                       (f'{name}_last_gap_s', 'n/a' if sig.last_gap is None
                        else f'{(sig.last_gap[1] - sig.last_gap[0]) / 1e9:.1f}'))
            if silent is None or silent > limit:
                stale.append(name)
            elif period is not None and sig.kept() >= 3:   # a rate is judged once it has a few arrivals
                if rate < 0.5e9 / period:
                    slow.append(name)
                elif 1e9 / period < 0.5 * configured_hz:
                    slower.append(f'{name} {1e9 / period:.2g} Hz ({configured_hz:g} configured)')
        for reason, n in sorted(rejects.counts.items()):
            values.append((f'rejects_{reason}', str(n)))
        values.append(('rejects_total', str(rejects.total)))
        required_stale = [n for n in stale if n in REQUIRED]
        if stale:
            level = STALE if required_stale else WARN
            message = 'silent: ' + ', '.join(stale)
        elif slow:
            level, message = WARN, 'below half its own rate (frames lost): ' + ', '.join(slow)
        else:
            level, message = OK, f'all {len(self.smap.specs)} inputs at rate'
            if slower:
                message += ('; slower than the parameters say, judged at their own rates: ' + ', '.join(slower)
                            + ' (set their rate_hz to what comes, as steer-monitor discover writes it: the '
                            "node's steady motion, which its analyses wait for, is judged at the angle's)")
        if rejects.total and level == OK:
            message += f'; {rejects.total} rejected ({", ".join(sorted(rejects.counts))})'
        return self._status('CAN input', level, message, values)

    def clearances(self, mon: LiveMonitor) -> Status:
        """The clearances in use, judged on their interval (:meth:`_clearances`)."""
        interval = mon.gaps_interval
        key = (mon.gaps, mon.gaps_source, None if interval is None else tuple(interval.items()),
               tuple(mon.estimate_info.items()), tuple(sorted(mon.last_assessed.items())))
        return self._memo('clearances', key, (mon.finding,), lambda: self._clearances(mon))

    def _clearances(self, mon: LiveMonitor) -> Status:
        """Each clearance judged on its interval (:func:`~steer_monitor.monitor.verdict.clearance_verdict`):
        OVER LIMIT (ERROR) when its lower end is past the limit, WARN when past the warning share,
        OK when assessed and within limits, and NOT ASSESSED (:meth:`_judged`) when the data cannot say:
        not estimated yet, a lower bound below the warning, an interval reaching from below the
        warning past the limit, or an analysis whose model does not explain the pressures (model
        health carries that WARN).
        A clearance not assessed now shows the last value that was, with its date."""
        cfg = self.cfg
        gaps = mon.gaps
        interval = mon.gaps_interval or {}
        f = mon.finding
        values = [('clearance_source', mon.gaps_source)]
        levels = []
        parts = []
        unexplained = f is not None and not f.explained
        for k, (key, value, limit) in enumerate((('2z', gaps.two_z, cfg.limit_2z), ('zgb', gaps.z_gb, cfg.limit_zgb))):
            lo, hi = interval.get(key, (None, None)) if interval else (None, None)
            values += [(f'clearance_{key}_mm', f'{value * 1e3:.3f}'),
                       (f'clearance_{key}_lo_mm', _f(None if lo is None else lo * 1e3)),
                       (f'clearance_{key}_hi_mm', _f(None if hi is None else hi * 1e3)),
                       (f'limit_{key}_mm', f'{limit * 1e3:.3f}')]
            name = '2Z' if key == '2z' else 'Z_gb'
            why = f.bound_why[k] if f is not None else ''
            reach = f.reach[k] if f is not None and f.reach is not None else None
            v = clearance_verdict(value, lo, hi, limit, cfg.clearance_warn_share, name, why, reach)
            if unexplained:
                v = Verdict(NOT_ASSESSED, v.share, 'the model in use does not explain the pressures '
                                                   f'(systematic part {f.systematic_bar:.2f} bar against '
                                                   f'{f.noise_bar:.2f} bar of sensor noise; see model health)')
            if lo is None:
                text = f'{name} {value * 1e3:.3f} mm configured'
            elif hi is None:      # a bound below the limit is no share of it
                text = f'{name} >= {lo * 1e3:.3f} mm' + (f' ({lo / limit:.0%} of limit)' if lo > limit else '')
            else:
                text = f'{name} {value * 1e3:.3f} mm [{lo * 1e3:.3f} .. {hi * 1e3:.3f}] ({value / limit:.0%} of limit)'
            text += f' {v.label}'
            if v.note:
                text += f': {v.note}'
            last = mon.last_assessed.get(key)
            if not v.assessed and last is not None:
                lv, llo, lhi, lt = last
                text += (f'; last assessed {lv * 1e3:.3f} mm [{llo * 1e3:.3f} .. {lhi * 1e3:.3f}] '
                         f'on the data of {utc_json(lt)}')
                values.append((f'clearance_{key}_last_assessed', f'{lv * 1e3:.3f} [{llo * 1e3:.3f} .. {lhi * 1e3:.3f}] '
                                                                 f'{utc_json(lt)}'))
            values.append((f'clearance_{key}_level', v.label))
            parts.append(text)
            levels.append(v.level)
        worst_level = worst(levels)
        message = '; '.join(parts) + f' [{mon.gaps_source}]'
        if not mon.gaps_interval:
            values.append(('clearance_interval', 'none: configured values, not estimated'))
        if f is not None:
            values.append(('judged', 'yes' if f.explained else 'no: the model does not explain the pressures'))
        values += sorted(mon.estimate_info.items())
        return self._judged('clearances', worst_level, message, values)

    def guide_beam(self, mon: LiveMonitor) -> Status:
        onset = self.guide_onset_deg(mon.gaps)
        state = mon.state
        k_now = state.share.k_gl if state is not None and state.share is not None else None
        values = [('k_gl', _f(k_now)), ('guide_onset_deg', _f(onset, '.2f')),
                  ('guide_idle_warn_deg', f'{self.cfg.guide_idle_warn_deg:g}')]
        if state is not None and state.share is not None:
            values += [('rudder_angle_deg', f'{math.degrees(state.alpha):.2f}'),
                       ('lateral_force_kn', f'{state.share.lateral / 1e3:.1f}'),
                       ('ram_force_kn', f'{state.share.ram_force / 1e3:.1f}'),
                       ('guide_force_kn', f'{state.share.guide_force / 1e3:.1f}')]
        warn = self.cfg.guide_idle_warn_deg
        idle = onset is None or onset > warn

        def carries(at: float | None) -> str:
            return ('carries nothing over the whole range' if at is None else
                    f'is idle up to {at:.2f} deg (warn above {warn:g} deg)' if at > warn else
                    f'carries load from {at:.2f} deg')

        # judged on the estimate, not the configured values, and on its interval: WARN only
        # when the guide is idle beyond the warning even at the smallest Z_gb the data allow;
        # where that cannot be said, NOT ASSESSED and why, never OK beside a passed threshold
        level = OK
        if not mon.gaps_interval:
            level = NOT_ASSESSED
            message = ('NOT ASSESSED: the clearances are not estimated yet; at the configured ones the guide beam '
                       f'{carries(onset)}')
        elif idle:
            lo = mon.gaps_interval.get('zgb', (None, None))[0]
            onset_lo = onset if lo is None else self.guide_onset_deg(Clearances(mon.gaps.two_z, lo))
            values.append(('guide_onset_lo_deg', _f(onset_lo, '.2f')))
            message = f'guide beam {carries(onset)}'
            if onset_lo is None or onset_lo > warn:
                level = WARN
            else:
                level = NOT_ASSESSED
                message = (f'NOT ASSESSED: on the estimate the guide beam {carries(onset)}, but from '
                           f'{onset_lo:.2f} deg at the low end of the Z_gb interval: the interval reaches either side '
                           'of the warning')
        else:
            hi = mon.gaps_interval.get('zgb', (None, None))[1]
            onset_hi = None if hi is None else self.guide_onset_deg(Clearances(mon.gaps.two_z, hi))
            values.append(('guide_onset_hi_deg', _f(onset_hi, '.2f')))
            message = f'guide beam {carries(onset)}'
            if onset_hi is None or onset_hi > warn:     # the interval reaches past the warning
                level = NOT_ASSESSED
                reach = ('the high end of the Z_gb interval is open' if hi is None else
                         'at the high end of the Z_gb interval it carries nothing' if onset_hi is None else
                         f'from {onset_hi:.2f} deg at the high end of the Z_gb interval')
                message = (f'NOT ASSESSED: on the estimate the guide beam {carries(onset)}, but {reach}: the interval '
                           'reaches either side of the warning')
        if k_now is not None:
            message += f'; K_gl now {k_now:.2f}'
        return self._judged('guide beam', level, message, values)

    def pumps_running(self, hard_over_s: float) -> int:
        """Pumps that ran a hard-over of ``hard_over_s`` [s] (:mod:`~steer_monitor.model.hardover`)."""
        return pumps_running(hard_over_s, self.gear.stock_to_ram, self.cfg.ram_speed_per_pump, self.cfg.pumps)

    def one_pump_hard_over_s(self) -> float:
        """The hard-over time of one pump at its nominal ram speed [s]."""
        return hard_over_time(self.gear.stock_to_ram, self.cfg.ram_speed_per_pump)

    def performance(self, mon: LiveMonitor) -> Status:
        """The hard-over time against SOLAS and the response to the last order step."""
        r = mon.response
        key = (mon.hard_over, None if r is None else (r.order, r.t_step_ns, r.direction_ok, r.delay_s, r.accuracy,
                                                       r.stalled_s, r.stalled_at))
        return self._memo('performance', key, (), lambda: self._performance(mon))

    def _performance(self, mon: LiveMonitor) -> Status:
        """The last hard-over judged against SOLAS (:func:`~steer_monitor.monitor.performance.solas_judgement`:
        WARN only when even its shortest reading is over, a sampling that leaves it open said),
        and the response to the last order step."""
        h = mon.hard_over
        values = [('hard_over_s', _f(None if h is None else h.seconds, '.1f')),
                  ('hard_over_min_s', _f(None if h is None else h.seconds_min, '.1f')),
                  ('solas_limit_s', f'{self.cfg.solas_hard_over_s:g}')]
        level, parts = OK, []
        if h is None:
            parts.append('no hard-over seen yet')
        else:
            pumps = self.pumps_running(h.seconds)
            values.append(('hard_over_pumps', str(pumps)))
            head = (f'hard-over 35 deg to 30 deg the other side in {hard_over_words(h)} with '
                    f"{pumps} pump{'s' if pumps > 1 else ''}")
            solas = self.cfg.solas_hard_over_s
            if pumps < self.cfg.pumps:     # SOLAS's time is for the gear's pumps: reported, not judged
                parts.append(f'{head}, as its time says (one pump: {self.one_pump_hard_over_s():.0f} s; SOLAS '
                             f'{solas:g} s is judged with {self.cfg.pumps})')
            else:
                within = solas_judgement(h, solas)
                if within is None:
                    parts.append(f'{head} (SOLAS {solas:g} s not judged: the angle\'s samples leave the time either '
                                 'side of it)')
                else:
                    level = OK if within else WARN
                    parts.append(f"{head} ({'within' if within else 'OVER'} SOLAS {solas:g} s)")
        r = mon.response
        values += [
            ('order_deg', _f(None if r is None else math.degrees(r.order), '.2f')),
            ('response_direction_ok', 'n/a' if r is None or r.direction_ok is None else str(r.direction_ok).lower()),
            ('response_delay_s', _f(None if r is None else r.delay_s, '.2f')),
            ('response_accuracy_deg', _f(None if r is None or r.accuracy is None else math.degrees(r.accuracy), '.2f')),
            ('response_stalled_s', _f(None if r is None else r.stalled_s, '.1f')),
        ]
        if r is not None and r.stalled_s is not None and r.stalled_at is not None:
            level = ERROR
            parts.append(
                f'rudder has not moved for {r.stalled_s:.0f} s since the order went to '
                f'{math.degrees(r.order):.1f} deg (rudder at {math.degrees(r.stalled_at):.1f} deg): the rudder '
                'angle sensor frozen, the rudder jammed, or no pump running'
            )
        elif r is not None and r.direction_ok is False:
            level = ERROR
            parts.append('rudder moved AGAINST the order')
        elif r is not None and r.delay_s is not None:
            parts.append(f'responds to orders in {r.delay_s:.2f} s')
        return self._status('steering performance', level, '; '.join(parts), values)

    def model_health(self, mon: LiveMonitor, why: str | None = None, off: str | None = None) -> Status:
        """Judged as ``analyze`` judges: the last analysis's verdict on the model in use (its
        residual's systematic part against the sensor noise, over the window it analysed):
        OK when the model explains the pressures, WARN when it does not (the message says what
        is left and where). The residual of the last minute of motion under that model is
        shown beside it, not judged. Before any analysis: not judged yet."""
        summary, motion_ns = mon.residual_summary(), mon.motion_ns
        return self._memo('model health', (summary, motion_ns, why, off), (mon.finding,),
                          lambda: self._model_health(mon, why, off, summary, motion_ns))

    def _model_health(self, mon: LiveMonitor, why: str | None, off: str | None,
                      summary: tuple[int, int, float | None], motion_ns: int) -> Status:
        """:meth:`model_health` from the residual's (count, instants not judged, RMS [bar]) and
        the steady motion counted [ns]."""
        count, skipped, rms = summary
        f = mon.finding
        values = [('residual_rms_bar', _f(rms, '.2f')), ('residual_samples', str(count)),
                  ('residual_instants_not_judged', str(skipped)),
                  ('motion_s', f'{motion_ns / 1e9:.0f}')]
        live = '' if rms is None else f'; last minute of motion: residual {rms:.2f} bar RMS under that model'
        if f is None:
            head = (f'not judged: {off}' if off is not None else
                    'not judged yet: no analysis of the data yet' if why is None else
                    f'not judged yet: the last analysis could not be made: {why}')
            if rms is not None:
                head += f'; declared model residual {rms:.2f} bar RMS over the last {count} samples'
            return self._status('model health', OK, head, values)
        effects = ', '.join(e.name for e in f.model)
        values += [('analysis_kind', f.kind), ('analysis_verdict', f.verdict),
                   ('analysis_rms_bar', f'{f.rms_bar:.2f}'), ('analysis_systematic_bar', f'{f.systematic_bar:.2f}'),
                   ('analysis_noise_bar', f'{f.noise_bar:.2f}'), ('analysis_motion_s', f'{f.motion_s:.0f}'),
                   ('analysis_effects', effects or 'none')]
        level = OK if f.explained else WARN
        message = f.message + live
        if why is not None:
            message += f' (the latest analysis could not be made: {why})'
        return self._status('model health', level, message, values)

    def rams(self, mon: LiveMonitor) -> Status:
        """How the two rams share the driving force: the one rams check
        (:class:`~steer_monitor.estimate.ramscheck.RamsCheck`, the same ``analyze``, ``report`` and
        ``fleet`` judge a log by) over the node's instants of steady motion, its level with
        its hysteresis: ERROR when one ram does next to no work or the two push against each
        other (a ram's pressures swapped in the map), WARN from the first window whose share's
        interval lies wholly outside the band ``50 +- ram_share_warn`` % until one lies wholly
        inside it, NOT ASSESSED (:meth:`_judged`) until a window has said either, OK after that."""
        check = mon.rams
        return self._memo('rams', (check.level, len(check.spans), check.pending if check.last is None else -1),
                          (check.last,), lambda: self._rams(check))

    def _rams(self, check: RamsCheck) -> Status:
        bar = self.gear.ram_area * 1e5
        warn = self.cfg.ram_share_warn
        w = check.last
        sh = None if w is None else w.share
        band = f'{100 * (0.5 - warn):.0f}-{100 * (0.5 + warn):.0f} %'
        values = [('ram_1_share_pct', 'n/a' if sh is None else f'{100 * sh.share[0]:.1f}'),
                  ('ram_2_share_pct', 'n/a' if sh is None else f'{100 * sh.share[1]:.1f}'),
                  ('ram_share_se_pct', 'n/a' if sh is None else f'{100 * sh.se:.2f}'),
                  ('ram_share_instants', '0' if sh is None else str(sh.instants)),
                  ('ram_force_spread_bar', 'n/a' if sh is None else f'{sh.spread / bar:.2f}'),
                  ('ram_force_offset_bar', 'n/a' if sh is None else f'{sh.offset / bar:.2f}'),
                  ('ram_share_warn_pct', f'{100 * warn:g}'),
                  ('ram_share_window_said', 'n/a' if w is None else w.said)]
        rule = (f'WARN while the share\'s interval lies wholly outside {band}, OK again once it lies wholly inside; '
                f'windows of {check.window} instants of steady motion')
        opened = check.open_span()
        if opened is not None:
            values.append(('ram_uneven_since_utc', utc_json(opened.start_ns) or ''))
        if check.spans:
            last = check.spans[-1]
            values += [('ram_uneven_last_start_utc', utc_json(last.start_ns) or ''),
                       ('ram_uneven_last_end_utc', utc_json(last.end_ns) or '')]
        if w is None:
            return self._judged('rams', NOT_ASSESSED, f'NOT ASSESSED: not judged yet: {check.pending} of the '
                                f'{check.window} instants of steady motion a window is judged over ({rule})', values)
        window = _share_words(sh)
        if check.level == OPPOSED:      # no share means anything until the map is right
            assert sh is not None
            return self._judged('rams', ERROR, opposed_cause(sh, None, PRESSURE_INPUTS) + '; no estimate is made from '
                                'them', values)
        if check.level == UNJUDGED:
            why = (f'{sh.instants} instants of steady motion, the rams\' mean force varying by {sh.spread / bar:.2f} '
                   'bar' if sh is not None and not enough(sh, self.gear.ram_area) else f'{window}, too uncertain')
            return self._judged('rams', NOT_ASSESSED, f'NOT ASSESSED: not judged yet: the last window {why} (judged '
                                f'from {MIN_SHARE_INSTANTS} instants and {MIN_SHARE_SPREAD_PA / 1e5:g} bar; {rule})',
                                values)
        held = '' if w.said == check.level else (
            f'; the last window {window}, ' + ('at the band\'s edge' if w.said == AT_EDGE else 'not judged')
            + ': the level held')
        if check.level == EVEN:
            before = '; last uneven: ' + describe(check.spans[-1]) if check.spans else ''
            return self._judged('rams', OK, f'the rams share the driving force: {window} over the last window'
                                f'{held} ({rule}){before}', values)
        weak = opened.ram if opened is not None else (sh.weaker if sh is not None else 0)
        since = '' if opened is None else f' since {utc_text(opened.start_ns)}'
        aux = check.last_aux
        cause = (weak_ram_cause(aux, weak, PRESSURE_INPUTS) if aux is not None and w.said in (UNEVEN, IDLE)
                 else UNEVEN_CAUSE.format(ram=weak + 1))
        if check.level == IDLE:
            return self._judged('rams', ERROR, f'ram {weak + 1} does next to no work{since}: {window} over the last '
                                f'window{held}: {cause}; on one ram the gear has half its torque ({rule})', values)
        return self._judged('rams', WARN, f'uneven{since}: {window} over the last window{held}: {cause} ({rule})',
                            values)
