"""The node's analyses: what it keeps of the data, when it analyses them, and how. Pure.

The node's clearances are ``analyze``'s of the data so far (:mod:`~steer_monitor.estimate.analyze`):
there is no second estimator. Its :class:`Analyst` keeps the samples of the window
(:class:`~steer_monitor.estimate.window.WindowBuffer`), counts the seconds of steady rudder motion,
and at each whole second of data asks its :class:`~steer_monitor.estimate.schedule.AnalysisSchedule`
whether an analysis is due:

* a ``loop`` job runs the whole residual loop on the window (the declared model, every
  candidate effect, the verdict);
* an ``estimate`` job runs :func:`~steer_monitor.estimate.analyze.analyze` under the model the
  last loop chose (its effects applied, no screening).

A job is the window's samples at that second and what kind it is; :func:`run_job` runs it
(a job runner: on the node's worker thread, at once in a replay and in tests).
Because a job's input is the data before its second, whatever runs it, and the schedule
depends on the data alone, a replay of the same frames runs the same analyses on the same
samples and gets the same :class:`~steer_monitor.estimate.finding.Finding` as the node did.

The state (:meth:`Analyst.save`, :meth:`Analyst.load`): the window's samples, the motion
counted, the schedule's progress, the last finding and the last loop's model, written
atomically, so a restart goes on from where it stopped.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from steer_monitor.atomic import atomic_write
from steer_monitor.estimate.analyze import analyze
from steer_monitor.estimate.effects import Effect
from steer_monitor.estimate.finding import Finding, finding_of
from steer_monitor.estimate.observe import EstimateError
from steer_monitor.estimate.schedule import AnalysisSchedule
from steer_monitor.estimate.window import WindowBuffer
from steer_monitor.model.gear import GearParams
from steer_monitor.model.inputs import INPUTS, Series
from steer_monitor.runtime import single_blas_thread

__all__ = [
    'ANALYSED',
    'STATE_VERSION',
    'Analyst',
    'AnalystSettings',
    'Job',
    'JobRunner',
    'Outcome',
    'SyncJobs',
    'describe',
    'run_job',
]

STATE_VERSION = 4               # 4: the data window and findings (3 and before: the binned moments of
                                # the estimator this one replaced)
#: the inputs an analysis reads (the order is not one)
ANALYSED = tuple(n for n in INPUTS if n != 'rudder_order')


@dataclass(frozen=True)
class AnalystSettings:
    """How the node analyses (``estimator.*`` parameters): the window of steady motion kept
    [s], the schedule's periods [s of motion], the smallest 2Z the new fit allows [m] and the
    rams' share beyond which a stretch is left out."""

    window_motion_s: float = 3600.0
    loop_every_s: float = 1800.0
    every_s: float = 300.0
    first_s: float = 240.0
    min_clearance_2z: float = 0.0
    ram_share_warn: float = 0.15


@dataclass(frozen=True)
class Job:
    """One analysis to run: the data before ``t_ns`` (the window's samples), of ``kind``."""

    seq: int
    t_ns: int
    kind: str
    signals: dict[str, Series]


@dataclass(frozen=True)
class Outcome:
    """What a job gave: the finding, or why there is none (too little motion, rams read the
    wrong way round, ...; ``failed``: the analysis raised, a defect), and the model later
    estimate jobs use (the loop's choice)."""

    seq: int
    t_ns: int
    kind: str
    finding: Finding | None
    why: str | None
    model: tuple[Effect, ...]
    failed: bool = False


def run_job(gear: GearParams, settings: AnalystSettings, job: Job, model: tuple[Effect, ...]) -> Outcome:
    """Run ``job``: ``analyze`` of its samples (the whole loop, or under ``model``, the last
    loop's choice). An analysis the data cannot support gives no finding and says why; one
    that fails otherwise (a defect) says so too and the monitoring goes on; either way the
    model stays the last loop's. BLAS runs on one thread (:func:`~steer_monitor.runtime.single_blas_thread`):
    its sums in one order, so the node's thread and a job run at once (a replay's) give the
    same finding to the bit."""
    single_blas_thread()
    try:
        a = analyze(gear, job.signals, min_clearance_2z=settings.min_clearance_2z,
                    ram_share_warn=settings.ram_share_warn, window_motion_s=settings.window_motion_s,
                    model=None if job.kind == 'loop' else model)
    except EstimateError as exc:
        return Outcome(job.seq, job.t_ns, job.kind, None, str(exc), model)
    except Exception as exc:  # noqa: BLE001 - a defect in one analysis must not stop the monitor or a replay
        return Outcome(job.seq, job.t_ns, job.kind, None, f'the analysis failed: {type(exc).__name__}: {exc}',
                       model, failed=True)
    f = finding_of(a, job.t_ns, job.kind)
    return Outcome(job.seq, job.t_ns, job.kind, f, None, f.model if job.kind == 'loop' else model)


