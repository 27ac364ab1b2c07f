"""A log's report page from its batch-path review: what ``steer-monitor report`` writes, and
what the fleet writes beside each log's result (:mod:`steer_monitor.ashore.logresult`).

The review is made once by the caller (:func:`~steer_monitor.ashore.batchpath.review_logs`); this
module gathers what the page shows around it (the parameters, the clearances a node
published when the inputs are its recordings) and writes it.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from steer_monitor.atomic import os_reason
from steer_monitor.errors import OutputError
from steer_monitor.monitor.messages import CLEARANCE_NAMES

__all__ = ['published_track', 'remove_report_debris', 'report_input', 'write_report_dir']


def published_track(paths: Sequence[Path]) -> Any:
    """The clearances a node published (``*/clearances``) in MCAP inputs, as an
    :class:`~steer_monitor.ashore.report.reviewpage.PublishedTrack`, or None."""
    import numpy as np
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    from steer_monitor.ashore.report.reviewpage import PublishedTrack
    from steer_monitor.logfiles.mcapcols import mcap_chunks_within_limits

    rows: list[tuple[int, list[float]]] = []
    for path in paths:
        # mcap's reader inflates a chunk to the size it declares: not a file with one beyond
        # what a chunk may hold (the frames' reader has said it is corrupt)
        if Path(path).suffix.lower() != '.mcap' or not mcap_chunks_within_limits(path):
            continue
        try:
            with open(path, 'rb') as fh:
                reader = make_reader(fh, validate_crcs=True, decoder_factories=[DecoderFactory()])
                summary = reader.get_summary()
                topics = [c.topic for c in summary.channels.values() if c.topic.endswith('/clearances')] \
                    if summary is not None else []
                if not topics:
                    continue
                for _, _, message, msg in reader.iter_decoded_messages(topics=topics):
                    values = _clearance_values(msg)
                    if values is not None:
                        rows.append((message.log_time, values))
        except Exception:   # a recording cut short has no summary: the plot goes without it
            continue
    if not rows:
        return None
    rows.sort(key=lambda r: r[0])
    t = np.array([r[0] for r in rows], np.int64)
    d = np.array([r[1] for r in rows], float)
    return PublishedTrack(t, *(d[:, k] for k in range(6)))


def _clearance_values(msg: Any) -> list[float] | None:
    """2Z, its low and high bound, Z_gb, its bounds [m] (NaN: none) from a ``~/clearances``
    message: named values in a ``sensor_msgs/JointState`` (this release's and the first
    releases'), an earlier release's ``steer_monitor_msgs/Clearances`` (decoded from the schema
    its recording carries) or labelled ``std_msgs/Float64MultiArray``; None for anything else."""
    two_z, z_gb = getattr(msg, 'gap_2z_m', None), getattr(msg, 'gap_zgb_m', None)
    if two_z is not None and z_gb is not None:
        return [float(v) for e in (two_z, z_gb) for v in (e.value, e.lo, e.hi)]
    names = getattr(msg, 'name', None)
    if names is not None:
        by_name = dict(zip(names, getattr(msg, 'position', [])))
        if all(k in by_name for k in CLEARANCE_NAMES):
            return [float(by_name[k]) for k in CLEARANCE_NAMES]
        return None
    layout = getattr(msg, 'layout', None)
    dims = layout.dim if layout is not None else []
    if dims and dims[0].label == ','.join(CLEARANCE_NAMES) and len(msg.data) == 6:
        return [float(v) for v in msg.data]
    return None


def report_input(paths: Sequence[Path], batch: Any, params: dict[str, Any], config_path: str | Path,
                 analysis: Any, analysis_note: str) -> Any:
    """The page's input for ``paths`` reviewed as ``batch`` (a
    :class:`~steer_monitor.ashore.batchpath.BatchRun`) with these parameters; ``analysis``: the model
    check (None, and ``analysis_note`` says why)."""
    from steer_monitor.ashore.report.reviewpage import ReportInput
    from steer_monitor.params import gear_from_params
    from steer_monitor.record.provenance import parameters_digest

    return ReportInput(', '.join(Path(p).name for p in paths), gear_from_params(params), batch.review, analysis,
                       analysis_note, published_track(paths), batch.frames, batch.rejects, batch.errors,
                       params['clearances.limit_2z_mm'] * 1e-3, params['clearances.limit_zgb_mm'] * 1e-3,
                       params['diagnostics.solas_hard_over_s'], params['hydraulics.pumps'],
                       params['hydraulics.ram_speed_per_pump_mm_s'] * 1e-3, params['diagnostics.clearance_warn_share'],
                       params['node.hardware_id'], params['gear.name'], str(config_path), parameters_digest(params))


def _temp_dir(out_dir: Path, pid: int | str) -> Path:
    return out_dir.with_name(f'.{out_dir.name}.{pid}.tmp')


def remove_report_debris(out_dir: str | Path) -> int:
    """Remove what writers of the page ``out_dir`` killed mid-write left beside it (their
    temporary directories); call it only when no writer of that page is running. Returns how
    many were removed."""
    out_dir = Path(out_dir)
    n = 0
    for tmp in out_dir.parent.glob(_temp_dir(out_dir, '*').name):
        if tmp.is_dir():
            shutil.rmtree(tmp, ignore_errors=True)
            n += 1
    return n


def write_report_dir(inp: Any, out_dir: str | Path) -> Path:
    """Write the page into ``out_dir`` whole or not at all: into a temporary directory beside
    it, then renamed (an earlier page there is replaced). For pages many workers write into
    one tree, where a worker that dies must not leave half a page behind. Returns the page."""
    from steer_monitor.ashore.report.reviewpage import write_review_report

    out_dir = Path(out_dir)
    tmp = _temp_dir(out_dir, os.getpid())
    try:
        out_dir.parent.mkdir(parents=True, exist_ok=True)
        shutil.rmtree(tmp, ignore_errors=True)
        write_review_report(inp, tmp)
        if out_dir.exists():
            shutil.rmtree(out_dir)
        os.replace(tmp, out_dir)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        msg = f'cannot write the report {out_dir}: {os_reason(exc)}'
        raise OutputError(msg) from exc
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    return out_dir / 'index.html'
