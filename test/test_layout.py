"""The package installs with pip into a prefix and builds with colcon; both layouts run.

Slow-ish (a few seconds each): each builds from a copy of the source tree, so the checkout
is left clean.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from test.conftest import ROOT

pytestmark = pytest.mark.layout

BIN = Path(sys.executable).parent


IGNORE = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'out', '__pycache__', '*.egg-info',
                                '.pytest_cache', '.hypothesis')


def _source_copy(tmp_path: Path) -> Path:
    """A copy of the repository (the ROS package at its root, what pip installs and what a
    workspace's ``src/`` holds as a clone) -> its directory."""
    src = tmp_path / 'src' / 'steer_monitor'
    shutil.copytree(ROOT, src, ignore=IGNORE)
    return src


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(('AMENT_', 'COLCON_', 'PYTHONPATH'))}
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.update(extra)
    return env


def _check_installed(python: str, script: Path, env: dict[str, str], share: Path) -> None:
    out = subprocess.run([str(script), 'fit', '240 H9/f9', '--json', '-'], env=env, check=True,
                         capture_output=True, text=True).stdout
    assert round(json.loads(out)['probable_max_mm'], 3) == 0.246
    where = subprocess.run([python, '-c', 'from steer_monitor.resources import default_config; '
                            'print(default_config())'], env=env, check=True, capture_output=True,
                           text=True, cwd='/').stdout.strip()
    assert Path(where) == share / 'config' / 'r18.yaml'
    out = subprocess.run([str(script), 'loadshare', '--json', '-'], env=env, check=True, cwd='/',
                         capture_output=True, text=True).stdout
    assert len(json.loads(out)['rows']) == 71


def _installed_files() -> list[str]:
    from importlib.metadata import distribution
    return sorted(str(f) for f in (distribution('steer_monitor').files or []))


def test_pip_install_layout(tmp_path):
    before = _installed_files()
    src = _source_copy(tmp_path)
    prefix = tmp_path / 'prefix'
    # --ignore-installed: install beside, never uninstall, the package in this environment.
    subprocess.run([sys.executable, '-m', 'pip', 'install', '--quiet', '--no-deps', '--ignore-installed',
                    '--no-build-isolation', '--prefix', str(prefix), str(src)],
                   check=True, env=_env(), cwd=tmp_path)
    share = prefix / 'share' / 'steer_monitor'
    assert (share / 'package.xml').is_file()
    for part in ('launch/monitor.launch.py', 'systemd/steer-monitor.service',
                 'config/aggregator/steer_monitor_analyzers.yaml'):
        assert (share / part).is_file(), part
    assert (share / 'config' / 'r18.yaml').is_file()
    assert (share / 'config' / 'r18_chain.yaml').is_file()
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / 'steer_monitor').is_file()
    script = prefix / 'bin' / 'steer-monitor'
    assert script.is_file()
    site = prefix / 'lib' / f'python{sys.version_info.major}.{sys.version_info.minor}' / 'site-packages'
    assert (site / 'steer_monitor' / 'model' / 'loadshare.py').is_file()
    # Run the prefix's copy, not the checkout: the prefix's site-packages first, the venv's
    # interpreter (and its dependencies), and sys.prefix pointing at the data files is what a
    # real pip install into that venv gives; here the ament index tells where share/ is.
    env = _env(PYTHONPATH=str(site), AMENT_PREFIX_PATH=str(prefix))
    _check_installed(sys.executable, script, env, share)
    assert _installed_files() == before, 'the test must not touch the environment it runs in'


