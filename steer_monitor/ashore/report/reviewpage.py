"""The page of ``steer-monitor report``: one self-contained HTML file (PNG plots inlined as
base64, and the same PNGs beside it) that an engineer reads without the tool.

Plots: rudder angle and pressures over time; K_gl, F_r and F_gb against the rudder angle from
the measured pressures (the paper's Fig. 7 from data, with the model's curves at the
estimated clearances); the clearance estimates with their 95 % intervals over time (and the
estimates the vessel published, when the log is a node recording or a replay); the
residual before and after the added effect; the hard-over times against SOLAS.

A log's page from its batch-path review (:func:`write_report_dir`, :func:`report_input`): what
``steer-monitor report`` writes, and the fleet beside each log's result.
"""

from __future__ import annotations

import base64
import html
import importlib.util
import io
import math
import os
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import UTC
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.ashore.report.analysispage import residual_figure
from steer_monitor.ashore.review import ReviewResult, share_at
from steer_monitor.atomic import ensure_dir, os_reason, write_files
from steer_monitor.errors import OutputError
from steer_monitor.estimate.analyze import Analysis
from steer_monitor.estimate.batch import ClearanceEstimate
from steer_monitor.estimate.intervals import Interval
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.hardover import pumps_running
from steer_monitor.model.loadshare import load_sharing_at
from steer_monitor.monitor.messages import CLEARANCE_NAMES
from steer_monitor.monitor.performance import hard_over_words, solas_judgement

__all__ = ['NOT_READABLE_NOTE', 'PLOTS', 'PUBLISHED_READABLE', 'PublishedTrack', 'ReportInput', 'clearances_words',
           'page_estimate', 'published_track', 'remove_report_debris', 'report_input', 'timeline_caveat',
           'write_report_dir', 'write_review_report']

#: whether the messages a node recorded can be decoded here (mcap-ros2-support: pip only, an
#: ashore dependency; a vessel's install has it not)
PUBLISHED_READABLE = importlib.util.find_spec('mcap_ros2') is not None
#: what ``report`` says of MCAP inputs when they cannot
NOT_READABLE_NOTE = ('the clearances the node published are not drawn: mcap-ros2-support, which decodes them, '
                     'is not installed (pip install mcap-ros2-support, or the package\'s ashore extra)')

#: file stem -> heading, in page order
PLOTS = {
    'timeseries': 'Rudder angle and cylinder pressures',
    'loadsharing': 'Load sharing against rudder angle (measured)',
    'clearances': 'Clearance estimates over time',
    'residual': 'Model residual before and after the added effect',
    'hardover': 'Hard-over times against SOLAS',
}


@dataclass(frozen=True)
class PublishedTrack:
    """The clearances a node published (``~/clearances``), (n,) arrays [ns], [m]; NaN: none."""

    t_ns: NDArray[np.int64]
    two_z: NDArray[np.float64]
    two_z_lo: NDArray[np.float64]
    two_z_hi: NDArray[np.float64]
    z_gb: NDArray[np.float64]
    z_gb_lo: NDArray[np.float64]
    z_gb_hi: NDArray[np.float64]


@dataclass(frozen=True)
class ReportInput:
    """Everything the page shows."""

    title: str
    gear: GearParams
    review: ReviewResult
    analysis: Analysis | None
    analysis_note: str
    published: PublishedTrack | None
    frames: int
    rejects: dict[str, int]
    errors: list[str]
    limit_2z: float
    limit_zgb: float
    solas_s: float
    #: the gear's pumps (SOLAS's time is judged with all running) and one pump's ram speed [m/s]
    pumps: int = 2
    ram_speed_per_pump: float = 15e-3
    warn_share: float = 0.8
    #: where it came from: vessel (hardware id), gear name, parameters file and digest
    hardware_id: str = ''
    gear_name: str = ''
    config: str = ''
    parameters_sha256: str = ''


def _png(fig: Any) -> bytes:
    import matplotlib.pyplot as plt
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=96, bbox_inches='tight')
    plt.close(fig)
    return buf.getvalue()


