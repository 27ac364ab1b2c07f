"""``steer-monitor run --params-file config/r18.yaml``: the monitor node, as ``ros2 run
steer_monitor monitor --ros-args --params-file ...`` starts it on a vessel."""

from __future__ import annotations

import argparse
from collections.abc import Sequence

__all__ = ['register', 'run']


def run(params_file: str, ros_args: Sequence[str] = ()) -> int:
    """Start the node. The parameters file is read and checked here first (one line naming the
    file and the key when it is bad), so rcl never meets a file it would refuse with a C
    traceback of its own."""
    from steer_monitor.params import load_params_file
    load_params_file(params_file)
    from steer_monitor.node.monitor_node import main
    return main(['steer-monitor', '--ros-args', '--params-file', params_file, *ros_args])


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('run', help='run the monitor node (ROS 2)',
                       description='Run the monitor node: listen on the steering CAN bus, publish '
                                   '/diagnostics and the typed topics, record MCAP. Ctrl-C or SIGTERM '
                                   'stops it and finishes the recording.')
    p.add_argument('--params-file', required=True, help='ROS 2 parameters file, e.g. config/r18.yaml')
    p.add_argument('ros_args', nargs=argparse.REMAINDER,
                   help='further ROS arguments after --, e.g. -- -p can.channel:=vcan0')
    p.set_defaults(handler=lambda a: run(a.params_file, [x for x in a.ros_args if x != '--']))