class JobRunner(Protocol):
    """Runs the analyst's jobs; ``result`` of a handle is the job's outcome (in submission order
    for the model each estimate job uses)."""

    def submit(self, job: Job) -> object: ...

    def result(self, handle: object) -> Outcome: ...

    def close(self) -> None: ...


class SyncJobs:
    """Each job runs when submitted, one after the other (offline, tests)."""

    def __init__(self, gear: GearParams, settings: AnalystSettings, model: tuple[Effect, ...] = ()) -> None:
        self.gear, self.settings, self.model = gear, settings, model

    def submit(self, job: Job) -> object:
        out = run_job(self.gear, self.settings, job, self.model)
        self.model = out.model
        return out

    def result(self, handle: object) -> Outcome:
        assert isinstance(handle, Outcome)
        return handle

    def close(self) -> None:
        pass


class Analyst:
    """See the module docstring. Not thread-safe: the pipeline calls it from one thread."""

    def __init__(self, gear: GearParams, settings: AnalystSettings) -> None:
        self.gear = gear
        self.settings = settings
        self.buffer = WindowBuffer(ANALYSED, gear.ram_area, settings.window_motion_s)
        self.schedule = AnalysisSchedule(settings.loop_every_s, settings.every_s, settings.first_s)
        self.finding: Finding | None = None        # the last applied
        self.model: tuple[Effect, ...] = ()         # the last loop's choice, as the job runner has it
        self.why: str | None = None                 # why the last job gave no finding
        self.motion_base_s = 0.0                    # motion counted before this run (a restart)
        #: per clearance ('2z', 'zgb'), the last finding that assessed it (two-sided, from a
        #: model that explains the data): (value, lo, hi [m], data time [ns])
        self.assessed: dict[str, tuple[float, float, float, int]] = {}
        self.jobs_made = 0
        self.requested = False                      # an analysis asked for now (:meth:`request`)

    def add(self, name: str, t_ns: int, value: float) -> None:
        self.buffer.add(name, t_ns, value)

    def add_many(self, name: str, times: list[int], values: list[float]) -> None:
        """Samples of one input in order: :meth:`add` of each."""
        self.buffer.extend(name, times, values)

    def due(self, t_ns: int, motion_s: float) -> Job | None:
        """At the whole second ``t_ns`` with ``motion_s`` seconds of steady motion counted in
        this run: compact the window when due, and the job due now, if any."""
        self.buffer.tick(t_ns)
        kind = self.schedule.due(self.motion_base_s + motion_s)
        if kind is None and self.requested:
            kind = 'loop'
        self.requested = False
        if kind is None:
            return None
        self.jobs_made += 1
        return Job(self.jobs_made, t_ns, kind, self.buffer.signals())

    def request(self) -> None:
        """Ask for an analysis (with its residual loop) of the window as it is, at the next whole
        second of data, whatever the schedule says (the schedule goes on as it was)."""
        self.requested = True

    def take(self, outcome: Outcome) -> Finding | None:
        """An outcome whose time has come: its finding (None: keep the last one, and say why)."""
        self.model = outcome.model
        if outcome.finding is None:
            self.why = outcome.why
            return None
        self.finding, self.why = outcome.finding, None
        f = outcome.finding
        if f.explained:
            for key, iv in (('2z', f.two_z), ('zgb', f.z_gb)):
                if iv.lo is not None and iv.hi is not None:
                    self.assessed[key] = (float(iv.value), float(iv.lo), float(iv.hi), int(f.t_ns))
        return outcome.finding

    def restart_stream(self, motion_s: float) -> None:
        """The data time went back: the motion counted so far is kept (the live model starts
        counting again), the window's samples too (they are of the time before)."""
        self.motion_base_s += motion_s

    # --- persistence ---------------------------------------------------------------------
    def save(self, path: str | Path, motion_s: float) -> Path:
        """Write the state atomically (an ``.npz``); ``motion_s``: the motion counted in this
        run. Raises :class:`~steer_monitor.errors.OutputError` naming the path and the
        system's reason."""
        path = Path(path)
        meta = {'version': STATE_VERSION, 'gear': _gear_signature(self.gear),
                'window_motion_s': self.settings.window_motion_s, 'motion_s': self.motion_base_s + motion_s,
                'schedule': self.schedule.to_dict(), 'model': [e.to_json() for e in self.model],
                'finding': None if self.finding is None else self.finding.to_json(),
                'assessed': {k: list(v) for k, v in self.assessed.items()}}
        arrays: dict[str, np.ndarray] = {}
        for name, ser in self.buffer.signals().items():
            arrays[f't_{name}'], arrays[f'v_{name}'] = ser.t_ns, ser.value
        with atomic_write(path, 'wb') as fh:
            np.savez(fh, meta=np.array(json.dumps(meta)), **arrays)
        return path

    def load(self, path: str | Path) -> float:
        """Take the state of :meth:`save` -> the motion counted [s]. Raises
        :class:`~steer_monitor.estimate.observe.EstimateError` naming what does not fit (an
        older format, another gear, a damaged file); the current state is kept."""
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as d:
                meta = json.loads(str(d['meta']))
                arrays = {k: d[k] for k in d.files if k != 'meta'}
        except Exception as exc:   # noqa: BLE001 - numpy's and zipfile's own errors on a damaged file
            msg = f'analysis state {path}: cannot read it ({type(exc).__name__}: {exc})'
            raise EstimateError(msg) from exc
        version = meta.get('version') if isinstance(meta, dict) else None
        if version != STATE_VERSION:
            older = isinstance(version, int) and version < STATE_VERSION
            msg = (f'analysis state {path}: format {version}' + (
                ', written by the estimator this release replaced (binned moments, no data to analyse)'
                if older else '') + f'; this build reads format {STATE_VERSION}')
            raise EstimateError(msg)
        try:
            if not np.allclose(meta['gear'], _gear_signature(self.gear)):
                msg = f'analysis state {path}: learned on another gear geometry; not used'
                raise EstimateError(msg)
            signals = _signals_of(arrays)
            schedule = AnalysisSchedule(self.settings.loop_every_s, self.settings.every_s, self.settings.first_s)
            schedule.restore(meta['schedule'])
            model = tuple(Effect.from_json(e) for e in meta['model'])
            finding = None if meta['finding'] is None else Finding.from_json(meta['finding'])
            motion = float(meta['motion_s'])
            assessed = {str(k): (float(v[0]), float(v[1]), float(v[2]), int(v[3]))
                        for k, v in dict(meta.get('assessed') or {}).items() if k in ('2z', 'zgb')}
            if not (math.isfinite(motion) and motion >= 0):
                msg = f'motion counted {motion!r} s'
                raise ValueError(msg)
        except EstimateError:
            raise
        except (ValueError, TypeError, KeyError) as exc:
            msg = f'analysis state {path}: damaged ({type(exc).__name__}: {exc}); not used'
            raise EstimateError(msg) from exc
        self.buffer.clear()
        self.buffer.load(signals)
        self.schedule, self.model, self.finding, self.motion_base_s = schedule, model, finding, motion
        self.assessed = assessed
        return motion


