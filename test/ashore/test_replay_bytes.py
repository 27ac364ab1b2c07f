"""The fast replay's equality with the per-frame reference, in a minute of make test (the
full set, every programme and effect and damaged logs, is test_replay.py's, slow)."""

from __future__ import annotations

from steer_monitor import sim
from steer_monitor.ashore.replay import replay
from steer_monitor.logfiles.logs import LogWriter
from test.ashore.replay_reference import reference_replay


def test_a_short_voyage_replays_to_the_reference_bytes(tmp_path, r18_params, can_db, busy):
    """A hard-over and a zig-zag with viscous friction, the analyses made often: the fast replay
    (runs decoded at once, states packed) writes the per-frame reference's file, byte for byte."""
    db, smap = can_db
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2,zigzag_10', max_duration_s=60.0,
                                          effects=(sim.parse_effect('viscous'),)), db, smap, 29)
    log = tmp_path / 'short.log'
    with LogWriter(log) as w:
        for f in s.frames.frames():
            w.write(f)
    fast = replay([log], tmp_path / 'fast.mcap', busy)
    ref = reference_replay([log], tmp_path / 'ref.mcap', busy)
    assert fast.states == ref.states > 1000 and fast.analyses == ref.analyses >= 2
    assert fast.finding == ref.finding and fast.motion_s == ref.motion_s
    assert (tmp_path / 'fast.mcap').read_bytes() == (tmp_path / 'ref.mcap').read_bytes()
