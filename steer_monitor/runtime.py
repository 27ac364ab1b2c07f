"""One BLAS thread per process.

The estimator's linear algebra is many small systems: per row of the clearance grid a batch
of normal equations of ~40 unknowns. OpenBLAS's second thread gives no speed there and
doubles the CPU it takes (its threads spin between calls). Measured on a full profile of the
estimator after 300 s of the voyage programme, three runs each:
0.84-0.93 s wall and 1.53-1.68 s CPU with two threads, 0.85-0.96 s wall and 0.85-0.96 s CPU
with one. One thread also makes an analysis's sums come in one order, so the node's worker
and a replay give the same finding to the bit. The node,
the CLI and the batch path's processes call :func:`single_blas_thread` at start, so the other
core stays free for the CAN reader, the DDS threads or the log reader.

Beside it, the process's other run-time settings: memory freed back to the system
(:func:`release_freed_memory`) and the cycle collector run less often over a long batch of work
that makes no reference cycles (:func:`fewer_collections`).
"""

from __future__ import annotations

import gc
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ['COLLECT_EVERY', 'fewer_collections', 'release_freed_memory', 'single_blas_thread']

#: container objects allocated (net) between two young collections within :func:`fewer_collections`
#: (Python's default: 700)
COLLECT_EVERY = 100_000

_limiter: object | None = None


def single_blas_thread() -> bool:
    """Limit the BLAS libraries numpy and scipy loaded to one thread, for the rest of the
    process (idempotent). Returns whether it could: threadpoolctl is optional (rosdep has no
    key for it; without it the answers are the same, the estimator's CPU up to double)."""
    global _limiter
    if _limiter is None:
        try:
            from threadpoolctl import threadpool_limits
        except ImportError:
            _limiter = False
        else:
            # the limit holds for the libraries loaded when it is set: load numpy's and
            # scipy's BLAS first (a process that had not imported them kept two threads)
            import numpy  # noqa: F401
            import scipy.linalg  # noqa: F401
            _limiter = threadpool_limits(limits=1, user_api='blas')
    return _limiter is not False


_trim: object | None = None


def release_freed_memory() -> bool:
    """Give the memory freed since the last call back to the system (glibc's ``malloc_trim``);
    False where there is none (another C library: a no-op).

    An analysis allocates a few hundred MB of arrays on the node's worker thread and frees them
    at its end, but glibc keeps what a thread's arena freed for the next allocation: the node's
    resident memory stayed at each analysis's peak and grew with the largest (307 to 459 MB
    over a 10-minute voyage, ``bench_node voyage``). Measured on four analyses of a 25-minute
    voyage on a worker thread: 394 MB resident after each without it, 195 MB with it.

    Objects in a reference cycle are freed only when Python's cycle collector runs, which it
    does on counts of container objects allocated, not of bytes: a cycle that holds an
    analysis's arrays (one held the fitters and their moments, 100-350 MB, until fixed) could
    outlive many analyses. So the collector runs first (about 35 ms of the interpreter's lock
    in the node's process, once per analysis)."""
    import gc
    gc.collect()
    global _trim
    if _trim is None:
        try:
            import ctypes
            _trim = ctypes.CDLL('libc.so.6').malloc_trim
        except (OSError, AttributeError):
            _trim = False
    if _trim is False:
        return False
    _trim(0)       # type: ignore[operator]
    return True


@contextmanager
def fewer_collections(every: int = COLLECT_EVERY) -> Iterator[None]:
    """Within the block, Python's cycle collector looks at young objects once per ``every``
    container objects allocated instead of 700; the thresholds before it are put back after.

    A replay makes short-lived tuples and lists by the million and no reference cycles (none
    found by a full collection after an hour's replay), so the collections only cost: with
    the default, 161 young and 14 older ones took 0.09 s of an hour's replay (counted by
    collector callbacks), each walking the long lists of numbers a run of frames is laid
    out in; with 100,000, none in the hour. Cycles are still collected, a hundred times
    less often."""
    before = gc.get_threshold()
    gc.set_threshold(every, *before[1:])
    try:
        yield
    finally:
        gc.set_threshold(*before)
