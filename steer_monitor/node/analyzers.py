"""diagnostic_aggregator's analyzer for one monitor's statuses. Pure (no ROS import): the
launch file and the packaged analyzer file are made from it.

Every status a monitor publishes is named after the node (``steer_monitor: clearances``,
diagnostic_updater's ``node: task``), so one GenericAnalyzer per monitor gathers them under
``Vessel/Steering gear``: those it always publishes are ``expected`` (shown "Missing", STALE,
until the monitor's first diagnostics, and STALE again when it stops), the recording matched by
its name alone (a monitor may record nothing).

The packaged file ``config/aggregator/steer_monitor_analyzers.yaml`` is :func:`analyzer_file`
for the default node name, keyed by :data:`AGGREGATOR_NODE`, the name ``aggregator_node`` gives
itself, so ``ros2 run diagnostic_aggregator aggregator_node --ros-args --params-file`` loads it.
"""

from __future__ import annotations

from typing import Any

from steer_monitor.monitor.diagnostics import status_name
from steer_monitor.params import NODE_NAME

__all__ = ['AGGREGATOR_NODE', 'ALWAYS', 'analyzer_file', 'analyzer_parameters']

#: the node name diagnostic_aggregator's aggregator_node takes (its Aggregator's constructor)
AGGREGATOR_NODE = 'analyzers'
#: the statuses a monitor publishes every time (the recording's only while it records)
ALWAYS = ('CAN input', 'CAN bus', 'clearances', 'guide beam', 'steering performance', 'model health', 'rams')
#: an item not heard for this long reads STALE (the monitor publishes once a second)
TIMEOUT_S = 5.0


def analyzer_parameters(node_name: str = NODE_NAME) -> dict[str, Any]:
    """The aggregator's ``ros__parameters`` for the monitor named ``node_name``: base path
    ``Vessel``, and one analyzer keyed by the node's name under ``Steering gear`` (with the
    node's name in brackets for a name other than the default: two gears on one ship)."""
    path = 'Steering gear' if node_name == NODE_NAME else f'Steering gear ({node_name})'
    return {'path': 'Vessel',
            node_name: {'type': 'diagnostic_aggregator/GenericAnalyzer', 'path': path,
                        'startswith': [status_name(node_name, '').rstrip()],
                        'expected': [status_name(node_name, item) for item in ALWAYS],
                        'timeout': TIMEOUT_S}}


def analyzer_file(node_name: str = NODE_NAME) -> dict[str, Any]:
    """A parameters file's document for ``aggregator_node``, keyed by its own node name."""
    return {AGGREGATOR_NODE: {'ros__parameters': analyzer_parameters(node_name)}}
