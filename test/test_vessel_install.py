"""The package as a vessel installs it: the Python libraries at the versions Ubuntu 24.04 packages
(read from the archive's snapshot, test/data/apt-packages.yaml), nothing else: no numba, no
cantools, no mcap, no threadpoolctl. Its commands and its node run, and say what they do
without numba.

Slow (a virtual environment made from PyPI, then an analysis interpreted): behind the slow
marker, which CI runs.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import uuid
from pathlib import Path

import pytest

from steer_monitor.compiled import INTERPRETED
from test.conftest import ROOT
from test.support.aptindex import load_snapshot

pytestmark = pytest.mark.slow

#: Ubuntu's package -> the distribution pip installs the same library from
PIP_NAMES = {'python3-numpy': 'numpy', 'python3-scipy': 'scipy', 'python3-yaml': 'PyYAML',
             'python3-ruamel.yaml': 'ruamel.yaml', 'python3-matplotlib': 'matplotlib', 'python3-can': 'python-can',
             'python3-tqdm': 'tqdm', 'python3-zstandard': 'zstandard', 'python3-lz4': 'lz4'}


def upstream(version: str) -> str:
    """A Debian version's upstream part: ``1:1.26.4+ds-6ubuntu1`` -> ``1.26.4``."""
    v = version.split(':', 1)[-1].rsplit('-', 1)[0]
    return re.split(r'\+(?:ds|dfsg)', v)[0]


def test_upstream_versions_of_debian_ones():
    assert [upstream(v) for v in ('1:1.26.4+ds-6ubuntu1', '4.0.2+dfsg-1build4', '0.17.21-1', '6.0.1-2build2')] == \
        ['1.26.4', '4.0.2', '0.17.21', '6.0.1']


def _noble_pins() -> list[str]:
    noble = load_snapshot()['ubuntu noble']
    return [f'{pip}=={upstream(noble[apt])}' for apt, pip in sorted(PIP_NAMES.items())]


@pytest.fixture(scope='module')
def vessel(tmp_path_factory) -> Path:
    """A virtual environment of ROS 2's wheels, Ubuntu 24.04's versions of the libraries and the
    package (a copy of the tree, without its pip dependencies) -> its bin directory."""
    tmp = tmp_path_factory.mktemp('vessel')
    venv = tmp / 'venv'
    subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True)
    pip = [str(venv / 'bin' / 'python'), '-m', 'pip', 'install', '-q', '--disable-pip-version-check']
    ros = [line.strip() for line in (ROOT / 'requirements-ros.txt').read_text().splitlines()
           if line.strip() and not line.startswith('#')]
    pinned = [ln for ln in (ROOT / 'constraints.txt').read_text().splitlines()
              if ln.split('==')[0].strip().lower() in {r.lower() for r in ros}]
    proc = subprocess.run([*pip, *pinned, *_noble_pins()], capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        pytest.fail(f'cannot make the vessel environment: {proc.stderr[-1500:]}')
    src = tmp / 'src'
    shutil.copytree(ROOT, src, ignore=shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'out',
                                                             '__pycache__', '*.egg-info', '.pytest_cache'))
    subprocess.run([*pip, '--no-deps', str(src)], check=True, capture_output=True)
    return venv / 'bin'


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(('PYTHONPATH', 'AMENT_', 'COLCON_'))}
    env.update(ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', OPENBLAS_NUM_THREADS='1')
    return env


def test_the_vessel_environment_has_ubuntus_libraries_and_nothing_from_pip_only(vessel):
    probe = ('import importlib.util, json, numpy, scipy, can\n'
             'print(json.dumps({"numpy": numpy.__version__, "scipy": scipy.__version__, "can": can.__version__,\n'
             '  "absent": [m for m in ("numba", "cantools", "mcap", "mcap_ros2", "threadpoolctl")\n'
             '             if importlib.util.find_spec(m) is None]}))\n')
    got = json.loads(subprocess.run([str(vessel / 'python'), '-c', probe], env=_env(), cwd='/', check=True,
                                    capture_output=True, text=True).stdout)
    noble = load_snapshot()['ubuntu noble']
    assert (got['numpy'], got['scipy'], got['can']) == tuple(
        upstream(noble[p]) for p in ('python3-numpy', 'python3-scipy', 'python3-can'))
    assert got['absent'] == ['numba', 'cantools', 'mcap', 'mcap_ros2', 'threadpoolctl']


def test_the_commands_run_there_and_say_they_run_interpreted(vessel, tmp_path):
    sm = str(vessel / 'steer-monitor')
    log = tmp_path / 'h.mcap'
    subprocess.run([sm, 'simulate', '--program', 'hard_over_2', '--out', str(log), '--seed', '9105'], env=_env(),
                   check=True, capture_output=True)
    p = subprocess.run([sm, 'analyze', str(log), '--json', '-'], env=_env(), capture_output=True, text=True,
                       check=False)
    assert p.returncode == 0, p.stderr
    assert p.stderr.splitlines() == [f'steer-monitor analyze: note: {INTERPRETED}']
    there = json.loads(p.stdout)
    # the same analysis here (numba, this environment's libraries): the same verdicts, the same
    # figures to the printed digits but for what other releases of numpy and scipy round apart
    here_out = tmp_path / 'here.json'
    from steer_monitor.cli.main import main
    assert main(['analyze', str(log), '--json', str(here_out)]) == 0
    here = json.loads(here_out.read_text())
    assert there['verdict'] == here['verdict']
    for key in ('clearance_2z_mm', 'clearance_zgb_mm', 'k_gl_max'):
        a, b = there[key], here[key]
        assert (a.get('level'), a['bounded']) == (b.get('level'), b['bounded']), key
        for x, y in zip([a['value'], *(a['ci95'] or [])], [b['value'], *(b['ci95'] or [])]):
            assert (x is None) == (y is None), key
            assert x is None or x == pytest.approx(y, rel=2e-3, abs=2e-4), key
    p = subprocess.run([sm, 'inspect', str(log)], env=_env(), capture_output=True, text=True, check=True)
    assert p.stdout.startswith(f'{log}: 6521 frames')


def test_the_node_records_there_and_says_its_analyses_are_off(vessel, tmp_path):
    from steer_monitor.node.monitor_node import ANALYSES_OFF_WITHOUT_NUMBA
    cmd = [str(vessel / 'python'), '-m', 'steer_monitor.node.monitor_node', '--ros-args',
           '-p', 'can.interface:=virtual', '-p', f'can.channel:=vessel-{uuid.uuid4().hex[:6]}',
           '-p', f'recording.directory:={tmp_path}']
    proc = subprocess.Popen(cmd, env=_env(), stderr=subprocess.PIPE, text=True, cwd='/')
    try:
        deadline = time.monotonic() + 60
        while not list(tmp_path.glob('*.mcap')) and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.2)
        time.sleep(2.0)
        proc.send_signal(signal.SIGINT)
        assert proc.wait(30) == 0
        err = proc.stderr.read()
    finally:
        if proc.poll() is None:
            proc.kill()
    assert [ln for ln in err.splitlines() if ln.endswith(ANALYSES_OFF_WITHOUT_NUMBA)]
    [recording] = tmp_path.glob('*.mcap')
    from mcap.reader import make_reader  # the installed release reads what the carried copy wrote
    with open(recording, 'rb') as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and '/diagnostics' in {c.topic for c in summary.channels.values()}
