"""Shared fixtures: the R-18 gear from config/r18.yaml."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
os.environ.setdefault('MPLBACKEND', 'Agg')

from steer_monitor.model import GearParams  # noqa: E402
from steer_monitor.params import gear_from_params, load_params_file  # noqa: E402

PKG = Path(__file__).resolve().parent.parent   # this ROS package: steer_monitor/ in the repository
ROOT = PKG.parent                               # the repository (steer_monitor and steer_monitor_msgs)
SHARED = ROOT.parent / 'shared'                 # ../shared beside the repository
R18_YAML = PKG / 'config' / 'r18.yaml'


@pytest.fixture(scope='session')
def r18_params() -> dict:
    return load_params_file(R18_YAML)


@pytest.fixture(scope='session')
def r18(r18_params) -> GearParams:
    return gear_from_params(r18_params)


@pytest.fixture(scope='session')
def can_db(r18_params):
    """(DBC codec, signal map) of the packaged R-18 config."""
    from steer_monitor.can.setup import can_setup
    return can_setup(r18_params, R18_YAML)


@pytest.fixture(scope='session')
def db(can_db):
    return can_db[0]


@pytest.fixture(scope='session')
def smap(can_db):
    return can_db[1]
