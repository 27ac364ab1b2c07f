"""Build the DBC codec and the signal map from validated parameters."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from steer_monitor.can.codec import CanDatabase, load_dbc
from steer_monitor.can.signals import SignalMap
from steer_monitor.resources import config_dir

__all__ = ['can_setup', 'dbc_path']


def dbc_path(params: Mapping[str, Any], config_path: str | Path | None = None) -> Path:
    """The DBC file: ``can.dbc_file`` as given when absolute, else beside the parameters
    file, else in the packaged config directory."""
    name = Path(params['can.dbc_file'])
    if name.is_absolute():
        return name
    if config_path is not None:
        beside = Path(config_path).resolve().parent / name
        if beside.is_file():
            return beside
    return config_dir() / name


def can_setup(params: Mapping[str, Any], config_path: str | Path | None = None) -> tuple[CanDatabase, SignalMap]:
    """(DBC codec, signal map checked against it)."""
    db = load_dbc(dbc_path(params, config_path))
    smap = SignalMap.from_params(params)
    smap.check(db)
    return db, smap
