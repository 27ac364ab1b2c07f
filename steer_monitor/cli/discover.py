"""``steer-monitor discover LOG...``: what is on the bus, and the signal map proposed for it.

Lists one stream per PGN, source address and instance (frames, rate, time span and, for
PGNs of the DBC, each field's range of valid values), the devices that claimed an address,
and the ``signals`` map :func:`~steer_monitor.ashore.discovery.propose` makes of them. Every
choice among several senders and every input not found is a note, printed on stderr too.
``--write-config OUT.yaml`` writes the parameters file (``--config``, or the packaged one)
with that map, ready for ``inspect --config OUT.yaml`` and ``run``.
"""

from __future__ import annotations

import argparse
import datetime
import io
import json
import math
import sys
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.ashore.discovery import RULES, Discovery, propose
from steer_monitor.atomic import atomic_path, check_target, is_stream, os_reason
from steer_monitor.can.busconfig import Setup, dbc_path, load_setup
from steer_monitor.can.rejects import REASONS, RejectCounter
from steer_monitor.can.signals import INPUTS, REQUIRED
from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import (
    add_date_option,
    any_text,
    check_json_target,
    date_notes,
    emit_json,
    json_to_stdout,
    report_read_errors,
    table,
    text_stream,
)
from steer_monitor.errors import InputError, ParameterError
from steer_monitor.logfiles.blocks import iter_log_blocks
from steer_monitor.logfiles.logs import LogError
from steer_monitor.params import NODE_NAME, load_params_file
from steer_monitor.resources import config_dir

__all__ = ['discover', 'register', 'run', 'write_config']

_SIGNAL_KEYS = ('pgn', 'field', 'instance', 'source', 'address', 'device_name', 'rate_hz')


def _pgn_names(path: str | Path | None) -> dict[int, str]:
    """PGN -> name from CANboat's PGN database (``canboat.json``), when given."""
    if path is None:
        return {}
    try:
        with open(path, encoding='utf-8') as fh:
            doc = json.load(fh)
        return {int(p['PGN']): str(p.get('Description') or p.get('Id')) for p in doc['PGNs']}
    except OSError as exc:
        msg = f'cannot read PGN database {path}: {exc.strerror or exc}'
        raise InputError(msg) from exc
    except (ValueError, KeyError, TypeError) as exc:
        msg = f'PGN database {path} is not CANboat\'s canboat.json ({type(exc).__name__}: {exc})'
        raise InputError(msg) from exc


def discover(paths: Sequence[str | Path], setup: Setup, date: datetime.date | None = None,
             pgn_database: str | Path | None = None) -> dict[str, Any]:
    """What ``paths`` hold, read with ``setup``'s DBC and map, as the JSON of
    ``discover --json`` (plus ``read_errors``)."""
    disc = Discovery(setup.db, _pgn_names(pgn_database))
    rejects = RejectCounter()
    errors: list[str] = []
    for path in paths:
        try:
            for block in iter_log_blocks(path, rejects, date):
                disc.add(block)
        except LogError as exc:
            errors.append(str(exc))
    if disc.frames == 0:
        msg = '; '.join(errors) if errors else 'no CAN frames in ' + ', '.join(str(p) for p in paths)
        raise InputError(msg)
    proposed, notes = propose(disc, setup.smap, REQUIRED)
    snap = rejects.snapshot()
    for reason, n in sorted(snap.counts.items()):
        notes.append(f'{n} record(s) are not listed: {REASONS[reason]}')
    for reason, n in sorted(disc.skipped.items()):
        if n:
            notes.append(f'{n} frame(s) are not listed: {REASONS[reason]}')
    return {
        'logs': [str(p) for p in paths],
        'config': str(setup.config_path),
        'frames': disc.frames,
        'streams': [s.as_dict() for s in disc.sorted_streams()],
        'devices': [d.as_dict() for d in sorted(disc.devices.values(), key=lambda d: (d.source, d.name))],
        'proposed': proposed,
        'missing_required': [n for n in REQUIRED if n in proposed and not proposed[n]['on_bus']],
        'rule': RULES,
        'notes': notes,
        'rejects': dict(sorted(snap.counts.items())),
        'read_errors': errors,
    }


