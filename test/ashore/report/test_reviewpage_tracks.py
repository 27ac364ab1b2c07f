"""Recordings made before the standard interfaces still read.

``test/data/recording_steer_monitor_msgs.mcap`` is the recording ``make demo`` made with the
release that published the load sharing and clearances as ``steer_monitor_msgs`` types
(the simulated hard-over of the R-18 gear, 71 s, 6,521 frames; the clearances estimated at its
end). The MCAP carries their schemas; nothing of that package is installed here.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest

from steer_monitor.cli.main import main
from test.conftest import ROOT

OLD = ROOT / 'test' / 'data' / 'recording_steer_monitor_msgs.mcap'


def _schemas(path: Path) -> dict[str, str]:
    from mcap.reader import make_reader
    with open(path, 'rb') as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None
    return {c.topic: summary.schemas[c.schema_id].name for c in summary.channels.values()}


def test_the_fixture_is_what_it_says():
    assert importlib.util.find_spec('steer_monitor_msgs') is None
    schemas = _schemas(OLD)
    assert schemas['/steer_monitor/clearances'] == 'steer_monitor_msgs/msg/Clearances'
    assert schemas['/steer_monitor/load_sharing'] == 'steer_monitor_msgs/msg/LoadSharing'


def test_the_old_clearances_are_read_for_the_report():
    """The node's published clearances from the old ``Clearances`` messages: configured until the
    estimate came (no interval), then the estimate with its interval (2Z from below only)."""
    from steer_monitor.ashore.report.reviewpage import published_track
    track = published_track([OLD])
    assert track is not None and len(track.t_ns) == 76
    assert (np.diff(track.t_ns) > 0).all()
    first = [a[0] for a in (track.two_z, track.two_z_lo, track.two_z_hi, track.z_gb, track.z_gb_lo, track.z_gb_hi)]
    assert first[0] == pytest.approx(0.6e-3) and first[3] == pytest.approx(0.25e-3)
    assert all(math.isnan(v) for v in (first[1], first[2], first[4], first[5]))
    last = [a[-1] for a in (track.two_z, track.two_z_lo, track.two_z_hi, track.z_gb, track.z_gb_lo, track.z_gb_hi)]
    assert 0.15e-3 < last[1] < last[0] and math.isnan(last[2])          # 2Z: a lower bound only
    assert last[4] < 0.25e-3 < last[5] and last[4] < last[3] < last[5]


def test_inspect_report_and_replay_read_an_old_recording(tmp_path, capsys):
    assert main(['inspect', str(OLD)]) == 0
    text = capsys.readouterr().out
    assert '6521 frames' in text and 'pressure_r2_port' in text
    assert main(['report', str(OLD), '--out', str(tmp_path / 'report')]) == 0
    page = (tmp_path / 'report' / 'index.html').read_text()
    assert 'alt="Clearance estimates over time"' in page
    out = tmp_path / 'again.mcap'
    assert main(['replay', str(OLD), '--out', str(out)]) == 0
    schemas = _schemas(out)
    assert schemas['/steer_monitor/clearances'] == 'sensor_msgs/msg/JointState'
    assert schemas['/steer_monitor/load_sharing'] == 'sensor_msgs/msg/JointState'
    assert schemas['/steering_can/rx'] == 'can_msgs/msg/Frame'
