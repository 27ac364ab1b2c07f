"""Where the DBC file is looked for: as given when absolute, beside the parameters file, then
the packaged config directory; a name found in neither is one error naming both places."""

from __future__ import annotations

import shutil

import pytest

from steer_monitor.can.busconfig import can_setup, dbc_path
from steer_monitor.can.codec import DbcError
from steer_monitor.params import load_params_file
from steer_monitor.resources import config_dir, default_config

PACKAGED = 'nmea2000_steering.dbc'


@pytest.fixture
def params():
    return dict(load_params_file(default_config()))


def test_packaged_dbc_when_no_parameters_file_or_none_beside_it(tmp_path, params):
    assert dbc_path(params) == config_dir() / PACKAGED
    assert dbc_path(params, tmp_path / 'vessel.yaml') == config_dir() / PACKAGED


def test_dbc_beside_the_parameters_file_comes_first(tmp_path, params):
    shutil.copy(config_dir() / PACKAGED, tmp_path / PACKAGED)
    assert dbc_path(params, tmp_path / 'vessel.yaml') == tmp_path / PACKAGED
    db, _ = can_setup(params, tmp_path / 'vessel.yaml')
    assert db.path == str(tmp_path / PACKAGED)


def test_absolute_dbc_as_given(tmp_path, params):
    params['can.dbc_file'] = str(tmp_path / 'x.dbc')
    assert dbc_path(params, tmp_path / 'vessel.yaml') == tmp_path / 'x.dbc'
    with pytest.raises(DbcError, match=r'cannot read DBC file .*x\.dbc: no such file'):
        can_setup(params, tmp_path / 'vessel.yaml')


def test_dbc_found_nowhere_names_both_places(tmp_path, params):
    params['can.dbc_file'] = 'missing.dbc'
    with pytest.raises(DbcError) as err:
        can_setup(params, tmp_path / 'vessel.yaml')
    assert str(err.value) == (
        f'cannot read DBC file missing.dbc (parameter can.dbc_file): not beside the parameters '
        f'file ({tmp_path / "missing.dbc"}) nor in the packaged config directory ({config_dir()})'
    )
