"""Replay: the live pipeline offline, deterministic, readable by independent readers."""

from __future__ import annotations

import json
import math

import pytest

from steer_monitor import sim
from steer_monitor.ashore.replay import ReplayError, replay
from steer_monitor.cli import main as cli
from steer_monitor.errors import OutputError
from steer_monitor.logfiles.logs import LogWriter
from steer_monitor.logfiles.mcapio import FRAME_TOPIC
from test.ashore.replay_reference import reference_replay

pytestmark = pytest.mark.slow

TOPICS = {'/diagnostics', '/steer_monitor/rudder', '/steer_monitor/load_sharing', '/steer_monitor/clearances',
          '/steer_monitor/clearance_source'}


@pytest.fixture(scope='module')
def logs(tmp_path_factory, r18_params, can_db):
    """Two consecutive simulated logs (hard-over, then zig-zag) as candump and MCAP."""
    db, smap = can_db
    d = tmp_path_factory.mktemp('replay')
    s = sim.run(r18_params, sim.SimConfig(program='hard_over_2,zigzag_10', max_duration_s=70.0), db, smap, 5)
    frames = s.frames.frames()
    half = len(frames) // 2
    paths = {}
    for name, part in (('a.log', frames[:half]), ('b.mcap', frames[half:]), ('all.log', frames)):
        with LogWriter(d / name) as w:
            for f in part:
                w.write(f)
        paths[name] = d / name
    return paths


def _read(path):
    from rosbags.highlevel import AnyReader
    out: dict[str, list] = {}
    with AnyReader([path]) as r:
        for conn, t, raw in r.messages():
            out.setdefault(conn.topic, []).append((t, r.deserialize(raw, conn.msgtype)))
    return out


def test_two_replays_are_identical_and_read_by_rosbags_and_mcap(tmp_path, logs):
    from mcap.reader import make_reader
    s1 = replay([logs['all.log']], tmp_path / 'one.mcap')
    s2 = replay([logs['all.log']], tmp_path / 'two.mcap')
    assert (tmp_path / 'one.mcap').read_bytes() == (tmp_path / 'two.mcap').read_bytes()
    assert s1.errors == [] and s1.frames == s2.frames > 5000
    msgs = _read(tmp_path / 'one.mcap')
    assert set(msgs) == TOPICS | {FRAME_TOPIC}
    assert len(msgs[FRAME_TOPIC]) == s1.frames
    assert len(msgs['/diagnostics']) == s1.diagnostics == len(msgs['/steer_monitor/clearances'])
    assert len(msgs['/steer_monitor/rudder']) == s1.states
    for t, m in msgs['/steer_monitor/rudder']:
        assert m.header.stamp.sec * 10**9 + m.header.stamp.nanosec == t
        assert m.name == ['rudder'] and math.isfinite(m.position[0])
    names = {st.name for _, m in msgs['/diagnostics'] for st in m.status}
    assert names == {'steer_monitor: CAN input', 'steer_monitor: clearances', 'steer_monitor: guide beam',
                     'steer_monitor: steering performance', 'steer_monitor: model health', 'steer_monitor: rams'}
    # the hard-over was seen and timed
    last = {st.name: {kv.key: kv.value for kv in st.values} for st in msgs['/diagnostics'][-1][1].status}
    assert 10 < float(last['steer_monitor: steering performance']['hard_over_s']) < 28
    with open(tmp_path / 'one.mcap', 'rb') as fh:
        n = sum(1 for _ in make_reader(fh, validate_crcs=True).iter_messages())
    assert n == sum(len(v) for v in msgs.values())


def _hostile(frames: list) -> list:
    """The frames with what a real bus brings: a 25 s gap, an error frame, an unknown PGN, a
    wrong length, duplicates, one frame stamped a day late, a late frame from the past."""
    from steer_monitor.can.frames import Frame
    t0, t1 = frames[0].t_ns, frames[-1].t_ns
    mid = (t0 + t1) // 2
    out = [f for f in frames if not mid <= f.t_ns < mid + 25_000_000_000]
    k = len(out) // 3
    g = out[k]
    out[k:k] = [Frame(g.t_ns, 0, b'', True, True), Frame(g.t_ns, 0x09FFFF10, bytes(8)),
                Frame(g.t_ns, g.can_id, g.data[:3]), g, g, Frame(g.t_ns - 5_000_000_000, g.can_id, g.data)]
    h = out[2 * k]        # far from those: their run is decoded at once, this one's frame by frame
    out[2 * k:2 * k] = [Frame(h.t_ns + 86_400_000_000_000, h.can_id, h.data)]
    return out


