"""Run every benchmark (``make bench``), each in a fresh process so that one's memory does not
count against the next. Benchmarks measure; they are not tests."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BENCHMARKS = ('bench.bench_loadshare', 'bench.bench_decode', 'bench.bench_estimate', 'bench.bench_replay',
              'bench.bench_replay_parts', 'bench.bench_feed', 'bench.bench_twins', 'bench.bench_node',
              'bench.bench_memory', 'bench.bench_analysis_memory', 'bench.bench_fleet')


def main() -> int:
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    failed = 0
    for module in BENCHMARKS:
        result = subprocess.run([sys.executable, '-m', module], cwd=ROOT, env=env)
        failed += result.returncode != 0
        print()
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
