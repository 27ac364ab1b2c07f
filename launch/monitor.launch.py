"""Launch the steering-gear monitor: ``ros2 launch steer_monitor monitor.launch.py``.

Arguments: ``params_file`` (default: the packaged R-18 parameters), ``interface`` and
``channel`` of the CAN bus (python-can's names: socketcan / can0), and ``aggregator``
(true: also start diagnostic_aggregator with the packaged analyzer for the gear's statuses).
SIGINT and SIGTERM (what launch and systemd send) stop the node cleanly; its MCAP file is
finished.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch.actions import DeclareLaunchArgument
from launch.conditions import IfCondition
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node

from launch import LaunchDescription


def generate_launch_description() -> LaunchDescription:
    share = get_package_share_directory('steer_monitor')
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=os.path.join(share, 'config', 'r18.yaml'),
                              description='ROS 2 parameters file of the gear (geometry, DBC, signal map)'),
        DeclareLaunchArgument('interface', default_value='socketcan', description="python-can interface"),
        DeclareLaunchArgument('channel', default_value='can0', description='CAN channel of the steering bus'),
        DeclareLaunchArgument('aggregator', default_value='false',
                              description='also run diagnostic_aggregator with the steering-gear analyzer'),
        Node(package='steer_monitor', executable='monitor', name='steer_monitor', output='screen',
             parameters=[LaunchConfiguration('params_file'),
                         {'can.interface': LaunchConfiguration('interface'),
                          'can.channel': LaunchConfiguration('channel')}],
             sigterm_timeout='10'),
        # under its own name, ``analyzers``, which the analyzer file is keyed by
        Node(package='diagnostic_aggregator', executable='aggregator_node',
             output='screen', condition=IfCondition(LaunchConfiguration('aggregator')),
             parameters=[os.path.join(share, 'config', 'aggregator', 'steer_monitor_analyzers.yaml')]),
    ])
