"""Which OS packages the distributions ROS 2 Jazzy and Kilted run on carry, for the packaging
test: ``python -m test.support.aptindex`` reads each distribution's package lists from its
archive (network) and writes :data:`SNAPSHOT`, for every OS package the rosdep keys of
package.xml (and :data:`ALSO`) name there, whether the distribution has it and its version.

Run it again when package.xml names a new key: the test fails on a package it does not find in
the snapshot, saying so."""

from __future__ import annotations

import datetime
import lzma
import sys
import urllib.request
from pathlib import Path

import yaml

__all__ = ['ALSO', 'DISTRIBUTIONS', 'SNAPSHOT', 'apt_names', 'load_snapshot', 'resolve']

ROOT = Path(__file__).resolve().parents[2]
SNAPSHOT = ROOT / 'test' / 'data' / 'apt-packages.yaml'
#: (os, codename) -> the archive's Packages lists (amd64): ROS 2 Jazzy and Kilted's Ubuntu 24.04
#: (their tier 1), Debian 12 (Jazzy's tier 3) and 13 (Kilted's)
DISTRIBUTIONS = {
    ('ubuntu', 'noble'): [f'http://archive.ubuntu.com/ubuntu/dists/{suite}/{part}/binary-amd64/Packages.xz'
                          for suite in ('noble', 'noble-updates') for part in ('main', 'universe')],
    ('debian', 'bookworm'): ['https://deb.debian.org/debian/dists/bookworm/main/binary-amd64/Packages.xz'],
    ('debian', 'trixie'): ['https://deb.debian.org/debian/dists/trixie/main/binary-amd64/Packages.xz'],
}
#: looked up too, though package.xml does not name them (what an optional dependency would need)
ALSO = ('python3-numba', 'python3-cantools', 'python3-mcap', 'python3-rosbags')


def resolve(rule: object, codename: str) -> list[str] | str | None:
    """A rosdep rule of one OS for ``codename``: the OS packages it installs, ``'pip'`` when it
    installs from pip, None when it installs nothing there."""
    if isinstance(rule, list):
        return [str(x) for x in rule]
    if isinstance(rule, dict):
        if 'pip' in rule:
            return 'pip'
        if 'apt' in rule:
            return resolve(rule['apt'], codename)
        if 'packages' in rule:
            return resolve(rule['packages'], codename)
        for key in (codename, '*'):
            if key in rule:
                return resolve(rule[key], codename)
        return None
    return None


def apt_names(keys: dict[str, dict], wanted: list[str]) -> set[str]:
    """Every OS package the rosdep ``keys`` named in ``wanted`` install on the distributions."""
    names: set[str] = set()
    for key in wanted:
        for (os_name, codename) in DISTRIBUTIONS:
            got = resolve(keys.get(key, {}).get(os_name), codename)
            if isinstance(got, list):
                names |= set(got)
    return names


def load_snapshot() -> dict[str, dict[str, str | None]]:
    """``'os codename'`` -> package -> version (None: the distribution does not have it)."""
    return yaml.safe_load(SNAPSHOT.read_text(encoding='utf-8'))['packages']


def _versions(urls: list[str]) -> dict[str, str]:
    found: dict[str, str] = {}
    for url in urls:
        with urllib.request.urlopen(url, timeout=120) as r:    # noqa: S310 (the distributions' archives)
            text = lzma.decompress(r.read()).decode('utf-8', 'replace')
        name = None
        for line in text.splitlines():
            if line.startswith('Package: '):
                name = line[9:].strip()
            elif line.startswith('Version: ') and name is not None:
                found.setdefault(name, line[9:].strip())
    return found


def main() -> int:
    from test.test_packaging import all_keys, declared_keys
    keys = all_keys()
    names = sorted(apt_names(keys, declared_keys()) | set(ALSO))
    packages = {}
    for (os_name, codename), urls in DISTRIBUTIONS.items():
        versions = _versions(urls)
        packages[f'{os_name} {codename}'] = {n: versions.get(n) for n in names}
    doc = {'read': datetime.date.today().isoformat(), 'from': {f'{o} {c}': u for (o, c), u in DISTRIBUTIONS.items()},
           'packages': packages}
    SNAPSHOT.write_text('# written by python -m test.support.aptindex: do not edit\n'
                        + yaml.safe_dump(doc, sort_keys=True, width=200), encoding='utf-8')
    print(f'{SNAPSHOT}: {len(names)} packages on {len(packages)} distributions')
    return 0


if __name__ == '__main__':
    sys.exit(main())
