"""The parameters of steer_monitor: one table, read from a ROS 2 parameters file.

The same table declares the node's ROS parameters (with descriptors) and validates the
YAML file the CLI reads, so ``config/r18.yaml`` works for both::

    steer_monitor:
      ros__parameters:
        gear:
          stock_to_ram_m: 0.600
          ...

Names are dotted paths (``gear.stock_to_ram_m``) and carry their unit, as engineers write
them; :func:`gear_from_params` converts to the SI records of :mod:`steer_monitor.model`.
A value ROS 2 would reject (an integer where a double is declared) is rejected here too.
"""

from __future__ import annotations

import difflib
import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from steer_monitor.errors import ParameterError
from steer_monitor.model.friction import FrictionParams
from steer_monitor.model.gear import Clearances, GearParams
from steer_monitor.model.isofits import parse_fit
from steer_monitor.model.torque import TorqueCurve
from steer_monitor.resources import default_config
from steer_monitor.yamlfile import load_yaml

__all__ = [
    'MAX_LIMIT_MULTIPLE',
    'NODE_NAME',
    'ParamsFile',
    'TIMESTAMP_MODES',
    'load_config',
    'PARAMETERS',
    'ParamSpec',
    'friction_from_params',
    'gaps_from_params',
    'given_gaps',
    'min_clearance_2z_from_params',
    'ram_share_warn_from_params',
    'gear_from_params',
    'load_params_file',
    'recorded_params',
    'unknown_parameter_message',
    'validate_params',
    'WRITABLE',
]

NODE_NAME = 'steer_monitor'
#: what ``can.timestamps`` may say (:class:`~steer_monitor.can.busclock.BusClock` reads them)
TIMESTAMP_MODES = ('auto', 'bus', 'host')


@dataclass(frozen=True)
class ParamSpec:
    """One parameter: dotted name, type, default (None: required), description and bounds.

    ``kind`` is one of ``'double'``, ``'integer'``, ``'bool'``, ``'string'``,
    ``'double_array'`` (the ROS 2 parameter types used here).
    """

    name: str
    kind: str
    default: Any
    description: str
    minimum: float | None = None
    maximum: float | None = None
    exclusive_minimum: bool = False


#: the parameters a running node lets be set (``ros2 param set``): thresholds that judge what
#: it sees, read again at the next status; the rest shape what it reads and keeps, and are
#: read only (set them in the parameters file and start the node again)
WRITABLE = frozenset({'diagnostics.stale_after_s', 'diagnostics.clearance_warn_share',
                      'diagnostics.guide_idle_warn_deg', 'diagnostics.solas_hard_over_s', 'clearances.limit_2z_mm',
                      'clearances.limit_zgb_mm'})

