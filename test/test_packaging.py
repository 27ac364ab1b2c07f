"""ROS 2 packaging: package.xml keys resolve in rosdistro's rosdep files, every imported
package is declared, and the launch file, analyzer and systemd unit are there and sound."""

from __future__ import annotations

import ast
import configparser
import os
import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import pytest
import yaml

from test.conftest import PKG, ROOT, SHARED

ROSDEP = SHARED / 'rosdep'
#: the rosdep keys this package ships (rosdistro's files lack them)
OWN_ROSDEP = PKG / 'rosdep' / 'steer_monitor.yaml'
#: ROS packages (resolved by rosdistro's distribution file, not by the rosdep key files)
ROS_PACKAGES = {'rclpy', 'rcl_interfaces', 'ament_index_python', 'diagnostic_msgs', 'std_msgs', 'sensor_msgs',
                'std_srvs', 'launch', 'launch_ros', 'ros2launch', 'diagnostic_aggregator'}
#: the package of this repository (rosdep skips it)
WORKSPACE = {'steer_monitor'}
MANIFESTS = [PKG / 'package.xml']
#: imported top-level module -> the rosdep key that installs it
MODULE_KEYS = {'numpy': 'python3-numpy', 'scipy': 'python3-scipy', 'yaml': 'python3-yaml',
               'ruamel': 'python3-ruamel.yaml',
               'matplotlib': 'python3-matplotlib', 'can': 'python3-can',
               'tqdm': 'python3-tqdm', 'zstandard': 'python3-zstandard', 'lz4': 'python3-lz4',
               'rclpy': 'rclpy', 'rcl_interfaces': 'rcl_interfaces', 'ament_index_python': 'ament_index_python',
               'diagnostic_msgs': 'diagnostic_msgs', 'std_msgs': 'std_msgs', 'sensor_msgs': 'sensor_msgs',
               'std_srvs': 'std_srvs',
               'builtin_interfaces': 'rclpy', 'launch': 'launch', 'launch_ros': 'launch_ros'}
#: imported, deliberately not declared, optional at run time (each says so where it is missed):
#: threadpoolctl has no rosdep key; numba's key names python3-numba, which Ubuntu 24.04 (ROS 2
#: Jazzy's and Kilted's) does not package (steer_monitor.compiled runs its loops interpreted)
OPTIONAL = {'threadpoolctl', 'numba'}
#: pip only, for what ashore commands do (the report's published clearances; setup.py's ashore
#: extra): a vessel's install has it not, and the command says so
OPTIONAL_ASHORE = {'mcap_ros2'}
#: ashore only (steer-monitor fleet; setup.py's 'ashore' extra), never imported by the vessel side
ASHORE = {'dask', 'distributed', 'pyarrow'}


def _depends(kind: str, manifest: Path = PKG / 'package.xml') -> list[str]:
    root = ET.parse(manifest).getroot()
    return [e.text.strip() for e in root.findall(kind) if e.text]


def rosdistro_keys() -> dict[str, dict]:
    """rosdistro's rosdep keys (its base and python files)."""
    keys: dict[str, dict] = {}
    for name in ('base.yaml', 'python.yaml'):
        keys.update(yaml.safe_load((ROSDEP / name).read_text(encoding='utf-8')))
    return keys


def own_keys() -> dict[str, dict]:
    return yaml.safe_load(OWN_ROSDEP.read_text(encoding='utf-8'))


def all_keys() -> dict[str, dict]:
    """The keys rosdep resolves once the package's own file is among its sources."""
    return {**rosdistro_keys(), **own_keys()}


def declared_keys() -> list[str]:
    """Every rosdep key package.xml names that is not a ROS package or this one."""
    kinds = ('exec_depend', 'test_depend', 'depend', 'build_depend', 'buildtool_depend')
    return [k for kind in kinds for k in _depends(kind) if k not in ROS_PACKAGES and k not in WORKSPACE]


@pytest.fixture(scope='module')
def rosdep_keys() -> dict[str, dict]:
    if not ROSDEP.is_dir():
        pytest.skip(f'{ROSDEP} is not here (../shared beside the repository holds it in CI)')
    return all_keys()


def test_the_packages_own_keys_are_not_rosdistros():
    """A key the package ships that rosdistro has come to hold is dropped from ours (two
    definitions of one key: rosdep takes the first source's)."""
    if not ROSDEP.is_dir():
        pytest.skip(f'{ROSDEP} is not here (../shared beside the repository holds it in CI)')
    assert set(own_keys()) & set(rosdistro_keys()) == set()


