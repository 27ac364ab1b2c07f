"""What the node loads at start: its resident memory is mostly the libraries it imports.

scipy.stats alone is about 20 MB resident; the node's statistics need only a few quantiles,
which scipy.special gives (the same functions scipy.stats calls)."""

from __future__ import annotations

import json
import os
import subprocess
import sys

HEAVY_UNUSED = ('scipy.stats', 'matplotlib', 'mcap_ros2', 'dask', 'pyarrow', 'duckdb')


def test_the_node_imports_no_library_it_does_not_use():
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    code = ('import json, sys; import steer_monitor.node.monitor_node; '
            f'print(json.dumps([m for m in {HEAVY_UNUSED!r} if m in sys.modules]))')
    out = subprocess.run([sys.executable, '-c', code], env=env, check=True, capture_output=True, text=True)
    assert json.loads(out.stdout.strip().splitlines()[-1]) == []
