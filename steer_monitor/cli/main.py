"""Entry point of ``steer-monitor``: parse arguments, dispatch, turn errors into messages."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from steer_monitor import __version__
from steer_monitor.cli import (accuracy, analyze, backlash, demo, fit, inspect, loadshare, recover, replay, report,
                               run, simulate, study)
from steer_monitor.errors import SteerMonitorError
from steer_monitor.threads import single_blas_thread

__all__ = ['build_parser', 'main']

SUBCOMMANDS = (fit, backlash, loadshare, simulate, inspect, analyze, accuracy, run, replay, report, recover, study, demo)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='steer-monitor',
        description='Condition monitor for ram-type (Rapson-slide) hydraulic steering gear.')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    for module in SUBCOMMANDS:
        module.register(sub)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    single_blas_thread()
    try:
        return int(args.handler(args))
    except SteerMonitorError as exc:
        print(f'steer-monitor {args.command}: error: {exc}', file=sys.stderr)
        return 1
    except BrokenPipeError:  # e.g. piped into head: not an error of ours
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except KeyboardInterrupt:
        print(f'steer-monitor {args.command}: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
