"""The HTML report of ``steer-monitor analyze``: one self-contained page (PNG plots inlined
as base64) with the clearance profiles and intervals, the torque curve, the residual before
and after the added effects, the residual against the variable it lives on when it is not
explained, and the candidates' scores."""

from __future__ import annotations

import base64
import html
import io
from pathlib import Path
from typing import Any

import numpy as np

from steer_monitor.atomic import write_text
from steer_monitor.estimate.analyze import Analysis
from steer_monitor.estimate.intervals import CHI2_1_95
from steer_monitor.jsonvocab import estimate_text

__all__ = ['located_figure', 'png_base64', 'residual_figure', 'write_analysis_report']


def png_base64(fig: Any) -> str:
    buf = io.BytesIO()
    fig.savefig(buf, format='png', dpi=96, bbox_inches='tight')
    import matplotlib.pyplot as plt
    plt.close(fig)
    return base64.b64encode(buf.getvalue()).decode('ascii')


def _plots(a: Analysis) -> dict[str, str]:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    f = a.final
    out: dict[str, str] = {}
    fig, ax = plt.subplots(1, 2, figsize=(10, 3.4))
    for k, (iv, label) in enumerate(((f.two_z, '2Z [mm]'), (f.z_gb, 'Z_gb [mm]'))):
        axis, prof = f.marginal_deviance(k)
        ax[k].plot(axis * 1e3, np.minimum(prof, 50), 'k-')
        ax[k].axhline(CHI2_1_95, color='tab:red', ls='--', label='95 % threshold')
        ax[k].set_xlabel(label)
        ax[k].set_ylabel('profile deviance (capped at 50)')
        one_sided = iv.hi is None and iv.lo is not None      # the plateau's best point is no estimate
        ax[k].set_title(f'{label}: >= {iv.lo * 1e3:.3f} mm (lower bound only)' if one_sided
                        else f'{label}: {iv.value * 1e3:.3f} mm')
        ax[k].legend(loc='upper right')
    out['profiles'] = png_base64(fig)
    angles, torque, band = f.torque_curve
    fig, ax = plt.subplots(figsize=(6, 3.4))
    deg = np.degrees(angles)
    ax.plot(deg, torque / 1e3, 'k-', label='estimated (service speed)')
    ax.fill_between(deg, (torque - band) / 1e3, (torque + band) / 1e3, color='0.8', label='95 % band')
    ax.set_xlabel('rudder angle [deg]')
    ax.set_ylabel('tiller torque [kN m]')
    ax.legend()
    out['torque'] = png_base64(fig)
    out['residual'] = png_base64(residual_figure(a))
    if a.located is not None:
        out['located'] = png_base64(located_figure(a))
    return out


def located_figure(a: Analysis) -> Any:
    """The residual (signed as the located term: times the direction of motion for a
    friction-like term) against the variable it lives on, on the rows of its shape, with the
    binned means, their 95 % band and the located range shaded."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from steer_monitor.estimate.locate import UNITS, WHAT

    loc = a.located
    assert loc is not None
    bar = a.final.ram_area * 1e5
    fig, ax = plt.subplots(figsize=(10, 3.8))
    ok = np.isfinite(loc.target)
    x, t = loc.x[ok], loc.target[ok] / bar
    if x.size > 20000:                 # a readable cloud, the same for a given log
        pick = np.linspace(0, x.size - 1, 20000).round().astype(int)
        x, t = x[pick], t[pick]
    ax.plot(x, t, '.', ms=1.5, color='0.65', label='residual (rows of the located shape)')
    centre = 0.5 * (loc.edges[1:] + loc.edges[:-1])
    used = loc.counts > 0
    ax.errorbar(centre[used], loc.means[used] / bar, yerr=1.96 * loc.se[used] / bar, fmt='o-', ms=3,
                color='tab:blue', label='binned mean, 95 %')
    ax.axvspan(loc.lo, loc.hi, color='tab:red', alpha=0.15, label='located range')
    ax.axhline(0.0, color='k', lw=0.8)
    signed = ' x direction of motion' if loc.shape.odd and not loc.shape.direction else ''
    name = f'|{WHAT[loc.variable]}|' if loc.either_side else WHAT[loc.variable]
    ax.set_xlabel(f'{name} [{UNITS[loc.variable]}]')
    ax.set_ylabel(f'residual{signed} [bar]')
    ax.set_ylim(*np.nanpercentile(t, [0.5, 99.5]) if t.size else (-1, 1))
    ax.set_title(f'where the unexplained residual lives ({loc.shape.ram_name}, {loc.shape.direction_name})')
    ax.legend(loc='upper right', fontsize=8)
    return fig


def residual_figure(a: Analysis) -> Any:
    """The ram-force residual over time in bar, under the declared model and after the
    adopted effect (the same when none was adopted)."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    bar = a.final.ram_area * 1e5
    effect = 'no effect adopted' if not a.steps else 'with ' + ', '.join(s.name for s in a.steps)
    if a.located is not None:
        effect += ', located term as a nuisance'
    panels = [(a.declared, a.observations, 'declared model')]
    if a.steps or a.located is not None:      # else the final model is the declared one: one panel
        panels.append((a.final, a.final_observations, f'final model ({effect})'))
    else:
        panels = [(a.declared, a.observations, 'declared model (no effect adopted: it is the final model)')]
    fig, ax = plt.subplots(len(panels), 1, figsize=(12, 2.6 * len(panels) + 0.4), sharex=True, squeeze=False)
    ax = ax[:, 0]
    for k, (est, obs, title) in enumerate(panels):
        t = (obs.t_ns - obs.t_ns[0]) / 1e9
        both = np.isfinite(est.residual)
        r = np.where(both.any(1), np.nansum(est.residual, 1) / np.maximum(both.sum(1), 1), np.nan) / bar
        ax[k].plot(t, r, '.', ms=1.5, color='tab:blue')
        ax[k].set_ylabel('residual [bar]')
        ax[k].set_title(f'{title}: RMS {est.rms / bar:.2f} bar, systematic {est.smooth_rms / bar:.2f} bar')
    ax[-1].set_xlabel('time [s]')
    return fig


