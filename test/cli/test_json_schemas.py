"""Every command's ``--json`` against its schema (docs/schemas/) and the vocabulary's rules
(docs/json.md), on real outputs: a simulated voyage through every command."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from steer_monitor.cli.main import main
from test.conftest import PKG

SCHEMAS = PKG / 'docs' / 'schemas'
COMMANDS = ('fit', 'backlash', 'loadshare', 'simulate', 'truth', 'discover', 'inspect', 'analyze', 'replay', 'report',
            'recover', 'fleet', 'fleet-json', 'accuracy')


@pytest.fixture(scope='module')
def outputs(tmp_path_factory) -> dict[str, Any]:
    """Each command's JSON on a 6-minute simulated voyage (manoeuvres, a hard-over, zigzags)."""
    d = tmp_path_factory.mktemp('json')
    log = d / 'v.log'
    got: dict[str, Any] = {}

    def run(name: str, argv: list[str], capsys_out: Path | None = None) -> None:
        import contextlib
        import io
        buf = io.StringIO()
        with contextlib.redirect_stdout(buf), contextlib.redirect_stderr(io.StringIO()):
            rc = main(argv)
        assert rc == 0, (name, rc)
        got[name] = json.loads(capsys_out.read_text() if capsys_out is not None else buf.getvalue())

    run('simulate', ['simulate', '--program', 'hard_over_2,zigzag_10', '--seed', '3', '--out', str(log), '--json', '-'])
    got['truth'] = json.loads((d / 'v.truth.json').read_text())
    run('fit', ['fit', '240 H9/f9', '--json', '-'])
    run('backlash', ['backlash', str(PKG / 'config' / 'r18_chain.yaml'), '--angle-deg', '20', '--limit-arcmin', '8',
                     '--json', '-'])
    run('loadshare', ['loadshare', '--json', '-'])
    run('discover', ['discover', str(log), '--json', '-'])
    run('inspect', ['inspect', str(log), '--json', '-'])
    run('analyze', ['analyze', str(log), '--json', str(d / 'a.json')], d / 'a.json')
    run('replay', ['replay', str(log), '--out', str(d / 'r.mcap'), '--json', '-'])
    run('report', ['report', str(d / 'r.mcap'), '--out', str(d / 'rep'), '--json', '-'])
    run('recover', ['recover', str(d / 'r.mcap'), '--out', str(d / 'rr.mcap'), '--json', '-'])
    (d / 'fleet' / 'mv').mkdir(parents=True)
    (d / 'fleet' / 'mv' / 'v.log').symlink_to(log)
    run('fleet', ['fleet', str(d / 'fleet' / 'mv'), '--out', str(d / 'fl'), '--workers', '1', '--json', '-',
                  '--no-reports'])
    got['fleet-json'] = json.loads((d / 'fl' / 'fleet.json').read_text())
    run('accuracy', ['accuracy', '--programmes', 'manoeuvres', '--grid-2z-mm', '0.1', '--grid-zgb-mm', '0.2',
                     '--jobs', '1', '--out', str(d / 'acc.md'), '--json', '-'])
    return got


def _validator(name: str):
    import jsonschema
    from referencing import Registry, Resource
    registry = Registry().with_resources(
        (p.name, Resource.from_contents(json.loads(p.read_text()))) for p in SCHEMAS.glob('*.schema.json'))
    schema = json.loads((SCHEMAS / f'{name}.schema.json').read_text())
    return jsonschema.Draft202012Validator(schema, registry=registry)


@pytest.mark.parametrize('name', COMMANDS)
def test_each_commands_json_validates_against_its_schema(outputs, name):
    errors = sorted(_validator(name).iter_errors(outputs[name]), key=lambda e: list(e.path))
    assert not errors, [f'{"/".join(map(str, e.path))}: {e.message}' for e in errors[:5]]


def test_a_schema_catches_a_changed_shape(outputs):
    """The schemas are not vacuous: a renamed key, a bare number for an estimate, a lower
    bound with a point value and a time in another spelling are each refused."""
    v = _validator('analyze')
    good = outputs['analyze']
    renamed = {('gap_2z_mm' if k == 'clearance_2z_mm' else k): x for k, x in good.items()}
    bare = {**good, 'k_gl_max': 0.59}
    pointed = {**good, 'clearance_2z_mm': {'value': 0.22, 'ci95': [0.197, None], 'bounded': False}}
    for bad in (renamed, bare, pointed):
        assert list(v.iter_errors(bad)), bad
    i = _validator('inspect')
    assert list(i.iter_errors({**outputs['inspect'], 'start_utc': '2026-01-01T00:00:00+00:00'}))


def _walk(x: Any, path: str, out: list[str]) -> None:
    if isinstance(x, dict):
        if 'ci95' in x:
            extra = {'level', 'note', 'limit_mm', 'at_range_edge', 'observable_to_mm'}
            if (set(x) - extra != {'value', 'ci95', 'bounded'}
                    or len(x['ci95']) != 2 or ('level' not in x and {'note', 'limit_mm', 'observable_to_mm'} & set(x))):
                out.append(f'{path}: an estimate is {{value, ci95, bounded, level?, note?, limit_mm?, at_range_edge?, '
                           'observable_to_mm?}}'
                           f', not {sorted(x)}')
            elif not x['bounded'] and x['value'] is not None:
                out.append(f'{path}: a bound has no point value')
        for k, v in x.items():
            p = f'{path}.{k}'
            if k.endswith('_kn') and 'speed' not in k and k not in ('min_kn', 'max_kn'):
                out.append(f'{p}: _kn is knots only')
            if re.fullmatch(r'(\w+_)?(start|end|first|last|before|after|until)_ns', k) and k[:-3] + '_utc' not in x:
                out.append(f'{p}: a time is *_utc and *_ns')
            if k in ('start', 'end', 'first', 'last', 'min', 'max') and 'unit' not in x:
                out.append(f'{p}: a value without its unit')
            _walk(v, p, out)
    elif isinstance(x, list):
        if x and all(isinstance(e, list) for e in x):
            out.append(f'{path}: tuples where labelled objects belong')
        for i, e in enumerate(x):
            _walk(e, f'{path}[{i}]', out)
    elif isinstance(x, float) and len(repr(abs(x)).replace('.', '').lstrip('0').split('e')[0]) > 9:
        out.append(f'{path}: {x!r} carries more digits than it means')


@pytest.mark.parametrize('name', COMMANDS)
def test_each_commands_json_follows_the_vocabulary(outputs, name):
    problems: list[str] = []
    _walk(outputs[name], name, problems)
    assert not problems, sorted(set(re.sub(r'\[\d+\]', '[]', p) for p in problems))[:10]