@dataclass(frozen=True)
class _TimeAxis:
    """Time since the first frame in the unit that suits the log's span: s under 2 min, min
    under 2 h, else h."""

    t0: int
    div: float
    unit: str

    @classmethod
    def of(cls, t0: int, t1: int) -> _TimeAxis:
        span = (t1 - t0) / 1e9
        return cls(t0, 1e9, 's') if span < 120 else cls(t0, 6e10, 'min') if span < 7200 else cls(t0, 3.6e12, 'h')

    def __call__(self, t_ns: NDArray[np.int64]) -> NDArray[np.float64]:
        return (np.asarray(t_ns) - self.t0) / self.div


def _message_fig(text: str) -> Any:
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(10, 1.6))
    ax.axis('off')
    ax.text(0.5, 0.5, text, ha='center', va='center', wrap=True, fontsize=11)
    return fig


def _timeseries(r: ReviewResult, tx: _TimeAxis) -> Any:
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(2, 1, figsize=(12, 5.6), sharex=True)
    h = tx(r.t_ns)
    ax[0].plot(h, np.degrees(r.alpha), 'k-', lw=0.6)
    ax[0].set_ylabel('rudder angle [deg]')
    ax[0].axhline(35, color='0.7', lw=0.6, ls=':')
    ax[0].axhline(-35, color='0.7', lw=0.6, ls=':')
    # ram 2 dashed over ram 1 solid: the two rams read nearly alike, and one would hide the other
    styles = (('ram 1 stbd', 'tab:green', '-', 1.2), ('ram 1 port', 'tab:red', '-', 1.2),
              ('ram 2 stbd', 'darkgreen', '--', 0.9), ('ram 2 port', 'darkred', '--', 0.9))
    for k, (label, color, ls, lw) in enumerate(styles):
        ax[1].plot(h, r.pressure[:, k] / 1e5, ls=ls, color=color, lw=lw, label=label)
    ax[1].set_ylabel('pressure [bar]')
    ax[1].set_xlabel(f'time since the first frame [{tx.unit}] (one point per second of data)')
    ax[1].legend(ncol=4, fontsize=8, loc='lower center', bbox_to_anchor=(0.5, 1.0), frameon=False)
    return fig


def _loadsharing(r: ReviewResult, gear: GearParams, est: ClearanceEstimate | None) -> Any:
    """The load sharing measured and modelled, at the page's estimate ``est`` (the model
    check's, else the review's last window; None: the configured clearances)."""
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.0))
    gaps = r.gaps if est is None else Clearances(est.two_z.value, est.z_gb.value)
    sh = r.share if gaps == r.gaps else share_at(gear, r.alpha, r.torque, gaps)
    deg = np.degrees(r.alpha)
    curve = np.radians(np.linspace(-math.degrees(gear.max_rudder), math.degrees(gear.max_rudder), 281))
    model = load_sharing_at(gear, curve, gaps)
    cdeg = np.degrees(curve)
    if sh is not None:
        ok = np.isfinite(sh.k_gl) & (r.direction != 0)
        rest = np.isfinite(sh.k_gl) & (r.direction == 0)
        ax[0].plot(deg[rest], sh.k_gl[rest], '.', ms=2, color='0.75', label='measured, at rest')
        ax[0].plot(deg[ok], sh.k_gl[ok], '.', ms=2, color='tab:blue', label='measured, moving')
        ax[1].plot(deg[ok | rest], sh.ram_force[ok | rest] / 1e3, '.', ms=2, color='tab:orange', label='F_r measured')
        ax[1].plot(deg[ok | rest], sh.guide_force[ok | rest] / 1e3, '.', ms=2, color='tab:green',
                   label='F_gb measured')
    ax[0].plot(cdeg, model.k_gl, 'k-', lw=1, label='model, service speed')
    ax[0].set_xlabel('rudder angle [deg]')
    ax[0].set_ylabel('K_gl = F_gb / (F_r + F_gb)')
    ax[0].set_ylim(-0.05, 1.05)
    ax[0].legend(fontsize=8, loc='lower center', bbox_to_anchor=(0.5, 1.02), ncol=3, frameon=False)
    ax[1].plot(cdeg, model.ram_force / 1e3, 'k-', lw=1, label='F_r model')
    ax[1].plot(cdeg, model.guide_force / 1e3, 'k--', lw=1, label='F_gb model')
    ax[1].set_xlabel('rudder angle [deg]')
    ax[1].set_ylabel('lateral force [kN]')
    ax[1].legend(fontsize=8, loc='lower center', bbox_to_anchor=(0.5, 1.02), ncol=2, frameon=False)
    fig.suptitle(clearances_words(gaps, None if est is None else (est.two_z, est.z_gb)), fontsize=10, y=1.1)
    return fig


