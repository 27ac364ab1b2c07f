"""The node fed at the full NMEA 2000 rate (1,908 frames/s) from the simulator for 60 s.

Simulator and node share one process (python-can's virtual bus lives in one process). The
simulator plays simulated frames in the main thread, sped up so that 1,908 frames arrive
per second; the node runs its executor, reader and recorder threads as in service. Measured:
frames dropped, CPU of the node (process CPU minus the simulator thread's, so it includes
the DDS threads), p99 latency from frame receipt to the published state, resident memory at
start and end. Targets: 0 dropped, < 25 % of a core, p99 < 20 ms, < 200 MB and no growth.
"""

from __future__ import annotations

import os
import tempfile
import threading
import time
import uuid

import numpy as np

BUS_RATE = 1908.0
SECONDS = 60.0


def _rss_mb() -> float:
    with open('/proc/self/status') as fh:
        for line in fh:
            if line.startswith('VmRSS:'):
                return int(line.split()[1]) / 1024.0
    return float('nan')


def main(seconds: float = SECONDS, record: bool = True) -> dict:
    import can
    import rclpy
    from rclpy.executors import SingleThreadedExecutor

    from steer_monitor import sim
    from steer_monitor.can.setup import can_setup
    from steer_monitor.node.monitor_node import MonitorNode
    from steer_monitor.node.params_ros import overrides_from_file
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config
    from steer_monitor.sim.live import play

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    frames = sim.run(params, sim.SimConfig(program='voyage'), db, smap, seed=1).frames
    native_rate = len(frames) / ((int(frames.t_ns[-1]) - int(frames.t_ns[0])) / 1e9)
    n = int(BUS_RATE * seconds)
    frames = frames.take(np.arange(min(n, len(frames))))
    factor = BUS_RATE / native_rate
    channel = f'bench-{uuid.uuid4().hex[:6]}'
    with tempfile.TemporaryDirectory() as tmp:
        context = rclpy.Context()
        rclpy.init(context=context)
        node = MonitorNode(parameter_overrides=overrides_from_file(str(config), {
            'can.interface': 'virtual', 'can.channel': channel,
            'recording.directory': tmp, 'recording.enabled': record}), context=context)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        spinner = threading.Thread(target=executor.spin, daemon=True)
        spinner.start()
        time.sleep(1.0)
        rss_start = _rss_mb()
        bus = can.Bus(interface='virtual', channel=channel)
        cpu0, main0, wall0 = sum(os.times()[:2]), time.thread_time(), time.monotonic()
        sent = play(frames, bus, factor)
        wall = time.monotonic() - wall0
        time.sleep(1.0)
        cpu = sum(os.times()[:2]) - cpu0
        sim_cpu = time.thread_time() - main0
        rss_end = _rss_mb()
        bus.shutdown()
        executor.shutdown()
        received = node.frames_received
        lat = np.array(node.latencies_ns) / 1e6
        node.close()
        context.try_shutdown()
    node_cpu = (cpu - sim_cpu) / (wall + 1.0)
    dropped = sent - received
    print(f'node at the full NMEA 2000 rate: {sent:,} frames in {wall:.1f} s ({sent / wall:,.0f} frames/s, '
          f'simulator sped up {factor:.1f}x)')
    print(f'  frames dropped       : {dropped} (received {received:,}; target 0)')
    print(f'  node CPU             : {100 * node_cpu:.1f} % of a core (target < 25 %)')
    print(f'  latency frame->state : p50 {np.percentile(lat, 50):.1f} ms, p99 {np.percentile(lat, 99):.1f} ms, '
          f'max {lat.max():.1f} ms (target p99 < 20 ms)')
    print(f'  resident memory      : {rss_start:.0f} MB at start, {rss_end:.0f} MB at end '
          f'(process, simulator included; target < 200 MB, no growth)')
    return {'sent': sent, 'dropped': dropped, 'cpu_share': node_cpu, 'p99_ms': float(np.percentile(lat, 99)),
            'rss_start_mb': rss_start, 'rss_end_mb': rss_end}


if __name__ == '__main__':
    main()