@pytest.mark.skipif(shutil.which('colcon', path=str(BIN)) is None, reason='colcon-core is not installed')
def test_colcon_build_layout(tmp_path):
    """``colcon build`` in a workspace whose src/ holds the clone finds the one package at its
    root (ament_python: no compiler, no CMake), and it runs from the install: its commands,
    its launch file, and its messages through rclpy."""
    src = _source_copy(tmp_path).parent
    ws = tmp_path / 'ws'
    ws.mkdir()
    venv = str(Path(sys.prefix))
    done = subprocess.run([str(BIN / 'colcon'), 'build', '--base-paths', str(src), '--event-handlers',
                           'console_direct-'], cwd=ws, env=_env(
        PATH=f'{BIN}{os.pathsep}{os.environ.get("PATH", "")}', AMENT_PREFIX_PATH=venv),
        capture_output=True, text=True)
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert 'Finished <<< steer_monitor ' in done.stdout and 'cmake' not in done.stdout.lower()
    assert sorted(p.name for p in (ws / 'install').iterdir() if p.is_dir()) == ['steer_monitor']
    install = ws / 'install' / 'steer_monitor'
    share = install / 'share' / 'steer_monitor'
    assert (share / 'package.xml').is_file()
    for part in ('launch/monitor.launch.py', 'systemd/steer-monitor.service',
                 'config/aggregator/steer_monitor_analyzers.yaml'):
        assert (share / part).is_file(), part
    assert (install / 'share' / 'ament_index' / 'resource_index' / 'packages' / 'steer_monitor').is_file()
    # Where `ros2 run steer_monitor <exe>` looks: lib/<package>/<exe>.
    script = install / 'lib' / 'steer_monitor' / 'steer-monitor'
    assert script.is_file() and os.access(script, os.X_OK)
    monitor = install / 'lib' / 'steer_monitor' / 'monitor'
    assert monitor.is_file() and os.access(monitor, os.X_OK)
    assert "'console_scripts', 'monitor'" in monitor.read_text() or 'monitor_node' in monitor.read_text()
    site = install / 'lib' / f'python{sys.version_info.major}.{sys.version_info.minor}' / 'site-packages'
    env = _env(PYTHONPATH=str(site), AMENT_PREFIX_PATH=f'{install}{os.pathsep}{sys.prefix}')
    _check_installed(sys.executable, script, env, share)
    _check_messages(site, env)


ROUND_TRIP = """
import math, sys, time
import rclpy
from rclpy.executors import SingleThreadedExecutor
from rclpy.serialization import deserialize_message
from sensor_msgs.msg import JointState
from steer_monitor.model.gear import Clearances
from steer_monitor.monitor.messages import CLEARANCE_NAMES, TOPICS, diag_messages
from steer_monitor.monitor.pipeline import DiagOut
from steer_monitor.node.rosmsg import message_class
from steer_monitor.record.cdr import FAST_ENCODERS
import steer_monitor
assert all(message_class(t) for _, t in TOPICS.values())
out = DiagOut(7_000_000_008, (), Clearances(6e-4, 2.5e-4), {'2z': (5e-4, None), 'zgb': (2.4e-4, 2.7e-4)}, 'estimated')
fields = next(f for k, _, f in diag_messages(out) if k == 'clearances')
m = FAST_ENCODERS['sensor_msgs/msg/JointState'](fields)
assert deserialize_message(m, JointState).position[5] == 2.7e-4
ctx = rclpy.Context()
rclpy.init(context=ctx)
node = rclpy.create_node('layout_check', context=ctx)
ex = SingleThreadedExecutor(context=ctx)
ex.add_node(node)
got = []
node.create_subscription(JointState, '/layout_check/clearances', got.append, 10)
pub = node.create_publisher(JointState, '/layout_check/clearances', 10)
deadline = time.time() + 20
while not got and time.time() < deadline:
    pub.publish(m)
    ex.spin_once(timeout_sec=0.1)
values = dict(zip(got[0].name, got[0].position))
assert list(got[0].name) == list(CLEARANCE_NAMES) and values['gap_2z_m'] == 6e-4 and math.isnan(values['gap_2z_hi_m'])
print('ok', steer_monitor.__file__)
ex.shutdown()
node.destroy_node()
rclpy.shutdown(context=ctx)
"""


def _check_messages(site: Path, env: dict[str, str]) -> None:
    """The installed package's messages: the clearances' CDR as the node publishes it, read by
    rclpy, published serialized (loopback) and received, standard interfaces from the ROS 2 install alone."""
    out = subprocess.run([sys.executable, '-c', ROUND_TRIP], env=env, capture_output=True, text=True, timeout=120,
                         cwd=site)
    assert out.returncode == 0 and out.stdout.split()[:1] == ['ok'], out.stderr[-2000:]
    assert Path(out.stdout.split()[1]).is_relative_to(site)   # the install's module, not the checkout's