def page_estimate(inp: ReportInput) -> ClearanceEstimate | None:
    """The clearance estimate the page rests on, one source for its boxes and figures: the
    model check's (``analyze``), else the review's last window (the plot of the clearances over
    time is the review's windows); None when the log gave none."""
    if inp.analysis is not None:
        return inp.analysis.final
    r = inp.review
    return r.estimates[-1].estimate if r.estimates else None


def timeline_caveat(analysis: Analysis | None) -> str:
    """What the plot of the clearances over time adds to its caption: the model its windows fit,
    the model check's (:func:`~steer_monitor.ashore.windowmodel.window_model`): the declared model
    with the effects the check adopted and, where it left a residual unexplained, the term it
    located taken out as it took it out, the intervals widened for the misfit (docs/accuracy-timeline.md)."""
    if analysis is None or analysis.verdict == 'declared':
        return ''
    said = ''
    if analysis.steps:
        said = (' The windows also fit the effects the model check adopted ('
                + ', '.join(s.name for s in analysis.steps) + ').')
    if analysis.verdict == 'unexplained':
        how = ('fitted with the term it located taken out' if analysis.located is not None
               else 'fitted with that residual counted as noise')
        said += (' The model check left a residual its model does not explain: the windows, as the clearances at '
                 f'the top of the page, are {how}, their intervals widened for it, and rest on an incomplete model.')
    return said


def clearances_words(gaps: Clearances, intervals: tuple[Interval, Interval] | None) -> str:
    """What the load-sharing figure's model was drawn at: the configured clearances
    (``intervals`` None), or each estimate with its interval; a clearance the data bound only
    from below is said to be a bound, with the value the model was drawn at (one of those the
    data allow), never as a point."""
    if intervals is None:
        return f'at the configured clearances 2Z {gaps.two_z * 1e3:.3f} mm, Z_gb {gaps.z_gb * 1e3:.3f} mm'
    parts = []
    for name, iv, drawn in (('2Z', intervals[0], gaps.two_z), ('Z_gb', intervals[1], gaps.z_gb)):
        if iv.lo is not None and iv.hi is not None:
            parts.append(f'{name} {drawn * 1e3:.3f} mm [{iv.lo * 1e3:.3f} .. {iv.hi * 1e3:.3f}]')
        elif iv.lo is not None:
            parts.append(f'{name} >= {iv.lo * 1e3:.3f} mm, a lower bound (drawn at {drawn * 1e3:.3f} mm)')
        elif iv.hi is not None:
            parts.append(f'{name} <= {iv.hi * 1e3:.3f} mm, an upper bound (drawn at {drawn * 1e3:.3f} mm)')
        else:
            parts.append(f'{name} not determined (drawn at {drawn * 1e3:.3f} mm)')
    return 'at the estimated clearances: ' + '; '.join(parts)


