"""``steer-monitor simulate``: the declared R-18 plant as NMEA 2000 frames, to a file (with a
truth JSON beside it) or live onto a python-can bus."""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any, TextIO

from steer_monitor import sim
from steer_monitor.atomic import atomic_path, check_target, os_reason, write_text
from steer_monitor.can.busconfig import load_setup
from steer_monitor.cli.options import add_config_option, add_force_option, add_json_option
from steer_monitor.cli.output import check_json_target, emit_json, json_to_stdout
from steer_monitor.errors import OutputError, ParameterError
from steer_monitor.logfiles.logs import WRITE_SUFFIXES, LogError, LogWriter
from steer_monitor.params import given_gaps
from steer_monitor.sim.gateway import forward, gateway_json, parse_gateway
from steer_monitor.utc import parse_utc, utc_json

__all__ = ['parse_speed_profile', 'register', 'run', 'truth_path']


def truth_path(out: Path) -> Path:
    """``voyage.log`` -> ``voyage.truth.json``."""
    return out.with_name(out.stem + '.truth.json')


def parse_speed_profile(text: str) -> tuple[tuple[float, float], ...]:
    """``'16'`` or ``'0:16,600:12'`` (seconds:knots) -> points."""
    points = []
    for part in text.split(','):
        t, sep, v = part.strip().rpartition(':')
        try:
            point = (float(t) if sep else 0.0, float(v))
        except ValueError:
            msg = f'--speed-profile {text!r}: expected knots, or seconds:knots pairs like "0:16,600:12"'
            raise ParameterError(msg) from None
        points.append(point)
    return tuple(points)


def _progress(total: int, enabled: bool) -> Any:
    from tqdm import tqdm
    return tqdm(total=total, unit='frame', unit_scale=True, disable=not enabled, file=sys.stderr,
                desc='writing')


