"""The libraries carried in ``steer_monitor/_vendor`` are their releases' code, each file as
released but for its absolute imports of itself made relative, with the licence beside it; and
the package uses the carried copy only."""

from __future__ import annotations

import importlib.metadata
import re
from pathlib import Path

import pytest

from steer_monitor._vendor import VENDORED
from test.conftest import PKG

VENDOR = PKG / 'steer_monitor' / '_vendor'


def _relative(text: str, name: str) -> str:
    """``from NAME.x import`` made ``from .x import``, as the vendoring does."""
    return re.sub(rf'^(\s*)from {name}\.', r'\1from .', text, flags=re.M)


@pytest.mark.parametrize('name', sorted(VENDORED))
def test_each_carried_file_is_the_releases_but_for_its_imports(name):
    try:
        dist = importlib.metadata.distribution(name)
    except importlib.metadata.PackageNotFoundError:
        pytest.skip(f'{name} is not installed here to compare with (make venv installs it)')
    assert dist.version == VENDORED[name], f'installed {name} {dist.version}, carried {VENDORED[name]}: take the new ' \
                                           f'release into steer_monitor/_vendor or pin the carried one'
    released = {Path(f.name).name: f for f in dist.files or [] if f.parts[0] == name and f.suffix in ('.py', '.typed')}
    carried = {p.name: p for p in (VENDOR / name).iterdir() if p.suffix in ('.py', '.typed')}
    assert set(carried) == set(released)
    changed = []
    for file, ref in sorted(released.items()):
        original = Path(dist.locate_file(ref)).read_text(encoding='utf-8')
        ours = carried[file].read_text(encoding='utf-8')
        assert ours == _relative(original, name), file
        changed += [file] if ours != original else []
    assert changed == ['exceptions.py']         # its one absolute import of itself
    licence = (VENDOR / name / 'LICENSE').read_text(encoding='utf-8')
    assert licence.startswith('MIT License') and 'Permission is hereby granted' in licence


def test_the_package_imports_only_the_carried_copy():
    """No module of the package imports the installed ``mcap`` (on a vessel there is none)."""
    import ast
    found = []
    for path in sorted((PKG / 'steer_monitor').rglob('*.py')):
        if VENDOR in path.parents:
            continue
        for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module] if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module else [])
            found += [f'{path.relative_to(PKG)}: {n}' for n in names if n.split('.')[0] in VENDORED]
    assert found == []


def test_the_licence_is_installed_with_the_package():
    setup = (PKG / 'setup.py').read_text(encoding='utf-8')
    assert "package_data={f'{PACKAGE}._vendor.mcap': ['LICENSE', 'py.typed']}" in setup
