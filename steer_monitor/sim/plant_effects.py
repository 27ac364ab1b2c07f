"""Undeclared effects the simulator can add on request (docs/residual-loop.md).

The declared model (section 4) is what the estimator assumes; these are what real gear adds
and the analysis must find in the residual without being told. Each switches on by name
with optional parameters, e.g. ``--effect viscous:c_ns_per_m=8e5``.

===================== ================================================================
name                  what it does (parameters, defaults)
===================== ================================================================
viscous               friction grows with ram speed: F_fr += c |v_ram|
                      (c_ns_per_m = 1.0e6 N s/m: 30 kN at 30 mm/s)
angle_delay           the rudder angle sensor reports alpha(t - tau) (tau_s = 0.25 s)
pressure_offset       one pressure transducer reads high by a constant
                      (input = pressure_r1_stbd, offset_bar = 3.0)
temp_friction         friction rises with oil temperature:
                      F_fr *= 1 + k (T - T_ref) (k_per_k = 0.02 /K, t_ref_c = 40 C)
pressure_friction     seal friction rises with the driving chamber's pressure:
                      F_fr += k A_r p_high (k = 0.03)
stribeck              extra friction near zero ram speed (Stribeck):
                      F_fr += F_st exp(-(|v| / v_s)^2) (f_st_n = 15e3 N, v_s_mm_s = 3.0)
ram_inertia           the moving mass (rams, crosshead, and the rudder's moment of
                      inertia seen at the rams, J / H^2) takes m a_ram from the ram force
                      (mass_kg = 60e3 kg); a mass does not change speed at once, so the
                      rudder's rate follows the valve's through a first-order lag
                      (rate_lag_s = 0.1 s; without it every valve step would be an
                      infinite acceleration, a spike in the pressures no real gear shows)
band_friction         *outside the analysis library*: a scored stretch of both rams'
                      bushings adds friction while the rudder is between two angles on
                      either side, F_fr += f_n for lo_deg <= |alpha| <= hi_deg
                      (f_n = 12e3 N, lo_deg = 12, hi_deg = 18)
ram_bypass            *a fault, not a model effect*: one ram's chambers joined (a bypass
                      or isolating valve open) from start_s to end_s [s of the programme]:
                      that ram carries the fraction carries of its force and the other
                      ram the rest, 2 - carries (ram = 1, carries = 0.0, start_s = 0,
                      end_s = 1e9). The rams' total force is kept as the declared plant
                      has it: the friction of a ram dragged along, and the driving ram's
                      larger lateral load, are not redistributed. The monitor's ``rams``
                      status is what names it (:mod:`~steer_monitor.estimate.rams`)
angle_stuck           *a fault, not a model effect*: the rudder angle sensor sends the
                      value it read at start_s (s of the programme) from then on, to
                      the last bit (a frozen sensor or gateway; the rudder itself moves
                      as ordered). The steering performance status names it, once an
                      order step finds the rudder standing (start_s = 0)
angle_zero            *a sensor fault*: the rudder angle transmitter's zero is off: it
                      reads offset_deg more to starboard than the rudder is, at every
                      angle (offset_deg = 0.6; negative: to port)
angle_span            *a sensor fault*: the transmitter's span is off: it reads the
                      angle span_pct per cent too large (negative: too small), so the
                      rudder's rate by as much (span_pct = 3.0)
pressure_span         *a sensor fault*: one pressure transducer's span is off: it reads
                      span_pct per cent high (negative: low), the error growing with the
                      pressure (input = pressure_r1_stbd, span_pct = 4.0); its zero is
                      pressure_offset
pressure_delay        *a sensor fault*: one pressure transducer's readings reach the bus
                      tau_s late (a slow converter or gateway stage): it reports
                      p(t - tau) (input = pressure_r1_stbd, tau_s = 0.2); the angle's is
                      angle_delay
===================== ================================================================

Sizes may be negative: a plant that departs from the declared law the other way (friction
*below* it near zero speed, say) is how the tests check that the analysis refuses an
unphysical fit. Several effects may be given at once (each name once); they add as listed in the plant
(:func:`~steer_monitor.sim.plant.simulate`): the friction terms, then temp_friction scales
the friction, then pressure_friction and ram_inertia act on the ram force; angle_delay and
pressure_offset act on the sensors, as do the sensor faults (a transmitter or transducer
reading otherwise than it should: the plant, and the gear's own follow-up, are untouched).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

from steer_monitor.errors import ParameterError

__all__ = ['EFFECTS', 'FAULTS', 'OUTSIDE_LIBRARY', 'SENSOR_FAULTS', 'Effect', 'parse_effect', 'split_effects']

EFFECTS: dict[str, dict[str, float | str]] = {
    'viscous': {'c_ns_per_m': 1.0e6},
    'angle_delay': {'tau_s': 0.25},
    'pressure_offset': {'input': 'pressure_r1_stbd', 'offset_bar': 3.0},
    'temp_friction': {'k_per_k': 0.02, 't_ref_c': 40.0},
    'pressure_friction': {'k': 0.03},
    'stribeck': {'f_st_n': 15e3, 'v_s_mm_s': 3.0},
    'ram_inertia': {'mass_kg': 60e3, 'rate_lag_s': 0.1},
    'band_friction': {'f_n': 12e3, 'lo_deg': 12.0, 'hi_deg': 18.0},
    'ram_bypass': {'ram': 1.0, 'carries': 0.0, 'start_s': 0.0, 'end_s': 1e9},
    'angle_stuck': {'start_s': 0.0},
    'angle_zero': {'offset_deg': 0.6},
    'angle_span': {'span_pct': 3.0},
    'pressure_span': {'input': 'pressure_r1_stbd', 'span_pct': 4.0},
    'pressure_delay': {'input': 'pressure_r1_stbd', 'tau_s': 0.2},
}

# The ones the analysis library has no candidate for (a test of the "unexplained" verdict).
OUTSIDE_LIBRARY = ('band_friction',)
# Faults of the gear rather than effects on its friction or sensors: not the residual loop's
# to name (another status does).
FAULTS = ('ram_bypass', 'angle_stuck')
# A sensor that reads otherwise than it should (zero, span, lag): the plant is right, the
# reading is not. The analysis library has no term of its own for these yet.
SENSOR_FAULTS = ('angle_zero', 'angle_span', 'pressure_span', 'pressure_delay')

_PRESSURES = ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')


@dataclass(frozen=True)
class Effect:
    """An undeclared effect with its parameters (defaults filled in)."""

    name: str
    params: Mapping[str, float | str] = field(default_factory=dict)

    def __getitem__(self, key: str) -> float | str:
        return self.params[key]


def split_effects(text: str) -> list[str]:
    """A comma-separated list of effects -> their texts: ``'viscous,band_friction:lo_deg=4,hi_deg=9'``
    -> ``['viscous', 'band_friction:lo_deg=4,hi_deg=9']`` (an item ``key=value`` with no ``:``
    is one more parameter of the effect before it). Each text is checked by :func:`parse_effect`."""
    out: list[str] = []
    for item in filter(None, (s.strip() for s in text.split(','))):
        if out and ':' not in item and '=' in item and ':' in out[-1]:
            out[-1] += f',{item}'
        else:
            out.append(item)
    return out


def parse_effect(text: str) -> Effect:
    """``'name'`` or ``'name:key=value,key=value'`` -> Effect, with a clear error when wrong."""
    name, _, rest = text.strip().partition(':')
    if name not in EFFECTS:
        msg = f'unknown effect {name!r} (choose from: {", ".join(EFFECTS)})'
        raise ParameterError(msg)
    params: dict[str, float | str] = dict(EFFECTS[name])
    for item in filter(None, (s.strip() for s in rest.split(','))):
        key, eq, value = item.partition('=')
        if not eq or key not in params:
            msg = f'effect {name}: unknown parameter {key!r} (parameters: {", ".join(params)})'
            raise ParameterError(msg)
        if isinstance(params[key], str):
            params[key] = value
        else:
            try:
                num = float(value)
            except ValueError:
                num = math.nan
            if not math.isfinite(num):
                msg = f'effect {name}: parameter {key} must be a number, got {value!r}'
                raise ParameterError(msg)
            params[key] = num
    if name == 'stribeck' and not float(params['v_s_mm_s']) > 0:
        msg = f'effect stribeck: v_s_mm_s must be more than 0, got {params["v_s_mm_s"]:g}'
        raise ParameterError(msg)
    if name in ('pressure_offset', 'pressure_span', 'pressure_delay') and params['input'] not in _PRESSURES:
        msg = f'effect {name}: input must be one of {", ".join(_PRESSURES)}, got {params["input"]!r}'
        raise ParameterError(msg)
    if name == 'pressure_delay' and not 0 <= float(params['tau_s']) <= 5:
        msg = f'effect pressure_delay: tau_s must lie in 0..5 s, got {params["tau_s"]}'
        raise ParameterError(msg)
    if name in ('angle_span', 'pressure_span') and not -50 < float(params['span_pct']) < 100:
        msg = f'effect {name}: span_pct must lie between -50 and 100 per cent, got {params["span_pct"]}'
        raise ParameterError(msg)
    if name == 'angle_zero' and not abs(float(params['offset_deg'])) <= 10:
        msg = f'effect angle_zero: offset_deg must lie in -10..10 deg, got {params["offset_deg"]}'
        raise ParameterError(msg)
    if name == 'angle_delay' and not 0 <= float(params['tau_s']) <= 5:
        msg = f'effect angle_delay: tau_s must lie in 0..5 s, got {params["tau_s"]}'
        raise ParameterError(msg)
    if name == 'ram_inertia' and not 0 <= float(params['rate_lag_s']) <= 5:
        msg = f'effect ram_inertia: rate_lag_s must lie in 0..5 s, got {params["rate_lag_s"]}'
        raise ParameterError(msg)
    if name == 'band_friction' and not 0 <= float(params['lo_deg']) < float(params['hi_deg']) <= 90:
        msg = f'effect band_friction: need 0 <= lo_deg < hi_deg <= 90, got {params["lo_deg"]} and {params["hi_deg"]}'
        raise ParameterError(msg)
    if name == 'ram_bypass' and (params['ram'] not in (1.0, 2.0) or not 0 <= float(params['carries']) <= 2
                                 or not float(params['start_s']) < float(params['end_s'])):
        msg = (f'effect ram_bypass: need ram 1 or 2, 0 <= carries <= 2 and start_s < end_s, got ram {params["ram"]:g}, '
               f'carries {params["carries"]:g}, start_s {params["start_s"]:g} and end_s {params["end_s"]:g}')
        raise ParameterError(msg)
    return Effect(name, params)
