"""Where the installed package keeps its data files (config/, DBC) in each layout."""

from __future__ import annotations

import sys
from pathlib import Path

from steer_monitor.errors import ParameterError

__all__ = ['config_dir', 'config_dirs', 'default_config', 'source_dirs']

PACKAGE = 'steer_monitor'


def _candidates() -> list[Path]:
    found: list[Path] = []
    try:  # colcon / ROS 2 install: share/steer_monitor via the ament index
        from ament_index_python.packages import PackageNotFoundError, get_package_share_directory
        try:
            found.append(Path(get_package_share_directory(PACKAGE)) / 'config')
        except (PackageNotFoundError, OSError):  # not in the index, or no AMENT_PREFIX_PATH
            pass
    except ImportError:
        pass
    found.append(Path(sys.prefix) / 'share' / PACKAGE / 'config')  # pip install
    found.append(Path(__file__).resolve().parent.parent / 'config')  # source tree / editable
    return found


def source_dirs() -> list[Path]:
    """The installed package's own directory and, when it runs from a source checkout (an
    editable install: ``package.xml`` and ``setup.py`` beside it), the checkout: no command
    writes into them unasked, whatever its default output."""
    pkg = Path(__file__).resolve().parent
    root = pkg.parent
    out = [pkg]
    if (root / 'package.xml').is_file() and (root / 'setup.py').is_file():
        out.append(root)
    return out


def config_dirs() -> list[Path]:
    """Every existing config directory of the installed package (the ament index's, pip's,
    the source tree's): the files a command must not write over unasked."""
    return [p for p in _candidates() if p.is_dir()]


def config_dir() -> Path:
    """The first existing config directory of the installed package."""
    for path in _candidates():
        if path.is_dir():
            return path
    msg = 'cannot find the steer_monitor config directory (looked in: ' + ', '.join(
        str(p) for p in _candidates()) + ')'
    raise ParameterError(msg)


def default_config(name: str = 'r18.yaml') -> Path:
    """Path of a packaged config file, e.g. the R-18 parameters."""
    for directory in _candidates():
        path = directory / name
        if path.is_file():
            return path
    msg = f'cannot find packaged config file {name!r}'
    raise ParameterError(msg)
