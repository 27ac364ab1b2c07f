"""Fixtures the ashore tests share."""

from __future__ import annotations

import pytest


@pytest.fixture(scope='session')
def busy(tmp_path_factory):
    """The R-18 parameters with the node's analyses made often (the first at 10 s of motion,
    an estimate every 10 s), so a replay of a minute of data runs several, loops and estimates."""
    from test.conftest import R18_YAML
    d = tmp_path_factory.mktemp('busy_config')
    text = (R18_YAML.read_text().replace('every_motion_s: 300.0', 'every_motion_s: 10.0')
            .replace('first_motion_s: 240.0', 'first_motion_s: 10.0'))
    assert 'every_motion_s: 10.0' in text and 'first_motion_s: 10.0' in text
    (d / 'busy.yaml').write_text(text)
    (d / 'nmea2000_steering.dbc').write_text((R18_YAML.parent / 'nmea2000_steering.dbc').read_text())
    return d / 'busy.yaml'
