"""Every relative link of the README and docs/ resolves from the file it is written in."""

from __future__ import annotations

import re

import pytest

from test.conftest import ROOT

PAGES = [ROOT / 'README.md', *sorted((ROOT / 'docs').glob('*.md'))]
LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')


@pytest.mark.parametrize('page', PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_relative_link_resolves(page):
    broken = []
    for m in LINK.finditer(page.read_text(encoding='utf-8')):
        target = m.group(1).split('#')[0]
        if not target or re.match(r'^[a-z]+:', target):
            continue
        if not (page.parent / target).exists():
            broken.append(m.group(1))
    assert broken == [], f'{page.name}: links that do not resolve from {page.parent}: {broken}'


def test_the_link_pattern_finds_a_broken_link(tmp_path):
    page = tmp_path / 'x.md'
    page.write_text('see [the docs](docs/nowhere.md) and [web](https://example.com)\n')
    assert [m.group(1) for m in LINK.finditer(page.read_text())] == ['docs/nowhere.md', 'https://example.com']
    assert not (page.parent / 'docs/nowhere.md').exists()
