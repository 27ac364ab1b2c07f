"""Entry point of ``steer-monitor``: parse arguments, dispatch, turn errors into messages."""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading
from collections.abc import Sequence

from steer_monitor import __version__
from steer_monitor.atomic import command_scope
from steer_monitor.compiled import interpreted_note
from steer_monitor.errors import SteerMonitorError
from steer_monitor.runtime import single_blas_thread

__all__ = ['Terminated', 'build_parser', 'main']

#: the subcommands, each a module of this package with ``register`` and ``run``, in help order
SUBCOMMANDS = ('fit', 'backlash', 'loadshare', 'simulate', 'discover', 'inspect', 'analyze', 'accuracy', 'run',
               'replay', 'report', 'fleet', 'recover', 'study', 'demo')


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The parser of every subcommand, or only of ``command`` (what :func:`main` runs: a
    command imports only what it needs; ``inspect`` does not load the estimator's compiled
    solver, which ``fit``'s module would, about 70 MB)."""
    parser = argparse.ArgumentParser(
        prog='steer-monitor',
        description='Condition monitor for ram-type (Rapson-slide) hydraulic steering gear.')
    parser.add_argument('--version', action='version', version=f'%(prog)s {__version__}')
    sub = parser.add_subparsers(dest='command', required=True, metavar='COMMAND')
    for name in SUBCOMMANDS if command not in SUBCOMMANDS else (command,):
        importlib.import_module(f'steer_monitor.cli.{name}').register(sub)
    return parser


def _command_of(argv: Sequence[str]) -> str | None:
    """The subcommand ``argv`` names (its first word not an option), or None."""
    return next((a for a in argv if not a.startswith('-')), None)


def _one_line(text: str) -> str:
    return ' '.join(str(text).split()) or '(no message)'


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, so that it ends as on Ctrl-C: outputs not yet
    complete removed (their temporary names), worker processes ended, one line said."""


def _terminate(signum: int, frame: object) -> None:
    raise Terminated


#: commands that run the model or the estimator's compiled loops (the others never wait on them;
#: the node says for itself what it does without numba)
COMPUTING = frozenset({'loadshare', 'analyze', 'accuracy', 'replay', 'report', 'fleet', 'study'})

#: commands that handle SIGTERM themselves (rclpy's handlers stop the node, which finishes
#: its recording)
OWN_SIGTERM = frozenset({'run', 'demo'})


def main(argv: Sequence[str] | None = None) -> int:
    """Run one subcommand. Every failure is one line on stderr and exit status 1 (argparse's
    usage errors: 2); never a traceback. SIGTERM ends a command as Ctrl-C does (status 143)."""
    words = list(sys.argv[1:] if argv is None else argv)
    parser = build_parser(_command_of(words))
    args = parser.parse_args(words)
    if getattr(args, 'node', None) is not None:
        if not args.config:
            parser.error('--node NAME names an entry of the file --config gives')
        from steer_monitor.params import ParamsFile  # here: numpy and the model load with it
        args.config = ParamsFile(args.config, args.node)
    single_blas_thread()
    where = f'steer-monitor {args.command}'
    if args.command in COMPUTING and (note := interpreted_note()) is not None:
        print(f'{where}: note: {note}', file=sys.stderr)
    ours = args.command not in OWN_SIGTERM and threading.current_thread() is threading.main_thread()
    previous = signal.signal(signal.SIGTERM, _terminate) if ours else None
    try:
        return _dispatch(args, where)
    finally:
        if ours:       # None: a handler not set from Python, which cannot be put back: the default
            signal.signal(signal.SIGTERM, signal.SIG_DFL if previous is None else previous)


def _dispatch(args: argparse.Namespace, where: str) -> int:
    try:
        with command_scope(force=bool(getattr(args, 'force', False))):
            return int(args.handler(args))
    except SteerMonitorError as exc:
        print(f'{where}: error: {_one_line(str(exc))}', file=sys.stderr)
        return 1
    except BrokenPipeError:  # e.g. piped into head: not an error of ours
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Terminated:
        print(f'{where}: terminated (SIGTERM)', file=sys.stderr)
        return 128 + signal.SIGTERM
    except KeyboardInterrupt:
        print(f'{where}: interrupted', file=sys.stderr)
        return 130
    except OSError as exc:     # a path the command did not convert itself
        name = exc.filename if exc.filename is not None else ''
        print(f'{where}: error: {name}{": " if name else ""}{_one_line(exc.strerror or str(exc))}', file=sys.stderr)
        return 1
    except MemoryError:
        print(f'{where}: error: out of memory (the input is larger than this machine can hold)', file=sys.stderr)
        return 1
    except Exception as exc:  # a defect of ours: still one line, and say so
        print(f'{where}: error: internal error, please report it: {type(exc).__name__}: {_one_line(str(exc))}',
              file=sys.stderr)
        return 1


if __name__ == '__main__':
    sys.exit(main())
