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

from test.conftest import REPO

pytestmark = pytest.mark.layout

BIN = Path(sys.executable).parent


def _source_copy(tmp_path: Path) -> Path:
    src = tmp_path / 'src' / 'steer_monitor'
    ignore = shutil.ignore_patterns('.venv', '.git', 'build', 'install', 'log', 'out', '__pycache__',
                                    '*.egg-info', '.pytest_cache', '.hypothesis')
    shutil.copytree(REPO, src, ignore=ignore)
    return src


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith(('AMENT_', 'COLCON_', 'PYTHONPATH'))}
    env['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
    env.update(extra)
    return env


def _check_installed(python: str, script: Path, env: dict[str, str], share: Path) -> None:
    out = subprocess.run([str(script), 'fit', '240 H9/f9', '--json'], env=env, check=True,
                         capture_output=True, text=True).stdout
    assert round(json.loads(out)['probable_max_mm'], 3) == 0.246
    where = subprocess.run([python, '-c', 'from steer_monitor.resources import default_config; '
                            'print(default_config())'], env=env, check=True, capture_output=True,
                           text=True, cwd='/').stdout.strip()
    assert Path(where) == share / 'config' / 'r18.yaml'
    out = subprocess.run([str(script), 'loadshare', '--json'], env=env, check=True, cwd='/',
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
    src = _source_copy(tmp_path)
    ws = tmp_path / 'ws'
    ws.mkdir()
    subprocess.run([str(BIN / 'colcon'), 'build', '--base-paths', str(src.parent)], cwd=ws, check=True,
                   env=_env(), capture_output=True)
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
    env = _env(PYTHONPATH=str(site), AMENT_PREFIX_PATH=str(install))
    _check_installed(sys.executable, script, env, share)