def _clearances(inp: ReportInput, tx: _TimeAxis) -> Any:
    import matplotlib.pyplot as plt
    r = inp.review
    fig, ax = plt.subplots(1, 2, figsize=(12, 4.0), sharex=True)
    for k, (name, attr, limit) in enumerate((('2Z', 'two_z', inp.limit_2z), ('Z_gb', 'z_gb', inp.limit_zgb))):
        a = ax[k]
        if inp.published is not None and len(inp.published.t_ns):
            o = inp.published
            hours = tx(o.t_ns)
            a.plot(hours, getattr(o, attr) * 1e3, '-', color='tab:purple', lw=0.8, label='published by the node')
            lo, hi = getattr(o, attr + '_lo') * 1e3, getattr(o, attr + '_hi') * 1e3
            a.fill_between(hours, lo, np.where(np.isfinite(hi), hi, np.nan), color='tab:purple', alpha=0.15, lw=0)
        for w in r.estimates:
            iv = getattr(w.estimate, attr)
            x = float(tx(np.array([w.t_end_ns]))[0])
            lo = iv.lo if iv.lo is not None else iv.value
            first = w is r.estimates[0]
            if iv.hi is None:        # a lower bound only: draw it as one
                a.annotate('', xy=(x, lo * 1e3 + 0.08), xytext=(x, lo * 1e3),
                           arrowprops={'arrowstyle': '->', 'color': 'tab:blue'})
                a.plot([x], [lo * 1e3], '_', ms=12, color='tab:blue',
                       label='batch: lower bound only' if first else None)
            else:
                a.errorbar([x], [iv.value * 1e3], yerr=[[iv.value * 1e3 - lo * 1e3], [iv.hi * 1e3 - iv.value * 1e3]],
                           fmt='o', color='tab:blue', capsize=4,
                           label='batch: estimate, 95 % interval' if first else None)
        a.axhline(limit * 1e3, color='tab:red', ls='--', lw=1, label=f'limit {limit * 1e3:.3f} mm')
        a.set_ylabel(f'{name} [mm]')
        a.set_xlabel(f'data up to [{tx.unit}]')
        a.set_ylim(bottom=0)
        a.set_title(f'{name}: estimate with 95 % interval (arrow: lower bound only)', fontsize=9)
        a.legend(fontsize=8, loc='lower center', bbox_to_anchor=(0.5, 1.08), ncol=2, frameon=False)
    return fig


def _pumps(inp: ReportInput, seconds: float) -> int:
    return pumps_running(seconds, inp.gear.stock_to_ram, inp.ram_speed_per_pump, inp.pumps)


def _hardover(r: ReviewResult, tx: _TimeAxis, inp: ReportInput) -> Any:
    """Hard-over times with the pumps that ran them: judged against SOLAS (green within, red
    over, orange where the angle's sampling leaves it open: the bar its longest reading, a line
    down to its shortest) only with all the gear's pumps; with fewer, grey and not judged."""
    import matplotlib.pyplot as plt
    solas = inp.solas_s
    fig, ax = plt.subplots(figsize=(12, 3.4))
    if r.hard_overs:
        x = tx(np.array([h.t_leave_ns for h in r.hard_overs]))
        y = np.array([h.seconds for h in r.hard_overs])
        n = [_pumps(inp, v) for v in y]
        judged = [solas_judgement(h, solas) for h in r.hard_overs]
        colors = ['tab:gray' if k < inp.pumps else {True: 'tab:green', False: 'tab:red', None: 'tab:orange'}[j]
                  for j, k in zip(judged, n)]
        span = float(tx(np.array([int(r.t_ns[-1])]))[0]) if len(r.t_ns) else float(x.max()) + 1.0
        ax.bar(x, y, width=max(span, 1e-9) / 60, color=colors)      # one bar is a bar, not the whole plot
        shortest = np.array([h.seconds_min for h in r.hard_overs])
        open_ = y - shortest >= 0.5
        if open_.any():
            ax.vlines(x[open_], shortest[open_], y[open_], color='k', lw=1)
        ax.set_xlim(0, max(span, float(x.max())) * 1.02 + 1e-9)
        for xi, yi, k in zip(x, y, n):
            ax.text(xi, yi, f"{yi:.1f} s\n{k} pump{'s' if k > 1 else ''}", ha='center', va='bottom', fontsize=8)
        ax.set_ylim(0, max(float(y.max()), solas) * 1.3)
    ax.axhline(solas, color='tab:red', ls='--', lw=1,
               label=f'SOLAS {solas:g} s (35 deg to 30 deg the other side, {inp.pumps} pumps; grey: fewer, not judged)')
    ax.set_xlabel(f'time of leaving hard over [{tx.unit}]')
    ax.set_ylabel('hard-over time [s]')
    ax.legend(fontsize=8, loc='lower right')
    return fig


