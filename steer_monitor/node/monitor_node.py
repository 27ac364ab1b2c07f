"""The ROS 2 node: a thin adapter over the CAN layer, the live monitor, the diagnostics and the
recorder.

Threads: a reader thread owns the bus (listen-only, reopened with backoff), decodes each
frame, updates the live model and publishes the state at most every 10 ms (and within 10 ms
of the last frame when the bus goes quiet); an estimator thread takes the decoded samples
through a queue (never blocking the reader), updates the online clearance estimate each
second of data and hands it to the live model, and keeps its state on disk; the executor
publishes diagnostics at 1 Hz; the recorder writes MCAP on its own thread. The live model is
shared under a lock. SIGINT and SIGTERM shut down cleanly, save the estimator state and
finish the MCAP file.

Topics (all standard message types):

================================ ============================== ===========================
topic                            type                           content
================================ ============================== ===========================
/diagnostics                     diagnostic_msgs/DiagnosticArray one status per concern, 1 Hz
~/rudder                         sensor_msgs/JointState          joint ``rudder``: position
                                                                 [rad], velocity [rad/s],
                                                                 effort = tiller torque from
                                                                 the pressures [N m]
~/load_sharing                   std_msgs/Float64MultiArray      labelled: lateral_n,
                                                                 ram_force_n, guide_force_n,
                                                                 k_gl, deflection_m, r_a_n,
                                                                 r_e_n, m_a_nm, case
~/clearances                     std_msgs/Float64MultiArray      labelled: gap_2z_m, lo, hi,
                                                                 gap_zgb_m, lo, hi (NaN: none)
~/clearance_source               std_msgs/String                 configured / estimated
================================ ============================== ===========================
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from rclpy.node import Node

from steer_monitor.can.bus import BusReader, ListenOnlyBus
from steer_monitor.can.decoder import Decoder
from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.can.setup import can_setup
from steer_monitor.errors import ParameterError, SteerMonitorError
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.estimate.online import OnlineEstimator
from steer_monitor.model.gear import Gaps
from steer_monitor.monitor.diagnostics import ERROR, OK, DiagnosticsBuilder, DiagnosticsConfig, Status
from steer_monitor.model.friction import FrictionParams
from steer_monitor.monitor.live import LiveMonitor, LiveState
from steer_monitor.node.params_ros import declare_parameters
from steer_monitor.params import gaps_from_params, gear_from_params, min_clearance_2z_from_params
from steer_monitor.record.msgdefs import msgdef
from steer_monitor.record.recorder import Recorder

__all__ = ['LOAD_LABELS', 'MonitorNode', 'main']

LOAD_LABELS = ('lateral_n', 'ram_force_n', 'guide_force_n', 'k_gl', 'deflection_m', 'r_a_n', 'r_e_n',
               'm_a_nm', 'case')
CLEARANCE_LABELS = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')
LATENCY_WINDOW = 200_000
PUBLISH_PERIOD_NS = 10_000_000
RECORD_BATCH = 256
RECORD_BATCH_NS = 50_000_000


class MonitorNode(Node):
    """The steering-gear monitor. Use as a context manager or call :meth:`close`."""

    def __init__(self, node_name: str = 'steer_monitor', *, parameter_overrides: Sequence[Any] | None = None,
                 context: Any = None, bus_opener: Callable[[], ListenOnlyBus] | None = None,
                 config_path: str | None = None) -> None:
        super().__init__(node_name, context=context, parameter_overrides=list(parameter_overrides or []))
        self.params = declare_parameters(self)
        p = self.params
        self.gear = gear_from_params(p)
        db, smap = can_setup(p, config_path)
        self.smap = smap
        self.rejects = RejectCounter()
        self.decoder = Decoder(db, smap, self.rejects)
        self.monitor = LiveMonitor(self.gear, gaps_from_params(p), 'configured',
                                   FrictionParams(p['model.seal_friction_n'], p['model.mu_bushing'], p['model.mu_guide']))
        self.diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(p), smap, self.gear)
        self.diag.guide_onset_deg(self.monitor.gaps)  # warm the cache before the first frame
        self.recorder: Recorder | None = None
        if p['recording.enabled']:
            self.recorder = Recorder(p['recording.directory'], p['recording.prefix'],
                                     int(p['recording.max_file_mb'] * (1 << 20)),
                                     p['recording.max_file_minutes'] * 60.0)
        self._make_publishers()
        self._lock = threading.Lock()          # guards the live monitor
        self._unpublished: list[int] = []      # receive times of frames not yet in a published state
        self._last_publish = 0
        self.latencies_ns: deque[int] = deque(maxlen=LATENCY_WINDOW)
        self.frames_received = 0
        self._stop = threading.Event()
        interface, channel = p['can.interface'], p['can.channel']
        opener = bus_opener or (lambda: ListenOnlyBus(interface, channel, p['can.bitrate']))
        self.reader = BusReader(opener, self.rejects, p['can.reopen_backoff_initial_s'],
                                p['can.reopen_backoff_max_s'], poll=PUBLISH_PERIOD_NS / 1e9)
        self._reader_thread = threading.Thread(target=self._read, name='steer_monitor-can', daemon=True)
        self._closed = False
        self.estimator: OnlineEstimator | None = None
        self._est_queue: deque = deque()
        self._est_thread: threading.Thread | None = None
        if p['estimator.enabled']:
            self._start_estimator()
        self.create_timer(1.0, self._publish_diagnostics)
        self._reader_thread.start()
        self.get_logger().info(
            f'listening on {interface}:{channel} (listen-only); {len(smap.specs)} inputs mapped; '
            + (f'recording to {p["recording.directory"]}' if self.recorder else 'recording off'))

    # --- estimator ---------------------------------------------------------------------------
    def _start_estimator(self) -> None:
        p = self.params
        self.estimator = OnlineEstimator(self.gear,
                                         min_clearance_2z=min_clearance_2z_from_params(p),
                                         half_life_s=p['estimator.half_life_h'] * 3600.0)
        path = p['estimator.state_file']
        if path:
            from pathlib import Path
            if Path(path).exists():
                try:
                    self.estimator.load(path)
                    self.get_logger().info(f'estimator state loaded from {path}: '
                                           f'{self.estimator.motion_s:.0f} s of rudder motion learned')
                    self._apply_estimate()
                except EstimateError as exc:
                    self.get_logger().warning(f'{exc}; starting the estimate afresh')
        self._est_thread = threading.Thread(target=self._estimate_loop, name='steer_monitor-estimator', daemon=True)
        self._est_thread.start()

    def _estimate_loop(self) -> None:
        est, queue, stop = self.estimator, self._est_queue, self._stop
        assert est is not None
        last_save = time.monotonic()
        every = self.params['estimator.save_every_s']
        while not stop.wait(0.25):
            while queue:
                est.add(queue.popleft())
            try:
                if est.update():
                    self._apply_estimate()
            except SteerMonitorError as exc:   # guards a defect: report, keep monitoring
                self.get_logger().error(f'estimator update failed: {exc}')
            if time.monotonic() - last_save >= every:
                self._save_estimator()
                last_save = time.monotonic()

    def _apply_estimate(self) -> None:
        est = self.estimator
        e = est.estimate if est is not None else None
        if e is None:
            return
        interval = {'2z': (e.two_z.lo, e.two_z.hi), 'zgb': (e.z_gb.lo, e.z_gb.hi)}
        with self._lock:
            fr = FrictionParams(*e.friction) if all(map(math.isfinite, e.friction)) else None
            self.monitor.set_gaps(Gaps(e.two_z.value, e.z_gb.value), 'estimated', interval, fr)
            k = e.k_gl_max
            self.monitor.estimate_info = {'k_gl_max_estimated': f'{k.value:.3f}',
                                          'k_gl_max_lo': 'n/a' if k.lo is None else f'{k.lo:.3f}',
                                          'k_gl_max_hi': 'n/a' if k.hi is None else f'{k.hi:.3f}',
                                          'estimate_rows': str(int(e.rows)),
                                          'estimate_motion_s': f'{est.motion_s:.0f}'}

    def _save_estimator(self) -> None:
        path = self.params['estimator.state_file']
        if self.estimator is None or not path:
            return
        try:
            self.estimator.save(path)
        except OSError as exc:
            self.get_logger().error(f'cannot save the estimator state to {path}: {exc}')

    # --- set-up ------------------------------------------------------------------------------
    def _make_publishers(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray, String

        self.pub_diag = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.pub_rudder = self.create_publisher(JointState, '~/rudder', 10)
        self.pub_load = self.create_publisher(Float64MultiArray, '~/load_sharing', 10)
        self.pub_clear = self.create_publisher(Float64MultiArray, '~/clearances', 10)
        self.pub_source = self.create_publisher(String, '~/clearance_source', 10)
        if self.recorder is not None:
            for pub, datatype in ((self.pub_diag, 'diagnostic_msgs/msg/DiagnosticArray'),
                                  (self.pub_rudder, 'sensor_msgs/msg/JointState'),
                                  (self.pub_load, 'std_msgs/msg/Float64MultiArray'),
                                  (self.pub_clear, 'std_msgs/msg/Float64MultiArray'),
                                  (self.pub_source, 'std_msgs/msg/String')):
                self.recorder.add_topic(pub.topic_name, datatype, msgdef(datatype))

    def _publish(self, pub: Any, msg: Any, t_ns: int) -> None:
        pub.publish(msg)
        if self.recorder is not None:
            from rclpy.serialization import serialize_message
            self.recorder.write(pub.topic_name, serialize_message(msg), t_ns)

    # --- reader thread -----------------------------------------------------------------------
    def _read(self) -> None:
        reader, decoder, recorder, monitor = self.reader, self.decoder, self.recorder, self.monitor
        est_queue = self._est_queue if self.estimator is not None else None
        stop = self._stop
        # frames go to the recorder in batches (one queue entry, packed at once): at most
        # RECORD_BATCH frames or RECORD_BATCH_NS old, and whatever is held when the bus idles
        batch: list[Frame] = []
        batch_start = 0
        try:
            while not stop.is_set():
                for frame in reader.frames(stop, idle=True):
                    received = time.monotonic_ns()
                    if frame is not None:
                        self.frames_received += 1
                        try:
                            samples = decoder.decode(frame)
                        except SteerMonitorError as exc:  # the decoder counts; this guards a defect
                            self.get_logger().error(f'decode failed: {exc}')
                            samples = []
                        if recorder is not None:
                            if not batch:
                                batch_start = received
                            batch.append(frame)
                    if batch and (frame is None or len(batch) >= RECORD_BATCH or received - batch_start >= RECORD_BATCH_NS):
                        recorder.write_frames(batch)
                        batch = []
                    if frame is not None:
                        if samples:
                            with self._lock:
                                for sample in samples:
                                    monitor.update(sample)
                            if est_queue is not None:
                                est_queue.extend(samples)
                        self._unpublished.append(received)
                    if self._unpublished and received - self._last_publish >= PUBLISH_PERIOD_NS:
                        self._flush_state(received)
        finally:
            if batch and recorder is not None:
                recorder.write_frames(batch)

    def _flush_state(self, now: int) -> None:
        with self._lock:
            state = self.monitor.state
        if state is not None:
            self._publish_state(state)
        done = time.monotonic_ns()
        self.latencies_ns.extend(done - t for t in self._unpublished)
        self._unpublished.clear()
        self._last_publish = now

    def _publish_state(self, st: LiveState) -> None:
        from builtin_interfaces.msg import Time
        from sensor_msgs.msg import JointState
        from std_msgs.msg import Float64MultiArray, MultiArrayDimension

        stamp = Time(sec=st.t_ns // 1_000_000_000, nanosec=st.t_ns % 1_000_000_000)
        js = JointState()
        js.header.stamp = stamp
        js.header.frame_id = 'rudder_stock'
        js.name = ['rudder']
        js.position = [st.alpha]
        js.velocity = [st.rate]
        js.effort = [math.copysign(st.torque_measured or 0.0, st.alpha)]
        self._publish(self.pub_rudder, js, st.t_ns)
        if st.share is not None:
            sh = st.share
            msg = Float64MultiArray()
            msg.layout.dim = [MultiArrayDimension(label=','.join(LOAD_LABELS), size=len(LOAD_LABELS), stride=len(LOAD_LABELS))]
            msg.data = [sh.lateral, sh.ram_force, sh.guide_force, sh.k_gl, sh.deflection, sh.r_a, sh.r_e,
                        sh.m_a, float(sh.case)]
            self._publish(self.pub_load, msg, st.t_ns)

    def _recording_status(self) -> Status | None:
        if self.recorder is None:
            return None
        st = self.recorder.status()
        values = (('recording_file', st.current_file or 'n/a'), ('recording_files', str(st.files)),
                  ('recording_messages', str(st.messages)), ('recording_failed', str(st.failed)),
                  ('recording_dropped', str(st.dropped)))
        return Status('steer_monitor: recording', OK if st.ok else ERROR, st.message,
                      self.params['node.hardware_id'], values)

    def _publish_diagnostics(self) -> None:
        from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
        from std_msgs.msg import Float64MultiArray, MultiArrayDimension, String

        now = time.time_ns()
        with self._lock:
            statuses = self.diag.build(self.monitor, self.rejects.snapshot(), now, self._recording_status())
            gaps, interval = self.monitor.gaps, self.monitor.gaps_interval or {}
            source = self.monitor.gaps_source
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        for s in statuses:
            arr.status.append(DiagnosticStatus(level=bytes([s.level]), name=s.name, message=s.message,
                                               hardware_id=s.hardware_id,
                                               values=[KeyValue(key=k, value=v) for k, v in s.values]))
        self._publish(self.pub_diag, arr, now)
        nan = float('nan')

        def bound(key: str, i: int) -> float:
            v = interval.get(key, (None, None))[i] if interval else None
            return nan if v is None else float(v)
        cl = Float64MultiArray()
        cl.layout.dim = [MultiArrayDimension(label=','.join(CLEARANCE_LABELS), size=6, stride=6)]
        cl.data = [gaps.two_z, bound('2z', 0), bound('2z', 1), gaps.z_gb, bound('zgb', 0), bound('zgb', 1)]
        self._publish(self.pub_clear, cl, now)
        self._publish(self.pub_source, String(data=source), now)

    # --- shutdown ----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop reading, finish the recording, destroy the node. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._reader_thread.join(5)
        if self._est_thread is not None:
            self._est_thread.join(10)
            self._save_estimator()
        self.reader.close()
        if self.recorder is not None:
            self.recorder.close()
        self.destroy_node()

    def __enter__(self) -> MonitorNode:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def main(args: Sequence[str] | None = None) -> int:
    """``ros2 run steer_monitor monitor --ros-args --params-file config/r18.yaml``."""
    import rclpy
    from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor

    rclpy.init(args=list(args) if args is not None else sys.argv)
    node = None
    try:
        try:
            node = MonitorNode()
        except (ParameterError, SteerMonitorError) as exc:
            print(f'steer_monitor: cannot start: {exc}', file=sys.stderr)
            return 2
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            executor.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        return 0
    finally:
        if node is not None:
            node.close()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == '__main__':
    sys.exit(main())
