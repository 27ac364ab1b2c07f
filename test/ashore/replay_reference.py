"""The per-frame replay: the oracle :func:`steer_monitor.ashore.replay.replay` is checked
against. Every frame through the node's pipeline one at a time (``Pipeline.feed``, the
decoder's per-frame path), every message built and written on its own as the node publishes
it, the states' load sharing solved by the live model: plain, slow (a third of the batched
replay's speed) and the same file, byte for byte."""

from __future__ import annotations

import datetime
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from steer_monitor.ashore import replay as R
from steer_monitor.can.frames import Frame
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.logfiles.blocks import iter_log_blocks
from steer_monitor.logfiles.logs import LogError
from steer_monitor.logfiles.mcapio import McapWriter
from steer_monitor.monitor.messages import diag_messages, state_messages
from steer_monitor.monitor.pipeline import Output, Pipeline, StateOut

__all__ = ['reference_replay']


def write_messages(writer: McapWriter, topics: dict[str, str], encoders: dict[str, Any],
                   msgs: list[tuple[str, int, Any]]) -> None:
    """Messages ``(topic key, time [ns], fields)`` written one at a time, in CDR by the fast
    encoder (``write_cdr``)."""
    for key, t_ns, fields in msgs:
        writer.write_cdr(topics[key], encoders[key](fields), t_ns)


def reference_replay(logs: Sequence[str | Path], output: str | Path, config: str | Path | None = None, *,
                     frames: bool = True, date: datetime.date | None = None,
                     progress: Callable[[int, int | None], None] | None = None) -> R.ReplaySummary:
    """:func:`~steer_monitor.ashore.replay.replay` done frame by frame."""
    return R.replay_with(_per_frame, logs, output, config, frames=frames, progress=progress, date=date,
                         defer_share=False)


def _per_frame(paths: list[Path], pipeline: Pipeline, writer: McapWriter, topics: dict[str, str],
               encoders: dict[str, Any], frames: bool, rejects: RejectCounter, summary: R.ReplaySummary,
               progress: Callable[[int, int | None], None] | None, date: datetime.date | None) -> None:
    R.add_channels(writer, topics, frames)
    span = R.SpanWatch(summary, pipeline.decoder.jumps.max_jump_ns)

    def emit(outs: list[Output]) -> None:
        for o in outs:
            if isinstance(o, StateOut):
                summary.states += 1
                write_messages(writer, topics, encoders, state_messages(o))
            else:
                summary.diagnostics += 1
                write_messages(writer, topics, encoders, diag_messages(o))

    batch: list[Frame] = []
    for path in paths:
        n_log = 0
        backwards = rejects['time_backwards']
        try:
            for block in iter_log_blocks(path, rejects, date):
                for frame in block.frames():
                    if frames:
                        batch.append(frame)
                    span.see(pipeline.clock(frame.t_ns), frame.t_ns)
                    emit(pipeline.feed(frame))
                    if len(batch) >= R.FRAME_BATCH:
                        writer.write_frames(batch)
                        batch = []
                    n_log += 1
                    if progress is not None and n_log % R.FRAME_BATCH == 0:
                        progress(R.FRAME_BATCH, summary.last_ns)
        except LogError as exc:
            summary.errors.append(str(exc))
        if progress is not None:
            progress(n_log % R.FRAME_BATCH, summary.last_ns)
        summary.frames += n_log
        R.note_overlap(summary, path, n_log, rejects['time_backwards'] - backwards)
    if batch:
        writer.write_frames(batch)
    emit(pipeline.finish())