@pytest.mark.parametrize('distribution', ['ubuntu noble'])
def test_every_key_installs_an_os_package_the_distribution_has(rosdep_keys, distribution):
    """On Ubuntu 24.04, ROS 2 Jazzy's and Kilted's platform, every key package.xml names installs
    OS packages (never pip: PEP 668 refuses it, and a vessel takes nothing from pip into the
    system Python), and each is in the archive (test/data/apt-packages.yaml, read from the
    archives by ``python -m test.support.aptindex``). Debian, their tier 3, is not held to it:
    rosdistro gives python3-ruamel.yaml no rule for Debian 12 or 13 (docs/vessel.md)."""
    from test.support.aptindex import load_snapshot, resolve
    os_name, codename = distribution.split()
    there = load_snapshot()[distribution]
    bad = {}
    for key in declared_keys():
        got = resolve(rosdep_keys[key].get(os_name), codename)
        if got == 'pip' or got is None:
            bad[key] = 'pip' if got == 'pip' else 'no rule'
            continue
        for name in got:
            if name not in there:
                bad[key] = f'{name} not in the snapshot: run python -m test.support.aptindex'
            elif there[name] is None:
                bad[key] = f'{name} is not in {distribution}'
    assert bad == {}


def test_the_snapshot_knows_what_ubuntu_lacks():
    """The snapshot is the archives' word, not ours: Ubuntu 24.04 lacks numba, cantools and
    mcap (which is why the package runs without the first and carries its own of the others)."""
    from test.support.aptindex import load_snapshot
    noble = load_snapshot()['ubuntu noble']
    assert (noble['python3-numba'], noble['python3-cantools'], noble['python3-mcap']) == (None, None, None)
    assert noble['python3-numpy'] is not None and noble['python3-zstandard'] is not None


@pytest.mark.parametrize('manifest', MANIFESTS, ids=lambda p: p.parent.name)
@pytest.mark.parametrize('kind', ['exec_depend', 'test_depend', 'depend', 'build_depend', 'buildtool_depend'])
def test_every_key_resolves_on_ubuntu_and_debian(rosdep_keys, kind, manifest):
    for key in _depends(kind, manifest):
        if key in ROS_PACKAGES or key in WORKSPACE:
            continue
        assert key in rosdep_keys, f'{key} is not a rosdep key'
        rule = rosdep_keys[key]
        assert 'ubuntu' in rule and 'debian' in rule, f'{key} has no ubuntu/debian rule'


def _modules(path: Path) -> set[str]:
    """The modules ``path`` imports, absolute dotted names (``from a.b import c``: a.b and a.b.c)."""
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found |= {node.module} | {f'{node.module}.{a.name}' for a in node.names}
    return found


def _imports(paths: list[Path]) -> set[str]:
    """The top-level packages ``paths`` import."""
    return {m.split('.')[0] for path in paths for m in _modules(path)}


def test_every_imported_package_is_declared():
    sources = sorted((PKG / 'steer_monitor').rglob('*.py')) + sorted((PKG / 'launch').glob('*.py'))
    third_party = _imports(sources) - set(sys.stdlib_module_names) - {'steer_monitor', '__future__'}
    declared = set(_depends('exec_depend'))
    missing = {m: MODULE_KEYS.get(m) for m in third_party - OPTIONAL - OPTIONAL_ASHORE - ASHORE
               if MODULE_KEYS.get(m) not in declared}
    assert missing == {}


def test_every_published_message_package_is_declared():
    """The node imports its message types by name (rosmsg.message_class), which the import
    scan above does not see: each type's package is an exec_depend, and each is a standard
    interface package of ROS 2 (no interface package of our own to build)."""
    from steer_monitor.monitor.messages import TOPICS
    declared = set(_depends('exec_depend'))
    packages = {datatype.split('/')[0] for _, datatype in TOPICS.values()}
    assert packages - declared == set()
    assert packages <= {'diagnostic_msgs', 'sensor_msgs', 'std_msgs'}


