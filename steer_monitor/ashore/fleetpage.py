"""The fleet page: vessels by the soonest limit date, per vessel its estimates with their
intervals, the wear trend with its 95 % band and the limits, and a table of its logs."""

from __future__ import annotations

import base64
import html
import io
import math
from pathlib import Path
from typing import Any

import numpy as np

from steer_monitor.ashore.fleet import FleetRun, fleet_json, vessel_trends
from steer_monitor.ashore.loganalysis import NOT_JUDGED
from steer_monitor.estimate.trend import Z95
from steer_monitor.jsonvocab import estimate_text

__all__ = ['fleet_page']


def _plot(rs: list[Any], params: dict[str, Any]) -> str:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.dates as mdates
    import matplotlib.pyplot as plt

    trends = vessel_trends(rs, params)
    fig, axes = plt.subplots(1, 2, figsize=(12, 3.2))
    for ax, (key, (tr, pts, _)) in zip(axes, trends.items()):
        name = '2Z' if '2z' in key else 'Z_gb'
        limit = params[f'clearances.limit_{key.split("_")[1]}_mm']
        to_dt = np.vectorize(lambda s: np.datetime64(int(s), 's'))
        two = [p for p in pts if p.hi is not None]
        one = [p for p in pts if p.hi is None]
        if two:
            t = to_dt([p.t_s for p in two])
            v = np.array([p.value for p in two]) * 1e3
            ax.errorbar(t, v, yerr=[v - np.array([p.lo for p in two]) * 1e3, np.array([p.hi for p in two]) * 1e3 - v],
                        fmt='o', ms=3, capsize=2, color='tab:blue', label='log: estimate, 95 %')
        if one:
            ax.plot(to_dt([p.t_s for p in one]), np.array([p.lo for p in one]) * 1e3, '^', color='tab:blue',
                    mfc='none', label='log: lower bound only')
        if tr is not None and pts:
            t0 = min(p.t_s for p in pts)
            t1 = max([p.t_s for p in pts] + [tr.limit_t if tr.limit_t is not None and math.isfinite(tr.limit_t)
                                             and tr.limit_t < t0 + 10 * 365.25 * 86400 else t0])
            ts = np.linspace(t0, t1, 100)
            line = (tr.level + tr.rate.value * (ts - tr.t_ref)) * 1e3
            se = (tr.rate.hi - tr.rate.value) / Z95   # type: ignore[operator]
            band = Z95 * se * np.abs(ts - tr.t_ref) * 1e3
            ax.plot(to_dt(ts), line, 'k-', lw=1, label='trend')
            ax.fill_between(to_dt(ts), line - band, line + band, color='0.6', alpha=0.3, lw=0,
                            label='trend: rate 95 %')
        ax.axhline(limit, color='tab:red', ls='--', lw=1, label=f'limit {limit:.3f} mm')
        ax.set_ylabel(f'{name} [mm]')
        ax.set_ylim(bottom=0)
        ax.xaxis.set_major_formatter(mdates.DateFormatter('%Y-%m'))
        ax.legend(fontsize=7, loc='lower center', bbox_to_anchor=(0.5, 1.0), ncol=3, frameon=False)
    fig.autofmt_xdate()
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=90, bbox_inches='tight')
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode('ascii')


