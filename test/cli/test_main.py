"""The entry point: SIGTERM ends a command as Ctrl-C does, and leaves nothing behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from steer_monitor.cli.main import main
from test.conftest import PKG


def _gone(pid: int) -> bool:
    """The process has ended (or is a zombie its parent has not reaped)."""
    try:
        with open(f'/proc/{pid}/stat') as fh:
            return fh.read().split(') ')[1].split()[0] == 'Z'
    except OSError:
        return True


def _children(pid: int) -> list[int]:
    with open(f'/proc/{pid}/task/{pid}/children') as fh:
        return [int(c) for c in fh.read().split()]


@pytest.mark.skipif(not os.path.isfile(f'/proc/{os.getpid()}/task/{os.getpid()}/children'),
                    reason='reads a process\'s children from Linux /proc')
def test_sigterm_ends_a_replay_cleanly(tmp_path):
    """SIGTERM (a service manager stopping a job, a batch system's time limit) killed the
    replay on the spot: its half-made MCAP stayed under its temporary name and its estimator
    process ran on, orphaned. Now: one line, status 143, no file left; and a replay starts no
    process (its analyses run in it), so none can be left behind."""
    log = tmp_path / 'voyage.log'
    assert main(['simulate', '--program', 'autopilot:1200', '--out', str(log)]) == 0
    out = tmp_path / 'out'
    out.mkdir()
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    said = tmp_path / 'stderr.txt'      # a file, not a pipe, which a child left alive would hold open
    workers: list[int] = []
    with open(said, 'w') as errors:
        proc = subprocess.Popen([sys.executable, '-m', 'steer_monitor.cli.main', 'replay', str(log), '--out',
                                 str(out / 'r.mcap')], env=env, cwd=PKG, stderr=errors)
    try:
        deadline = time.time() + 60
        while not list(out.iterdir()) and time.time() < deadline:    # writing has begun
            time.sleep(0.01)
        assert list(out.iterdir()), 'the replay never started its output'
        workers = _children(proc.pid)
        proc.send_signal(signal.SIGTERM)
        rc = proc.wait(30)
    finally:
        if proc.poll() is None:
            proc.kill()
        for w in workers:
            if not _gone(w):
                os.kill(w, signal.SIGKILL)
    err = said.read_text()
    assert rc == 143 and err == 'steer-monitor replay: terminated (SIGTERM)\n', (rc, err)
    assert list(out.iterdir()) == []
    assert workers == [], f'the replay started processes {workers}: each must end with it (test that then)'


def test_the_sigterm_handler_is_the_caller_s_again_afterwards(capsys):
    before = signal.getsignal(signal.SIGTERM)
    assert main(['fit', '240 H9/f9']) == 0
    assert signal.getsignal(signal.SIGTERM) is before


@pytest.mark.parametrize('command', ['replay', 'discover', 'analyze', 'recover'])
def test_an_output_to_stdout_in_a_pipe_is_the_file_and_the_words_go_to_stderr(tmp_path, command):
    """``--out /dev/stdout | ...``: as root, the link /dev/stdout was replaced by the file; an MCAP asked where it
    was (a pipe cannot say: 'Illegal
    seek'), discover read its written file back (from the pipe: it hung), and the summary for
    people went into the same stream as the file's bytes. Now the pipe carries the file alone,
    the same bytes as a file of that name."""
    log = tmp_path / 'zz.log'
    assert main(['simulate', '--program', 'zigzag_10', '--out', str(log), '--max-duration', '60']) == 0
    made = tmp_path / 'made.mcap'
    if command == 'recover':
        assert main(['replay', str(log), '--out', str(made), '--no-frames']) == 0
    argv = {'replay': ['replay', str(log), '--no-frames', '--out'],
            'discover': ['discover', str(log), '--write-config'],
            'analyze': ['analyze', str(log), '--json'],
            'recover': ['recover', str(made), '--out']}[command]
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    stdout = tmp_path / 'stdout'        # what /dev/stdout is, where a version that replaces it harms nothing
    stdout.symlink_to('/proc/self/fd/1')
    piped = subprocess.run([sys.executable, '-m', 'steer_monitor.cli.main', *argv, str(stdout)], env=env,
                           cwd=PKG, capture_output=True, timeout=120, check=False)
    assert piped.returncode == 0, piped.stderr
    in_file = tmp_path / {'replay': 'r.mcap', 'discover': 'v.yaml', 'analyze': 'a.json', 'recover': 'c.mcap'}[command]
    done = subprocess.run([sys.executable, '-m', 'steer_monitor.cli.main', *argv, str(in_file)], env=env,
                          cwd=PKG, capture_output=True, timeout=120, check=False)
    assert done.returncode == 0, done.stderr
    if command == 'analyze':      # its timing differs from run to run
        import json
        a, b = json.loads(piped.stdout), json.loads(in_file.read_text())
        a.pop('analysis_s'), b.pop('analysis_s')
        assert a == b
    elif command != 'replay':
        assert piped.stdout == in_file.read_bytes()
    else:       # a replay's metadata holds its output's name
        import io

        from mcap.reader import make_reader

        def messages(data: bytes) -> list:
            return [(c.topic, m.log_time, m.data) for _, c, m in make_reader(io.BytesIO(data)).iter_messages()]
        assert messages(piped.stdout) == messages(in_file.read_bytes()) != []
    words = piped.stderr.decode()
    if command != 'analyze':
        assert str(stdout) in words, words
    assert stdout.is_symlink()


def test_a_command_loads_only_what_it_needs():
    """`steer-monitor inspect` parses with its own module only: it does not load the
    estimator's compiled solver (numba, about 70 MB of resident memory), which the modules of
    fit, analyze or report would."""
    import subprocess
    import sys
    probe = ('import sys\n'
             'from steer_monitor.cli.main import build_parser\n'
             'build_parser("inspect").parse_args(["inspect", "x.log"])\n'
             'print("numba" in sys.modules, "steer_monitor.cli.fit" in sys.modules)\n')
    out = subprocess.run([sys.executable, '-c', probe], capture_output=True, text=True, check=True).stdout.split()
    assert out == ['False', 'False'], out


def _vessel_files(tmp_path):
    """The packaged gear's parameters as a vessel keys them: one file for ``port_gear`` alone,
    one for two gears (what both share under ``/**``, each its own channel)."""
    import yaml
    base = yaml.safe_load((PKG / 'config' / 'r18.yaml').read_text())['steer_monitor']['ros__parameters']
    shared = {'/**': {'ros__parameters': base}}
    one, two = tmp_path / 'one.yaml', tmp_path / 'two.yaml'
    one.write_text(yaml.safe_dump({**shared, 'port_gear': {'ros__parameters': {'can': {'channel': 'can2'}}}}))
    two.write_text(yaml.safe_dump({**shared, 'port_gear': {'ros__parameters': {'can': {'channel': 'can2'}}},
                                   '/stbd_gear': {'ros__parameters': {'can': {'channel': 'can1'}}}}))
    return one, two


def test_a_command_reads_a_vessel_file_keyed_by_its_nodes_name(tmp_path, capsys):
    """A file of one node (``port_gear:``) reads as it is; a file of two says whose with
    ``--node``; without it, one line naming them; ``--node`` without a file is a usage error."""
    one, two = _vessel_files(tmp_path)
    assert main(['loadshare', '--config', str(one), '--step-deg', '5']) == 0
    assert main(['loadshare', '--config', str(two), '--node', 'stbd_gear', '--step-deg', '5']) == 0
    capsys.readouterr()
    assert main(['loadshare', '--config', str(two), '--step-deg', '5']) == 1
    assert capsys.readouterr().err == (f'steer-monitor loadshare: error: parameters file {two} holds the parameters of '
                                       'nodes port_gear, stbd_gear: say whose with --node NAME\n')
    assert main(['loadshare', '--config', str(one.with_name('none.yaml')), '--node', 'aft_gear']) == 1
    assert 'none.yaml' in capsys.readouterr().err
    with pytest.raises(SystemExit) as exc:
        main(['loadshare', '--node', 'port_gear'])
    assert exc.value.code == 2 and '--node NAME names an entry of the file --config gives' in capsys.readouterr().err


def test_the_node_named_is_the_one_a_command_reads(tmp_path):
    """Which entry is read: the channel each gear's entry sets over what ``/**`` shares."""
    from steer_monitor.params import ParamsFile, load_config
    _, two = _vessel_files(tmp_path)
    assert load_config(ParamsFile(str(two), 'port_gear'))[1]['can.channel'] == 'can2'
    assert load_config(ParamsFile(str(two), 'stbd_gear'))[1]['can.channel'] == 'can1'
    # a node of no entry of its own gets what /** gives every node, as ROS 2 gives it
    assert load_config(ParamsFile(str(two), 'aft_gear'))[1]['can.channel'] == 'can0'
