"""The replay's progress bar: data time out of the logs' spans, shown on a terminal or when
asked, nothing on a pipe."""

from __future__ import annotations

import io

import pytest

from steer_monitor import sim
from steer_monitor.cli import main as cli
from steer_monitor.cli.progress import DataTimeProgress, log_spans
from steer_monitor.logfiles.logs import LogWriter


@pytest.fixture(scope='module')
def two_logs(tmp_path_factory, r18_params, can_db):
    """A simulated hard-over cut in two: a candump log and an MCAP."""
    db, smap = can_db
    d = tmp_path_factory.mktemp('progress')
    frames = sim.run(r18_params, sim.SimConfig(program='hard_over_2', max_duration_s=12.0), db, smap, 2).frames.frames()
    half = len(frames) // 2
    out = []
    for name, part in (('a.log', frames[:half]), ('b.mcap', frames[half:])):
        with LogWriter(d / name) as w:
            for f in part:
                w.write(f)
        out.append((d / name, part[0].t_ns, part[-1].t_ns))
    return out


def test_spans_are_the_first_and_last_frames(two_logs):
    assert log_spans([p for p, _, _ in two_logs]) == [(a, b) for _, a, b in two_logs]


def test_a_log_whose_end_cannot_be_told_gives_no_spans(tmp_path, two_logs):
    raw = tmp_path / 'x.raw'      # canboat's plain format: its end is not read cheaply
    raw.write_text('2016-04-09T16:41:09.078Z,2,127245,204,255,8,ff,f8,ff,7f,ff,7f,ff,ff\n')
    assert log_spans([two_logs[0][0], raw]) is None


class _Tty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_percentage_of_the_data_time():
    err = _Tty()
    spans = [(0, 40_000_000_000), (100_000_000_000, 160_000_000_000)]     # 40 s, then 60 s after a pause
    with DataTimeProgress(spans, 'replay', err) as bar:
        assert bar.done_s(20_000_000_000) == 20.0
        assert bar.done_s(70_000_000_000) == 40.0       # in the pause: the first log is done
        assert bar.done_s(130_000_000_000) == 70.0
        bar(4096, 130_000_000_000)
        bar(10, 160_000_000_000)
    text = err.getvalue()
    assert 'replay (s of data)' in text and '100%' in text and '100/100 s' in text and '4,106 frames' in text


def test_frames_without_a_total_when_a_span_is_unknown():
    err = _Tty()
    with DataTimeProgress(None, 'replay', err) as bar:
        bar(4096, None)
    assert '4.10kframe' in err.getvalue() and '%' not in err.getvalue()


def test_nothing_on_a_pipe_unless_forced():
    pipe = io.StringIO()
    with DataTimeProgress([(0, 10)], 'replay', pipe) as bar:
        bar(5, 10)
    assert pipe.getvalue() == ''
    with DataTimeProgress([(0, 10_000_000_000)], 'replay', pipe, force=True) as bar:
        bar(5, 10_000_000_000)
    assert '100%' in pipe.getvalue()


@pytest.mark.parametrize('flag, shown', [([], False), (['--progress'], True)])
def test_replay_cli_shows_progress_when_asked(tmp_path, two_logs, capsys, flag, shown):
    rc = cli.main(['replay', *(str(p) for p, _, _ in two_logs), '--out', str(tmp_path / 'o.mcap'), *flag])
    assert rc == 0
    err = capsys.readouterr().err
    assert ('100%' in err) is shown, err
