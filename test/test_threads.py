"""One BLAS thread per process (steer_monitor.threads)."""

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
            'from steer_monitor.threads import single_blas_thread\n'
            'single_blas_thread(); single_blas_thread()\n'
            'import steer_monitor.estimate.fit, scipy.linalg\n'
            'blas = [i for i in threadpool_info() if i["user_api"] == "blas"]\n'
            'assert len(blas) >= 2, blas\n'
            'print(sorted({i["num_threads"] for i in blas}))\n')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == '[1]'
