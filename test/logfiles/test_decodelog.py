"""Logs whose clock steps: the step is said in one line, the data after it kept as a new
stretch, and the estimate made of nearly all the frames."""

from __future__ import annotations

import json

import numpy as np
import pytest

from steer_monitor import sim
from steer_monitor.can.decoder import STITCH_GAP_NS, Decoder
from steer_monitor.can.frames import FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.decodelog import decode_logs
from steer_monitor.logfiles.logs import write_candump
from steer_monitor.model import Clearances

HOUR = 3600 * 10**9


@pytest.fixture(scope='module')
def voyage(r18_params, can_db):
    """A clean 25-minute realistic voyage (seed and clearances of no other test)."""
    db, smap = can_db
    return sim.run(r18_params, sim.SimConfig(program='realistic:1500', gaps=Clearances.from_mm(0.33, 0.205)), db, smap,
                   77).frames


def _stepped(frames: FrameArrays, step_ns: int) -> FrameArrays:
    t = frames.t_ns.copy()
    t[len(t) // 2:] += step_ns
    return FrameArrays(t, frames.can_id, frames.dlc, frames.data, frames.flags)


def _write(path, frames):
    with open(path, 'wb') as fh:
        write_candump(fh, frames)
    return path


@pytest.mark.parametrize('step_ns, said', [
    (-HOUR, "the frames' clock steps back 60.0 min after"),
    (-10**9, None),                                   # within the jump limit: a second of frames refused
    (24 * HOUR, "the frames' clock jumps forward 24.00 h after"),
])
def test_a_clock_step_keeps_the_data_after_it(voyage, can_db, tmp_path, step_ns, said):
    db, smap = can_db
    path = _write(tmp_path / 'stepped.log', _stepped(voyage, step_ns))
    rejects = RejectCounter()
    logs = decode_logs([path], db, smap, rejects)
    samples = sum(len(s) for s in logs.signals.values())
    plain = decode_logs([_write(tmp_path / 'plain.log', voyage)], db, smap, RejectCounter())
    assert samples >= 0.99 * sum(len(s) for s in plain.signals.values())
    for s in logs.signals.values():
        assert (np.diff(s.t_ns) > 0).all()           # one stream, in time order
    if said is None:
        assert logs.notes == () and rejects['time_backwards'] <= 0.01 * len(voyage)
    else:
        assert len(logs.notes) == 1 and logs.notes[0].startswith(said), logs.notes
        [st] = logs.clock_steps
        assert st.after_ns - st.before_ns == pytest.approx(step_ns, abs=2e8)
        if step_ns < 0:                               # put after the data before it, a minute later
            assert st.shift_ns == st.before_ns - st.after_ns + STITCH_GAP_NS
            assert 'kept as a new stretch' in logs.notes[0]


@pytest.mark.slow
@pytest.mark.parametrize('step_ns', [-HOUR, -10**9, 24 * HOUR])
def test_analyze_of_a_stepped_log_matches_the_unstepped_one(voyage, tmp_path, capsys, step_ns):
    """The estimate uses at least 99 % of the frames and matches the unstepped log's within
    its interval; the step is a note on stderr and in the JSON."""
    from steer_monitor.cli import analyze as A

    got = {}
    for name, frames in (('plain', voyage), ('stepped', _stepped(voyage, step_ns))):
        out = tmp_path / f'{name}.json'
        assert A.run(_write(tmp_path / f'{name}.log', frames), json_out=out) == 0
        got[name] = json.loads(out.read_text())
    plain, stepped = got['plain'], got['stepped']
    assert sum(stepped['data']['rejects'].values()) <= 0.01 * stepped['data']['frames']
    lo, hi = plain['clearance_zgb_mm']['ci95']
    assert lo <= stepped['clearance_zgb_mm']['value'] <= hi
    assert stepped['verdict'] == plain['verdict'] == 'declared'
    err = capsys.readouterr().err
    if abs(step_ns) > 5 * 10**9:
        assert len(stepped['data']['clock_steps']) == 1 and 'note: ' in err and "frames' clock" in err
    else:
        assert stepped['data']['clock_steps'] == []


def test_the_node_path_does_not_stitch(voyage, can_db):
    """Live (and a replay), a step back restarts the monitor instead: the decoder alone keeps
    the frames' own times and refuses the earlier ones."""
    db, smap = can_db
    d = Decoder(db, smap)
    out = d.decode_arrays(_stepped(voyage, -HOUR), final=True)
    assert d.clock_steps == [] and d.rejects['time_backwards'] > 0.4 * len(voyage)
    assert max(int(s.t_ns.max()) for s in out.values() if len(s)) < int(voyage.t_ns[-1])
