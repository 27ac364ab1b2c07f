"""Replay: the live pipeline (decode, model, analyses, diagnostics) run offline over logs,
writing the topics the node publishes to one MCAP.

The same :class:`~steer_monitor.monitor.pipeline.Pipeline` the node runs, fed from log files
instead of a bus, with its analyses run at once when due instead of on a worker thread (the
pipeline applies their findings at the same data time either way). At once, not in worker
processes: a replay reaches a finding's time a few milliseconds after its job starts, so it
would wait for each in turn anyway (measured on the hour log: 9.4 s at once, 11.9 s with a
pool of processes, 10.3 s with a thread, docs/benchmarks.md). Deterministic: the same logs give
the same file, byte for byte. Differences from a node's recording, by design: no
``steer_monitor: recording`` status (a replay records nothing live), and no diagnostics on wall
time while a bus is silent (a log has no silence to wait through, only gaps, which the data
clock steps over).

Logs are taken in order of their first frame. A log that breaks off gives what came before
the break; the replay goes on with the next one and reports the error.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.atomic import atomic_path, check_target, os_reason
from steer_monitor.can.busconfig import Setup, can_setup, load_setup
from steer_monitor.can.codec import DbcError
from steer_monitor.can.decoder import Decoder
from steer_monitor.can.frames import FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.errors import ParameterError, SteerMonitorError
from steer_monitor.estimate.finding import Finding
from steer_monitor.estimate.sampling import missing_steering
from steer_monitor.logfiles.blocks import in_time_order, iter_log_blocks
from steer_monitor.logfiles.logs import LogError, log_path_problem
from steer_monitor.logfiles.mcapio import (
    FRAME_DATATYPE,
    FRAME_MSGDEF,
    FRAME_TOPIC,
    McapWriter,
    leading_metadata,
    pack_messages,
)
from steer_monitor.logfiles.rosbag2meta import offered_qos_profiles
from steer_monitor.model.gear import GearParams
from steer_monitor.monitor.analyst import Analyst, SyncJobs
from steer_monitor.monitor.diagnostics import DiagnosticsBuilder, DiagnosticsConfig
from steer_monitor.monitor.live import LiveMonitor
from steer_monitor.monitor.messages import TOPICS, diag_messages, topic_name, topic_qos
from steer_monitor.monitor.pipeline import DiagOut, Output, Pipeline, StateOut, analyst_from_params
from steer_monitor.monitor.runfeed import StateRun
from steer_monitor.params import (
    friction_from_params,
    gaps_from_params,
    gear_from_params,
    ram_share_warn_from_params,
    recorded_params,
)
from steer_monitor.record.cdr import FAST_ENCODERS
from steer_monitor.record.msgdefs import msgdef
from steer_monitor.record.provenance import PARAMETERS_RECORD, RUN_RECORD, run_metadata
from steer_monitor.record.staterecords import pack_states
from steer_monitor.resources import default_config
from steer_monitor.runtime import fewer_collections

__all__ = ['CLEARANCES_STATUS', 'FRAME_BATCH', 'ReplayError', 'ReplaySummary', 'Runner', 'SpanWatch', 'add_channels',
           'note_overlap', 'recorded_setup', 'replay', 'replay_with', 'summary_json', 'write_outputs']

#: frames decoded and laid out at once, their outputs written together (about three minutes of
#: gear traffic): a run's fixed costs (decoding's passes per PGN, the lay-out, the rates' plan)
#: spread over that many (at 4,096 an hour's replay without analyses took 2.51 s of CPU
#: against 2.37 s, six runs each; the peak memory is 13 MB higher at this size)
FRAME_BATCH = 16384


class ReplayError(SteerMonitorError):
    """A replay cannot start (no logs, an output that cannot be written)."""


#: the clearances status's name after the node's own prefix
CLEARANCES_STATUS = ': clearances'

@dataclass
class ReplaySummary:
    """What a replay did."""

    output: str
    logs: list[str]
    frames: int = 0
    states: int = 0
    diagnostics: int = 0
    rejects: dict[str, int] = field(default_factory=dict)
    errors: list[str] = field(default_factory=list)
    first_ns: int | None = None
    last_ns: int | None = None
    #: the last analysis applied (None: none was), the motion counted [s], analyses run
    finding: Finding | None = None
    motion_s: float = 0.0
    analyses: int = 0
    #: the steady motion the first analysis waits for [s] and why the last one gave nothing ('')
    first_motion_s: float = 0.0
    why: str = ''
    #: what the user should know that is no error (a log within the time of the ones before it)
    notes: list[str] = field(default_factory=list)
    #: the node's last clearances status, as it published it: (level in words, NOT ASSESSED where
    #: it says so, and message); None before any
    clearances: tuple[str, str] | None = None


def replay(logs: Sequence[str | Path], output: str | Path, config: str | Path | None = None, *,
           frames: bool = True, estimator: bool = True, node_name: str = 'steer_monitor',
           progress: Callable[[int, int | None], None] | None = None,
           date: datetime.date | None = None) -> ReplaySummary:
    """Replay ``logs`` into ``output`` (an MCAP) with the parameters file ``config`` (None:
    those the first log was recorded with, when it is a recording that carries them
    (:func:`recorded_setup`), else the packaged R-18 ones). ``frames``: record the raw frames
    too, as the node does. ``progress`` is called with the number of frames done since its last call
    and the data time reached [ns] (None before the stream's time is confirmed). The file is
    the one the node's pipeline gives frame by frame with each message written as it comes
    (the tests' per-frame oracle, ``test/ashore/replay_reference.py``), byte for byte."""
    return replay_with(_run, logs, output, config, frames=frames, estimator=estimator, node_name=node_name,
                       progress=progress, date=date, defer_share=True)


#: how a replay feeds the logs' frames through the pipeline and writes what it emits:
#: ``run(paths, pipeline, writer, topics, encoders, frames, rejects, summary, progress, date)``
Runner = Callable[..., None]


def replay_with(run: Runner, logs: Sequence[str | Path], output: str | Path, config: str | Path | None = None, *,
                frames: bool = True, estimator: bool = True, node_name: str = 'steer_monitor',
                progress: Callable[[int, int | None], None] | None = None,
                date: datetime.date | None = None, defer_share: bool = True) -> ReplaySummary:
    """:func:`replay` with the feeding and writing done by ``run`` (:func:`replay` passes its
    batched one; the tests pass the per-frame oracle). ``defer_share``: the states' load
    sharing is solved when they are written, in batches, not by the live model."""
    if not logs:
        msg = 'no log given'
        raise ReplayError(msg)
    paths = in_time_order([Path(p) for p in logs], date)
    for p in paths:
        problem = log_path_problem(p)
        if problem is not None:
            raise ReplayError(problem)
    check_target(output, [*paths, config])
    recorded = recorded_setup(paths[0]) if config is None else None
    config_path, params, db, smap = recorded[0] if recorded is not None else load_setup(config)
    gear = gear_from_params(params)
    rejects = RejectCounter()
    monitor = LiveMonitor(gear, gaps_from_params(params), 'configured', friction_from_params(params),
                          defer_share=defer_share, ram_share_warn=ram_share_warn_from_params(params),
                          angle_period_ns=smap.period_ns('rudder_angle'))
    diag = DiagnosticsBuilder(DiagnosticsConfig.from_params(params), smap, gear)
    summary = ReplaySummary(str(output), [str(p) for p in paths])
    if recorded is not None:
        summary.notes.append(recorded[1])
    analyst: Analyst | None = None
    jobs: SyncJobs | None = None
    if estimator and params['estimator.enabled']:
        analyst = analyst_from_params(gear, params)
        jobs = SyncJobs(gear, analyst.settings)
    pipeline = Pipeline(Decoder(db, smap, rejects), rejects, monitor, diag, analyst, jobs,
                        on_failed=summary.errors.append)
    try:
        with fewer_collections():
            return _replay(run, paths, output, config_path, params, pipeline, summary, node_name, frames, progress,
                           date)
    finally:
        pipeline.close()


def recorded_setup(log: str | Path) -> tuple[Setup, str] | None:
    """The setup an MCAP recording was made with (its parameters metadata, written by the
    node and ``replay``: :mod:`~steer_monitor.record.provenance`), and a note saying so; None
    when ``log`` carries none. A node's recording replayed with its own parameters gives what
    the node published, whatever the packaged defaults have become. The DBC is looked for
    beside the parameters file the recording names, then in the packaged config. Raises
    :class:`~steer_monitor.errors.ParameterError` naming the log when the recorded parameters
    do not validate."""
    meta = leading_metadata(log) if str(log).lower().endswith('.mcap') else {}
    values = meta.get(PARAMETERS_RECORD)
    if not values:
        return None
    named = meta.get(RUN_RECORD, {}).get('parameters_file')
    where = Path(named) if named and Path(named).is_file() else default_config()
    try:
        params, dropped = recorded_params(values)
        db, smap = can_setup(params, where)
    except (DbcError, ParameterError) as exc:
        msg = f'{log}: the parameters it was recorded with: {exc} (give --config)'
        raise ParameterError(msg) from None
    note = (f'{log}: replayed with the parameters it was recorded with (--config to use others)'
            + (f'; not read by this version: {", ".join(dropped)}' if dropped else ''))
    return Setup(where, params, db, smap), note


def _replay(run: Runner, paths: list[Path], output: str | Path, config_path: Path, params: Any, pipeline: Pipeline,
            summary: ReplaySummary, node_name: str, frames: bool,
            progress: Callable[[int, int | None], None] | None, date: datetime.date | None) -> ReplaySummary:
    """The replay once set up: the MCAP written atomically, the summary filled in."""
    rejects = pipeline.rejects
    topics = {key: topic_name(key, node_name) for key in TOPICS}
    encoders = {key: FAST_ENCODERS[dt] for key, (_, dt) in TOPICS.items()}     # every topic has its CDR encoder
    with atomic_path(output) as tmp:
        try:
            writer = McapWriter(tmp)
        except OSError as exc:
            msg = f'cannot write {output}: {os_reason(exc)}'
            raise ReplayError(msg) from exc
        with writer:
            for name, data in run_metadata(params, config_path, 'steer-monitor replay').items():
                writer.add_metadata(name, data)
            run(paths, pipeline, writer, topics, encoders, frames, rejects, summary, progress, date)
        if summary.frames == 0:     # nothing to write: no output rather than an empty one
            msg = summary.errors[0] if summary.errors else 'no frame in ' + ', '.join(str(p) for p in paths)
            raise ReplayError(msg)
        missing = missing_steering({n: a.total for n, a in pipeline.monitor.signals.items()}, pressures=False)
        if missing is not None:     # the statuses of a bus without the gear say nothing of it
            msg = f"{', '.join(str(p) for p in paths)}: {missing}"
            raise ReplayError(msg)
    summary.rejects = dict(sorted(rejects.snapshot().counts.items()))
    if pipeline.analyst is not None:
        a = pipeline.analyst
        summary.finding, summary.motion_s, summary.analyses = a.finding, a.motion_base_s + pipeline.monitor.motion_s, \
            a.jobs_made
        summary.first_motion_s, summary.why = a.settings.first_s, a.why or ''
    else:
        summary.why = 'the analyses were not asked for'
        summary.first_motion_s = math.inf
    return summary


def add_channels(writer: McapWriter, topics: dict[str, str], frames: bool) -> None:
    """The schemas and channels of the node's topics (and of the frames, with ``frames``)."""
    for key, (_, datatype) in TOPICS.items():
        writer.add_schema(datatype, msgdef(datatype))
        writer.add_channel(topics[key], datatype, offered_qos_profiles(*topic_qos(key)))
    if frames:
        writer.add_schema(FRAME_DATATYPE, FRAME_MSGDEF)
        writer.add_channel(FRAME_TOPIC, FRAME_DATATYPE)


def write_outputs(writer: McapWriter, outputs: Sequence[Output], channels: dict[str, int],
                  encoders: dict[str, Any], gear: GearParams | None) -> None:
    """Outputs written in their order, as one batch: the load sharing of all their states
    solved at once (with ``gear``), their records packed at once
    (:func:`~steer_monitor.record.staterecords.pack_states`), each diagnostics round's
    records (its messages' CDR by ``encoders``, per topic key) put after the states before
    it, and the whole appended at once (``McapWriter.write_records``). ``channels``: the MCAP
    channel of each topic key."""
    if not outputs:
        return
    p = pack_states([o.state if isinstance(o, StateOut) else o for o in outputs if not isinstance(o, DiagOut)],
                    channels['rudder'], channels['load_sharing'], gear)
    sizes = np.diff(p.offsets)
    data: list[bytes] = []
    cids: list[NDArray[np.uint16]] = []
    times: list[NDArray[np.int64]] = []
    lengths: list[NDArray[np.int64]] = []
    done = seen = 0            # state records taken, states passed

    def states_until_seen() -> None:
        nonlocal done
        end = int(p.state_ends[seen - 1]) if seen else 0
        if end > done:
            data.append(p.data[int(p.offsets[done]):int(p.offsets[end])])
            cids.append(p.channels[done:end])
            times.append(p.log_times[done:end])
            lengths.append(sizes[done:end])
            done = end
    for o in outputs:
        if isinstance(o, StateOut):
            seen += 1
        elif isinstance(o, StateRun):
            seen += len(o)
        else:
            states_until_seen()
            msgs = diag_messages(o)
            c = np.array([channels[key] for key, _, _ in msgs], np.uint16)
            t = np.array([t_ns for _, t_ns, _ in msgs], np.int64)
            raw, offsets = pack_messages(c, [encoders[key](fields) for key, _, fields in msgs], t)
            data.append(raw)
            cids.append(c)
            times.append(t)
            lengths.append(np.diff(offsets))
    states_until_seen()
    if not lengths:
        return
    offsets = np.zeros(sum(x.size for x in lengths) + 1, np.int64)
    np.cumsum(np.concatenate(lengths), out=offsets[1:])
    writer.write_records(b''.join(data), np.concatenate(cids), np.concatenate(times), offsets)


class SpanWatch:
    """The span of the stream a replay saw: :meth:`see` the stream's time before each frame
    (or a run's first and last) and its stamp; the first and last times go to the summary (a
    glitched stamp does not stretch it)."""

    def __init__(self, summary: ReplaySummary, max_jump_ns: int) -> None:
        self.summary, self.jump = summary, max_jump_ns
        self.early: int | None = None     # the first stamp, while the stream's first frames await confirmation

    def see(self, t: int | None, stamp: int) -> None:
        s = self.summary
        if t is None:
            self.early = stamp if self.early is None else self.early
        else:
            if s.first_ns is None:     # the confirmed stream's own start
                s.first_ns = self.early if self.early is not None and 0 <= t - self.early <= self.jump else t
            s.last_ns = t


def note_overlap(summary: ReplaySummary, path: Path, n_log: int, refused: int) -> None:
    """A log most of whose frames were refused as older than the logs before it, noted."""
    if n_log and refused > n_log // 2:
        summary.notes.append(f'{path}: {refused} of its {n_log} frames lie within the time of the logs before '
                             'it (the logs overlap, or one is a copy): refused as time_backwards')


def _run(paths: list[Path], pipeline: Pipeline, writer: McapWriter, topics: dict[str, str],
         encoders: dict[str, Any], frames: bool, rejects: RejectCounter, summary: ReplaySummary,
         progress: Callable[[int, int | None], None] | None, date: datetime.date | None) -> None:
    """Feed every frame of ``paths`` through ``pipeline`` in runs the decoder takes at once,
    writing what it emits (and the frames) to ``writer``: the states' load sharing solved and
    their records packed in batches of up to ``FRAME_BATCH`` frames' outputs, the diagnostics'
    records packed among them, each batch's records written at once."""
    add_channels(writer, topics, frames)
    queue: list[Output] = []       # outputs not yet written, their states solved and packed together
    channels = {key: writer.channel_id(topics[key]) for key in TOPICS}
    gear = pipeline.monitor.gear

    def flush() -> None:
        write_outputs(writer, queue, channels, encoders, gear)
        queue.clear()

    def emit(outs: list[Output]) -> None:
        for o in outs:
            if isinstance(o, StateOut):
                summary.states += 1
            elif isinstance(o, StateRun):
                summary.states += len(o)
            else:
                summary.diagnostics += 1
                summary.clearances = next(((st.label, st.message) for st in o.statuses
                                           if st.name.endswith(CLEARANCES_STATUS)), summary.clearances)
            queue.append(o)

    span = SpanWatch(summary, pipeline.decoder.jumps.max_jump_ns)
    pending: list[FrameArrays] = []  # the frames fed since the outputs and frames were last written
    pending_n = 0
    for path in paths:
        n_log = 0
        backwards = rejects['time_backwards']
        try:
            for block in iter_log_blocks(path, rejects, date):
                # runs of frames decoded at once, cut where the per-frame path writes its frames
                pos = 0
                while pos < len(block):
                    k = min(len(block) - pos, FRAME_BATCH - pending_n)
                    part = block.take(np.arange(pos, pos + k))
                    pos += k
                    emit(pipeline.feed_frames(part, span.see))
                    if frames:
                        pending.append(part)
                    pending_n += k
                    if pending_n >= FRAME_BATCH:
                        flush()
                        if pending:
                            writer.write_frames(FrameArrays.concat(pending))
                        pending, pending_n = [], 0
                    n_log += k
                    if progress is not None:
                        progress(k, summary.last_ns)
        except LogError as exc:
            summary.errors.append(str(exc))
        summary.frames += n_log
        note_overlap(summary, path, n_log, rejects['time_backwards'] - backwards)
    flush()
    if pending:
        writer.write_frames(FrameArrays.concat(pending))
    emit(pipeline.finish())
    flush()


def summary_json(s: ReplaySummary) -> dict[str, Any]:
    """The summary in engineers' units (clearances in mm)."""
    e = s.finding

    def iv(v: Any, scale: float) -> dict[str, Any] | None:
        if v is None:
            return None
        return v.scaled(scale, 6)
    span = 0.0 if s.first_ns is None or s.last_ns is None else (s.last_ns - s.first_ns) / 1e9
    return {'output': s.output, 'logs': s.logs, 'frames': s.frames, 'span_s': round(span, 3), 'states': s.states,
            'diagnostics': s.diagnostics, 'rejects': s.rejects, 'errors': s.errors, 'notes': s.notes,
            'analyses': s.analyses, 'motion_s': round(s.motion_s, 1),
            'clearances_status': None if s.clearances is None else {'level': s.clearances[0],
                                                                     'message': s.clearances[1]},
            'final_estimate': None if e is None else {
                'clearance_2z_mm': iv(e.two_z, 1e3), 'clearance_zgb_mm': iv(e.z_gb, 1e3),
                'k_gl_max': iv(e.k_gl_max, 1.0), 'verdict': e.verdict, 'kind': e.kind,
                'effects': [x.name for x in e.model], 'data_before_ns': e.t_ns}}
