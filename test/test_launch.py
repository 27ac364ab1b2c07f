"""``monitor.launch.py`` run on stand-ins of launch and launch_ros (pip has no ``launch``): the
nodes it starts for given arguments, with the parameters each gets, in the order ROS 2 applies
them (the last wins)."""

from __future__ import annotations

import importlib.util
import sys
import types
from typing import Any

import pytest

from steer_monitor.node.analyzers import analyzer_parameters
from steer_monitor.node.launchargs import monitor_parameters, truthy
from test.conftest import PKG

SHARE = '/opt/ros/share/steer_monitor'


class _Recorded:
    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self.args, self.kwargs = args, kwargs


class _Config:
    def __init__(self, name: str) -> None:
        self.name = name

    def perform(self, context: dict[str, str]) -> str:
        return context[self.name]


def _stand_ins(monkeypatch) -> None:
    mods = {name: types.ModuleType(name) for name in
            ('launch', 'launch.actions', 'launch.substitutions', 'launch.conditions', 'launch_ros',
             'launch_ros.actions', 'ament_index_python', 'ament_index_python.packages')}
    mods['launch'].LaunchDescription = lambda entities: list(entities)
    mods['launch.actions'].DeclareLaunchArgument = type('DeclareLaunchArgument', (_Recorded,), {})
    mods['launch.actions'].OpaqueFunction = type('OpaqueFunction', (_Recorded,), {})
    mods['launch.substitutions'].LaunchConfiguration = _Config
    mods['launch.conditions'].IfCondition = type('IfCondition', (_Recorded,), {})
    mods['launch_ros.actions'].Node = type('Node', (_Recorded,), {})
    mods['ament_index_python.packages'].get_package_share_directory = lambda package: SHARE
    for name, mod in mods.items():
        monkeypatch.setitem(sys.modules, name, mod)


def _launch(monkeypatch, **given: str) -> list[dict[str, Any]]:
    """The keywords of each Node the launch file starts with the arguments ``given`` (the others
    at their defaults)."""
    _stand_ins(monkeypatch)
    spec = importlib.util.spec_from_file_location('monitor_launch', PKG / 'launch' / 'monitor.launch.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    entities = mod.generate_launch_description()
    args = {e.args[0]: e.kwargs['default_value'] for e in entities if type(e).__name__ == 'DeclareLaunchArgument'}
    assert set(given) <= set(args), set(given) - set(args)
    context = args | given
    nodes = []
    for e in entities:
        if type(e).__name__ == 'OpaqueFunction':
            nodes += [n.kwargs for n in e.kwargs['function'](context)]
    return nodes


def test_the_arguments_and_their_defaults(monkeypatch):
    _stand_ins(monkeypatch)
    spec = importlib.util.spec_from_file_location('monitor_launch', PKG / 'launch' / 'monitor.launch.py')
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    args = {e.args[0]: e.kwargs['default_value'] for e in mod.generate_launch_description()
            if type(e).__name__ == 'DeclareLaunchArgument'}
    assert args == {'name': 'steer_monitor', 'params_file': f'{SHARE}/config/r18.yaml', 'interface': '',
                    'channel': '', 'aggregator': 'false'}


def test_the_parameters_file_holds_unless_an_argument_is_given(monkeypatch):
    """Before, the launch file always put its own interface and channel after the file, so a
    vessel's file could not set them."""
    (monitor,) = _launch(monkeypatch, params_file='/etc/steer_monitor/vessel.yaml')
    assert monitor['parameters'] == ['/etc/steer_monitor/vessel.yaml'] and monitor['name'] == 'steer_monitor'
    (monitor,) = _launch(monkeypatch, params_file='/etc/v.yaml', channel='can1')
    assert monitor['parameters'] == ['/etc/v.yaml', {'can.channel': 'can1'}]      # after the file: it wins
    (monitor,) = _launch(monkeypatch, interface='virtual', channel='x')
    assert monitor['parameters'] == [f'{SHARE}/config/r18.yaml', {'can.interface': 'virtual', 'can.channel': 'x'}]


def test_a_second_gear_and_its_aggregator(monkeypatch):
    """The node under the name given; the aggregator under its own (``analyzers``), with the
    analyzer for that name."""
    monitor, aggregator = _launch(monkeypatch, name='port_gear', params_file='/etc/v.yaml', aggregator='true')
    assert monitor['name'] == 'port_gear'
    assert aggregator['executable'] == 'aggregator_node' and 'name' not in aggregator
    assert aggregator['parameters'] == [analyzer_parameters('port_gear')]
    assert analyzer_parameters('port_gear')['port_gear']['startswith'] == ['port_gear:']
    assert len(_launch(monkeypatch, aggregator='False')) == 1


def test_the_launch_arguments_alone():
    assert monitor_parameters('f.yaml', interface='', channel='') == ['f.yaml']
    assert monitor_parameters('f.yaml', channel='can0') == ['f.yaml', {'can.channel': 'can0'}]
    with pytest.raises(TypeError, match='not an overriding launch argument: bitrate'):
        monitor_parameters('f.yaml', bitrate='250000')
    assert [truthy(t) for t in ('true', 'True', '1', 'false', 'FALSE', '0')] == [True] * 3 + [False] * 3
    with pytest.raises(ValueError, match="expected true or false, got 'yes'"):
        truthy('yes')
