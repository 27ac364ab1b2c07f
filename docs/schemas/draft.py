"""Draft a command's JSON Schema from real outputs: ``python docs/schemas/draft.py NAME OUT.json...``.

The schemas in this directory were drafted by this (genson, from the outputs of the command on
simulated voyages) and then read by hand; the vocabulary's shapes (an estimate, a time) are
referenced from ``vocabulary.schema.json`` rather than repeated. Re-draft when a command's JSON
changes on purpose, and read the difference.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from genson import SchemaBuilder

HERE = Path(__file__).resolve().parent
ESTIMATE = {'value', 'ci95', 'bounded'}


def _refine(node: Any) -> Any:
    """Estimates and times by reference to the vocabulary; objects keep their keys required."""
    if isinstance(node, dict):
        props = node.get('properties')
        if isinstance(props, dict) and ESTIMATE <= set(props) and set(props) <= ESTIMATE | {'level'}:
            return {'$ref': 'vocabulary.schema.json#/$defs/estimate_with_level' if 'level' in props
                    else 'vocabulary.schema.json#/$defs/estimate'}
        out = {k: _refine(v) for k, v in node.items()}
        if isinstance(props, dict):
            for key in list(out['properties']):
                if key.endswith('_date_utc'):
                    out['properties'][key] = {'$ref': 'vocabulary.schema.json#/$defs/date'}
                elif key.endswith('_utc'):
                    out['properties'][key] = {'$ref': 'vocabulary.schema.json#/$defs/utc'}
        return out
    if isinstance(node, list):
        return [_refine(v) for v in node]
    return node


def draft(name: str, outputs: list[Path]) -> dict[str, Any]:
    builder = SchemaBuilder('https://json-schema.org/draft/2020-12/schema')
    for path in outputs:
        builder.add_object(json.loads(path.read_text(encoding='utf-8')))
    schema = _refine(builder.to_schema())
    schema['title'] = f'steer-monitor {name} --json'
    schema['$id'] = f'{name}.schema.json'
    return schema


if __name__ == '__main__':
    name, *files = sys.argv[1:]
    (HERE / f'{name}.schema.json').write_text(json.dumps(draft(name, [Path(f) for f in files]), indent=1) + '\n')
