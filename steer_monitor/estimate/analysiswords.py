"""The analysis's verdict in words: the message, what an adopted effect cannot say, and the
stretches the rams check left out. Pure."""

from __future__ import annotations

import math
from collections.abc import Sequence

from steer_monitor.estimate.batch import ClearanceEstimate
from steer_monitor.estimate.intervals import Interval
from steer_monitor.estimate.ramscheck import UnevenSpan, describe
from steer_monitor.estimate.screening import Screening, Step

__all__ = ['CAVEATS', 'given_text', 'message', 'skew_equivalent_s', 'uneven_note', 'verdict_text']

#: what an adopted effect's parameters cannot say, added to the message when it is adopted
CAVEATS = {
    'ram_inertia': 'the mass is an apparent one: it reads low where the rudder changes speed faster than '
                   "the angle's samples show (27 t for 60 t on a simulated voyage, docs/residual-loop.md), and "
                   'beside strong viscous friction a timing skew between angle and pressures looks like a mass',
}


def skew_equivalent_s(steps: Sequence[Step]) -> float | None:
    """The timing skew [s] between angle and pressures that, with the viscous friction the
    steps found, puts the adopted ram inertia's force into the residual: a viscous force read
    at a rate tau late is c (v + tau a), so a mass m is also what a skew tau = m / c shows.
    None unless both were adopted with positive values."""
    params = {s.name: s.params for s in steps}
    mass, visc = params.get('ram_inertia', {}).get('mass_kg'), params.get('viscous', {}).get('c_ns_per_m')
    if not isinstance(mass, Interval) or not isinstance(visc, Interval):
        return None
    if not (mass.value > 0 and visc.value > 0 and math.isfinite(mass.value / visc.value)):
        return None
    return mass.value / visc.value


def message(verdict: str, declared: ClearanceEstimate, final: ClearanceEstimate | None,
             best: Screening | None, steps: Sequence[Step] = (), given: bool = False) -> str:
    names = [s.name for s in steps]
    text = given_text(verdict, final or declared, names) if given else verdict_text(verdict, declared, final, best,
                                                                                        names)
    caveats = [f'{n}: {CAVEATS[n]}' for n in names if n in CAVEATS]
    skew = skew_equivalent_s(steps)
    if skew is not None:
        caveats.append(f'with the viscous friction found, this mass is what a skew of {1e3 * skew:.0f} ms between '
                       f'the angle and the pressures would show')
    return text + (f' ({"; ".join(caveats)})' if caveats else '')


def given_text(verdict: str, est: ClearanceEstimate, names: list[str]) -> str:
    """The sentence of a run under a given model (no screening)."""
    bar = 1e5 * est.ram_area
    model = 'the declared model' + (f' with {", ".join(names)}' if names else '')
    figures = f'residual {est.rms / bar:.2f} bar RMS, of which {est.smooth_rms / bar:.2f} bar systematic'
    if verdict == 'unexplained':
        return (f'residual not explained: under the model the residual loop last chose ({model}), {figures}, '
                f'more than half the sensor noise ({est.noise_rms / bar:.2f} bar)')
    return f'{model} (the residual loop\'s last choice) explains the data to the sensor noise: {figures}'


def verdict_text(verdict: str, declared: ClearanceEstimate, final: ClearanceEstimate | None,
                  best: Screening | None, names: list[str] | None) -> str:
    bar = 1e5 * declared.ram_area
    added = ', then '.join(names or [])
    if verdict == 'declared':
        return (f'the declared model explains the data to the sensor noise: residual {declared.rms / bar:.2f} bar '
                f'RMS, of which {declared.smooth_rms / bar:.2f} bar systematic; no effect added')
    if verdict == 'effect' and final is not None:
        return (f'added {added}: residual {declared.rms / bar:.2f} -> {final.rms / bar:.2f} bar RMS '
                f'(systematic part {declared.smooth_rms / bar:.2f} -> {final.smooth_rms / bar:.2f} bar)')
    if names and final is not None:
        text = (
            f'residual not explained: added {added} (residual {declared.rms / bar:.2f} -> {final.rms / bar:.2f} bar '
            f'RMS), and a systematic part of {final.smooth_rms / bar:.2f} bar remains that no effect in the '
            f'library explains'
        )
    else:
        text = (f'residual not explained: {declared.rms / bar:.2f} bar RMS with a systematic part of '
                f'{declared.smooth_rms / bar:.2f} bar that no effect in the library explains')
    if best is not None:
        text += f' (closest: {best.name}, held-out error -{100 * best.cv_gain:.0f} %)'
    return text


def uneven_note(spans: Sequence[UnevenSpan]) -> str:
    """What the message says of the stretches left out ('' when none)."""
    if not spans:
        return ''
    return ('; the rams did not share the force evenly, and those stretches are left out of the fit: '
            + '; '.join(describe(sp) for sp in spans))
