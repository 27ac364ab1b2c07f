"""The ROS 2 node: a thin adapter over the CAN layer, the monitor pipeline and the recorder.

Threads: a reader thread owns the bus (listen-only, reopened with backoff) and feeds each frame
to the :class:`~steer_monitor.monitor.pipeline.Pipeline`, which decides on the frames' own
timestamps what to publish: the state at the end of each 10 ms slot of data, and at each whole
second of data the diagnostics, the clearances in use and their source. So a replay of the same
frames (``steer-monitor replay``) publishes the same values. The analyses of the data window
(``steer-monitor analyze`` of it, :mod:`~steer_monitor.monitor.analyst`) run on a worker thread
and the window is kept on disk; their findings reach the live model a fixed data time after
each job started (:func:`~steer_monitor.monitor.pipeline.apply_delay_ns`). The executor's 1 Hz timer publishes
diagnostics on wall
time only when the bus has been silent for more than 1.5 s (that is where STALE shows). Each
message is published as its CDR (:data:`~steer_monitor.record.cdr.FAST_ENCODERS`), the bytes
the recording and a replay hold; the recorder writes MCAP on its own thread, the reader's
frames and messages handed to it in batches (:mod:`~steer_monitor.node.recordbatch`). SIGINT
and SIGTERM shut down cleanly: the outputs of the last frames, the analyses' state, and the
MCAP file finished.

Topics (standard message types only) are listed in
:mod:`steer_monitor.monitor.messages`.
"""

from __future__ import annotations

import contextlib
import math
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_srvs.srv import Trigger

from steer_monitor.can.bus import BusReader, ListenOnlyBus
from steer_monitor.can.busclock import BusClock
from steer_monitor.can.busconfig import can_setup
from steer_monitor.can.buserrors import BusErrors
from steer_monitor.can.decoder import Decoder
from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.compiled import COMPILED
from steer_monitor.errors import ParameterError, SteerMonitorError
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.logfiles.rosbag2meta import offered_qos_profiles
from steer_monitor.monitor.analyst import Analyst, Outcome, describe
from steer_monitor.monitor.diagnostics import DiagnosticsBuilder, DiagnosticsConfig, Status
from steer_monitor.monitor.live import LiveMonitor
from steer_monitor.monitor.messages import TOPICS, diag_messages, state_messages, topic_qos
from steer_monitor.monitor.pipeline import DiagOut, Output, Pipeline, StateOut, ThreadedJobs, analyst_from_params
from steer_monitor.node.params_ros import declare_parameters
from steer_monitor.node.recordbatch import RecordBatches
from steer_monitor.node.rosmsg import message_class
from steer_monitor.node.statefile import StateFile
from steer_monitor.node.statuses import bus_status, clock_words, recording_status
from steer_monitor.params import (
    WRITABLE,
    friction_from_params,
    gaps_from_params,
    gear_from_params,
    ram_share_warn_from_params,
    validate_params,
)
from steer_monitor.record.cdr import FAST_ENCODERS
from steer_monitor.record.msgdefs import msgdef
from steer_monitor.record.provenance import run_metadata
from steer_monitor.record.recorder import Recorder
from steer_monitor.runtime import single_blas_thread
from steer_monitor.utc import utc_text

__all__ = ['ANALYSES_OFF_BY_PARAMETER', 'ANALYSES_OFF_WITHOUT_NUMBA', 'MonitorNode', 'main']

#: why the node runs no analysis: the parameter says so
ANALYSES_OFF_BY_PARAMETER = 'the analyses are off (estimator.enabled: false)'
#: why the node runs no analysis: numba is missing. Interpreted, an analysis holds the
#: interpreter for tens of seconds to minutes, while the bus reader waits for it: measured on
#: a 10-minute voyage at the full bus rate, 39,221 frames dropped and states published up to
#: 114 s late (python -m bench.bench_node voyage with numba hidden, docs/vessel.md)
ANALYSES_OFF_WITHOUT_NUMBA = ('the analyses are off: numba is not installed on this host, and an analysis '
                              'interpreted would hold up the bus reader; the live model, the statuses and the '
                              'recording go on: analyse the recordings ashore (steer-monitor analyze), or install '
                              'python3-numba where the OS packages it, or numba in the environment the node runs in')