def fleet_page(run: FleetRun) -> str:
    """The page's HTML (self-contained: plots inlined)."""
    esc = html.escape
    data = fleet_json(run)
    parts = []
    warn = ' class="WARN"'
    for v in data['vessels']:
        rs = run.results[v['name']]
        rows = ''.join(
            f"<tr><td>{_log_cell(lg)}</td><td>{esc(lg['start_utc'] or '-')}</td>"
            f"<td>{_clearance_cell(lg['clearance_2z_mm'])}</td><td>{_clearance_cell(lg['clearance_zgb_mm'])}</td>"
            f"<td>{esc(_check_text(lg))}</td>"
            f"<td{warn if lg['uneven_rams'] else ''}>{esc(_rams(lg['uneven_rams']))}</td></tr>"
            for lg in v['logs'])
        trend = '; '.join(
            f"{'2Z' if '2z' in key else 'Z_gb'}: " + (
                f"since {v['beyond_reach'][key]['since_utc']} {v['beyond_reach'][key]['message']}; the logs up to "
                'then: ' if v['beyond_reach'][key] is not None else '') + (
                'too few judged estimates for a trend' if t is None else
                t['message'] + (f", limit reached {t['limit_date_utc']} [{t['limit_date_ci95'][0]} .. "
                                f"{t['limit_date_ci95'][1] or 'later'}]" if t['limit_date_utc'] else ''))
            for key, t in v['trend'].items())
        parts.append(
            f"<section><h2>{esc(v['name'])}</h2><p>{esc(trend)}</p>"
            f"<img alt=\"{esc(v['name'])}\" src=\"data:image/png;base64,{_plot(rs, run.params[v['name']])}\">"
            "<table><tr><th>log</th><th>start (UTC)</th><th>2Z [mm]</th><th>Z_gb [mm]</th><th>model check</th>"
            "<th>rams</th></tr>"
            f"{rows}</table></section>"
        )
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>steer_monitor fleet</title>
<style>body{{font-family:sans-serif;max-width:1200px;margin:2em auto;color:#222}}img{{width:100%}}
td,th{{padding:2px 10px;text-align:left}}table{{border-collapse:collapse}}tr:nth-child(even){{background:#f2f2f2}}
.OK{{color:#2e7d32}}.WARN{{color:#ef6c00;font-weight:bold}}.OVER{{color:#c62828;font-weight:bold}}</style></head>
<body><h1>Steering gears of the fleet</h1>
<p>Vessels by the soonest date a clearance reaches its limit (95 % interval in brackets). {data['analysed']} logs
analysed in this run, {data['reused']} kept from earlier runs, {len(data['failed'])} failed.</p>
{''.join(parts)}
</body></html>
"""
    return page


def _log_cell(lg: dict[str, Any]) -> str:
    """The log's name, a link to its report page when there is one, and the log whose time
    it holds (left out of the trend) when there is one."""
    name = html.escape(Path(lg['log']).name)
    if lg.get('report'):
        name = f'<a href="{html.escape(Path(lg["report"]).as_posix(), quote=True)}">{name}</a>'
    if lg.get('same_time_as'):
        name += f' (the time of {html.escape(Path(lg["same_time_as"]).name)}: not in the trend)'
    return name


def _css(level: str) -> str:
    return 'NONE' if level == NOT_JUDGED else level.split()[0]


def _clearance_cell(d: dict[str, Any]) -> str:
    """A clearance's estimate and its own level (a log's two are judged apart: one may be
    fine where the other is not assessed)."""
    return f"{_iv(d)} <span class=\"{html.escape(_css(d['level']))}\">{html.escape(d['level'])}</span>"


def _check_text(lg: dict[str, Any]) -> str:
    """The model check's verdict on a log (or why the log gave none)."""
    if lg['error']:
        return lg['error']
    mc = lg['model_check']
    if mc is None:
        return '-'
    if mc['verdict'] == 'unexplained':
        return 'the model does not explain the pressures: neither clearance judged'
    return f"with {', '.join(mc['effects'])}" if mc['effects'] else 'the declared model'


def _iv(d: dict[str, Any] | None) -> str:
    if d is None:
        return '-'
    return html.escape(estimate_text(d, digits=3))


def _rams(spans: list[dict[str, Any]]) -> str:
    """The stretches where the rams did not share the force evenly, shortly ('even' when none)."""
    if not spans:
        return 'even'
    return '; '.join(f"ram {u['ram']} {u['share_pct']:.0f} % {(u['start_utc'] or '')[:16].replace('T', ' ')}"
                     f"-{(u['end_utc'] or '')[11:16]}" for u in spans) + ' (left out)'