def test_the_card_layout_at_the_root():
    """One ament_python package at the repository's root, as ROS 2 lays out an ament_python package, and
    nothing that needs a compiler."""
    for name in ('package.xml', 'setup.py', 'setup.cfg', 'README.md', 'resource/steer_monitor', 'config/r18.yaml',
                 'launch/monitor.launch.py', 'systemd/steer-monitor.service', 'steer_monitor/__init__.py',
                 'test/conftest.py'):
        assert (ROOT / name).exists(), name
    root = ET.parse(ROOT / 'package.xml').getroot()
    assert root.findtext('export/build_type') == 'ament_python'
    assert not (ROOT / 'steer_monitor_msgs').exists()
    skip = {'.git', '.venv', 'build', 'install', 'log', 'out', '.hypothesis', '.pytest_cache', '__pycache__'}
    found = []
    for top, dirs, files in os.walk(ROOT):
        dirs[:] = [d for d in dirs if d not in skip]
        found += [Path(top, f) for f in files if f == 'CMakeLists.txt' or f.endswith(('.msg', '.srv', '.action'))]
    assert found == []


def test_ashore_dependencies_stay_ashore():
    """Dask and pyarrow are imported only by the fleet's modules of the ashore subpackage and
    the fleet command, which the node never imports."""
    fleet = {('ashore', 'fleet.py'), ('ashore', 'store.py'), ('cli', 'fleet.py')}
    others = [p for p in sorted((PKG / 'steer_monitor').rglob('*.py')) if p.parts[-2:] not in fleet]
    assert _imports(others) & ASHORE == set()
    extras = (PKG / 'setup.py').read_text()
    assert "'ashore': ['dask[distributed]" in extras and 'pyarrow' in extras


#: the vessel side and the pure core: what the node runs
VESSEL = ('can', 'logfiles', 'model', 'estimate', 'monitor', 'node', 'record', 'sim')


@pytest.mark.parametrize('part', VESSEL)
def test_the_vessel_side_never_imports_the_shore_side(part):
    for path in sorted((PKG / 'steer_monitor' / part).rglob('*.py')):
        shore = {m for m in _modules(path) if m.startswith(('steer_monitor.ashore', 'steer_monitor.cli'))}
        assert not shore, f'{path.relative_to(PKG)} imports {sorted(shore)}'


@pytest.mark.parametrize('part', ['model', 'estimate', 'monitor'])
def test_the_core_is_pure(part):
    """Physics, estimation and the live monitor take arrays and records: no ROS, bus or file
    format library, and none of the package's log files."""
    for path in sorted((PKG / 'steer_monitor' / part).rglob('*.py')):
        assert _imports([path]) & {'rclpy', 'can', 'mcap', 'mcap_ros2', 'cantools'} == set(), path
        assert not {m for m in _modules(path) if m.startswith('steer_monitor.logfiles')}, path


def test_the_bus_side_stands_apart_from_the_log_files():
    """``can/`` is the bus (frames, codec, signals, devices, decoder, bus clock): it reads no
    log file; ``logfiles/`` builds on it, and discovery is an ashore tool."""
    for path in sorted((PKG / 'steer_monitor' / 'can').rglob('*.py')):
        mods = {m for m in _modules(path) if m.startswith(('steer_monitor.logfiles', 'steer_monitor.ashore'))}
        assert not mods, f'{path.relative_to(PKG)} imports {sorted(mods)}'
    assert _imports(sorted((PKG / 'steer_monitor' / 'can').rglob('*.py'))) & {'mcap', 'mcap_ros2'} == set()
    assert not (PKG / 'steer_monitor' / 'can' / 'discover.py').exists()


def test_the_package_carries_its_licence_and_what_its_readme_runs():
    """The licence package.xml and setup.py name, whole, installed beside package.xml; the
    `ros2 launch` verb the README starts the node with is a dependency (ros2launch), as are the
    packages its launch file imports."""
    root = ET.parse(PKG / 'package.xml').getroot()
    assert root.findtext('license') == 'Apache-2.0'
    text = (ROOT / 'LICENSE').read_text(encoding='utf-8')
    assert 'Apache License' in text and 'Version 2.0, January 2004' in text and 'END OF TERMS AND CONDITIONS' in text
    assert "'LICENSE'" in (ROOT / 'setup.py').read_text(encoding='utf-8')
    readme = (ROOT / 'README.md').read_text(encoding='utf-8')
    assert 'ros2 launch steer_monitor monitor.launch.py' in readme
    declared = set(_depends('exec_depend'))
    assert 'ros2launch' in declared
    launch = _imports([PKG / 'launch' / 'monitor.launch.py'])
    assert launch - {'os', 'steer_monitor'} <= declared, launch - declared     # its own package, and the stdlib


