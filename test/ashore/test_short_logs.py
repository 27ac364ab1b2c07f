"""Short, cut and odd logs: ``analyze``, ``report`` and the fleet's per-log path
raise nothing but the one-line refusals a user reads, and agree on what the log can say.

The cases are drawn from a seeded generator (a property test without a framework): a
programme, a length of 1 to 10 minutes, clearances anywhere in their range, an effect or none,
and the file cut at a random byte (mid-line as often as not), none of them tuned on.
"""

from __future__ import annotations

import math
import random

import pytest

from steer_monitor import sim
from steer_monitor.logfiles.logs import write_candump
from steer_monitor.model import Clearances

pytestmark = pytest.mark.slow

PROGRAMMES = ('hard_over_2', 'hard_over_1', 'zigzag_10', 'zigzag_25', 'autopilot', 'autopilot_db', 'hold',
              'hold_at:-20/300', 'speed:8,autopilot', 'voyage', 'realistic')
EFFECTS = ('', '', 'viscous', 'angle_delay', 'pressure_offset', 'temp_friction', 'pressure_friction', 'stribeck',
           'ram_inertia', 'band_friction')
CASES = 12


def _case(k: int) -> dict:
    rng = random.Random(3700 + k)
    return {'program': PROGRAMMES[k % len(PROGRAMMES)], 'seconds': rng.uniform(60.0, 600.0),
            'gaps': (round(rng.uniform(0.1, 0.7), 4), round(rng.uniform(0.03, 0.35), 4)),
            'effect': rng.choice(EFFECTS), 'seed': rng.randrange(10**6), 'cut': rng.uniform(0.3, 1.0)}


@pytest.mark.parametrize('k', range(CASES))
def test_a_short_log_gives_an_answer_or_a_one_line_refusal(r18_params, can_db, tmp_path, k):
    from steer_monitor.ashore import loganalysis as A
    from steer_monitor.ashore.store import log_result
    from steer_monitor.cli import report as R
    from steer_monitor.errors import SteerMonitorError

    c = _case(k)
    db, smap = can_db
    effects = (sim.parse_effect(c['effect']),) if c['effect'] else ()
    s = sim.run(r18_params, sim.SimConfig(program=c['program'], gaps=Clearances.from_mm(*c['gaps']),
                                          max_duration_s=c['seconds'], effects=effects), db, smap, c['seed'])
    path = tmp_path / 'short.log'
    with open(path, 'wb') as fh:
        write_candump(fh, s.frames)
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * c['cut'])])          # cut anywhere, mid-line too

    try:
        a, out = A.analyze_log(path)
        assert {'value', 'ci95', 'bounded'} <= set(out['clearance_zgb_mm'])     # the JSON a script reads
    except SteerMonitorError as exc:                            # the one line a user reads
        assert '\n' not in str(exc) and 'internal error' not in str(exc)
        a = None
    assert R.run([str(path)], tmp_path / 'report', out=_Sink(), err=_Sink()) in (0, 1)
    assert (tmp_path / 'report' / 'index.html').is_file()
    r = log_result('v', str(path), None, 'x', 'y')
    assert not r.error.startswith('internal error'), r.error
    # the fleet's answer is analyze's on the same log (a short log: the model check is of all of it)
    if a is None:
        assert r.z_gb != r.z_gb and r.verdict == ''            # NaN: no estimate, no verdict
    else:
        assert _same((r.z_gb, r.z_gb_lo, r.z_gb_hi), _flat(a.final.z_gb))
        assert _same((r.two_z, r.two_z_lo, r.two_z_hi), _flat(a.final.two_z))
        assert r.verdict == a.verdict and r.effects == ','.join(st.name for st in a.steps)


def _same(xs, ys) -> bool:
    """Equal to 1e-9 relative (the same computation; BLAS may sum in another order), NaN
    to NaN."""
    return all((x != x and y != y) or math.isclose(x, y, rel_tol=1e-9) for x, y in zip(xs, ys, strict=True))


def _flat(iv):
    nan = float('nan')
    return (iv.value, nan if iv.lo is None else iv.lo, nan if iv.hi is None else iv.hi)


class _Sink:
    def write(self, text: str) -> int:
        return len(text)

    def flush(self) -> None:
        pass

    def isatty(self) -> bool:
        return False
