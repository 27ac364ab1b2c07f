"""What a recording was made with: software version, gear and parameters, as MCAP metadata.

Two records, written at the start of every file the recorder or ``replay`` writes:
``steer_monitor`` (version, gear, hardware id, parameters file when known, and the SHA-256 of
the validated parameters, so two logs taken with the same configuration say so) and
``steer_monitor.parameters`` (every parameter, its value as JSON). A log ashore can then be
reviewed with the configuration it was taken with. Pure: no mcap here.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from steer_monitor import __version__

__all__ = ['PARAMETERS_RECORD', 'RUN_RECORD', 'parameters_digest', 'run_metadata']

RUN_RECORD = 'steer_monitor'
PARAMETERS_RECORD = 'steer_monitor.parameters'


def parameters_digest(params: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the validated parameters in a canonical JSON form."""
    text = json.dumps({k: params[k] for k in sorted(params)}, sort_keys=True, separators=(',', ':'))
    return hashlib.sha256(text.encode()).hexdigest()


def run_metadata(params: Mapping[str, Any], config_path: str | Path | None = None,
                 writer: str = 'steer_monitor node') -> dict[str, dict[str, str]]:
    """The two metadata records (name -> string map) for a recording made with ``params``."""
    run = {'software': 'steer_monitor', 'version': __version__, 'writer': writer,
           'gear': str(params.get('gear.name', '')), 'hardware_id': str(params.get('node.hardware_id', '')),
           'parameters_sha256': parameters_digest(params)}
    if config_path is not None:
        run['parameters_file'] = str(config_path)
    return {RUN_RECORD: run, PARAMETERS_RECORD: {k: json.dumps(params[k]) for k in sorted(params)}}
