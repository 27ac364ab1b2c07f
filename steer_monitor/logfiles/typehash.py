"""ROS 2 type hashes (REP-2011's ``RIHS01_``), as rosbag2 writes them beside each topic
(``topic_type_hash``), from the concatenated ``ros2msg`` text the MCAP schemas hold. Pure.

The hash is the SHA-256 of the type's description in JSON (its fields, each with its type id,
array capacity, string bound and nested type name; then every type it refers to, sorted by
name), written as rosidl writes it (``rosidl_generator_type_description``). Constants and
default values are not part of it.
"""

from __future__ import annotations

import hashlib
import json
import re
from typing import Any

#: the line between the types of a concatenated definition
SEPARATOR = '=' * 80

__all__ = ['SEPARATOR', 'type_hash']

# type_description_interfaces/msg/FieldType
_IDS = {'int8': 2, 'uint8': 3, 'int16': 4, 'uint16': 5, 'int32': 6, 'uint32': 7, 'int64': 8, 'uint64': 9,
        'float32': 10, 'float64': 11, 'char': 13, 'bool': 15, 'byte': 16, 'string': 17, 'wstring': 18}
_NESTED, _BOUNDED_STRING, _BOUNDED_WSTRING = 1, 21, 22
_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144
_FIELD = re.compile(r'^(?P<base>[A-Za-z_][\w/]*)(<=(?P<bound>\d+))?(\[(?P<seq><=)?(?P<size>\d*)\])?$')


def _sections(msgdef: str, datatype: str) -> dict[str, str]:
    """type name -> its own text, from the concatenated definition of ``datatype``."""
    out: dict[str, str] = {}
    name, lines = datatype, []
    for line in msgdef.splitlines():
        if line.strip() == SEPARATOR:
            out[name], name, lines = '\n'.join(lines), '', []
        elif not name and line.startswith('MSG: '):
            pkg, _, typ = line[5:].strip().rpartition('/')
            name = f'{pkg.split("/")[0]}/msg/{typ}'
        else:
            lines.append(line)
    out[name] = '\n'.join(lines)
    return out


def _fields(text: str, pkg: str) -> list[dict[str, Any]]:
    fields = []
    for raw in text.splitlines():
        line = raw.split('#', 1)[0].strip()
        if not line:
            continue
        typ, *after = line.split()
        if '=' in after[0] or after[1:2] and after[1].startswith('='):
            continue            # a constant: TYPE NAME=VALUE (or NAME = VALUE)
        name = after[0]
        m = _FIELD.match(typ)
        if m is None:
            raise ValueError(f'cannot read the field type {typ!r}')
        base, bound, size = m['base'], m['bound'], m['size']
        nested = ''
        if base in _IDS:
            type_id = _IDS[base]
            if bound is not None:
                type_id = _BOUNDED_STRING if base == 'string' else _BOUNDED_WSTRING
        else:
            type_id = _NESTED
            if base == 'Header':
                base = 'std_msgs/Header'
            p, _, t = base.rpartition('/')
            nested = f'{p or pkg}/msg/{t}'
        capacity = 0
        if m.group(4) is not None:            # an array
            if size and not m['seq']:
                type_id, capacity = type_id + _ARRAY, int(size)
            elif size:
                type_id, capacity = type_id + _BOUNDED_SEQUENCE, int(size)
            else:
                type_id += _UNBOUNDED_SEQUENCE
        fields.append({'name': name, 'type': {'type_id': type_id, 'capacity': capacity,
                                              'string_capacity': int(bound or 0), 'nested_type_name': nested}})
    if not fields:      # an empty message has one placeholder field (rosidl)
        fields.append({'name': 'structure_needs_at_least_one_member',
                       'type': {'type_id': 3, 'capacity': 0, 'string_capacity': 0, 'nested_type_name': ''}})
    return fields


def type_hash(datatype: str, msgdef: str) -> str:
    """The ``RIHS01_`` hash of ``datatype`` (``pkg/msg/Name``) from its concatenated definition."""
    texts = _sections(msgdef, datatype)
    described: dict[str, list[dict[str, Any]]] = {}
    todo = [datatype]
    while todo:
        name = todo.pop()
        if name in described:
            continue
        if name not in texts:
            raise ValueError(f'{datatype}: the definition of {name} is not in its text')
        described[name] = _fields(texts[name], name.split('/')[0])
        todo += [f['type']['nested_type_name'] for f in described[name] if f['type']['nested_type_name']]
    whole = {'type_description': {'type_name': datatype, 'fields': described[datatype]},
             'referenced_type_descriptions': [{'type_name': n, 'fields': described[n]}
                                              for n in sorted(described) if n != datatype]}
    text = json.dumps(whole, skipkeys=False, ensure_ascii=True, check_circular=True, allow_nan=False, indent=None,
                      separators=(', ', ': '), sort_keys=False)
    return 'RIHS01_' + hashlib.sha256(text.encode('utf-8')).hexdigest()
