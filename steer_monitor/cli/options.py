"""Options several commands share, declared once: the parameters file, ``--json`` and
``--force``."""

from __future__ import annotations

import argparse

from steer_monitor.logfiles.formats import formats_text

__all__ = ['CONFIG_HELP', 'LOG_FORMATS', 'add_config_option', 'add_force_option', 'add_json_option']

#: the logs every command reads, in the help's words
LOG_FORMATS = formats_text()

#: what ``--config`` means in every command; a command adds what its default is, when it differs
CONFIG_HELP = 'ROS 2 parameters file of the gear (default: the packaged R-18, config/r18.yaml)'


def add_config_option(parser: argparse.ArgumentParser, default: str | None = None, role: str | None = None) -> None:
    """``--config FILE``: the parameters file. ``default`` replaces the default's words (e.g.
    replay: the parameters recorded in an MCAP); ``role`` says what else the command does with
    it (e.g. discover: which file ``--write-config`` starts from)."""
    text = CONFIG_HELP if default is None else f'ROS 2 parameters file of the gear (default: {default})'
    if role:
        text = f'{text}; {role}'
    parser.add_argument('--config', metavar='FILE', help=text)
    parser.add_argument('--node', metavar='NAME',
                        help="whose entry of the parameters file to read (default: steer_monitor's, else the file's "
                             'only node: a vessel file for port_gear reads as it is)')


def add_force_option(parser: argparse.ArgumentParser) -> None:
    """``--force``: let an output replace a file the command reads or a packaged file (refused
    otherwise, with one line saying which)."""
    parser.add_argument('--force', action='store_true',
                        help='write an output even over a file this command reads or a file of the installed package')


def add_json_option(parser: argparse.ArgumentParser, what: str = 'the answer') -> None:
    """``--json OUT``: ``what`` as JSON (docs/json.md) written to the file ``OUT``, or to
    stdout for ``-`` (then the words for people are left out). The same on every command."""
    parser.add_argument('--json', dest='json_out', metavar='OUT',
                        help=f"write {what} as JSON to OUT ('-': stdout, instead of the text)")
