"""Run every benchmark (``make bench``). Benchmarks measure; they are not tests."""

from __future__ import annotations

import os
import sys
from pathlib import Path

os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from bench import bench_decode, bench_loadshare, bench_node  # noqa: E402

BENCHMARKS = (bench_loadshare, bench_decode, bench_node)


def main() -> int:
    for bench in BENCHMARKS:
        bench.main()
        print()
    return 0


if __name__ == '__main__':
    sys.exit(main())