def write_config(out: str | Path, setup: Setup, proposed: dict[str, dict[str, Any]],
                 logs: Sequence[str], notes: Sequence[str]) -> None:
    """``setup``'s parameters file with its ``signals`` replaced by ``proposed``, written to
    ``out`` (atomically; checked to load before it is renamed). A round trip of the file it
    adapts (ruamel.yaml): its comments ("# H", "# L, bushing A to bushing E", "# assumed": the
    hints a user is told to check), its order and its numbers as written (2.1e+11 stays so)
    are kept; only the signals' values (and the DBC's path, when it is a vessel's own) change,
    and a header says where they came from."""
    from ruamel.yaml import YAML
    from ruamel.yaml.comments import CommentedMap

    rt = YAML(typ='rt')
    rt.width = 4096                 # a signal's flow mapping on one line, as the file writes it
    rt.preserve_quotes = True
    try:
        doc = rt.load(Path(setup.config_path).read_text(encoding='utf-8'))
    except OSError as exc:
        raise ParameterError(f'cannot read {setup.config_path}: {os_reason(exc)}') from exc
    params = _ros_parameters(doc, setup.config_path)
    signals = params.setdefault('signals', CommentedMap())
    for name in INPUTS:
        if name in proposed:
            node = signals.setdefault(name, CommentedMap())
            for key in _SIGNAL_KEYS:
                node[key] = proposed[name][key]
    dbc = dbc_path(setup.params, setup.config_path)
    if dbc.parent.resolve() != config_dir().resolve():     # a vessel's own DBC: where it is
        params.setdefault('can', CommentedMap())['dbc_file'] = str(dbc.resolve())
    header = [f'Written by steer-monitor discover from {", ".join(logs)}', f'on {datetime.date.today()}, '
              f'from {setup.config_path}. Check the signals map before running.', '',
              'Rule: ' + RULES, ''] + [f'note: {n}' for n in notes]
    buf = io.StringIO()
    rt.dump(doc, buf)
    text = ''.join(f'# {h}'.rstrip().replace('\n', ' ') + '\n' for h in header) + buf.getvalue()
    with atomic_path(out) as tmp:
        if is_stream(tmp):          # /dev/stdout: checked in a file of its own, then written
            with tempfile.TemporaryDirectory() as d:
                _check_written(Path(d) / 'proposed.yaml', text)
            tmp.write_text(text, encoding='utf-8')
        else:
            _check_written(tmp, text)


def _ros_parameters(doc: Any, path: str | Path) -> Any:
    """The ``ros__parameters`` mapping of a parameters file's document (ParameterError naming
    the file when it has none)."""
    node = doc.get(NODE_NAME) if hasattr(doc, 'get') else None
    params = node.get('ros__parameters') if hasattr(node, 'get') else None
    if not hasattr(params, 'setdefault'):
        msg = f'{path}: no {NODE_NAME}: ros__parameters mapping to adapt'
        raise ParameterError(msg)
    return params