def test_launch_file_declares_its_arguments():
    src = (PKG / 'launch' / 'monitor.launch.py').read_text(encoding='utf-8')
    tree = ast.parse(src)
    assert any(isinstance(n, ast.FunctionDef) and n.name == 'generate_launch_description' for n in tree.body)
    args = [n.args[0].value for n in ast.walk(tree) if isinstance(n, ast.Call)
            and getattr(n.func, 'id', '') == 'DeclareLaunchArgument']
    assert args == ['name', 'params_file', 'interface', 'channel', 'aggregator']


def test_systemd_unit_stops_with_sigint_and_restarts():
    unit = configparser.ConfigParser(strict=False, interpolation=None)
    unit.optionxform = str
    unit.read_string((PKG / 'systemd' / 'steer-monitor.service').read_text())
    svc = unit['Service']
    assert svc['KillSignal'] == 'SIGINT' and svc['Restart'] == 'on-failure'
    assert 'ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST' in svc['Environment']
    assert 'ros2 launch steer_monitor monitor.launch.py' in svc['ExecStart']


#: what the pure core may not load, even through another module: ROS, the bus and log file
#: libraries, and the package's own I/O and vessel or shore parts
NOT_IN_THE_CORE = ('rclpy', 'can', 'mcap', 'mcap_ros2', 'cantools', 'rosbags', 'dask', 'pyarrow')
NOT_IN_THE_CORE_PARTS = ('can', 'logfiles', 'record', 'node', 'ashore', 'cli', 'monitor', 'sim')


def _core_modules() -> list[str]:
    return sorted(f'steer_monitor.{p.parent.name}' + ('' if p.stem == '__init__' else f'.{p.stem}')
                  for part in ('model', 'estimate') for p in (PKG / 'steer_monitor' / part).glob('*.py'))


def test_the_core_loads_nothing_of_the_io_even_transitively():
    """Every module of ``model/`` and ``estimate/`` imported in a fresh interpreter: what
    ``sys.modules`` then holds is numbers, the core and the package's root helpers (none of
    them loads anything else either: had one, it would be there)."""
    import json
    import subprocess
    import sys
    names = _core_modules()
    probe = ('import importlib, json, sys\n'
             'for name in json.loads(sys.argv[1]):\n'
             '    importlib.import_module(name)\n'
             'print(json.dumps(sorted(sys.modules)))\n')
    p = subprocess.run([sys.executable, '-c', probe, json.dumps(names)], capture_output=True, text=True, check=True,
                       cwd=PKG)
    loaded = json.loads(p.stdout)
    bad = [m for m in loaded if m.split('.')[0] in NOT_IN_THE_CORE
           or (m.startswith('steer_monitor.') and m.split('.')[1] in NOT_IN_THE_CORE_PARTS)]
    assert len(names) >= 20 and set(names) <= set(loaded) and bad == []


def _unit_imports() -> dict[str, set[str]]:
    """Which part of the package (a subpackage, or a module at its root) imports which other,
    at any level (a function's own imports too)."""
    graph: dict[str, set[str]] = {}
    for path in (PKG / 'steer_monitor').rglob('*.py'):
        unit = path.relative_to(PKG / 'steer_monitor').parts[0].removesuffix('.py')
        for mod in _modules(path):
            if mod.startswith('steer_monitor.'):
                other = mod.split('.')[1]
                if other != unit:
                    graph.setdefault(unit, set()).add(other)
    return graph


def test_no_two_parts_of_the_package_import_each_other():
    """The parts of the package form layers: no cycle between subpackages (or the modules at
    its root), of any length."""
    graph = _unit_imports()
    state: dict[str, int] = {}
    path: list[str] = []

    def visit(u: str) -> list[str] | None:
        state[u] = 1
        path.append(u)
        for v in sorted(graph.get(u, ())):
            if state.get(v) == 1:
                return path[path.index(v):] + [v]
            if v not in state and (cycle := visit(v)):
                return cycle
        state[u] = 2
        path.pop()
        return None

    for u in sorted(graph):
        if u not in state:
            assert visit(u) is None, ' -> '.join(path[path.index(path[-1]):]) if path else ''
    assert {'can', 'logfiles', 'model', 'estimate', 'monitor', 'ashore'} <= set(graph)
