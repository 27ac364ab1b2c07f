"""Declare the parameter table on an rclpy node, with descriptors, and read it back validated."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from steer_monitor.errors import ParameterError
from steer_monitor.params import PARAMETERS, WRITABLE, ParamSpec, validate_params

__all__ = ['declare_parameters', 'overrides_from_file', 'why_refused']


def _descriptor(spec: ParamSpec) -> Any:
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, ParameterType

    kind = {'double': ParameterType.PARAMETER_DOUBLE, 'integer': ParameterType.PARAMETER_INTEGER,
            'bool': ParameterType.PARAMETER_BOOL, 'string': ParameterType.PARAMETER_STRING,
            'double_array': ParameterType.PARAMETER_DOUBLE_ARRAY}[spec.kind]
    d = ParameterDescriptor(name=spec.name, type=kind, description=spec.description,
                            read_only=spec.name not in WRITABLE)
    if spec.kind == 'double' and spec.minimum is not None and spec.maximum is not None:
        d.floating_point_range = [FloatingPointRange(from_value=float(spec.minimum),
                                                     to_value=float(spec.maximum), step=0.0)]
    if spec.kind == 'integer' and spec.minimum is not None and spec.maximum is not None:
        d.integer_range = [IntegerRange(from_value=int(spec.minimum), to_value=int(spec.maximum), step=0)]
    return d


def declare_parameters(node: Any) -> dict[str, Any]:
    """Declare every parameter on ``node`` and return them validated (dotted names).

    A value of the wrong type or out of range, a missing required one, or an unknown name in
    the parameters file raises :class:`ParameterError` naming it.
    """
    from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
    from rclpy.parameter import Parameter

    type_of = {'double': Parameter.Type.DOUBLE, 'integer': Parameter.Type.INTEGER,
               'bool': Parameter.Type.BOOL, 'string': Parameter.Type.STRING,
               'double_array': Parameter.Type.DOUBLE_ARRAY}
    overrides = dict(getattr(node, '_parameter_overrides', {}) or {})
    known = {s.name for s in PARAMETERS}
    unknown = sorted(set(overrides) - known - {'use_sim_time'})
    if unknown:
        from steer_monitor.params import unknown_parameter_message
        raise ParameterError(unknown_parameter_message(unknown))
    # Without any gear parameter (no parameters file given), the packaged one is the default,
    # said in the log: a node started bare monitors the R-18 gear it describes rather than
    # failing on the first required parameter; a node of another name refuses (its file's
    # entry is keyed for another node, or none was given). Given some, a missing required one
    # is an error: another gear's file must not be completed silently with R-18 values.
    packaged: dict[str, Any] = {}
    if not any(name.startswith('gear.') for name in overrides):
        from steer_monitor.params import NODE_NAME
        if node.get_name() != NODE_NAME:
            # a second monitor (``__node:=port_gear``) must not take the first gear's parameters
            name = node.get_name()
            msg = (f'node {name}: no gear parameters for it: give it a parameters file with an entry "{name}:" '
                   f'(or "/**:") at the top; only a node named {NODE_NAME} falls back to the packaged R-18 gear')
            raise ParameterError(msg)
        from steer_monitor.params import load_params_file
        from steer_monitor.resources import default_config
        path = default_config()
        packaged = load_params_file(path)
        node.get_logger().info(f'no gear parameters given: using the packaged parameters file {path}')
    values: dict[str, Any] = {}
    for spec in PARAMETERS:
        descriptor = _descriptor(spec)
        default = packaged.get(spec.name, spec.default)
        if default is None:
            default = type_of[spec.kind]
        try:
            param = node.declare_parameter(spec.name, default, descriptor)
        except InvalidParameterTypeException as exc:
            given = overrides.get(spec.name)
            shown = given.value if given is not None else '?'
            msg = (f'parameter {spec.name}: expected {spec.kind.replace("_", " ")}, got {shown!r} '
                   f'({why_refused(spec.kind, shown, exc)})')
            raise ParameterError(msg) from exc
        except InvalidParameterValueException as exc:
            msg = f'parameter {spec.name}: {exc}'
            raise ParameterError(msg) from exc
        if param.type_ != Parameter.Type.NOT_SET:
            value = param.value
            if spec.kind == 'double_array':
                value = [float(v) for v in value]
            values[spec.name] = value
    return validate_params(values)


def why_refused(kind: str, given: Any, exc: Exception) -> str:
    """Why a value was refused: for whole numbers given to a double (ROS types ``0`` as an
    integer and does not convert it), how to write them; else rclpy's words."""
    whole = (isinstance(given, int) and not isinstance(given, bool)) or \
        (isinstance(given, (list, tuple)) and bool(given) and all(isinstance(v, int) and not isinstance(v, bool)
                                                                  for v in given))
    if kind == 'double' and whole:
        return f'ROS reads a whole number as an integer: write {given}.0'
    if kind == 'double_array' and whole:
        return f'ROS reads whole numbers as integers: write [{", ".join(f"{v}.0" for v in given)}]'
    return str(exc)


def overrides_from_file(path: str, extra: Mapping[str, Any] | None = None) -> list[Any]:
    """rclpy Parameters from a parameters file with ``extra`` dotted overrides on top, the
    whole set validated (for tests, benchmarks and the in-process demo)."""
    from rclpy.parameter import Parameter

    from steer_monitor.params import load_params_file

    values = load_params_file(path)
    values.update(extra or {})
    return [Parameter(name, value=value) for name, value in validate_params(values).items()]