LATENCY_WINDOW = 200_000
POLL_S = 0.01
SWITCH_INTERVAL_S = 0.001
SILENT_DIAG_S = 1.5
GUARD_LOG_S = 10.0      # a defect the node survives is logged at most this often (it may recur every frame)


class MonitorNode(Node):
    """The steering-gear monitor. Use as a context manager or call :meth:`close`."""

    def __init__(self, node_name: str = 'steer_monitor', *, parameter_overrides: Sequence[Any] | None = None,
                 context: Any = None, bus_opener: Callable[[], ListenOnlyBus] | None = None,
                 config_path: str | None = None) -> None:
        super().__init__(node_name, context=context, parameter_overrides=list(parameter_overrides or []))
        self._node_name_kept = self.get_name()
        if not single_blas_thread():   # the analyses' profiles: a second BLAS thread only spins
            self.get_logger().info('threadpoolctl is not installed: BLAS keeps its own threads '
                                   '(same answers, more CPU; pip install threadpoolctl)')
        # the analysis thread runs Python and numpy under the GIL for seconds;
        # the reader thread gets the GIL back within 1 ms of asking, not the default 5 ms
        sys.setswitchinterval(min(sys.getswitchinterval(), SWITCH_INTERVAL_S))
        self.params = declare_parameters(self)
        p = self.params
        self.gear = gear_from_params(p)
        db, smap = can_setup(p, config_path)
        self.smap = smap
        self._db = db
        self.rejects = RejectCounter()
        self.monitor = self._new_monitor()
        self.diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(p, self._node_name_kept), smap, self.gear)
        self.diag.guide_onset_deg(self.monitor.gaps)  # warm the cache before the first frame
        # the message types before anything opens: a package not built stops the node here
        self._classes = {key: message_class(datatype) for key, (_, datatype) in TOPICS.items()}
        self.recorder: Recorder | None = None
        if p['recording.enabled']:
            self.recorder = Recorder(p['recording.directory'], p['recording.prefix'],
                                     int(p['recording.max_file_mb'] * (1 << 20)),
                                     p['recording.max_file_minutes'] * 60.0,
                                     metadata=run_metadata(p, config_path), on_error=self._recording_failed,
                                     max_total_bytes=int(p['recording.max_total_gb'] * 1e9),
                                     keep_free_bytes=int(p['recording.keep_free_gb'] * 1e9),
                                     on_removed=self._recording_removed)
        try:
            self._start(config_path, bus_opener)
        except BaseException:       # a signal or an error while starting: what was opened is closed
            self._abort_start()
            raise

    def _start(self, config_path: str | None, bus_opener: Callable[[], ListenOnlyBus] | None) -> None:
        """The rest of the node's start, after its recorder opened (see :meth:`_abort_start`)."""
        p = self.params
        smap = self.smap
        self._make_publishers()
        self._lock = threading.Lock()          # guards the pipeline and the live model
        self._unpublished: deque[int] = deque()   # bus timestamps of state-changing frames not yet published
        self.latencies_ns: deque[int] = deque(maxlen=LATENCY_WINDOW)
        self.frames_received = 0
        self._last_diag = time.monotonic()
        self._bus_mode: tuple[bool | None, str] = (None, 'bus not opened yet')
        self._bus_clock: BusClock | None = None
        self._clock_told: tuple[bool | None, int] = (None, 0)
        self.bus_errors = BusErrors()          # the controller's error state, from its error frames
        self.state_file = StateFile.from_params(p['estimator.state_file'], p['recording.directory'],
                                                lambda text: self._log().error(text),
                                                lambda text: self._log().info(text))
        self._stop = threading.Event()
        self._closed = False
        self._closing = False
        self._bus_listening_told = False
        self.analyst: Analyst | None = None
        #: why no analysis runs (None: they run)
        self.analyses_off = (ANALYSES_OFF_BY_PARAMETER if not p['estimator.enabled'] else
                             ANALYSES_OFF_WITHOUT_NUMBA if not COMPILED else None)
        if self.analyses_off == ANALYSES_OFF_WITHOUT_NUMBA:
            self.get_logger().warning(ANALYSES_OFF_WITHOUT_NUMBA)
        jobs = self._start_analyst() if self.analyses_off is None else None
        self.pipeline = self._new_pipeline(jobs)
        self.restarts = 0                      # times the monitor started again after the data time went back
        interface, channel = p['can.interface'], p['can.channel']
        opener = bus_opener or (lambda: ListenOnlyBus(interface, channel, p['can.bitrate'], p['can.timestamps']))
        self.reader = BusReader(opener, self.rejects, p['can.reopen_backoff_initial_s'],
                                p['can.reopen_backoff_max_s'], poll=POLL_S + p['can.read_batch_ms'] * 1e-3,
                                batch=p['can.read_batch_ms'] * 1e-3,
                                on_open=self._bus_opened, on_error=self._bus_failed)
        self._reader_thread = threading.Thread(target=self._read, name='steer_monitor-can', daemon=True)
        self.create_timer(1.0, self._silent_diagnostics)
        self.add_on_set_parameters_callback(self._set_parameters)
        for service, handler in (('~/analyse_now', self._analyse_now), ('~/split_recording', self._split_recording),
                                 ('~/save_state', self._save_state)):
            self.create_service(Trigger, service, handler)
        self._reader_thread.start()
        self.get_logger().info(
            f'opening {interface}:{channel} (listen-only); {len(smap.specs)} inputs mapped; '
            + (f'recording to {Path(p["recording.directory"]).resolve()}' if self.recorder else 'recording off'))

    def _abort_start(self) -> None:
        """Stopped while starting (Ctrl-C as it loads, an error after the recorder opened): stop
        the threads started so far and finish the recording, so no file is left unfinished."""
        stop = getattr(self, '_stop', None)
        if stop is not None:
            stop.set()
        thread = getattr(self, '_reader_thread', None)
        if thread is not None and thread.is_alive():
            thread.join(5)
        for part in ('pipeline', 'reader', 'recorder'):
            obj = getattr(self, part, None)
            if obj is not None:
                with contextlib.suppress(Exception):
                    obj.close()

    def _recording_failed(self, text: str | None) -> None:
        """The recorder stopped reaching the disk (or reaches it again): in the log once, the
        recording status has it meanwhile."""
        if text is None:
            self._log().info(f'recording to {self.params["recording.directory"]} again')
        else:
            retry = self.recorder.retry_s if self.recorder is not None else math.nan
            self._log().error(f'cannot record: {text}; messages are lost until a write reaches the disk '
                              f'(tried again every {retry:g} s)')

    def _recording_removed(self, path: Path, size: int, why: str) -> None:
        """The recorder removed an old recording to keep the directory's budget: in the log."""
        self._log().info(f'removed the oldest recording {path} ({size / 1e6:.3g} MB): {why}')

    def _bus_opened(self, bus: ListenOnlyBus) -> None:
        """Keep what the bus handle says of its controller and its clock, for the CAN bus status."""
        self._bus_mode = (getattr(bus, 'silent', None), getattr(bus, 'silent_how', 'not reported'))
        self._bus_clock = getattr(bus, 'clock', None)
        self._clock_told = (None, 0)
        if not self._bus_listening_told:      # said once it is true, not before the bus is open
            self._bus_listening_told = True
            self._log().info(f"listening on {self.params['can.interface']}:{self.params['can.channel']}")

    def _clock_text(self) -> str:
        """What the frames' times are, in words; said in the log when it changes (the first
        frame shows whether the interface keeps UTC; an adapter's clock may step later)."""
        clock = self._bus_clock
        text = clock_words(clock)
        if clock is not None and clock.relative is not None:
            told = (clock.relative, clock.steps)
            if told != self._clock_told and (clock.relative or clock.steps):
                self._clock_told = told
                self._log().warning(f'CAN frame times: {text}')
        return text

    def _bus_failed(self, text: str | None) -> None:
        """A bus failure unlike the last one (the CAN bus status has it too), once, not at every
        retry; None: the bus is open again."""
        p = self.params
        if text is None:
            self._log().info(f"CAN bus {p['can.interface']}:{p['can.channel']} open again")
        else:
            self._log().warning(f"{text}; trying again every {p['can.reopen_backoff_max_s']:g} s at most")

    def _bus_status(self) -> Status:
        """The node's own status of its bus (:func:`~steer_monitor.node.statuses.bus_status`)."""
        silent, how = self._bus_mode
        p = self.params
        return bus_status(f"{p['can.interface']}:{p['can.channel']}", silent, how, self._clock_text(), self.restarts,
                          self.reader.last_error, p['node.hardware_id'], self._node_name_kept, self.bus_errors)

    # --- analyses ----------------------------------------------------------------------------
    def _start_analyst(self) -> ThreadedJobs:
        """The analyst (its state loaded when kept), its job runner, and the timer that saves its
        state every ``estimator.save_every_s``."""
        p = self.params
        self.analyst = analyst = analyst_from_params(self.gear, p)
        path = self.state_file.path
        if path is not None and path.exists():
            try:
                motion = analyst.load(path)
                self.get_logger().info(
                    f'analysis state loaded from {path}: {motion:.0f} s of rudder motion counted, '
                    + (describe(analyst.finding) if analyst.finding is not None else 'no finding yet'))
            except EstimateError as exc:
                self.get_logger().warning(f'{exc}; starting the analyses afresh')
        self.create_timer(p['estimator.save_every_s'], self.save_analyses)
        return self._analysis_jobs(analyst)

    def _analysis_jobs(self, analyst: Analyst) -> ThreadedJobs:
        return ThreadedJobs(self.gear, analyst.settings, analyst.model, after=self._analysed)

    def analyses_running(self) -> int:
        """Analyses submitted and not yet run to their end (0 with the analyses off)."""
        jobs = self.pipeline.jobs
        return jobs.pending if isinstance(jobs, ThreadedJobs) else 0

    def analyses_done(self) -> list[str]:
        """Each analysis this pipeline ran, as 'kind CPU s' (for a benchmark or a log line)."""
        jobs = self.pipeline.jobs
        return [f'{kind} {cpu:.2f} s' for kind, cpu in jobs.done] if isinstance(jobs, ThreadedJobs) else []

    def _analysed(self, out: Outcome) -> None:
        """On the analysis thread, after each job: one line in the log."""
        if out.failed:
            self._log().error(f'{out.kind} analysis of the data before {utc_text(out.t_ns)}: {out.why}',
                              throttle_duration_sec=GUARD_LOG_S)
        elif out.finding is not None:
            self._log().info(f'{out.kind} analysis of the data before {utc_text(out.t_ns)}: '
                             f'{describe(out.finding)}')
        else:
            self._log().info(f'{out.kind} analysis of the data before {utc_text(out.t_ns)}: none ({out.why})')

    def _new_monitor(self) -> LiveMonitor:
        """A live model on the configured clearances and friction (until an analysis comes)."""
        p = self.params
        return LiveMonitor(self.gear, gaps_from_params(p), 'configured', friction_from_params(p),
                           ram_share_warn=ram_share_warn_from_params(p),
                           angle_period_ns=self.smap.period_ns('rudder_angle'))

    def _new_pipeline(self, jobs: ThreadedJobs | None) -> Pipeline:
        """The pipeline over a new decoder, on the live model, diagnostics and analyst in use."""
        return Pipeline(Decoder(self._db, self.smap, self.rejects), self.rejects, self.monitor, self.diag,
                        self.analyst if jobs is not None else None, jobs, off=self.analyses_off)

    def _log(self) -> Any:
        """The node's logger while ROS runs; once a signal has shut the context down (the node
        is closing), a child logger that does not publish to /rosout, so a last line is not
        followed by rcl's complaint that it could not be published. For every line that may
        come while closing: the recorder's, the bus reader's and the estimator's callbacks, the
        statuses of the last outputs, the state saved."""
        if self.context.ok():
            return self.get_logger()
        import rclpy.logging
        # the name kept from the start: a callback of the reader thread that comes after the
        # node was destroyed (it outlived close's wait) cannot ask the node for it
        return rclpy.logging.get_logger(f'{self._node_name_kept}.closing')

    def save_analyses(self) -> None:
        """Save the analyses' state (the window, the schedule, the last finding:
        :class:`~steer_monitor.node.statefile.StateFile`): on the executor's timer and when
        closing, under the pipeline's lock (the reader thread feeds the window)."""
        if self.analyst is None:
            return
        with self._lock:
            self.state_file.save(self.analyst, self.monitor.motion_s)

    @property
    def save_error(self) -> str | None:
        """The analyses' state's last save failure, until a save succeeds."""
        return self.state_file.error

    # --- set-up ------------------------------------------------------------------------------
    def _make_publishers(self) -> None:
        self._pubs: dict[str, tuple[Any, str]] = {}
        for key, (topic, datatype) in TOPICS.items():
            depth, latched = topic_qos(key)
            qos = QoSProfile(depth=depth, reliability=ReliabilityPolicy.RELIABLE,
                             durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE)
            pub = self.create_publisher(self._classes[key], topic, qos)
            self._pubs[key] = (pub, datatype)
            if self.recorder is not None:
                self.recorder.add_topic(pub.topic_name, datatype, msgdef(datatype),
                                        offered_qos_profiles(depth, latched))

    def _publish(self, key: str, fields: dict[str, Any], t_ns: int, held: RecordBatches | None = None,
                 now_ns: int = 0) -> None:
        """Publish a message and record it: with the reader thread's batches (``held``, at
        ``now_ns`` monotonic [ns]), among them; otherwise to the recorder itself. What is
        published is what is recorded and what a replay writes: the message's CDR
        (:data:`~steer_monitor.record.cdr.FAST_ENCODERS`, which rclpy's Fast-CDR reads), handed
        to rclpy serialized."""
        pub, datatype = self._pubs[key]
        cdr = FAST_ENCODERS[datatype](fields)
        try:
            pub.publish(cdr)
        except Exception:    # rclpy's errors once its context is shut down; only while closing
            if not self._closing:
                raise
        if self.recorder is not None:
            if held is not None:
                held.add_message(pub.topic_name, cdr, t_ns, now_ns)
            else:
                self.recorder.write(pub.topic_name, cdr, t_ns)

    def _publish_outputs(self, outs: list[Output], held: RecordBatches | None = None, now_ns: int = 0) -> None:
        """Publish and record the pipeline's outputs (``held``, ``now_ns``: see :meth:`_publish`)."""
        for o in outs:
            if isinstance(o, StateOut):
                for key, t_ns, fields in state_messages(o):
                    self._publish(key, fields, t_ns, held, now_ns)
                done, pending, upto = time.time_ns(), self._unpublished, o.state.t_ns
                while pending and pending[0] <= upto:     # the frames this state reflects
                    self.latencies_ns.append(done - pending.popleft())
            elif isinstance(o, DiagOut):
                self._publish_diag(o, held, now_ns)
            else:       # the node's live model solves each state's load sharing: no state columns come
                msg = f'the pipeline gave the node an output it does not publish: {type(o).__name__}'
                raise TypeError(msg)

    def _publish_diag(self, o: DiagOut, held: RecordBatches | None = None, now_ns: int = 0) -> None:
        rec = self._recording_status()
        extra = (self._bus_status(),) + (() if rec is None else (rec,))
        for key, t_ns, fields in diag_messages(o, extra):
            self._publish(key, fields, t_ns, held, now_ns)
        self._last_diag = time.monotonic()

    # --- the data time going back ------------------------------------------------------------
    def _restart_monitor(self) -> list[Output]:
        """Under the lock, on the reader thread: the frames' time has gone back (the host clock
        set back by NTP, an operator or a GPS receiver; see :mod:`~steer_monitor.can.timejump`).
        The decoder would refuse every frame until the clock passed the last time it accepted,
        for as long as the clock was ahead (years, after a GPS week rollover). Instead the
        monitor starts again from the new time as a restart would: the old pipeline's last
        outputs, then a new decoder, live model and schedule; the analyst keeps its finding,
        schedule and the motion counted, but not the window's samples (they lie after the new
        time); its jobs not yet run are dropped, as on stopping. Returns the
        old pipeline's last outputs; the caller publishes them, then splits the recording, so
        the new time goes to a new file."""
        old = self.pipeline
        step_ns = old.decoder.jumps.step_back_ns
        outs = old.finish()
        old.close()
        self.monitor = self._new_monitor()
        jobs = None
        analyst = self.analyst
        if analyst is not None:
            analyst.restart_stream(old.monitor.motion_s)
            analyst.buffer.clear()
            jobs = self._analysis_jobs(analyst)
        self.pipeline = self._new_pipeline(jobs)
        self.restarts += 1
        self._log().warning(f'the CAN frames\' time went back {step_ns / 1e9:.1f} s (the host clock set back?): '
                            'the monitor starts again from the new time, keeping the last analysis'
                            + ('; the recording goes on in a new file' if self.recorder is not None else ''))
        return outs

    # --- reader thread -----------------------------------------------------------------------
    def _read(self) -> None:
        """The reader thread: each read of the bus (what it held, :meth:`BusReader.batches`)
        recorded and fed to the pipeline as one part (:meth:`Pipeline.feed_frames`, the path a
        replay takes); while the bus is quiet, the pipeline told the wall time (:meth:`Pipeline.idle`)."""
        reader, lock, stop = self.reader, self._lock, self._stop
        batches = RecordBatches(self.recorder) if self.recorder is not None else None
        try:
            while not stop.is_set():
                for frames in reader.batches(stop):
                    received = time.monotonic_ns()
                    self.frames_received += len(frames)
                    for f in frames:
                        if f.is_error:
                            self._error_frame(f)
                    cut = batches.add(frames, received) if batches is not None else 0
                    taken, later = len(frames), []
                    try:
                        with lock:
                            pipeline = self.pipeline
                            if frames:
                                outs = pipeline.feed_frames(frames, until_step_back=True)
                                # the frames the next states reflect: their latency runs from their bus
                                # timestamps (the interface's receive time, wall clock), so the time
                                # they waited in the receive queue counts
                                self._unpublished += pipeline.changed_stamps
                                taken = pipeline.taken
                            else:
                                outs = pipeline.idle(time.time_ns())
                            restarted = bool(pipeline.decoder.jumps.steps_back)
                            if restarted:
                                outs += self._restart_monitor()
                                self._unpublished.clear()    # stamps of the old time: no new state reflects them
                                if taken < len(frames):      # the read's frames after the step: the new monitor's
                                    later = self.pipeline.feed_frames(frames[taken:])
                                    self._unpublished += self.pipeline.changed_stamps
                    except SteerMonitorError as exc:  # the decoder counts rejects; this guards a defect
                        self.get_logger().error(f'frames not processed: {exc}', throttle_duration_sec=GUARD_LOG_S)
                        outs, restarted = [], False
                    if outs:
                        self._publish_outputs(outs, batches, received)
                    if restarted and batches is not None:
                        # each file holds one time: the old one's frames and outputs, then the new one's
                        batches.split(cut + taken, received)
                    if later:
                        self._publish_outputs(later, batches, received)
                    if batches is not None:
                        batches.hand_over_if_due(not frames, received)
        finally:
            if batches is not None:
                batches.close()

    def _error_frame(self, f: Frame) -> None:
        """An error frame: the controller's state followed; a change to error-passive or bus-off,
        or back, in the log."""
        before = self.bus_errors.state
        self.bus_errors.feed(f.t_ns, f.can_id, f.data)
        if self.bus_errors.state != before:
            self.get_logger().warning(f'CAN controller {before} -> {self.bus_errors.state} at {utc_text(f.t_ns)}')

    # --- acting on the monitor: writable parameters and services ---------------------------
    def _set_parameters(self, params: list[Any]) -> Any:
        """``ros2 param set``: only :data:`~steer_monitor.params.WRITABLE` ones, checked as the
        parameters file is; the statuses are judged by them from the next one on."""
        from rcl_interfaces.msg import SetParametersResult

        changed = {q.name: q.value for q in params}
        refused = sorted(set(changed) - WRITABLE)
        if refused:
            reason = (f'read only while the node runs: {", ".join(refused)} (set it in the parameters file and start '
                      'the node again)')
            return SetParametersResult(successful=False, reason=reason)
        try:
            values = validate_params({**self.params, **changed})
        except ParameterError as exc:
            return SetParametersResult(successful=False, reason=str(exc))
        with self._lock:
            self.params = values
            self.diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(values, self._node_name_kept), self.smap,
                                           self.gear)
            self.pipeline.diag = self.diag
        self.get_logger().info('parameters set: ' + ', '.join(f'{k} = {v}' for k, v in sorted(changed.items())))
        return SetParametersResult(successful=True)

    def _analyse_now(self, request: Any, response: Any) -> Any:
        """``~/analyse_now`` (std_srvs/Trigger): an analysis of the data so far at the next second."""
        if self.analyst is None:
            response.success, response.message = False, self.analyses_off
            return response
        with self._lock:
            self.analyst.request()
        response.success = True
        response.message = 'an analysis of the data so far starts at the next second of data'
        return response

    def _split_recording(self, request: Any, response: Any) -> Any:
        """``~/split_recording`` (std_srvs/Trigger): finish the recording and go on in a new file."""
        if self.recorder is None:
            response.success, response.message = False, 'not recording (recording.enabled: false)'
            return response
        self.recorder.split()
        response.success = True
        response.message = 'the recording is finished at the next message and goes on in a new file'
        return response

    def _save_state(self, request: Any, response: Any) -> Any:
        """``~/save_state`` (std_srvs/Trigger): save the analyses' state now."""
        if self.analyst is None or self.state_file.path is None:
            response.success = False
            response.message = (self.analyses_off if self.analyst is None else
                                'no state file (estimator.state_file is empty)')
            return response
        self.save_analyses()
        error = self.save_error
        response.success = error is None
        response.message = f'saved to {self.state_file.path}' if error is None else error
        return response

    def _recording_status(self) -> Status | None:
        if self.recorder is None:
            return None
        return recording_status(self.recorder.status(), self.params['node.hardware_id'], self._node_name_kept)

    def _silent_diagnostics(self) -> None:
        """1 Hz on wall time: publish diagnostics only when the data clock has stopped (no
        frames, so no whole second of data comes): this is where inputs go STALE."""
        if time.monotonic() - self._last_diag < SILENT_DIAG_S:
            return
        with self._lock:
            out = self.pipeline.diagnostics_now(time.time_ns())
        self._publish_diag(out)

    # --- shutdown ----------------------------------------------------------------------------
    def close(self) -> None:
        """Stop reading, finish the recording, destroy the node. Idempotent."""
        if self._closed:
            return
        self._closed = True
        self._stop.set()
        self._reader_thread.join(5)
        if not self._reader_thread.is_alive():
            self._finish_outputs()
        self.pipeline.close()            # waits for the running analysis
        self.save_analyses()
        self.reader.close()
        if self.recorder is not None:
            self.recorder.close()
            st = self.recorder.status()
            lost = st.lost()
            if lost is not None:
                self._log().warning(f'recording: {lost}; {st.message}')
        self.destroy_node()

    def _finish_outputs(self) -> None:
        """On stopping: the state of the last frames and the second they end in, as a replay
        of the recording ends (the bus did not go quiet long enough for them to go out), so
        the recording holds what its frames gave. Published if ROS still runs (a signal may
        have shut its context down), recorded either way."""
        try:
            with self._lock:
                outs = self.pipeline.finish()
        except SteerMonitorError as exc:
            self._log().error(f'last outputs not processed: {exc}')
            return
        self._closing = True
        self._publish_outputs(outs)

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
        except (KeyboardInterrupt, ExternalShutdownException):
            return 0            # stopped while starting: what it had opened is closed
        executor = SingleThreadedExecutor()
        executor.add_node(node)
        try:
            executor.spin()
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        except Exception:
            # SIGINT/SIGTERM shut the context down from rclpy's signal handler; when that comes
            # while the executor builds its wait set, rclpy raises its RCLError ("the given
            # context is not valid") instead of ExternalShutdownException: the same stop
            if node.context.ok():
                raise
        return 0
    finally:
        if node is not None:
            node.close()
        if rclpy.ok():
            rclpy.shutdown()


if __name__ == '__main__':
    sys.exit(main())