PARAMETERS: tuple[ParamSpec, ...] = (
    # Gear geometry and material (docs/physics.md).
    ParamSpec('gear.name', 'string', 'R-18', 'gear model, for reports'),
    ParamSpec('gear.stock_to_ram_m', 'double', None, 'H: rudder-stock axis to ram axis [m]',
              0.0, 10.0, True),
    ParamSpec('gear.bushing_span_m', 'double', None,
              'L: distance between the two cylinder bushings of one ram [m]', 0.0, 20.0, True),
    ParamSpec('gear.ram_outer_diameter_m', 'double', None, 'd: ram outer diameter [m]',
              0.0, 2.0, True),
    ParamSpec('gear.ram_inner_diameter_m', 'double', 0.0,
              'd1: ram inner diameter, 0 for a solid ram [m]', 0.0, 2.0),
    ParamSpec('gear.youngs_modulus_pa', 'double', 2.1e11, 'E of ram and guide beam [Pa]',
              0.0, 1e12, True),
    ParamSpec('gear.guide_beam_inertia_mm4', 'double', None,
              'J_gb: guide-beam section second moment of area [mm^4]', 0.0, 1e14, True),
    ParamSpec('gear.guide_beam_span_m', 'double', None,
              'L_gb: guide-beam span, both ends clamped [m]', 0.0, 20.0, True),
    ParamSpec('gear.bushing_length_m', 'double', None, 'l_s: length of the ram bushing [m]',
              0.0, 5.0, True),
    ParamSpec('gear.rams', 'integer', 2, 'n: rams acting on the tiller', 1, 8),
    ParamSpec('gear.max_rudder_deg', 'double', 35.0, 'largest rudder angle of the gear [deg]',
              0.0, 60.0, True),
    ParamSpec('gear.euler_amplification', 'bool', False,
              'amplify ram compliance by 1/(1 - Fa/F_Eu); the paper neglects it (0.31 %)'),
    # Tiller torque at service speed.
    ParamSpec('torque.angle_deg', 'double_array', None,
              'rudder angles of the tiller torque curve, from 0, increasing [deg]'),
    ParamSpec('torque.torque_knm', 'double_array', None,
              'tiller torque at those angles at service speed, from 0, monotone [kN m]'),
    ParamSpec('torque.service_speed_kn', 'double', 16.0,
              'ship speed at which the torque curve holds [kn]', 0.0, 60.0, True),
    # Hydraulics.
    ParamSpec('hydraulics.pumps', 'integer', 2, 'main pumps that can run together', 1, 4),
    ParamSpec('hydraulics.ram_speed_per_pump_mm_s', 'double', 15.0,
              'ram speed per running pump [mm/s]', 0.0, 1000.0, True),
    # Clearances: current (configured) values and limits.
    ParamSpec('clearances.gap_2z_mm', 'double', 0.6,
              '2Z: diametral ram/bushing clearance used until estimated [mm]', 0.0, 5.0),
    ParamSpec('clearances.gap_zgb_mm', 'double', 0.25,
              'Z_gb: slipper/guide-beam clearance used until estimated [mm]', 0.0, 5.0),
    ParamSpec('clearances.limit_2z_mm', 'double', 0.6, '[2Z]: wear limit of 2Z [mm]',
              0.0, 5.0, True),
    ParamSpec('clearances.limit_zgb_mm', 'double', 0.25, '[Z_gb]: wear limit of Z_gb [mm]',
              0.0, 5.0, True),
    ParamSpec('clearances.new_fit', 'string', '240 H9/f9',
              'ISO 286 fit of ram and bushing when new'),
    # The steering CAN bus (listen only).
    ParamSpec('can.interface', 'string', 'socketcan',
              'python-can interface: socketcan on a vessel, virtual in tests'),
    ParamSpec('can.channel', 'string', 'can0', 'bus channel, e.g. can0 or vcan0'),
    ParamSpec('can.bitrate', 'integer', 250000, 'bit rate [bit/s] (NMEA 2000: 250000)', 10000, 1000000),
    ParamSpec('can.dbc_file', 'string', 'nmea2000_steering.dbc',
              'DBC of the steering PGNs; relative paths are looked up in the config directory'),
    ParamSpec('can.reopen_backoff_initial_s', 'double', 0.5,
              'first wait before reopening a failed bus [s]', 0.0, 60.0, True),
    ParamSpec('can.reopen_backoff_max_s', 'double', 10.0,
              'longest wait between reopen attempts [s]', 0.0, 600.0, True),
    ParamSpec('can.read_batch_ms', 'double', 5.0,
              'on a busy bus, read what has arrived every this many ms and take it as one part (a frame '
              'waits at most about this long; 0: no pause, more CPU) [ms]', 0.0, 100.0),
    ParamSpec('can.max_abs_rudder_deg', 'double', 45.0,
              'rudder angles beyond this are physically impossible [deg]', 0.0, 90.0, True),
    ParamSpec('can.min_pressure_bar', 'double', -1.0,
              'cylinder pressures below this are physically impossible [bar]', -10.0, 0.0),
    ParamSpec('can.max_pressure_bar', 'double', 400.0,
              'cylinder pressures above this are physically impossible [bar]', 0.0, 2000.0, True),
    ParamSpec('can.timestamps', 'string', 'auto',
              "frame times: 'auto' (the interface's while they agree with the host clock, else the "
              "interface's intervals put on the host clock: adapters that count from power-up), 'bus' "
              "(the interface's as they are) or 'host' (the host clock when read)"),
    ParamSpec('can.max_time_jump_s', 'double', 5.0,
              'a frame this far in time from the frames before and after it is a time jump, '
              'rejected unless about 0.5 s of frames confirm the new time (a clock step) [s]', 0.01, 86400.0, True),
    # The node.
    ParamSpec('node.hardware_id', 'string', 'steering_gear', 'hardware_id of the diagnostics'),
    ParamSpec('diagnostics.stale_after_s', 'double', 2.0,
              'an input silent this long (or three of its periods) is STALE [s]', 0.0, 600.0, True),
    ParamSpec('diagnostics.clearance_warn_share', 'double', 0.8,
              'WARN when a clearance reaches this share of its limit', 0.0, 1.0, True),
    ParamSpec('diagnostics.guide_idle_warn_deg', 'double', 10.0,
              'WARN when the guide beam carries nothing up to beyond this angle [deg]', 0.0, 60.0),
    ParamSpec('diagnostics.solas_hard_over_s', 'double', 28.0,
              'SOLAS limit, 35 deg one side to 30 deg the other [s]', 0.0, 600.0, True),
    ParamSpec('diagnostics.ram_share_warn_pct', 'double', 15.0,
              "WARN when a ram's share of the driving force departs from an even half by more than this "
              '[percentage points]', 1.0, 40.0),
    ParamSpec('model.seal_friction_n', 'double', 9000.0,
              'seal friction F_s used until estimated [N]', 0.0, 1e7),
    ParamSpec('model.mu_bushing', 'double', 0.13, 'ram bushing friction coefficient until estimated', 0.0, 2.0),
    ParamSpec('model.mu_guide', 'double', 0.05, 'guide slipper friction coefficient until estimated', 0.0, 2.0),
    ParamSpec('estimator.enabled', 'bool', True, 'analyse the data (steer-monitor analyze of the window) and feed '
              'the clearances found to the live model'),
    ParamSpec('estimator.state_file', 'string', 'steer_monitor_estimator.npz',
              'where the node keeps its data window and last analysis across restarts; a relative name is in '
              'recording.directory (empty: not kept)'),
    ParamSpec('estimator.window_motion_h', 'double', 1.0,
              'the analyses look at the last this many hours of steady rudder motion (older data are '
              'forgotten; memory about 1.5 MB an hour) [h]', 0.0, 100.0, True),
    ParamSpec('estimator.first_motion_s', 'double', 240.0,
              'the first analysis when this many seconds of steady rudder motion are in (fewer do not pin a '
              'clearance down: docs/accuracy-online.md) [s]', 10.0, 1e6),
    ParamSpec('estimator.loop_every_motion_s', 'double', 1800.0,
              'the whole residual loop runs at estimator.first_motion_s of motion, each time the motion doubles, '
              'then every this many seconds of motion [s]', 10.0, 1e6),
    ParamSpec('estimator.every_motion_s', 'double', 300.0,
              'between loops, the estimate under the model the loop chose every this many seconds of motion [s]',
              10.0, 1e6),
    ParamSpec('estimator.save_every_s', 'double', 60.0, 'write the analyses\' state this often [s]', 1.0, 1e6),
    ParamSpec('recording.enabled', 'bool', True, 'record raw frames and published topics to MCAP'),
    ParamSpec('recording.directory', 'string', 'steer_monitor_logs', 'where MCAP files go'),
    ParamSpec('recording.prefix', 'string', 'steer_monitor', 'MCAP file name prefix'),
    ParamSpec('recording.max_file_mb', 'double', 512.0, 'start a new MCAP file beyond this size [MB]',
              0.0, 1e6, True),
    ParamSpec('recording.max_file_minutes', 'double', 60.0, 'start a new MCAP file after this long [min]',
              0.0, 1e6, True),
    ParamSpec('recording.max_total_gb', 'double', 0.0,
              "remove the oldest recordings while this prefix's recordings in the directory take more "
              'than this [GB] (0: no limit)', 0.0, 1e6),
    ParamSpec('recording.keep_free_gb', 'double', 2.0,
              'remove the oldest recordings while the disk has less than this free [GB] (0: never for space)',
              0.0, 1e6),
) + tuple(
    spec
    for name, (pgn, fld, instance, source, rate) in {
        'rudder_angle': (127245, 'Position', 0, -1, 10.0),
        'rudder_order': (127245, 'AngleOrder', 0, -1, 10.0),
        'pressure_r1_stbd': (130314, 'Pressure', 0, 4, 20.0),
        'pressure_r1_port': (130314, 'Pressure', 1, 4, 20.0),
        'pressure_r2_stbd': (130314, 'Pressure', 2, 4, 20.0),
        'pressure_r2_port': (130314, 'Pressure', 3, 4, 20.0),
        'ship_speed': (128259, 'SpeedWaterReferenced', -1, -1, 1.0),
        'oil_temperature': (130316, 'Temperature', 0, 3, 0.5),
    }.items()
    for spec in (
        ParamSpec(f'signals.{name}.pgn', 'integer', pgn,
                  f'PGN that carries {name} (0: not on this bus)', 0, 0x3FFFF),
        ParamSpec(f'signals.{name}.field', 'string', fld, f'DBC signal of that PGN holding {name}'),
        ParamSpec(f'signals.{name}.instance', 'integer', instance,
                  'instance field to match (-1: any)', -1, 255),
        ParamSpec(f'signals.{name}.source', 'integer', source,
                  'source field to match (-1: any)', -1, 255),
        ParamSpec(f'signals.{name}.address', 'integer', -1,
                  'CAN source address to match (-1: any)', -1, 253),
        ParamSpec(f'signals.{name}.device_name', 'string', '',
                  "device NAME to match, 16 hex digits from address claims ('': any)"),
        ParamSpec(f'signals.{name}.rate_hz', 'double', rate, f'expected rate of {name} [Hz]',
                  0.0, 1000.0, True),
    )
)