@pytest.mark.parametrize('case', ['all', 'no frames', 'split', 'hostile', 'two hours apart', 'broken'])
def test_the_fast_replay_writes_the_reference_bytes(tmp_path, logs, busy, case):
    """States are packed in batches, runs of frames decoded at once; the file is the
    per-frame reference's (every message built and written one at a time), byte for byte,
    chunk boundaries included, and so are the analyses."""
    paths = {'split': [logs['b.mcap'], logs['a.log']]}.get(case, [logs['all.log']])
    if case in ('hostile', 'two hours apart'):
        from steer_monitor.can.frames import Frame
        from steer_monitor.logfiles.blocks import iter_log
        frames = list(iter_log(logs['all.log']))
        if case == 'hostile':
            frames = _hostile(frames)
        else:       # a clock step (or a log that resumes) of two hours, within one file
            half = len(frames) // 2
            frames[half:] = [Frame(f.t_ns + 7_200_000_000_000, f.can_id, f.data) for f in frames[half:]]
        paths = [tmp_path / 'changed.log']
        with LogWriter(paths[0]) as w:
            for f in frames:
                w.write(f)
    if case == 'broken':            # a log that breaks off, then the next one
        paths = [logs['a.log'], tmp_path / 'cut.mcap']
        raw = logs['b.mcap'].read_bytes()
        paths[1].write_bytes(raw[: len(raw) // 2])
    fast = replay(paths, tmp_path / 'fast.mcap', busy, frames=case != 'no frames')
    ref = reference_replay(paths, tmp_path / 'ref.mcap', busy, frames=case != 'no frames')
    assert fast.states == ref.states > 1000 and fast.rejects == ref.rejects and fast.errors == ref.errors
    assert fast.finding == ref.finding and fast.motion_s == ref.motion_s
    assert fast.analyses == ref.analyses >= {'hostile': 1, 'broken': 0}.get(case, 3)
    assert (tmp_path / 'fast.mcap').read_bytes() == (tmp_path / 'ref.mcap').read_bytes()
    if case == 'hostile':
        assert {'error_frame', 'unknown_id', 'wrong_length', 'duplicate', 'time_jump', 'time_backwards'} <= set(
            ref.rejects
        )


def test_split_logs_in_any_order_give_the_whole_log(tmp_path, logs):
    whole = replay([logs['all.log']], tmp_path / 'whole.mcap', frames=False)
    split = replay([logs['b.mcap'], logs['a.log']], tmp_path / 'split.mcap', frames=False)
    assert split.logs == [str(logs['a.log']), str(logs['b.mcap'])]
    assert (tmp_path / 'whole.mcap').read_bytes() == (tmp_path / 'split.mcap').read_bytes()
    assert split.frames == whole.frames


def test_a_broken_log_keeps_what_came_before_and_goes_on(tmp_path, logs, capsys):
    cut = tmp_path / 'cut.mcap'
    raw = logs['b.mcap'].read_bytes()
    cut.write_bytes(raw[: len(raw) // 2])
    s = replay([logs['a.log'], cut], tmp_path / 'out.mcap', frames=False)
    assert len(s.errors) == 1 and 'cut.mcap' in s.errors[0] and 'frames before it were read' in s.errors[0]
    assert s.frames > 0
    assert _read(tmp_path / 'out.mcap')['/diagnostics']           # the output is finished and readable
    rc = cli.main(['replay', str(logs['a.log']), str(cut), '--out', str(tmp_path / 'cli.mcap')])
    assert rc == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and err[0].startswith('steer-monitor replay: error: ') and 'cut.mcap' in err[0]


@pytest.mark.parametrize(('args', 'message'), [
    ([], 'no log given'),
    (['missing.log'], 'missing.log does not exist'),
    (['adir'], 'adir is a directory, not a file'),
])
def test_bad_inputs_are_named(tmp_path, args, message):
    (tmp_path / 'adir').mkdir()
    with pytest.raises(ReplayError, match=message):
        replay([tmp_path / a for a in args], tmp_path / 'x.mcap')


def test_unwritable_output_is_named(tmp_path, logs):
    with pytest.raises(OutputError, match='cannot write .*: no directory'):
        replay([logs['a.log']], tmp_path / 'no' / 'such' / 'dir' / 'x.mcap')


def test_a_replay_without_frames_given_as_a_log_says_what_it_is(tmp_path, logs, capsys):
    """Its topics are not CAN frames: every command says so and what to do, in one line."""
    replay([logs['a.log']], tmp_path / 'nof.mcap', frames=False)
    for command in ('inspect', 'report'):
        argv = [command, str(tmp_path / 'nof.mcap')]
        argv += ['--out', str(tmp_path / 'page')] if command == 'report' else []
        assert cli.main(argv) == 1
        err = capsys.readouterr().err.splitlines()
        assert len(err) == 1 and 'no CAN frames' in err[0], err
        assert err[0].endswith("these are the monitor's topics without the raw frames, as a replay made with "
                               "--no-frames writes them: replay the log it was made from without --no-frames"), err


def test_cli_json(tmp_path, logs, capsys):
    rc = cli.main(['replay', str(logs['a.log']), '--out', str(tmp_path / 'j.mcap'), '--json', '-', '--no-frames'])
    assert rc == 0
    d = json.loads(capsys.readouterr().out)
    assert d['frames'] > 0 and d['errors'] == [] and d['diagnostics'] > 10
    topics = _read(tmp_path / 'j.mcap')
    assert FRAME_TOPIC not in topics
    # the clearances' verdict said is the last the node published, read back by an independent reader
    last = [st for _, msg in topics['/diagnostics'] for st in msg.status if st.name.endswith(': clearances')][-1]
    said = {kv.key: kv.value for kv in last.values}
    level = said['assessment'] if said['assessment'] == 'NOT ASSESSED' else \
        {0: 'OK', 1: 'WARN', 2: 'ERROR', 3: 'STALE'}[int(last.level)]
    assert d['clearances_status'] == {'level': level, 'message': last.message}
    rc = cli.main(['replay', str(logs['a.log']), '--out', str(tmp_path / 't.mcap'), '--no-frames'])
    assert rc == 0
    assert (f"the node's clearances status at the end: {d['clearances_status']['level']} {last.message}\n"
            in capsys.readouterr().out)


PROGRAMMES = ['hard_over_2', 'hard_over_1', 'zigzag_10', 'autopilot:60', 'pumps:1,autopilot_db:60', 'hold:20',
              'hold_at:-7.3/20,zigzag_5', 'speed:8,hold:10,speed:16,zigzag_10', 'pumps:1,zigzag_10,pumps:2,zigzag_10',
              'voyage', 'realistic']


@pytest.mark.parametrize(('program', 'effect'), [(p, None) for p in PROGRAMMES] +
                         [('hard_over_2,zigzag_10', e) for e in sim.EFFECTS])
def test_every_programme_and_effect_replays_to_the_reference_bytes(tmp_path, r18_params, can_db, program, effect):
    """Each helm programme (75 s of it) and each effect of the simulator (the analysis library's
    and the band of friction outside it), replayed fast and by the per-frame reference."""
    db, smap = can_db
    effects = (sim.parse_effect(effect),) if effect else ()
    s = sim.run(r18_params, sim.SimConfig(program=program, max_duration_s=75.0, effects=effects), db, smap, 11)
    log = tmp_path / 'voyage.log'
    with LogWriter(log) as w:
        for f in s.frames.frames():
            w.write(f)
    fast = replay([log], tmp_path / 'fast.mcap')
    ref = reference_replay([log], tmp_path / 'ref.mcap')
    assert fast.states == ref.states > 1000 and fast.errors == ref.errors == []
    assert fast.finding == ref.finding and fast.motion_s == ref.motion_s
    assert (tmp_path / 'fast.mcap').read_bytes() == (tmp_path / 'ref.mcap').read_bytes()


def test_analyses_that_fail_are_errors_where_the_reference_puts_them(tmp_path, logs, busy, monkeypatch):
    """Analyses that raise (a defect), on both sides of a damaged log's error: each is one error
    in the summary when its finding would have come, the replay goes on, and the fast replay's
    errors and file are the reference's."""
    import steer_monitor.monitor.analyst as A
    calls = {'n': 0}
    real = A.analyze

    def failing(*args, **kwargs):
        calls['n'] += 1
        if calls['n'] % 2 == 1:
            msg = f'analysis {calls["n"]} refused'
            raise ValueError(msg)
        return real(*args, **kwargs)
    monkeypatch.setattr(A, 'analyze', failing)
    from steer_monitor.can.busconfig import load_setup
    from steer_monitor.logfiles.mcapio import McapWriter
    _, params, db, smap = load_setup(busy)
    frames = sim.run(params, sim.SimConfig(program='hard_over_2,zigzag_10,zigzag_20', max_duration_s=150.0), db, smap,
                     5).frames.frames()
    third = len(frames) // 3
    paths = [tmp_path / 'first.log', tmp_path / 'cut.mcap', tmp_path / 'last.log']
    for path, part in ((paths[0], frames[:third]), (paths[2], frames[2 * third:])):
        with LogWriter(path) as w:
            for f in part:
                w.write(f)
    with McapWriter(paths[1], chunk_size=4096) as w:      # small chunks: half the file holds frames
        for f in frames[third:2 * third]:
            w.write_frame(f)
    raw = paths[1].read_bytes()
    paths[1].write_bytes(raw[: len(raw) // 2])       # the middle log breaks off
    ref = reference_replay(paths, tmp_path / 'ref.mcap', busy)
    calls['n'] = 0
    again = replay(paths, tmp_path / 'again.mcap', busy)
    failed = [e for e in ref.errors if e.startswith('the analysis failed: ValueError: analysis')]
    assert failed and len(ref.errors) > len(failed)
    assert again.errors == ref.errors
    assert (tmp_path / 'again.mcap').read_bytes() == (tmp_path / 'ref.mcap').read_bytes()


def test_a_log_within_the_time_of_the_ones_before_it_is_said(tmp_path, logs, capsys):
    """A copy or an overlapping log given with the others: its frames were refused as
    time_backwards, said only among the reject counts."""
    s = replay([logs['a.log'], logs['b.mcap']], tmp_path / 'ab.mcap', frames=False)
    assert s.notes == []
    rc = cli.main(['replay', str(logs['all.log']), str(logs['a.log']), '--out', str(tmp_path / 'x.mcap'),
                   '--no-frames', '--json', '-'])
    captured = capsys.readouterr()
    assert rc == 0
    (note,) = json.loads(captured.out)['notes']
    assert note.startswith(f"{logs['a.log']}: ") and note.endswith(
        'frames lie within the time of the logs before it (the logs overlap, or one is a copy): refused as '
        'time_backwards')
    assert captured.err == f'steer-monitor replay: note: {note}\n'


def test_a_recording_is_replayed_with_the_parameters_it_was_made_with(logs, busy, tmp_path):
    """A replay of a recording made with other parameters (here: analyses every 10 s of
    motion) without --config uses them, says so, and gives what a replay with that file gives."""
    from steer_monitor.ashore.replay import replay

    src = tmp_path / 'node.mcap'
    replay([logs['all.log']], src, busy)                   # a recording that carries busy's parameters
    a = replay([src], tmp_path / 'a.mcap', busy, frames=False)
    b = replay([src], tmp_path / 'b.mcap', frames=False)
    assert any('replayed with the parameters it was recorded with' in n for n in b.notes)
    assert a.analyses == b.analyses > 3 and a.finding == b.finding
    assert (tmp_path / 'a.mcap').read_bytes() == (tmp_path / 'b.mcap').read_bytes()


def test_recorded_parameters_that_do_not_validate_are_refused_in_one_line(tmp_path):
    from steer_monitor.ashore.replay import recorded_setup
    from steer_monitor.errors import ParameterError
    from steer_monitor.logfiles.mcapio import McapWriter
    from steer_monitor.params import load_config
    from steer_monitor.record.provenance import run_metadata

    _, params = load_config(None)
    path = tmp_path / 'bad.mcap'
    with McapWriter(path) as w:
        for name, data in run_metadata(params).items():
            if name.endswith('parameters'):
                data = {**data, 'estimator.every_motion_s': '-5.0', 'estimator.half_life_h': '2.0'}
            w.add_metadata(name, data)
    with pytest.raises(ParameterError, match=r'bad\.mcap: the parameters it was recorded with: parameter '
                                              r'estimator\.every_motion_s.*\(give --config\)$'):
        recorded_setup(path)