def run(config: str | Path | None = None, program: str = 'hard_over_2', out_path: str | Path | None = None,
        bus: str | None = None, speed_factor: float = 1.0, seed: int = 0,
        gap_2z_mm: float | None = None, gap_zgb_mm: float | None = None,
        speed_profile: str | None = None, effects: Sequence[str] = (), noise: bool = True,
        max_duration_s: float = 7200.0, json_out: str | Path | None = None, out: TextIO | None = None,
        real_bus: bool = False, start_ns: int | None = None, gateway: str | None = None) -> int:
    """Simulate into a file or onto a bus; with ``gateway`` (``--gateway``,
    :func:`~steer_monitor.sim.gateway.parse_gateway`'s text), the frames as a gateway between
    the sensors and the bus forwards them (slower, late, some lost). Onto anything but python-can's ``virtual`` bus or
    a vcan link only with ``real_bus`` (``--i-know-this-is-a-real-bus``): a simulator's frames
    on a vessel's steering bus would be read as the rudder."""
    out = out or sys.stdout
    if (out_path is None) == (bus is None):
        msg = 'give exactly one of --out FILE and --bus INTERFACE:CHANNEL'
        raise ParameterError(msg)
    if bus is not None:
        from steer_monitor.can.bus import transmit_refusal
        interface, sep, channel = bus.partition(':')
        if not sep or not channel:
            msg = f'--bus {bus!r}: expected INTERFACE:CHANNEL, e.g. virtual:steering or socketcan:vcan0'
            raise ParameterError(msg)
        refusal = transmit_refusal(interface, channel)
        if refusal is not None and not real_bus:
            msg = (f'--bus {bus}: {refusal}; the simulator sends only onto virtual buses unless you add '
                   '--i-know-this-is-a-real-bus')
            raise ParameterError(msg)
    if not (math.isfinite(max_duration_s) and max_duration_s > 0):
        msg = f'--max-duration must be more than 0 s, got {max_duration_s!r}'
        raise ParameterError(msg)
    if seed < 0:
        msg = f'--seed must be a whole number >= 0, got {seed}'
        raise ParameterError(msg)
    if not (math.isfinite(speed_factor) and speed_factor >= 0):
        msg = f'--speed-factor must be >= 0 (0: as fast as possible), got {speed_factor!r}'
        raise ParameterError(msg)
    if out_path is not None:          # before the simulation, not after
        suffix = Path(out_path).suffix.lower()
        if suffix not in WRITE_SUFFIXES:
            msg = (f'--out {out_path}: simulate writes a log ending in .log (candump), .blf or .mcap, '
                   f'not {suffix or "a name without a suffix"!r}')
            raise ParameterError(msg)
        for target in (Path(out_path), truth_path(Path(out_path))):
            check_target(target, [config])
    check_json_target(json_out, [config, out_path])
    forwarding = None if gateway is None else parse_gateway(gateway)
    _, params, db, smap = load_setup(config)
    gaps = given_gaps(params, gap_2z_mm, gap_zgb_mm)
    profile = parse_speed_profile(speed_profile) if speed_profile else ((0.0, params['torque.service_speed_kn']),)
    cfg = sim.SimConfig(program=program, gaps=gaps, speed_profile=profile,
                        effects=tuple(sim.parse_effect(e) for e in effects), noise=noise,
                        max_duration_s=max_duration_s,
                        **({} if start_ns is None else {'start_ns': start_ns}))
    result = sim.run(params, cfg, db, smap, seed)
    if forwarding is not None:
        result = replace(result, frames=forward(result.frames, forwarding, db, seed + 1))
    truth = sim.truth(params, cfg, result, seed)
    if forwarding is not None:
        truth['gateway'] = gateway_json(forwarding)
    if out_path is not None:
        path = Path(out_path)
        tpath = truth_path(path)
        progress = _progress(len(result.frames), sys.stderr.isatty() and not json_to_stdout(json_out))
        with atomic_path(path) as tmp:
            try:
                writer = LogWriter(tmp)
            except LogError as exc:        # it names the temporary file; the user gave path
                cause = exc.__cause__
                msg = f'cannot write log {path}: {os_reason(cause) if isinstance(cause, OSError) else exc}'
                raise OutputError(msg) from exc
            with writer, progress:
                for i, frame in enumerate(result.frames.frames(channel='can0')):
                    writer.write(frame)
                    if i % 4096 == 4095:
                        progress.update(4096)
                progress.update(len(result.frames) % 4096)
            write_text(tpath, json.dumps(truth, indent=2) + '\n')
        truth['output'] = str(path)
        truth['truth_file'] = str(tpath)
    else:
        import can

        from steer_monitor.can.bus import BusError
        from steer_monitor.sim.playback import play
        interface, _, channel = bus.partition(':')
        try:
            handle = can.Bus(interface=interface, channel=channel)
        except (can.CanError, OSError, ValueError, ImportError) as exc:
            msg = f'cannot open CAN bus {bus}: {exc}'
            raise BusError(msg) from exc
        try:
            truth['sent'] = play(result.frames, handle, speed_factor)
        finally:
            handle.shutdown()
        truth['output'] = bus
    emit_json(truth, json_out, out)
    if not json_to_stdout(json_out):
        cut = f' (cut at --max-duration {max_duration_s:g} s)' if result.plant.cut else ''
        out.write(f"simulated {truth['program']} for {truth['duration_s']:.1f} s{cut}: {truth['frames']} frames "
                  f"-> {truth['output']}" + (f" (truth: {truth['truth_file']})" if 'truth_file' in truth else '')
                  + '\n')
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('simulate', help='simulate the gear as NMEA 2000 frames (file or live bus)',
                       description='Simulate the declared plant of the gear and encode it as NMEA 2000 '
                                   'frames, to a file (.log, .blf, .mcap, with a truth JSON beside it) '
                                   'or live onto a python-can bus.')
    add_config_option(p)
    p.add_argument('--program', default='hard_over_2',
                   help=f'helm programme, comma-separated steps from: {", ".join(sim.PROGRAMS)} '
                        '(e.g. "hard_over_2,zigzag_10,autopilot:600"); default hard_over_2')
    target = p.add_mutually_exclusive_group(required=True)
    target.add_argument('--out', help='output file: .log (candump), .blf or .mcap')
    target.add_argument('--bus', help='live output, INTERFACE:CHANNEL, e.g. virtual:steering')
    p.add_argument('--speed-factor', type=float, default=1.0,
                   help='live output pace relative to real time (0: as fast as possible)')
    p.add_argument('--seed', type=int, default=0, help='random seed (same seed, same bytes)')
    p.add_argument('--gap-2z', type=float, help='true 2Z [mm] (default: config)')
    p.add_argument('--gap-zgb', type=float, help='true Z_gb [mm] (default: config)')
    p.add_argument('--speed-profile', help='ship speed: knots, or "s:kn,s:kn" (default: service speed)')
    p.add_argument('--effect', action='append', default=[], metavar='NAME[:k=v,...]',
                   help=f'add an undeclared effect: {", ".join(sim.EFFECTS)}')
    p.add_argument('--no-noise', action='store_true', help='no sensor noise (quantisation stays)')
    p.add_argument(
        '--max-duration',
        type=float,
        default=7200.0,
        help='cut the programme after this many seconds (default: %(default)g)',
    )
    add_json_option(p, 'the truth')
    p.add_argument('--i-know-this-is-a-real-bus', dest='real_bus', action='store_true',
                   help='allow --bus on a hardware interface (the frames are sent onto that bus)')
    p.add_argument('--start', type=_utc_arg, metavar='UTC',
                   help='the time the log starts, ISO 8601 (e.g. 2026-03-01T08:00:00Z; default '
                        f'{utc_json(sim.DEFAULT_START_NS)}): logs of a simulated fleet at their own dates')
    p.add_argument('--gateway', metavar='RATES[,k=v...]',
                   help='forward the frames as a gateway does: rates in Hz per message (rudder, pressure, speed, '
                        'temperature or a PGN), mode=hold|decimate, loss (share of time the bus is bad), burst '
                        '[s], latency, jitter, timeout [s], outage=START+SECONDS; e.g. '
                        '"rudder=2,pressure=0.5,loss=0.02,outage=600+3"')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.config, a.program, a.out, a.bus, a.speed_factor, a.seed,
                                         a.gap_2z, a.gap_zgb, a.speed_profile, a.effect, not a.no_noise,
                                         a.max_duration, a.json_out, real_bus=a.real_bus, start_ns=a.start,
                                         gateway=a.gateway))


def _utc_arg(text: str) -> int:
    try:
        return parse_utc(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