def _check_written(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` and load it back as a parameters file."""
    path.write_text(text, encoding='utf-8')
    try:
        load_params_file(path)
    except ParameterError as exc:   # a defect of ours if it happens: nothing is written
        msg = f'the proposed parameters do not validate: {exc}'
        raise ParameterError(msg) from exc


#: the DBC's SI units as the other commands print them (inspect, analyze): (scale, offset, unit)
_ENGINEERS = {'rad': (180.0 / math.pi, 0.0, 'deg'), 'Pa': (1e-5, 0.0, 'bar'), 'K': (1.0, -273.15, 'degC'),
              'm/s': (3600.0 / 1852.0, 0.0, 'kn')}


def _fmt_range(f: dict[str, Any]) -> str:
    """A field's range in the units inspect and analyze print (the JSON keeps the DBC's)."""
    if f['min'] is None:
        return 'n/a'
    scale, offset, unit = _ENGINEERS.get(f['unit'], (1.0, 0.0, f['unit']))
    return f"{f['min'] * scale + offset:.4g}..{f['max'] * scale + offset:.4g} {unit}".strip()


def run(paths: Sequence[str | Path], config: str | Path | None = None, date: datetime.date | None = None,
        json_out: str | Path | None = None, write: str | Path | None = None, pgn_database: str | Path | None = None,
        out: TextIO | None = None, err: TextIO | None = None) -> int:
    """Print what the logs hold and the proposed map; write it with ``write``. 1 (one line
    per log on ``err``) when a log broke off or had corrupt parts."""
    out = out or sys.stdout
    err = err or sys.stderr
    out = text_stream([write, json_out], out, err)
    if write is not None:
        check_target(write, [*paths, config, pgn_database])
    check_json_target(json_out, [*paths, config, pgn_database, write])
    date_notes('discover', paths, date, err)
    setup = load_setup(config)
    d = discover(paths, setup, date, pgn_database)
    emit_json({k: v for k, v in d.items() if k != 'read_errors'}, json_out, out)
    if not json_to_stdout(json_out):
        out.write(f"{', '.join(d['logs'])}: {d['frames']} frames, {len(d['streams'])} streams, "
                  f"{len(d['devices'])} devices\n\n")
        rows = []
        for s in d['streams']:
            fields = {k: f for k, f in s['fields'].items() if k not in ('SID', 'Instance')}
            rows.append([s['pgn'], s['name'] or '?', s['source'], '-' if s['instance'] is None else s['instance'],
                         s['frames'], '-' if s['rate_hz'] is None else f"{s['rate_hz']:.1f}",
                         '; '.join(f'{k} {_fmt_range(f)}' for k, f in fields.items())])
        table(['PGN', 'name', 'addr', 'inst', 'frames', 'Hz', 'fields (valid range)'], rows, out)
        if d['devices']:
            out.write('\ndevices (address claims):\n')
            table(['addr', 'NAME', 'manufacturer', 'function', 'class', 'claims'],
                  [[v['source'], v['name_hex'], v['manufacturer_code'], v['device_function'], v['device_class'],
                    v['claims']] for v in d['devices']], out)
        out.write('\nproposed signals:\n')
        table(['input', 'on bus', 'PGN', 'field', 'inst', 'source', 'addr', 'device', 'Hz'],
              [[n, 'yes' if v['on_bus'] else ('NO (kept as given)' if n in REQUIRED else 'no (left out)'),
                v['pgn'] or '-', v['field'], any_text(v['instance']), any_text(v['source']), any_text(v['address']),
                v['device_name'] or '-',
                v['rate_hz']] for n, v in d['proposed'].items()], out)
    for note in d['notes']:
        err.write(f'steer-monitor discover: note: {note}\n')
    if write is not None:
        write_config(write, setup, d['proposed'], d['logs'], d['notes'])
        err.write(f'steer-monitor discover: wrote {write}: check it, then: steer-monitor inspect {d["logs"][0]} '
                  f'--config {write}\n')
    status = report_read_errors('discover', d['read_errors'], err)
    if d['missing_required']:
        err.write(f'steer-monitor discover: error: the bus lacks inputs the monitor needs: '
                  f'{", ".join(d["missing_required"])}; the map {"written " if write else ""}keeps them as the given '
                  f'map has them, so it is partial: find where the gear sends them (a longer log, another bus)\n')
        return 1
    return status


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('discover', help='what is on a CAN bus, and a signal map for it',
                       description='Streams (PGN, source address, instance) with rates and field ranges, devices '
                                   'from address claims, and a proposed signals map, from CAN logs of any '
                                   'format read (candump, ASC, BLF, MCAP, CANboat plain, YDWG raw).')
    p.add_argument('logs', nargs='+', help='log files (a minute of the bus is enough)')
    add_config_option(p, role='its DBC and map say where inputs are looked for; --write-config starts from it')
    add_date_option(p)
    p.add_argument('--write-config', metavar='OUT.yaml', help='write the parameters file with the proposed map')
    p.add_argument('--pgn-database', metavar='canboat.json',
                   help="CANboat's PGN database, to name the PGNs the DBC does not know")
    add_json_option(p, 'the streams, devices and proposed map')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.logs, a.config, a.date, a.json_out, a.write_config, a.pgn_database))