_BY_NAME = {p.name: p for p in PARAMETERS}


def _flatten(tree: Mapping[str, Any], prefix: str = '') -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(_flatten(value, f'{name}.'))
        else:
            flat[name] = value
    return flat


def _check_value(spec: ParamSpec, value: Any) -> Any:
    name = spec.name
    if spec.kind == 'double':
        if isinstance(value, bool) or not isinstance(value, float):
            hint = f' (write {value}.0: ROS 2 reads {value} as an integer)' if isinstance(value, int) \
                and not isinstance(value, bool) else ''
            msg = f'parameter {name}: expected a floating-point number, got {value!r}{hint}'
            raise ParameterError(msg)
        if not math.isfinite(value):
            msg = f'parameter {name}: must be finite, got {value!r}'
            raise ParameterError(msg)
        _check_bounds(spec, value)
        return value
    if spec.kind == 'integer':
        if isinstance(value, bool) or not isinstance(value, int):
            msg = f'parameter {name}: expected a whole number, got {value!r}'
            raise ParameterError(msg)
        _check_bounds(spec, value)
        return value
    if spec.kind == 'bool':
        if not isinstance(value, bool):
            msg = f'parameter {name}: expected true or false, got {value!r}'
            raise ParameterError(msg)
        return value
    if spec.kind == 'string':
        if not isinstance(value, str):
            msg = f'parameter {name}: expected text, got {value!r}'
            raise ParameterError(msg)
        return value
    if spec.kind == 'double_array':
        if not isinstance(value, (list, tuple)) or not value:
            msg = f'parameter {name}: expected a non-empty list of numbers, got {value!r}'
            raise ParameterError(msg)
        for i, item in enumerate(value):
            if isinstance(item, bool) or not isinstance(item, float) or not math.isfinite(item):
                msg = (f'parameter {name}[{i}]: expected a finite floating-point number, got '
                       f'{item!r} (ROS 2 double arrays need every item written with a decimal point)')
                raise ParameterError(msg)
        return [float(v) for v in value]
    raise AssertionError(f'unknown parameter kind {spec.kind}')


