"""Shared fixtures: the R-18 gear from config/r18.yaml."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest
from hypothesis import settings

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')

# The suite is the same every run (a test that fails one run in twenty is a red CI waiting to
# happen): hypothesis draws its examples from a fixed seed. HYPOTHESIS_PROFILE=explore draws new
# ones each run, to look for failures on purpose.
settings.register_profile('repeatable', derandomize=True)
settings.register_profile('explore', derandomize=False)
settings.load_profile(os.environ.get('HYPOTHESIS_PROFILE', 'repeatable'))
os.environ.setdefault('MPLBACKEND', 'Agg')

from steer_monitor.model import GearParams  # noqa: E402
from steer_monitor.params import gear_from_params, load_params_file  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent  # the repository: one ament_python package at its root
PKG = ROOT                                      # the ROS package (package.xml, setup.py) is the root
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
    from steer_monitor.can.busconfig import can_setup
    return can_setup(r18_params, R18_YAML)


@pytest.fixture(scope='session')
def db(can_db):
    return can_db[0]


@pytest.fixture(scope='session')
def smap(can_db):
    return can_db[1]


@pytest.fixture
def small_tmpfs(tmp_path):
    """A 512 KiB tmpfs, to fill a disk for real (root and a kernel that allows the mount;
    skipped otherwise)."""
    where = tmp_path / 'small'
    where.mkdir()
    if os.geteuid() != 0:
        pytest.skip('mounting a small tmpfs needs root; the disk-full test runs in CI as root')
    done = subprocess.run(['mount', '-t', 'tmpfs', '-o', 'size=512k', 'tmpfs', str(where)],
                          capture_output=True, text=True, check=False)
    if done.returncode != 0:
        pytest.skip(f'cannot mount a small tmpfs here: {done.stderr.strip() or done.returncode}')
    try:
        yield where
    finally:
        subprocess.run(['umount', '-l', str(where)], check=False)


def fill(where: Path) -> None:
    """Take every free block of the file system holding ``where`` (a file ``filler.bin`` in
    it): the next write there fails with 'No space left on device'."""
    import contextlib
    with open(where / 'filler.bin', 'wb', buffering=0) as fh, contextlib.suppress(OSError):
        while True:
            fh.write(bytes(4096))


@pytest.fixture
def full_tmpfs(small_tmpfs):
    """:func:`small_tmpfs` filled (:func:`fill`); a new, empty file can still be made."""
    fill(small_tmpfs)
    return small_tmpfs
