"""``steer-monitor demo``: the main job on built-in defaults, in one process.

The simulated R-18 gear (SOLAS hard-over with two pumps, about 70 s of real time) plays onto
a python-can virtual bus; the monitor node listens, runs the model, publishes /diagnostics
and records MCAP; a listener prints each diagnostic status when its level changes or it
becomes assessed, and every 10 s a line with the rudder angle, K_gl and the model residual.
After the simulator stops, the input goes STALE. Then the load-sharing study of paper 004 is
written beside the recording, and the report page of the recording (``steer-monitor report``)
in ``OUT/report``.
"""

from __future__ import annotations

import argparse
import io
import sys
import threading
import time
import uuid
from pathlib import Path
from typing import Any, TextIO

from steer_monitor.cli.options import add_config_option, add_force_option
from steer_monitor.errors import ParameterError

__all__ = ['register', 'residual_text', 'run']

DEMO_FIRST_MOTION_S = 30.0


def residual_text(values: dict[str, str]) -> str:
    """The residual for the console line, from the diagnostics' key values: 'x.xx bar', or
    'n/a' with why when the model judged no instant of the last minute."""
    rms = values.get('residual_rms_bar', 'n/a')
    if rms != 'n/a':
        return f'{rms} bar'
    skipped = values.get('residual_instants_not_judged', '0')
    if skipped not in ('0', ''):
        return f'n/a ({skipped} instants not judged: a clearance known from below only)'
    return 'n/a'


def run(out_dir: str | Path = 'out', config: str | Path | None = None, program: str = 'hard_over_2',
        after_s: float = 4.0, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    import can
    import rclpy
    from diagnostic_msgs.msg import DiagnosticArray
    from rclpy.executors import SingleThreadedExecutor

    from steer_monitor import sim
    from steer_monitor.can.busconfig import load_setup
    from steer_monitor.cli import study
    from steer_monitor.monitor.diagnostics import ASSESSMENT_KEY, LEVEL_NAMES
    from steer_monitor.node.monitor_node import MonitorNode
    from steer_monitor.node.params_ros import overrides_from_file
    from steer_monitor.sim.playback import play

    out_dir = Path(out_dir)
    record_dir = out_dir / 'recordings'
    try:
        record_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        msg = f'cannot create output directory {record_dir}: {exc.strerror or exc}'
        raise ParameterError(msg) from exc
    config_path, params, db, smap = load_setup(config)
    frames = sim.run(params, sim.SimConfig(program=program), db, smap, seed=1).frames
    channel = f'steer-demo-{uuid.uuid4().hex[:6]}'
    duration = (int(frames.t_ns[-1]) - int(frames.t_ns[0])) / 1e9

    out.write(f'== steer_monitor demo: simulated {params["gear.name"]} gear -> virtual CAN -> monitor node ==\n'
              f'simulator: {program}, {len(frames)} NMEA 2000 frames over {duration:.0f} s (real time); '
              f'true gaps 2Z 0.600 mm, Z_gb 0.250 mm\n\n')
    context = rclpy.Context()
    rclpy.init(context=context)
    # a minute of helm holds 50 s of motion: the demo analyses after 30 s of it, to show one
    # (on a vessel the first waits for estimator.first_motion_s, four minutes of motion)
    overrides = overrides_from_file(str(config_path), {
        'can.interface': 'virtual', 'can.channel': channel,
        'recording.directory': str(record_dir), 'recording.enabled': True,
        'estimator.first_motion_s': DEMO_FIRST_MOTION_S})
    node = MonitorNode(parameter_overrides=overrides, context=context, config_path=str(config_path))
    listener = rclpy.create_node('steer_monitor_demo_listener', context=context)
    seen: dict[str, tuple[int, str | None]] = {}
    t_start = time.monotonic()
    last_line = [0.0]
    lock = threading.Lock()

    def on_diagnostics(msg: Any) -> None:
        with lock:
            now = time.monotonic() - t_start
            values: dict[str, str] = {}
            for s in msg.status:
                level = s.level[0] if isinstance(s.level, bytes) else int(s.level)
                own = {kv.key: kv.value for kv in s.values}
                values.update(own)
                # a line when the level changes, or whether the status has assessed the gear
                state = (level, own.get(ASSESSMENT_KEY))
                if seen.get(s.name) != state:
                    seen[s.name] = state
                    out.write(f'[{now:5.1f} s] {LEVEL_NAMES.get(level, level):5} '
                              f'{s.name.split(": ", 1)[-1]}: {s.message}\n')
            if now - last_line[0] >= 10.0:
                last_line[0] = now
                out.write(f'[{now:5.1f} s]       rudder {values.get("rudder_angle_deg", "n/a")} deg, '
                          f'K_gl {values.get("k_gl", "n/a")}, ram {values.get("ram_force_kn", "n/a")} kN, '
                          f'guide {values.get("guide_force_kn", "n/a")} kN, residual {residual_text(values)}, '
                          f'hard-over {values.get("hard_over_s", "n/a")} s\n')
            out.flush()

    listener.create_subscription(DiagnosticArray, '/diagnostics', on_diagnostics, 10)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    executor.add_node(listener)
    spinner = threading.Thread(target=executor.spin, daemon=True)
    spinner.start()
    bus = can.Bus(interface='virtual', channel=channel)
    try:
        sent = play(frames, bus, 1.0)
        out.write(f'[{time.monotonic() - t_start:5.1f} s] simulator stopped after {sent} frames\n')
        time.sleep(after_s)
    except KeyboardInterrupt:
        out.write('interrupted\n')
    finally:
        bus.shutdown()
        executor.shutdown()
        received = node.frames_received
        node.close()
        listener.destroy_node()
        context.try_shutdown()
    files = [str(p) for p in node.recorder.files] if node.recorder else []
    rec = node.recorder.status() if node.recorder else None
    lost = rec.lost() if rec is not None else None
    out.write(f'\nnode received {received} frames, transmitted none; '
              f'recorded {", ".join(files) or "nothing"}'
              + (f' ({lost}: {rec.message})' if rec is not None and lost else '') + '\n')
    buf = io.StringIO()
    study.run(out_dir, config_path, buf)
    out.write(f'load-sharing study (paper 004): {out_dir / "fig7_load_sharing.png"}, '
              f'{out_dir / "gap_study.png"}, {out_dir / "summary.json"} (steer-monitor study prints it)\n')
    if files:
        from steer_monitor.cli import report
        buf = io.StringIO()
        report.run(files, out_dir / 'report', config_path, out=buf)
        out.write(f'report of the recording (plots): {out_dir / "report" / "index.html"}\n')
    out.write(f'inspect the recording: steer-monitor inspect {files[0] if files else "FILE.mcap"}; '
              f'replay it: steer-monitor replay {files[0] if files else "FILE.mcap"} --out replay.mcap\n')
    return 0


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser('demo', help='the main job on built-in defaults (simulator, node, diagnostics, MCAP)',
                       description='Simulated gear on a virtual CAN bus, the monitor node, a diagnostics '
                                   'listener and an MCAP recording, for about a minute; then the '
                                   'load-sharing study and the report page of the recording.')
    p.add_argument('--out', default='out', help='output directory (default: out)')
    add_config_option(p)
    p.add_argument('--program', default='hard_over_2', help='helm programme of the simulator')
    add_force_option(p)
    p.set_defaults(handler=lambda a: run(a.out, a.config, a.program))