def _check_bounds(spec: ParamSpec, value: float) -> None:
    lo, hi = spec.minimum, spec.maximum
    if lo is not None and (value < lo or (spec.exclusive_minimum and value == lo)):
        op = '>' if spec.exclusive_minimum else '>='
        msg = f'parameter {spec.name}: must be {op} {lo:g}, got {value!r}'
        raise ParameterError(msg)
    if hi is not None and value > hi:
        msg = f'parameter {spec.name}: must be <= {hi:g}, got {value!r}'
        raise ParameterError(msg)


#: parameters of earlier releases: what to do instead
RETIRED = {
    'estimator.half_life_h': 'the analyses keep the last estimator.window_motion_h hours of steady motion instead '
                             '(remove it, or set that)',
    'diagnostics.residual_warn_bar': 'model health is judged as steer-monitor analyze judges, from the systematic part '
                                     'of the misfit against the sensor noise (remove it)',
}


def unknown_parameter_message(unknown: list[str]) -> str:
    """The line for parameters nobody declares (sorted): the first named, a retired one said
    as such, the closest known name suggested ("did you mean can.channel?")."""
    name = unknown[0]
    if name in RETIRED:
        return f'parameter {name} is no longer read: {RETIRED[name]}'
    close = difflib.get_close_matches(name, list(_BY_NAME), n=1, cutoff=0.75)
    return f'unknown parameter {name}' + (f' (did you mean {close[0]}?)' if close else '') + (
        f' (and {len(unknown) - 1} more)' if len(unknown) > 1 else '')