def _iv_text(iv: Any, scale: float, unit: str) -> str:
    """An estimate in the words every command uses (a bound said as one, no point beside it)."""
    from steer_monitor.jsonvocab import estimate_text
    return estimate_text(iv.scaled(scale, 4), unit, 3)


def _utc(t_ns: int) -> str:
    from datetime import datetime
    return datetime.fromtimestamp(t_ns / 1e9, tz=UTC).strftime('%Y-%m-%d %H:%M:%S UTC')


def _verdict_block(inp: ReportInput) -> str:
    """One box per clearance: OK / WARN / OVER LIMIT / NOT ASSESSED (the live diagnostics' rule,
    on the model check's estimate and its interval); % of limit, the interval, why; then where
    the page came from and what each level means."""
    from steer_monitor import __version__
    from steer_monitor.ashore.loganalysis import NOT_JUDGED, headlines

    esc = html.escape
    r = inp.review
    boxes = []
    what = {'2Z': 'ram bushing', 'Z_gb': 'guide slipper'}
    for h in headlines(inp.analysis, inp.limit_2z, inp.limit_zgb, inp.warn_share):
        name, iv, limit = h.name, h.estimate, h.limit
        if iv is None:
            boxes.append(f'<div class="box NONE" id="verdict-{name}"><h2>{name} ({what[name]})</h2>'
                         f'<div class="big">{NOT_JUDGED}</div><div>{esc(inp.analysis_note or h.note)}</div></div>')
            continue
        if iv.hi is None:
            point = f'at least {iv.lo * 1e3:.3f} mm' + (
                f' ({iv.lo / limit:.0%} of the {limit * 1e3:.3f} mm limit)' if iv.lo > limit else '')
            rng = 'no clamping of the ram shows at the loads seen: no upper bound'
        else:
            point = f'{iv.value * 1e3:.3f} mm, {iv.value / limit:.0%} of the {limit * 1e3:.3f} mm limit'
            rng = f'95 % interval {iv.lo * 1e3:.3f} .. {iv.hi * 1e3:.3f} mm'
        if iv.hi is None and name == 'Z_gb':
            rng = 'the guide beam never touched at the loads seen: no upper bound'
        css = 'NONE' if h.level == NOT_JUDGED else h.level.split()[0]
        if iv.hi is None and h.note:      # the note says why it is a bound, and what would assess it
            rng = ''
        boxes.append(f'<div class="box {css}" id="verdict-{name}"><h2>{name} ({what[name]})</h2>'
                     f'<div class="big">{h.level.upper()}</div><div>{esc(point)}</div>'
                     + (f'<div>{esc(rng)}</div>' if rng else '')
                     + (f'<div>{esc(h.note)}</div>' if h.note else '') + '</div>')
    span = (f'{_utc(int(r.t_ns[0]))} to {_utc(int(r.t_ns[-1]))}' if len(r.t_ns) else 'no rudder angle')
    prov = (f'{esc(inp.gear_name)} gear; data {esc(span)}; parameters {esc(inp.config or "(packaged)")} '
            f'(SHA-256 {esc(inp.parameters_sha256[:12])}); steer_monitor {esc(__version__)}. '
            f'Clearances from the model check (analyze of the last hours of data). OK: assessed and below '
            f'{inp.warn_share:.0%} of its limit; WARN from it; OVER LIMIT when even the interval\'s low end is '
            f'past the limit; NOT ASSESSED when the data cannot say (no estimate, a lower bound below the warning, '
            f'an interval reaching from below the warning past the limit, or a model that does not explain '
            f'the pressures), with why.')
    return f'<div class="verdict">{"".join(boxes)}</div><p class="prov">{prov}</p>'