def _signals_of(arrays: Mapping[str, np.ndarray]) -> dict[str, Series]:
    out: dict[str, Series] = {}
    for key, t in arrays.items():
        if not key.startswith('t_'):
            continue
        name = key[2:]
        if name not in ANALYSED:
            msg = f'samples of an unknown input {name!r}'
            raise ValueError(msg)
        v = arrays.get(f'v_{name}')
        t = np.asarray(t)
        if v is None or t.ndim != 1 or v.shape != t.shape or t.dtype.kind != 'i' or not np.all(np.diff(t) >= 0):
            msg = f'the samples of {name} are not a time series'
            raise ValueError(msg)
        out[name] = Series(t.astype(np.int64), np.asarray(v, float))
    return out


def _gear_signature(gear: GearParams) -> list[float]:
    return [gear.stock_to_ram, gear.bushing_span, gear.ram_outer_diameter, gear.ram_inner_diameter,
            gear.youngs_modulus, gear.guide_beam_inertia, gear.guide_beam_span, gear.bushing_length,
            float(gear.rams), gear.max_rudder]


def describe(finding: Finding) -> str:
    """One line of a finding, for a log or a summary."""
    def mm(iv: Any) -> str:
        if iv.hi is None:
            return f'>= {1e3 * (iv.lo if iv.lo is not None else iv.value):.3f} mm'
        return f'{1e3 * iv.value:.3f} mm [{1e3 * iv.lo:.3f} .. {1e3 * iv.hi:.3f}]'
    return f'2Z {mm(finding.two_z)}, Z_gb {mm(finding.z_gb)} ({finding.kind}, {finding.verdict})'