def validate_params(values: Mapping[str, Any]) -> dict[str, Any]:
    """Check flat dotted parameters against :data:`PARAMETERS`; fill defaults.

    Raises :class:`ParameterError` naming the first unknown, missing or bad parameter.
    """
    unknown = sorted(set(values) - set(_BY_NAME))
    if unknown:
        raise ParameterError(unknown_parameter_message(unknown))
    out: dict[str, Any] = {}
    for spec in PARAMETERS:
        if spec.name in values:
            out[spec.name] = _check_value(spec, values[spec.name])
        elif spec.default is None:
            msg = f'missing parameter {spec.name}: {spec.description}'
            raise ParameterError(msg)
        else:
            out[spec.name] = spec.default
    # Cross-checks that give a clearer message than the records would.
    if out['can.timestamps'] not in TIMESTAMP_MODES:
        msg = f"parameter can.timestamps: expected one of {', '.join(TIMESTAMP_MODES)}, got {out['can.timestamps']!r}"
        raise ParameterError(msg)
    total_mb = out['recording.max_total_gb'] * 1000.0
    if 0.0 < total_mb < 2.0 * out['recording.max_file_mb'] * (1 << 20) / 1e6:
        msg = (f"parameter recording.max_total_gb: {out['recording.max_total_gb']:g} GB does not hold two files "
               f"of recording.max_file_mb ({out['recording.max_file_mb']:g} MB): the one being written and the "
               'last finished; give at least twice that, or 0 for no limit')
        raise ParameterError(msg)
    if len(out['torque.angle_deg']) != len(out['torque.torque_knm']):
        msg = (f'parameter torque.torque_knm: has {len(out["torque.torque_knm"])} values but '
               f'torque.angle_deg has {len(out["torque.angle_deg"])}')
        raise ParameterError(msg)
    try:
        parse_fit(out['clearances.new_fit'])
    except ValueError as exc:
        msg = f'parameter clearances.new_fit: {exc}'
        raise ParameterError(msg) from exc
    try:
        gear_from_params(out)
    except ParameterError as exc:
        msg = f'parameters gear.* / torque.*: {exc}'
        raise ParameterError(msg) from exc
    return out