def _words(d: Any) -> str:
    """Parameters as an engineer reads them: ``v_s_mm_s 3; f_st_n 15000 [12000 .. 18000]``, not
    a Python dict."""
    if not d:
        return '-'
    if not isinstance(d, dict):
        return str(d)
    out = []
    for k, v in d.items():
        if isinstance(v, dict) and 'value' in v:
            out.append(f'{k} {estimate_text(v)}')
        elif isinstance(v, float):
            out.append(f'{k} {v:g}')
        else:
            out.append(f'{k} {v}')
    return '; '.join(out)


def _num(x: float | None, fmt: str) -> str:
    return '-' if x is None else format(x, fmt)


def write_analysis_report(a: Analysis, result: dict[str, Any], path: str | Path) -> Path:
    """Write the page; returns its path."""
    plots = _plots(a)
    esc = html.escape

    def iv(d: dict[str, Any]) -> str:
        return estimate_text(d)

    rows = ''.join(f'<tr><td>{esc(name)}</td><td>{esc(iv(result[key]))}</td></tr>'
                   for name, key in (('2Z [mm]', 'clearance_2z_mm'), ('Z_gb [mm]', 'clearance_zgb_mm'),
                                     ('K_gl max', 'k_gl_max'), ('F_s [N]', 'seal_friction_n'),
                                     ('mu_b', 'mu_bushing'), ('mu_g', 'mu_guide')))
    scr = ''.join(
        f"<tr><td>{esc(s['name'])}</td><td>{esc(_words(s['fixed']))}</td><td>{s['held_out_gain']:.3f}</td>"
        f"<td>{s['delta_bic']:.1f}</td><td>{s['rmse_bar']:.3f}</td><td>{'yes' if s['passes'] else 'no'}</td></tr>"
        for s in result['screening']
    )
    inputs = result.get('data', {}).get('inputs', {})
    timing = ''.join(
        f'<tr><td>{esc(name)}</td><td>{v["samples"]}</td><td>{_num(v["period_s"], ".3f")}</td>'
        f'<td>{_num(None if v["jitter_s"] is None else v["jitter_s"] * 1e3, ".1f")}</td><td>{v["frames_lost"]}</td>'
        f'<td>{v["gaps_over_1s"]}</td><td>{v["expected_rate_hz"]:g}</td></tr>' for name, v in inputs.items())
    notes = ''.join(f'<li>{esc(n)}</li>' for n in result.get('data', {}).get('notes', []))
    effects = result['effects']
    eff = 'none' if not effects else '; '.join(
        f"{esc(e['name'])} ({e['rmse_before_bar']} &rarr; {e['rmse_after_bar']} bar): {esc(_words(e['params']))}"
        for e in effects)
    img = ''.join(f'<h2>{esc(title)}</h2><img alt="{esc(key)}" src="data:image/png;base64,{plots[key]}">'
                  for key, title in (('profiles', 'Clearance profiles'), ('torque', 'Tiller torque'),
                                     ('residual', 'Residual before and after'),
                                     ('located', 'Where the unexplained residual lives'))
                  if key in plots)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>steer_monitor analysis</title>
<style>body{{font-family:sans-serif;max-width:1100px;margin:2em auto}}td,th{{padding:2px 10px;text-align:left}}
table{{border-collapse:collapse}}tr:nth-child(even){{background:#f2f2f2}}img{{max-width:100%}}</style></head>
<body><h1>Clearance analysis: {esc(str(result.get('data', {}).get('log', '')))}</h1>
<p><b>{esc(result['message'])}</b></p>
<table><tr><th>quantity</th><th>value [95 % interval]</th></tr>{rows}</table>
<p>Added effects: {eff}. Residual {result['rmse_before_bar']} &rarr; {result['rmse_after_bar']} bar RMS
({result['rmse_before_n'] / 1e3:.3f} &rarr; {result['rmse_after_n'] / 1e3:.3f} kN of ram force).</p>
{img}
<h2>Candidates</h2><table><tr><th>effect</th><th>fixed</th><th>held-out gain</th><th>&Delta;BIC</th>
<th>RMS [bar]</th><th>passes</th></tr>{scr}</table>
<h2>The inputs as they came</h2><table><tr><th>input</th><th>samples</th><th>period [s]</th><th>jitter [ms]</th>
<th>frames lost</th><th>gaps over 1 s</th><th>configured [Hz]</th></tr>{timing}</table>
{f'<ul>{notes}</ul>' if notes else ''}
</body></html>
"""
    path = Path(path)
    write_text(path, page)
    return path
