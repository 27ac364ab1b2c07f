"""``steer-monitor report``: the page, looked at in a real browser (headless Chromium)."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import pytest

from steer_monitor import sim
from steer_monitor.ashore.report.reviewpage import PLOTS
from steer_monitor.cli import main as cli
from steer_monitor.logfiles.logs import LogWriter

pytestmark = pytest.mark.slow

CHROMIUM = next((p for p in (shutil.which(n) for n in ('chromium', 'chromium-browser', 'google-chrome')) if p), None)


@pytest.fixture(scope='module')
def logs(tmp_path_factory, r18_params, can_db):
    """A candump log with hard-overs and zig-zags, and its replay (an MCAP with the node's topics)."""
    from steer_monitor.ashore.replay import replay
    db, smap = can_db
    d = tmp_path_factory.mktemp('report')
    frames = sim.run(r18_params, sim.SimConfig(program='hard_over_2,zigzag_20,zigzag_10', max_duration_s=240.0),
                     db, smap, 8).frames
    log = d / 'gear.log'
    with LogWriter(log) as w:
        for f in frames.frames():
            w.write(f)
    rep = d / 'replay.mcap'
    replay([log], rep)
    return {'log': log, 'replay': rep}


def _chromium(*args: str) -> str:
    out = subprocess.run([CHROMIUM, '--headless=new', '--no-sandbox', '--disable-gpu', '--hide-scrollbars',
                          '--no-first-run', *args], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    return out.stdout


@pytest.mark.skipif(CHROMIUM is None, reason='no Chromium on this machine (Debian: apt-get install chromium); '
                                            '.ci/run installs it')
@pytest.mark.parametrize('which', ['log', 'replay'])
def test_page_renders_every_plot_in_chromium(tmp_path, logs, which, capsys):
    out = tmp_path / 'rep'
    assert cli.main(['report', str(logs[which]), '--out', str(out), '--json', '-']) == 0
    summary = json.loads(capsys.readouterr().out)
    assert (
        summary['estimates'] >= 1
        and summary['hard_overs_s']
        and summary['model_check']['verdict'] in ('declared', 'effect')
    )
    page = out / 'index.html'
    for key in PLOTS:
        assert (out / f'{key}.png').stat().st_size > 5000
    dom = _chromium('--virtual-time-budget=10000', '--dump-dom', page.as_uri())
    rendered = re.search(r'data-plots-rendered="(\d+)/(\d+)"', dom)
    assert rendered is not None, dom[:500]
    assert rendered.groups() == (str(len(PLOTS)), str(len(PLOTS)))
    for key in PLOTS:
        assert re.search(rf'id="plot-{key}"[^>]*data-rendered="yes"|data-rendered="yes"[^>]*id="plot-{key}"', dom), key
    assert '2Z (ram bushing)' in dom and 'hard-overs' in dom
    for name in ('2Z', 'Z_gb'):        # the verdict, first on the page
        box = re.search(rf'id="verdict-{name}">(.*?)</div></div>', dom)
        assert box is not None and re.search(r'class="big">(OK|WARN|OVER LIMIT|NOT ASSESSED)<',
                                             box.group(1)), name
    assert 'R-18 gear; data 20' in dom and 'SHA-256' in dom and 'steer_monitor 0.1.0' in dom
    for key in ('clearance_2z_mm', 'clearance_zgb_mm'):      # with the level the page's verdict box shows
        assert set(summary[key]) - {'observable_to_mm'} == {'value', 'ci95', 'bounded', 'level'}
        assert summary[key]['level'] in ('OK', 'WARN', 'OVER LIMIT', 'NOT ASSESSED'), summary[key]
    assert set(summary['k_gl_max']) >= {'value', 'ci95', 'bounded'}
    shot = tmp_path / 'shot.png'
    _chromium('--window-size=1200,5000', f'--screenshot={shot}', page.as_uri())
    import matplotlib.image as mpimg
    img = mpimg.imread(shot)
    assert img.shape[:2] == (5000, 1200)
    # not blank: the plots put ink on most of the page's height
    ink = (img[:, :, :3].mean(axis=2) < 0.9).any(axis=1)
    assert ink[:4000].mean() > 0.3


def test_the_estimates_a_replay_published_are_read(logs):
    from steer_monitor.ashore.report.reviewpage import published_track
    track = published_track([logs['replay']])
    assert track is not None and len(track.t_ns) > 100
    assert (track.t_ns[1:] > track.t_ns[:-1]).all()
    assert published_track([logs['log']]) is None


def test_a_recording_with_a_chunk_declaring_too_much_is_not_handed_to_mcaps_reader(tmp_path, logs):
    """mcap's reader inflates a chunk to the size it declares (a hostile 100 kB chunk can
    declare gigabytes): a file with a chunk beyond what one may hold gives no published track
    (its frames' reader has said it is corrupt), nothing is inflated."""
    import struct
    import tracemalloc

    from steer_monitor.ashore.report.reviewpage import published_track
    from steer_monitor.logfiles.mcapcols import MAX_CHUNK_BYTES, mcap_chunks_within_limits
    data = bytearray(logs['replay'].read_bytes())
    pos = 8
    while data[pos] != 0x06:                                  # the first chunk record
        pos += 9 + struct.unpack_from('<Q', data, pos + 1)[0]
    struct.pack_into('<Q', data, pos + 9 + 16, 3 << 30)      # declares 3 GiB
    path = tmp_path / 'declares.mcap'
    path.write_bytes(bytes(data))
    assert mcap_chunks_within_limits(logs['replay']) and not mcap_chunks_within_limits(path)
    assert 3 << 30 > MAX_CHUNK_BYTES
    tracemalloc.start()
    try:
        assert published_track([path]) is None
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 64 << 20, peak
    assert not mcap_chunks_within_limits(logs['log'])        # not an MCAP
    cut = tmp_path / 'cut.mcap'
    cut.write_bytes(bytes(logs['replay'].read_bytes()[:pos + 20]))
    assert mcap_chunks_within_limits(cut)                     # cut inside a chunk header: the readers say so


@pytest.mark.parametrize(('args', 'message'), [
    (['missing.log'], 'does not exist'),
    (['{log}', '--analysis-hours', '-1'], 'analysis-hours must be a finite number >= 0, got -1.0'),
    (['{log}', '--analysis-hours', 'nan'], 'analysis-hours must be a finite number >= 0, got nan'),
    (['{log}', '--analysis-hours', 'inf'], 'analysis-hours must be a finite number >= 0, got inf'),
])
def test_bad_arguments_are_named(tmp_path, logs, args, message, capsys):
    args = [a.format(log=logs['log']) for a in args]
    assert cli.main(['report', *args, '--out', str(tmp_path / 'x')]) == 1
    assert message in capsys.readouterr().err


def test_clearances_of_older_recordings_are_read(tmp_path):
    """Recordings made before the clearances were named carry them as a labelled
    Float64MultiArray; the report reads those too (and leaves other arrays alone)."""
    import math

    from steer_monitor.ashore.report.reviewpage import published_track
    from steer_monitor.logfiles.mcapio import McapWriter
    from steer_monitor.monitor.messages import CLEARANCE_NAMES
    from steer_monitor.record import msgdef
    dt = 'std_msgs/msg/Float64MultiArray'
    path = tmp_path / 'old.mcap'
    with McapWriter(path) as w:
        w.add_schema(dt, msgdef(dt))
        w.add_channel('/steer_monitor/clearances', dt)
        for k, labels in enumerate((CLEARANCE_NAMES, ('something', 'else'))):
            data = [0.6e-3, 0.2e-3, math.nan, 0.25e-3, 0.24e-3, 0.27e-3][:len(labels)]
            w.write('/steer_monitor/clearances', {'layout': {'dim': [{'label': ','.join(labels), 'size': len(labels),
                                                                      'stride': len(labels)}], 'data_offset': 0},
                                                  'data': data}, 1_700_000_000_000_000_000 + k * 1_000_000_000)
    track = published_track([path])
    assert track is not None and track.t_ns.tolist() == [1_700_000_000_000_000_000]
    assert math.isclose(track.z_gb[0], 0.25e-3) and math.isnan(track.two_z_hi[0])


def test_clearances_of_jointstate_recordings_are_read(tmp_path):
    """Recordings made between the two (named values in a JointState, with a ``bounded``
    flag per clearance) are read by name; a JointState without those names is left alone."""
    import math

    from steer_monitor.ashore.report.reviewpage import published_track
    from steer_monitor.logfiles.mcapio import McapWriter
    from steer_monitor.record import msgdef
    dt = 'sensor_msgs/msg/JointState'
    names = ['gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_2z_bounded',
             'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m', 'gap_zgb_bounded']
    values = [0.6e-3, 0.2e-3, math.nan, 0.0, 0.25e-3, 0.24e-3, 0.27e-3, 1.0]
    path = tmp_path / 'joint.mcap'
    with McapWriter(path) as w:
        w.add_schema(dt, msgdef(dt))
        w.add_channel('/steer_monitor/clearances', dt)
        for k, (n, v) in enumerate(((names, values), (['rudder'], [0.1]))):
            w.write('/steer_monitor/clearances', {
                'header': {'stamp': {'sec': 0, 'nanosec': 0}, 'frame_id': ''}, 'name': n, 'position': v,
                'velocity': [math.nan] * len(v), 'effort': [math.nan] * len(v)},
                1_700_000_000_000_000_000 + k * 1_000_000_000)
    track = published_track([path])
    assert track is not None and track.t_ns.tolist() == [1_700_000_000_000_000_000]
    assert math.isclose(track.two_z[0], 0.6e-3) and math.isclose(track.z_gb_hi[0], 0.27e-3)
    assert math.isnan(track.two_z_hi[0])


def test_a_page_that_cannot_be_written_whole_leaves_the_earlier_one(tmp_path, logs, capsys, monkeypatch):
    """The disk fills while the page's files are written (here: the fourth file's flush to disk
    fails with ENOSPC): one line, and the directory holds the earlier page and plots as they
    were, not new plots beside an old page, nor any temporary."""
    import errno
    import os

    import steer_monitor.atomic as atomic
    out = tmp_path / 'rep'
    assert cli.main(['report', str(logs['log']), '--out', str(out), '--analysis-hours', '0']) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    assert sorted(before) == sorted(['index.html'] + [f'{k}.png' for k in PLOTS])
    calls = []

    def fsync(fd: int) -> None:
        calls.append(fd)
        if len(calls) == 4:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
    monkeypatch.setattr(atomic.os, 'fsync', fsync)
    capsys.readouterr()
    assert cli.main(['report', str(logs['replay']), '--out', str(out), '--analysis-hours', '0']) == 1
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 1 and re.fullmatch(r'steer-monitor report: error: cannot write .*\.png: No space left on '
                                          r'device', err[0]), err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_the_load_sharing_figure_says_a_bound_is_a_bound():
    from steer_monitor.ashore.report.reviewpage import clearances_words
    from steer_monitor.estimate.intervals import Interval
    from steer_monitor.model.gear import Clearances
    gaps = Clearances.from_mm(0.9, 0.25)
    assert clearances_words(gaps, None) == 'at the configured clearances 2Z 0.900 mm, Z_gb 0.250 mm'
    words = clearances_words(gaps, (Interval(0.9e-3, 0.41e-3, None), Interval(0.25e-3, 0.22e-3, 0.28e-3)))
    assert words == ('at the estimated clearances: 2Z >= 0.410 mm, a lower bound (drawn at 0.900 mm); '
                     'Z_gb 0.250 mm [0.220 .. 0.280]')
    assert '0.900 mm [' not in words and 'not determined' in clearances_words(gaps, (Interval(0.9e-3, None, None),) * 2)


def test_the_timeline_says_which_model_its_windows_fit():
    from types import SimpleNamespace

    from steer_monitor.ashore.report.reviewpage import timeline_caveat
    assert timeline_caveat(None) == ''
    assert timeline_caveat(SimpleNamespace(verdict='declared', steps=())) == ''
    said = timeline_caveat(SimpleNamespace(verdict='effect', steps=(SimpleNamespace(name='viscous'),)))
    assert said == ' The windows also fit the effects the model check adopted (viscous).'
    said = timeline_caveat(SimpleNamespace(verdict='unexplained', steps=(SimpleNamespace(name='stribeck'),),
                                           located=object()))
    assert '(stribeck)' in said and 'does not explain' in said and 'the term it located taken out' in said
    said = timeline_caveat(SimpleNamespace(verdict='unexplained', steps=(), located=None))
    assert 'adopted' not in said and 'counted as noise' in said and 'incomplete model' in said


def test_without_mcap_ros2_the_published_clearances_are_left_out_and_report_says_so(tmp_path):
    """mcap-ros2-support (pip, ashore) decodes what a node published; without it the page goes
    without that track, and ``report`` of an MCAP says why first."""
    import subprocess
    import sys

    from test.conftest import ROOT
    code = ("import sys; sys.modules['mcap_ros2'] = None\n"
            "from steer_monitor.ashore.report import reviewpage as r\n"
            "print(r.PUBLISHED_READABLE, r.published_track([sys.argv[1]]))\n"
            "from steer_monitor.cli.main import main\n"
            "raise SystemExit(main(['report', sys.argv[1], '--out', sys.argv[2]]))\n")
    mcap = tmp_path / 'nothing.mcap'
    mcap.write_bytes(b'')
    p = subprocess.run([sys.executable, '-c', code, str(mcap), str(tmp_path / 'out')], capture_output=True,
                       text=True, cwd=ROOT, timeout=120, check=False)
    from steer_monitor.ashore.report.reviewpage import NOT_READABLE_NOTE
    assert p.stdout.splitlines()[0] == 'False None'
    assert p.stderr.splitlines()[0] == f'steer-monitor report: note: {NOT_READABLE_NOTE}'