def recorded_params(values: Mapping[str, str]) -> tuple[dict[str, Any], list[str]]:
    """The validated parameters a recording was made with (its ``steer_monitor.parameters``
    metadata: each value as JSON), and the names left out: parameters this version does not
    read (retired, or of a later version); those it lacks take their defaults. Raises
    :class:`ParameterError` naming what does not fit."""
    decoded: dict[str, Any] = {}
    dropped: list[str] = []
    for name, text in values.items():
        if name not in _BY_NAME:
            dropped.append(name)
            continue
        try:
            decoded[name] = json.loads(text)
        except (TypeError, ValueError):
            msg = f'the recorded parameter {name} is not JSON: {str(text)[:60]!r}'
            raise ParameterError(msg) from None
    return validate_params(decoded), sorted(dropped)


class ParamsFile(str):
    """A parameters file's path as given on a command line, with the node whose entry to read
    (``--node``; None: :func:`load_params_file`'s rule)."""

    node: str | None = None

    def __new__(cls, path: str, node: str | None = None) -> ParamsFile:
        out = super().__new__(cls, path)
        out.node = node
        return out


def load_config(config: str | Path | None) -> tuple[Path, dict[str, Any]]:
    """(path, validated parameters) of the parameters file ``config`` (a :class:`ParamsFile`
    says which node's entry), or of the packaged R-18 one when it is None or empty."""
    path = Path(config) if config else default_config()
    return path, load_params_file(path, getattr(config, 'node', None))


def load_params_file(path: str | Path, node_name: str | None = NODE_NAME) -> dict[str, Any]:
    """Read and validate a ROS 2 parameters file; returns flat dotted parameters.

    The file holds ``<node_name>: ros__parameters: {...}`` (``/**`` is accepted too, and
    merged under the node's own entry as ROS 2 does). ``node_name`` None (a command ashore,
    which runs no node): the entry of :data:`NODE_NAME`, else the file's only node entry (a
    vessel's file for ``port_gear``), else the file's ``/**`` alone; a file of several other
    nodes is refused, naming them (``--node`` says which).
    """
    path = Path(path)
    doc = load_yaml(path, 'parameters file')
    shown = node_name or NODE_NAME
    if not isinstance(doc, Mapping):
        msg = f'parameters file {path}: expected "{shown}: ros__parameters:" at the top'
        raise ParameterError(msg)
    if node_name is None:
        node_name = _the_node(path, doc)
    merged: dict[str, Any] = {}
    found = False
    for key in ('/**', node_name, f'/{node_name}'):
        entry = doc.get(key)
        if entry is None:
            continue
        if not isinstance(entry, Mapping) or not isinstance(entry.get('ros__parameters'), Mapping):
            msg = f'parameters file {path}: "{key}" must hold a "ros__parameters" mapping'
            raise ParameterError(msg)
        merged.update(_flatten(entry['ros__parameters']))
        found = True
    if not found:
        msg = f'parameters file {path}: no entry for node "{node_name}" (expected "{node_name}: ros__parameters:")'
        raise ParameterError(msg)
    try:
        return validate_params(merged)
    except ParameterError as exc:
        msg = f'{path}: {exc}'
        raise ParameterError(msg) from exc


def _the_node(path: Path, doc: Mapping[str, Any]) -> str:
    """Whose entry a command reads when not told: :data:`NODE_NAME`'s, else the only node's."""
    nodes = sorted(str(k).lstrip('/') for k in doc if k != '/**')
    if NODE_NAME in nodes or not nodes:
        return NODE_NAME
    if len(nodes) == 1:
        return nodes[0]
    msg = (f'parameters file {path} holds the parameters of nodes {", ".join(nodes)}: say whose with --node NAME')
    raise ParameterError(msg)


