"""Build the DBC codec and the signal map from validated parameters."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any, NamedTuple

from steer_monitor.can.codec import CanDatabase, DbcError, load_dbc
from steer_monitor.can.signals import SignalMap
from steer_monitor.params import load_config
from steer_monitor.resources import config_dir

__all__ = ['Setup', 'can_setup', 'dbc_path', 'load_setup']


def dbc_path(params: Mapping[str, Any], config_path: str | Path | None = None) -> Path:
    """The DBC file: ``can.dbc_file`` as given when absolute, else beside the parameters
    file, else in the packaged config directory."""
    name = Path(params['can.dbc_file'])
    if name.is_absolute():
        return name
    packaged = config_dir() / name
    if config_path is not None:
        beside = Path(config_path).resolve().parent / name
        if beside.is_file():
            return beside
        if not packaged.is_file():
            msg = (f'cannot read DBC file {name} (parameter can.dbc_file): not beside the parameters file '
                   f'({beside}) nor in the packaged config directory ({packaged.parent})')
            raise DbcError(msg)
    return packaged


def can_setup(params: Mapping[str, Any], config_path: str | Path | None = None) -> tuple[CanDatabase, SignalMap]:
    """(DBC codec, signal map checked against it)."""
    db = load_dbc(dbc_path(params, config_path))
    smap = SignalMap.from_params(params)
    smap.check(db)
    return db, smap


class Setup(NamedTuple):
    """A parameters file, its validated parameters, its DBC codec and signal map."""

    config_path: Path
    params: dict[str, Any]
    db: CanDatabase
    smap: SignalMap


def load_setup(config: str | Path | None) -> Setup:
    """:class:`Setup` of the parameters file ``config`` (the packaged R-18 one when None)."""
    path, params = load_config(config)
    return Setup(path, params, *can_setup(params, path))
