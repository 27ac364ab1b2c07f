"""Launch the steering-gear monitor: ``ros2 launch steer_monitor monitor.launch.py``.

Arguments: ``name`` (the node's name, ``steer_monitor``; another for a second gear on one ship:
its statuses and topics carry it, and its parameters file must hold an entry for it),
``params_file`` (default: the packaged R-18 parameters), ``interface`` and ``channel`` of the
CAN bus (python-can's names, e.g. socketcan / can0: given, they override the parameters file's
``can.interface`` / ``can.channel``; not given, the file's hold), and ``aggregator`` (true: also
start diagnostic_aggregator with the analyzer for this monitor's statuses). SIGINT and SIGTERM
(what launch and systemd send) stop the node cleanly; its MCAP file is finished.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription
from steer_monitor.node.analyzers import analyzer_parameters
from steer_monitor.node.launchargs import monitor_parameters, truthy
from steer_monitor.params import NODE_NAME


def _nodes(context, *args, **kwargs):
    def arg(name):
        return LaunchConfiguration(name).perform(context)

    name = arg('name')
    nodes = [Node(package='steer_monitor', executable='monitor', name=name, output='screen',
                  parameters=monitor_parameters(arg('params_file'), interface=arg('interface'),
                                                channel=arg('channel')),
                  sigterm_timeout='10')]
    if truthy(arg('aggregator')):
        # under its own name, ``analyzers``; its parameters made for this monitor's name
        nodes.append(Node(package='diagnostic_aggregator', executable='aggregator_node', output='screen',
                          parameters=[analyzer_parameters(name)]))
    return nodes


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory('steer_monitor')
    return LaunchDescription([
        DeclareLaunchArgument('name', default_value=NODE_NAME,
                              description="the monitor node's name (a second gear: another name)"),
        DeclareLaunchArgument('params_file', default_value=os.path.join(share, 'config', 'r18.yaml'),
                              description='ROS 2 parameters file of the gear (geometry, DBC, signal map)'),
        DeclareLaunchArgument('interface', default_value='',
                              description="python-can interface (empty: the parameters file's can.interface)"),
        DeclareLaunchArgument('channel', default_value='',
                              description="CAN channel of the steering bus (empty: the parameters file's can.channel)"),
        DeclareLaunchArgument('aggregator', default_value='false',
                              description='also run diagnostic_aggregator with the steering-gear analyzer'),
        OpaqueFunction(function=_nodes),
    ])
