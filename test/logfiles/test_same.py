"""A log given twice is read once: the same file under two names, a link, or a copy."""

from __future__ import annotations

from steer_monitor.logfiles.same import distinct_logs


def test_the_same_data_is_kept_once_and_said(tmp_path):
    a, b, c = tmp_path / 'a.log', tmp_path / 'b.log', tmp_path / 'c.log'
    a.write_text('(1.0) can0 123#00\n')
    b.write_text('(1.0) can0 123#00\n')                 # a copy
    c.write_text('(2.0) can0 123#00\n')                 # other data
    link = tmp_path / 'link.log'
    link.symlink_to(a)
    endless = tmp_path / 'endless.log'
    endless.symlink_to('/dev/zero')                     # never read here: it has no end
    kept, notes = distinct_logs([a, c, b, link, a, tmp_path / 'missing.log', endless])
    assert kept == [a, c, tmp_path / 'missing.log', endless]     # the reader names what is not a log
    assert notes == [f'{b} holds the same data as {a}: read once', f'{link} holds the same data as {a}: read once',
                     f'{a} holds the same data as {a}: read once']


def test_report_of_one_log_given_twice_counts_it_once(tmp_path, capsys):
    import json

    from steer_monitor.cli.main import main
    log = tmp_path / 'h.log'
    assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '30', '--out', str(log)]) == 0
    capsys.readouterr()
    assert main(['report', str(log), '--out', str(tmp_path / 'one'), '--analysis-hours', '0', '--json', '-']) == 0
    once = json.loads(capsys.readouterr().out)
    assert main(['report', str(log), str(log), '--out', str(tmp_path / 'two'), '--analysis-hours', '0',
                 '--json', '-']) == 0
    cap = capsys.readouterr()
    twice = json.loads(cap.out)
    assert f'steer-monitor report: note: {log} holds the same data as {log}: read once' in cap.err
    assert twice['frames'] == once['frames'] and twice['hard_overs_s'] == once['hard_overs_s']
