"""Logs read into a review: the batch path behind ``steer-monitor report``, the fleet and the
replay benchmark. The logs (taken in the order of their first frames) are read in blocks of
columns and decoded vectorized, in a second process where two cores are there, and each block
goes to a :class:`~steer_monitor.ashore.review.Review`; no Python object per frame. A log that
breaks off gives what came before it, the error reported. :func:`refit_windows` reads them again
for the windows under a model check's model.
"""

from __future__ import annotations

import datetime
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from steer_monitor.ashore.review import Review, ReviewResult
from steer_monitor.ashore.windowmodel import Nuisance
from steer_monitor.can.busconfig import load_setup
from steer_monitor.can.decoder import Decoder, clock_notes
from steer_monitor.can.frames import FrameArrays
from steer_monitor.can.rejects import RejectCounter
from steer_monitor.estimate.effects import Effect
from steer_monitor.logfiles.blocks import in_time_order, iter_log_blocks, log_end_ns
from steer_monitor.logfiles.logs import LogError
from steer_monitor.params import (
    gaps_from_params,
    gear_from_params,
    min_clearance_2z_from_params,
    ram_share_warn_from_params,
)

__all__ = ['BatchRun', 'refit_windows', 'review_logs']


@dataclass
class BatchRun:
    """A review and what reading the logs met."""

    review: ReviewResult
    logs: list[str]
    frames: int
    rejects: dict[str, int]
    errors: list[str]
    #: samples decoded per input
    samples: dict[str, int] = field(default_factory=dict)


def _decoded(paths: list[Path], db: object, smap: object, rejects: RejectCounter,
             date: datetime.date | None = None) -> Iterator[tuple[str, Any, int]]:
    """Read and decode ``paths`` in order: ('block', signals, frames) per block, ('error',
    text, 0) for a log that breaks off, ('note', text, 0) for what to say of the frames'
    clock (a step back is stitched: :class:`~steer_monitor.can.decoder.Decoder`), and last
    ('done', reject counts, 0)."""
    decoder = Decoder(db, smap, rejects, stitch=True)  # type: ignore[arg-type]
    for path in paths:
        try:
            for block in iter_log_blocks(path, rejects, date):
                yield 'block', decoder.decode_arrays(block), len(block)
        except LogError as exc:
            yield 'error', str(exc), 0
    yield 'block', decoder.decode_arrays(FrameArrays.empty(), final=True), 0   # frames held at the end
    for note in clock_notes(decoder.clock_steps):
        yield 'note', note, 0
    yield 'done', dict(rejects.snapshot().counts), 0


def _produce(paths: list[Path], db: object, smap: object, out: object, date: datetime.date | None) -> None:
    """:func:`_decoded` in a second process, onto the queue ``out``."""
    rejects = RejectCounter()
    try:
        for item in _decoded(paths, db, smap, rejects, date):
            out.put(item)  # type: ignore[attr-defined]
    except BaseException as exc:   # a defect: say so rather than leave the reader waiting
        out.put(('error', f'reading failed: {type(exc).__name__}: {exc}', 0))  # type: ignore[attr-defined]
        out.put(('done', dict(rejects.snapshot().counts), 0))  # type: ignore[attr-defined]


def review_logs(logs: Sequence[str | Path], config: str | Path | None = None, *, jobs: int | None = None,
                progress: Callable[[int], None] | None = None, date: datetime.date | None = None,
                model: Sequence[Effect] = (), nuisance: Nuisance | None = None) -> BatchRun:
    """Review ``logs`` (taken in order of their first frame) with the configuration's gear and
    signal map, its estimates under ``model`` and ``nuisance`` (:class:`Review`). A log that breaks off gives
    what came before; the error is reported."""
    import multiprocessing as mp
    import os

    paths = in_time_order([Path(p) for p in logs], date)
    _, params, db, smap = load_setup(config)
    gear = gear_from_params(params)
    jobs = min(jobs or os.cpu_count() or 1, 2)
    review = Review(gear, gaps_from_params(params), min_clearance_2z=min_clearance_2z_from_params(params),
                    ram_share_warn=ram_share_warn_from_params(params), model=model, nuisance=nuisance)
    ends = [log_end_ns(p) for p in paths]
    end = None if not ends or None in ends else max(e for e in ends if e is not None)
    frames = 0
    errors: list[str] = []
    notes: list[str] = []
    counts: dict[str, int] = {}
    samples: dict[str, int] = {}
    proc = None
    if jobs > 1:
        ctx = mp.get_context('fork')
        queue = ctx.Queue(maxsize=4)
        proc = ctx.Process(target=_produce, args=(paths, db, smap, queue, date), daemon=True)
        proc.start()
        items: Iterator[tuple[str, Any, int]] = iter(queue.get, None)
    else:
        items = _decoded(paths, db, smap, RejectCounter(), date)
    try:
        for kind, payload, n in items:
            if kind == 'block':
                frames += n
                for name, series in payload.items():
                    samples[name] = samples.get(name, 0) + len(series)
                review.add(payload)
                if end is not None and frames == n:
                    review.plan(end)
                if progress is not None:
                    progress(n)
            elif kind == 'error':
                errors.append(payload)
            elif kind == 'note':
                notes.append(payload)
            else:
                counts = payload
                break
    finally:
        if proc is not None:
            proc.join(5)
            if proc.is_alive():
                proc.kill()
    result = review.finish()
    result.notes[:0] = notes
    return BatchRun(result, [str(p) for p in paths], frames, dict(sorted(counts.items())), errors, samples)


def refit_windows(batch: BatchRun, model: Sequence[Effect], config: str | Path | None = None, *,
                  nuisance: Nuisance | None = None, progress: Callable[[int], None] | None = None,
                  date: datetime.date | None = None) -> BatchRun:
    """``batch`` with its clearance windows estimated again under ``model`` and ``nuisance``
    (what a model check of the logs fitted, :func:`~steer_monitor.ashore.windowmodel.window_model`; the
    logs read again), so that
    they fit the model the clearances the page gives rest on; the rest of the review as it was,
    the new pass's notes added. ``batch`` itself when the check fitted the declared model alone."""
    if not model and nuisance is None:
        return batch
    again = review_logs(batch.logs, config, progress=progress, date=date, model=model, nuisance=nuisance).review
    r = batch.review
    return replace(batch, review=replace(r, estimates=again.estimates,
                                         notes=r.notes + [n for n in again.notes if n not in r.notes]))
