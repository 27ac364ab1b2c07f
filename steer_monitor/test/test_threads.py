"""One BLAS thread per process (steer_monitor.threads)."""

from __future__ import annotations

import subprocess
import sys


def test_single_blas_thread_limits_every_blas_library_and_is_idempotent():
    # in a fresh process: the limit is process-wide and stays for its life
    code = ('import numpy\n'
            'from threadpoolctl import threadpool_info\n'
            'from steer_monitor.threads import single_blas_thread\n'
            'single_blas_thread(); single_blas_thread()\n'
            'blas = [i for i in threadpool_info() if i["user_api"] == "blas"]\n'
            'assert blas, "numpy loaded no BLAS threadpoolctl knows"\n'
            'print(sorted({i["num_threads"] for i in blas}))\n')
    out = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == '[1]'
