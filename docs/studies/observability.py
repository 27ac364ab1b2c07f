"""How far each clearance can show in the pressures of each shipped gear: the figure and the
table of docs/observability.md.

For each gear config: the largest 2Z at which the ram clamps in its bushing, against Z_gb,
and the largest Z_gb at which the guide beam carries load, against 2Z
(:func:`steer_monitor.model.reach.reach`), under the gear's largest loads (a hard-over at
service speed) and under a hard-over at half of it and to 20 deg at service speed (what a
voyage of course keeping and slow manoeuvres holds). Beyond its curve a clearance changes no
pressure: the data can give only a lower bound, and a measurement tells the rest.

Run from the repository: ``.venv/bin/python docs/studies/observability.py docs/observability.md``
(writes the figure beside it, ``observability.png``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

CONFIGS = ('r18.yaml',)
KNOT = 1852.0 / 3600.0


def _curves(gear):
    from steer_monitor.model.reach import gear_loads, reach
    alpha, torque = gear_loads(gear)
    v = gear.torque.service_speed
    loads = {'hard-over at service speed': (alpha, torque),
             'hard-over at half speed': (alpha, np.abs(gear.torque(alpha, 0.5 * v))),
             '20 deg at service speed': (alpha[alpha <= math.radians(20.0) + 1e-9],
                                         torque[alpha <= math.radians(20.0) + 1e-9])}
    zgb = np.linspace(0.0, 0.6e-3, 61)
    tz = np.linspace(0.0, 1.5e-3, 61)
    out = {}
    for name, (a, t) in loads.items():
        out[name] = ([reach(gear, 0, a, t, z) for z in zgb], [reach(gear, 1, a, t, z) for z in tz])
    return zgb, tz, out


def main(argv: list[str]) -> int:
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    from steer_monitor.params import gear_from_params, load_params_file
    from steer_monitor.resources import default_config
    md = Path(argv[0])
    png = md.with_suffix('.png')
    root = Path(default_config()).parent
    fig, axes = plt.subplots(len(CONFIGS), 2, figsize=(11, 4.2 * len(CONFIGS)), squeeze=False)
    rows = []
    for k, cfg in enumerate(CONFIGS):
        params = load_params_file(str(root / cfg))
        gear = gear_from_params(params)
        l2z, lzgb = params['clearances.limit_2z_mm'], params['clearances.limit_zgb_mm']
        zgb, tz, curves = _curves(gear)
        ax2z, axzgb = axes[k]
        for name, (r2z, rzgb) in curves.items():
            ax2z.plot(zgb * 1e3, np.array(r2z) * 1e3, label=name)
            axzgb.plot(tz * 1e3, np.array(rzgb) * 1e3, label=name)
        for ax, limit, other_limit, title, xl, yl in (
                (ax2z, l2z, lzgb, 'ram bushing 2Z', 'Z_gb [mm]', 'largest 2Z that clamps [mm]'),
                (axzgb, lzgb, l2z, 'guide slipper Z_gb', '2Z [mm]', 'largest Z_gb the beam carries at [mm]')):
            ax.axhline(limit, color='k', ls='--', lw=0.8, label=f'limit {limit:g} mm')
            ax.axvline(other_limit, color='grey', ls=':', lw=0.8, label=f'other limit {other_limit:g} mm')
            ax.set(title=f'{cfg}: {title}', xlabel=xl, ylabel=yl)
            ax.set_ylim(bottom=0)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        service = curves['hard-over at service speed']
        for z in (0.05e-3, 0.10e-3, 0.15e-3, 0.20e-3, 0.25e-3, 0.30e-3):
            i = int(np.argmin(np.abs(zgb - z)))
            rows.append(f'| {cfg} | Z_gb {z * 1e3:.2f} mm | 2Z up to {service[0][i] * 1e3:.3f} mm '
                        f'({service[0][i] * 1e3 / l2z:.0%} of its {l2z:g} mm limit) | '
                        f'{curves["hard-over at half speed"][0][i] * 1e3:.3f} mm | '
                        f'{curves["20 deg at service speed"][0][i] * 1e3:.3f} mm |')
        for z in (0.1e-3, 0.3e-3, 0.6e-3, 1.0e-3):
            i = int(np.argmin(np.abs(tz - z)))
            rows.append(f'| {cfg} | 2Z {z * 1e3:.2f} mm | Z_gb up to {service[1][i] * 1e3:.3f} mm '
                        f'({service[1][i] * 1e3 / lzgb:.0%} of its {lzgb:g} mm limit) | '
                        f'{curves["hard-over at half speed"][1][i] * 1e3:.3f} mm | '
                        f'{curves["20 deg at service speed"][1][i] * 1e3:.3f} mm |')
    fig.tight_layout()
    fig.savefig(png, dpi=90)
    command = f'.venv/bin/python docs/studies/observability.py {argv[0]}'
    md.write_text('\n'.join([
        '# How far each clearance can show in the pressures',
        '',
        f'Made by `{command}` (docs/studies/observability.py; the load-sharing model of '
        'steer_monitor/model/reach.py, the one the estimator fits).',
        '',
        'A clearance shows in the cylinder pressures only past its contact: 2Z once the ram clamps in '
        'its bushing, Z_gb once the guide beam carries load. Below the load that makes the contact, the '
        'clearance changes no pressure, however large it is. So each gear has, for each clearance, a '
        'largest value its loads can show, which depends on the other clearance and on the load: the '
        'larger the rudder angle and the faster the ship, the further. Past it the data give only a '
        'lower bound, whatever manoeuvre is made, and the clearance has to be measured: `analyze`, the '
        'report, the node and the fleet then say "beyond what the pressures can show on this gear" and '
        'name no manoeuvre. Where a manoeuvre can show more than the data did, they name it, with its '
        'angle, its speed and how far it would show the clearance (`observable_to_mm` in the JSON: '
        '`loads_seen` and `gear`).',
        '',
        f'![Observable range of each clearance]({png.name})',
        '',
        'Read off the figure, under a hard-over at service speed (the gear\'s largest loads), at half '
        'speed and to 20 deg at service speed:',
        '',
        '| gear | the other clearance | hard-over at service speed | hard-over at half speed '
        '| 20 deg at service speed |',
        '|---|---|---|---|---|',
        *rows,
        '',
        'On the R-18 the ram bushing is the blind one: at its guide clearance of 0.25 mm, 2Z past about '
        '0.2 mm (a third of its 0.6 mm limit) never clamps, so a worn bushing is told by measurement, not '
        'by the pressures; the guide slipper shows well past its limit at any bushing clearance.',
        '',
    ]))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
