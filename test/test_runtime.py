"""One BLAS thread per process (steer_monitor.runtime)."""

from __future__ import annotations

import subprocess
import sys

import pytest


@pytest.mark.parametrize('first', ['', 'import numpy\n'])
def test_single_blas_thread_limits_every_blas_library_and_is_idempotent(first):
    """In a fresh process (the limit is process-wide and stays for its life), called before
    numpy is imported or after: numpy's and scipy's BLAS both keep one thread, scipy's too
    when the estimator loads it later (the limit holds for the libraries loaded when it is
    set; called first, it once limited none)."""
    code = (first + 'from threadpoolctl import threadpool_info\n'
            'from steer_monitor.runtime import single_blas_thread\n'
            'single_blas_thread(); single_blas_thread()\n'
            'import steer_monitor.estimate.fit, scipy.linalg\n'
            'blas = [i for i in threadpool_info() if i["user_api"] == "blas"]\n'
            'assert len(blas) >= 2, blas\n'
            'print(sorted({i["num_threads"] for i in blas}))\n')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == '[1]'


def test_fewer_collections_raises_the_young_threshold_and_puts_it_back():
    """Within the block the young generation is collected once per COLLECT_EVERY container
    objects; after it, on a normal exit or an exception, the thresholds are those before."""
    import gc

    from steer_monitor.runtime import COLLECT_EVERY, fewer_collections

    before = gc.get_threshold()
    try:
        gc.set_threshold(321, 7, 9)
        with fewer_collections():
            assert gc.get_threshold() == (COLLECT_EVERY, 7, 9)
        assert gc.get_threshold() == (321, 7, 9)
        with pytest.raises(RuntimeError, match='inside'), fewer_collections(5000):
            assert gc.get_threshold() == (5000, 7, 9)
            raise RuntimeError('inside')
        assert gc.get_threshold() == (321, 7, 9)
    finally:
        gc.set_threshold(*before)


def test_a_replay_makes_no_reference_cycles(tmp_path):
    """What fewer_collections relies on around a replay: a minute of a voyage replayed leaves
    nothing for a full collection to find (cycles would wait for the rarer collections)."""
    import gc

    from steer_monitor import sim
    from steer_monitor.ashore.replay import replay
    from steer_monitor.can.busconfig import can_setup
    from steer_monitor.logfiles.logs import write_candump
    from steer_monitor.params import load_params_file
    from steer_monitor.resources import default_config

    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    fa = sim.run(params, sim.SimConfig(program='voyage', max_duration_s=90.0), db, smap, seed=3).frames
    log = tmp_path / 'voyage.log'
    with open(log, 'wb') as fh:
        write_candump(fh, fa)
    replay([log], tmp_path / 'warm.mcap', estimator=False)      # first use: imports, compiled kernels
    gc.collect()
    was = gc.isenabled()
    gc.disable()
    try:
        replay([log], tmp_path / 'out.mcap', estimator=False)
        assert gc.collect() == 0
    finally:
        if was:
            gc.enable()