def write_review_report(inp: ReportInput, out_dir: str | Path) -> Path:
    """Write ``index.html`` and the PNGs into ``out_dir``; returns the page's path."""
    import matplotlib
    matplotlib.use('Agg')

    out_dir = ensure_dir(out_dir)
    r = inp.review
    t0 = int(r.t_ns[0]) if len(r.t_ns) else 0
    tx = _TimeAxis.of(t0, int(r.t_ns[-1]) if len(r.t_ns) else 0)
    figs = {
        'timeseries': _timeseries(r, tx) if len(r.t_ns) else _message_fig('no rudder angle in the log'),
        'loadsharing': _loadsharing(r, inp.gear, page_estimate(inp)),
        'clearances': _clearances(inp, tx),
        'residual': residual_figure(inp.analysis) if inp.analysis is not None else _message_fig(inp.analysis_note),
        'hardover': _hardover(r, tx, inp),
    }
    images = {key: _png(fig) for key, fig in figs.items()}
    esc = html.escape
    verdict = _verdict_block(inp)
    span_h = (int(r.t_ns[-1]) - t0) / 3.6e12 if len(r.t_ns) else 0.0
    rows = [
        ('log', inp.title),
        ('frames', f'{inp.frames:,d}'),
        ('data', f'{span_h:.2f} h, {r.motion_s / 60:.0f} min of steady rudder motion'),
    ]
    e = page_estimate(inp)
    if e is not None:
        src = '' if inp.analysis is not None else ' (the review\'s last window: no model check)'
        rows += [('2Z (ram bushing)', _iv_text(e.two_z, 1e3, 'mm') + f'; limit {inp.limit_2z * 1e3:.3f} mm' + src),
                 ('Z_gb (guide slipper)', _iv_text(e.z_gb, 1e3, 'mm') + f'; limit {inp.limit_zgb * 1e3:.3f} mm' + src),
                 ('K_gl max over the angles seen', _iv_text(e.k_gl_max, 1.0, '') + src)]
    else:
        rows.append(('clearances', 'not estimated: ' + '; '.join(r.notes)))
    if r.hard_overs:
        full = [h for h in r.hard_overs if _pumps(inp, h.seconds) >= inp.pumps]
        text = f'{len(r.hard_overs)}'
        if full:
            worst = max(full, key=lambda h: (h.seconds_min, h.seconds))
            within = solas_judgement(worst, inp.solas_s)
            said = {True: 'within', False: 'OVER', None: 'not judged against'}[within]
            text += (f'; with all {inp.pumps} pumps: {len(full)}, slowest {hard_over_words(worst)} '
                     f'({said} SOLAS {inp.solas_s:g} s' + (': the angle\'s samples leave the time either side of it)'
                                                           if within is None else ')'))
        if len(full) < len(r.hard_overs):
            text += (f'; with fewer pumps: {len(r.hard_overs) - len(full)} (not judged against SOLAS, which '
                     f'assumes {inp.pumps})')
        rows.append(('hard-overs', text))
    else:
        rows.append(('hard-overs', 'none in the log'))
    if inp.analysis is not None:
        rows.append(('model check', inp.analysis.message))
    if inp.rejects:
        rows.append(('rejected frames', ', '.join(f'{k} {v}' for k, v in inp.rejects.items())))
    for err in inp.errors:
        rows.append(('error', err))
    table = ''.join(f'<tr><th>{esc(k)}</th><td>{esc(v)}</td></tr>' for k, v in rows)
    notes = ''.join(f'<li>{esc(n)}</li>' for n in r.notes)
    captions = {
        'timeseries': 'One point per second of data. Pressures are the four transducers (ram 1 and 2, '
                      'starboard and port chambers).',
        'loadsharing': 'The measured pressures give the tiller torque; the load-sharing model splits the '
                       'lateral force between ram (F_r) and guide beam (F_gb) at the clearances in the '
                       'title (paper 004, Fig. 7). Grey: rudder at rest (the pressure holds friction too).',
        'clearances': 'Each point uses all the data up to its time, fitted with the declared model. An arrow '
                      'marks a lower bound only: no clamping of the ram in its bushing shows at the loads seen, so '
                      'the data cannot say how large 2Z is, only that it is at least this.'
                      + timeline_caveat(inp.analysis),
        'residual': 'Ram-force residual of the fitted model, in bar of cylinder pressure: what the '
                    'declared model leaves, and what is left after the effect the data support.',
        'hardover': 'From leaving 35 deg to reaching 30 deg the other side, as SOLAS II-1/29 asks, with the '
                    'pumps that ran it (told from its time). Green: within SOLAS with all pumps; red: over it; '
                    'orange: the angle sampled too slowly to tell (the line: from its shortest to its longest '
                    'reading); grey: fewer pumps, reported and not judged.',
    }
    body = ''.join(
        f'<section id="{key}"><h2>{esc(title)}</h2>'
        f'<img class="plot" id="plot-{key}" alt="{esc(title)}" src="data:image/png;base64,'
        f'{base64.b64encode(images[key]).decode("ascii")}"><p class="caption">{esc(captions[key])}</p></section>'
        for key, title in PLOTS.items())
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>steer_monitor report: {esc(inp.title)}</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto;color:#222}}
th,td{{padding:3px 12px;text-align:left;vertical-align:top}}table{{border-collapse:collapse}}
tr:nth-child(even){{background:#f2f2f2}}img.plot{{width:100%;display:block}}.caption{{color:#555;font-size:90%}}
section{{margin-top:2em}}.verdict{{display:flex;gap:1em;margin:1em 0}}
.box{{flex:1;border-radius:6px;padding:0.6em 1em;color:#fff}}.box h2{{margin:0;font-size:120%}}
.box .big{{font-size:160%;font-weight:bold}}.OK{{background:#2e7d32}}.WARN{{background:#ef6c00}}
.OVER{{background:#c62828}}.NONE{{background:#757575}}.prov{{color:#555;font-size:90%}}</style>
<script>window.addEventListener('load', function () {{
  var imgs = document.querySelectorAll('img.plot'), ok = 0;
  imgs.forEach(function (i) {{ var r = i.complete && i.naturalWidth > 0; i.dataset.rendered = r ? 'yes' : 'no'; if
  (r) ok++; }});
  document.body.dataset.plotsRendered = ok + '/' + imgs.length;
}});</script></head>
<body><h1>Steering gear report: {esc(inp.hardware_id or inp.gear_name)}</h1>
{verdict}
<table>{table}</table>
{'<ul class="notes">' + notes + '</ul>' if notes else ''}
{body}
<p class="caption">steer_monitor; the physics and its sources: paper 004 (load sharing on the R-18 gear) and
paper 000 (backlash from the fits).</p>
</body></html>
"""
    path = out_dir / 'index.html'
    # all or none (a full disk does not leave new plots beside an earlier page); the page
    # renamed last, so it is never there without its plots
    write_files({path: page.encode('utf-8'), **{out_dir / f'{key}.png': png for key, png in images.items()}})
    return path


def published_track(paths: Sequence[Path]) -> Any:
    """The clearances a node published (``*/clearances``) in MCAP inputs, as an
    :class:`~steer_monitor.ashore.report.reviewpage.PublishedTrack`, or None (none published,
    or mcap-ros2-support, which decodes them, not installed: :data:`PUBLISHED_READABLE`)."""
    if not PUBLISHED_READABLE:
        return None
    import numpy as np
    from mcap_ros2.decoder import DecoderFactory

    from steer_monitor._vendor.mcap.reader import make_reader
    from steer_monitor.logfiles.mcapcols import mcap_chunks_within_limits

    rows: list[tuple[int, list[float]]] = []
    for path in paths:
        # mcap's reader inflates a chunk to the size it declares: not a file with one beyond
        # what a chunk may hold (the frames' reader has said it is corrupt)
        if Path(path).suffix.lower() != '.mcap' or not mcap_chunks_within_limits(path):
            continue
        try:
            with open(path, 'rb') as fh:
                reader = make_reader(fh, validate_crcs=True, decoder_factories=[DecoderFactory()])
                summary = reader.get_summary()
                topics = [c.topic for c in summary.channels.values() if c.topic.endswith('/clearances')] \
                    if summary is not None else []
                if not topics:
                    continue
                for _, _, message, msg in reader.iter_decoded_messages(topics=topics):
                    values = _clearance_values(msg)
                    if values is not None:
                        rows.append((message.log_time, values))
        except Exception:   # a recording cut short has no summary: the plot goes without it
            continue
    if not rows:
        return None
    rows.sort(key=lambda r: r[0])
    t = np.array([r[0] for r in rows], np.int64)
    d = np.array([r[1] for r in rows], float)
    return PublishedTrack(t, *(d[:, k] for k in range(6)))


def _clearance_values(msg: Any) -> list[float] | None:
    """2Z, its low and high bound, Z_gb, its bounds [m] (NaN: none) from a ``~/clearances``
    message: named values in a ``sensor_msgs/JointState`` (this release's and the first
    releases'), an earlier release's ``steer_monitor_msgs/Clearances`` (decoded from the schema
    its recording carries) or labelled ``std_msgs/Float64MultiArray``; None for anything else."""
    two_z, z_gb = getattr(msg, 'gap_2z_m', None), getattr(msg, 'gap_zgb_m', None)
    if two_z is not None and z_gb is not None:
        return [float(v) for e in (two_z, z_gb) for v in (e.value, e.lo, e.hi)]
    names = getattr(msg, 'name', None)
    if names is not None:
        by_name = dict(zip(names, getattr(msg, 'position', [])))
        if all(k in by_name for k in CLEARANCE_NAMES):
            return [float(by_name[k]) for k in CLEARANCE_NAMES]
        return None
    layout = getattr(msg, 'layout', None)
    dims = layout.dim if layout is not None else []
    if dims and dims[0].label == ','.join(CLEARANCE_NAMES) and len(msg.data) == 6:
        return [float(v) for v in msg.data]
    return None


def report_input(paths: Sequence[Path], batch: Any, params: dict[str, Any], config_path: str | Path,
                 analysis: Any, analysis_note: str) -> Any:
    """The page's input for ``paths`` reviewed as ``batch`` (a
    :class:`~steer_monitor.ashore.reviewlogs.BatchRun`) with these parameters; ``analysis``: the model
    check (None, and ``analysis_note`` says why)."""
    from steer_monitor.params import gear_from_params
    from steer_monitor.record.provenance import parameters_digest

    return ReportInput(', '.join(Path(p).name for p in paths), gear_from_params(params), batch.review, analysis,
                       analysis_note, published_track(paths), batch.frames, batch.rejects, batch.errors,
                       params['clearances.limit_2z_mm'] * 1e-3, params['clearances.limit_zgb_mm'] * 1e-3,
                       params['diagnostics.solas_hard_over_s'], params['hydraulics.pumps'],
                       params['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3, params['diagnostics.clearance_warn_share'],
                       params['node.hardware_id'], params['gear.name'], str(config_path), parameters_digest(params))


def _temp_dir(out_dir: Path, pid: int | str) -> Path:
    return out_dir.with_name(f'.{out_dir.name}.{pid}.tmp')


def remove_report_debris(out_dir: str | Path) -> int:
    """Remove what writers of the page ``out_dir`` killed mid-write left beside it (their
    temporary directories); call it only when no writer of that page is running. Returns how
    many were removed."""
    out_dir = Path(out_dir)
    n = 0
    for tmp in out_dir.parent.glob(_temp_dir(out_dir, '*').name):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
            n += 1
    return n


def write_report_dir(inp: Any, out_dir: str | Path) -> Path:
    """Write the page into ``out_dir`` whole or not at all: into a temporary directory beside
    it, then renamed (an earlier page there is replaced). For pages many workers write into
    one tree, where a worker that dies must not leave half a page behind. Returns the page."""

    out_dir = Path(out_dir)
    tmp = _temp_dir(out_dir, os.getpid())
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(tmp, ignore_errors=True)
        write_review_report(inp, tmp)
        if out_dir.exists():
            shutil.rmtree(out_dir)
        os.replace(tmp, out_dir)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        msg = f'cannot write the report {out_dir}: {os_reason(exc)}'
        raise OutputError(msg) from exc
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out_dir / 'index.html'