def gear_from_params(p: Mapping[str, Any]) -> GearParams:
    """The SI gear record from validated parameters."""
    torque = TorqueCurve.from_degrees_knm(p['torque.angle_deg'], p['torque.torque_knm'],
                                          p['torque.service_speed_kn'])
    return GearParams(
        stock_to_ram=p['gear.stock_to_ram_m'],
        bushing_span=p['gear.bushing_span_m'],
        ram_outer_diameter=p['gear.ram_outer_diameter_m'],
        ram_inner_diameter=p['gear.ram_inner_diameter_m'],
        youngs_modulus=p['gear.youngs_modulus_pa'],
        guide_beam_inertia=p['gear.guide_beam_inertia_mm4'] * 1e-12,
        guide_beam_span=p['gear.guide_beam_span_m'],
        bushing_length=p['gear.bushing_length_m'],
        rams=p['gear.rams'],
        torque=torque,
        max_rudder=math.radians(p['gear.max_rudder_deg']),
        euler_amplification=p['gear.euler_amplification'],
    )


def gaps_from_params(p: Mapping[str, Any]) -> Clearances:
    """The configured clearances (SI) from validated parameters."""
    return Clearances.from_mm(p['clearances.gap_2z_mm'], p['clearances.gap_zgb_mm'])


#: a clearance given on a command line may be at most this many times its wear limit: further
#: worn, the gear is out of service, and a figure so far out is a slip of the units or a digit
MAX_LIMIT_MULTIPLE = 4.0


def given_gaps(p: Mapping[str, Any], gap_2z_mm: float | None, gap_zgb_mm: float | None,
               options: tuple[str, str] = ('--gap-2z', '--gap-zgb')) -> Clearances:
    """The clearances a command is given [mm] (None: the configured one), in SI;
    :class:`ParameterError` naming the ``options`` for one below 0, not a number, or more
    than :data:`MAX_LIMIT_MULTIPLE` times its limit (``clearances.limit_*_mm``)."""
    configured = gaps_from_params(p)
    out = []
    for option, value, limit_key, default in ((options[0], gap_2z_mm, 'clearances.limit_2z_mm', configured.two_z),
                                              (options[1], gap_zgb_mm, 'clearances.limit_zgb_mm', configured.z_gb)):
        if value is None:
            out.append(default * 1e3)
            continue
        if not (math.isfinite(value) and value >= 0.0):
            msg = f'{option} must be a clearance of at least 0 mm, got {value:g} mm'
            raise ParameterError(msg)
        limit = p[limit_key]
        if value > MAX_LIMIT_MULTIPLE * limit:
            msg = (f'{option} {value:g} mm is {value / limit:.0f} times the {limit:g} mm wear limit ({limit_key}): '
                   f'a gear worn so far is out of service; give at most {MAX_LIMIT_MULTIPLE * limit:g} mm')
            raise ParameterError(msg)
        out.append(value)
    return Clearances.from_mm(*out)


def friction_from_params(p: Mapping[str, Any]) -> FrictionParams:
    """The configured friction (F_s [N], mu_b, mu_g) the live model uses until estimated."""
    return FrictionParams(p['model.seal_friction_n'], p['model.mu_bushing'], p['model.mu_guide'])


def ram_share_warn_from_params(p: Mapping[str, Any]) -> float:
    """How far a ram's share of the driving force may depart from an even half before it is
    uneven, as a fraction (``diagnostics.ram_share_warn_pct`` is in percentage points)."""
    return p['diagnostics.ram_share_warn_pct'] / 100.0


def min_clearance_2z_from_params(p: Mapping[str, Any]) -> float:
    """The smallest ram-bushing clearance 2Z of the new fit [m] (>= 0): wear only opens a fit,
    so the estimator's 2Z grid starts there."""
    return max(parse_fit(p['clearances.new_fit']).clearance.minimum, 0.0)
