"""ISO 286 fits and the clearance of a joint (paper 000).

Paper 000 describes a hole or shaft by its mean size and half-tolerance::

    A  = A_nom + (dU + dL) / 2        mean size
    dA = (dU - dL) / 2                half-tolerance (limit deviation about the mean)

A joint's clearance is ``mean hole - mean shaft``; its deviation combines the two
half-tolerances by root-sum-square (probable) or by plain sum (worst case, which gives the
ISO limits of the fit).

Tolerance tables: ISO 286-1:2010 table 1 (standard tolerance grades IT5..IT11) and
tables 2-3 (fundamental deviations of shafts c, d, e, f, g, h, js, k, m, n, p), nominal
sizes above 0 up to and including 500 mm, hole basis (H holes). No maintained Python
package carries these tables, so they are written out here and pinned by published rows in
``test/model/test_isofits.py``. Values in the tables are micrometres; everything returned is SI
(metres).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from steer_monitor.errors import FitError

__all__ = [
    'GRADES',
    'MAX_NOMINAL_MM',
    'SHAFT_LETTERS',
    'Clearance',
    'Fit',
    'Tolerance',
    'clearance_of',
    'hole_tolerance',
    'it_value',
    'parse_fit',
    'shaft_tolerance',
]

MAX_NOMINAL_MM = 500.0
GRADES = (5, 6, 7, 8, 9, 10, 11)
SHAFT_LETTERS = ('c', 'd', 'e', 'f', 'g', 'h', 'js', 'k', 'm', 'n', 'p')

_UM = 1e-6

# Main size steps (upper bound, mm): a size belongs to the first step whose bound is >= it.
_STEPS_MM = (3, 6, 10, 18, 30, 50, 80, 120, 180, 250, 315, 400, 500)

# ISO 286-1 table 1: standard tolerance IT in micrometres, per main size step.
_IT_UM: dict[int, tuple[int, ...]] = {
    5: (4, 5, 6, 8, 9, 11, 13, 15, 18, 20, 23, 25, 27),
    6: (6, 8, 9, 11, 13, 16, 19, 22, 25, 29, 32, 36, 40),
    7: (10, 12, 15, 18, 21, 25, 30, 35, 40, 46, 52, 57, 63),
    8: (14, 18, 22, 27, 33, 39, 46, 54, 63, 72, 81, 89, 97),
    9: (25, 30, 36, 43, 52, 62, 74, 87, 100, 115, 130, 140, 155),
    10: (40, 48, 58, 70, 84, 100, 120, 140, 160, 185, 210, 230, 250),
    11: (60, 75, 90, 110, 130, 160, 190, 220, 250, 290, 320, 360, 400),
}

# Upper deviation es (um) of shafts d..h, constant over each main step.
_ES_UM: dict[str, tuple[int, ...]] = {
    'd': (-20, -30, -40, -50, -65, -80, -100, -120, -145, -170, -190, -210, -230),
    'e': (-14, -20, -25, -32, -40, -50, -60, -72, -85, -100, -110, -125, -135),
    'f': (-6, -10, -13, -16, -20, -25, -30, -36, -43, -50, -56, -62, -68),
    'g': (-2, -4, -5, -6, -7, -9, -10, -12, -14, -15, -17, -18, -20),
    'h': (0,) * 13,
}

# Shaft c: es over the intermediate steps (upper bound mm, es um).
_C_ES_UM = (
    (3, -60), (6, -70), (10, -80), (18, -95), (30, -110), (40, -120), (50, -130),
    (65, -140), (80, -150), (100, -170), (120, -180), (140, -200), (160, -210), (180, -230),
    (200, -240), (225, -260), (250, -280), (280, -300), (315, -330), (355, -360),
    (400, -400), (450, -440), (500, -480),
)

# Lower deviation ei (um) of shafts k (grades 4..7 only; 0 otherwise), m, n, p.
_EI_UM: dict[str, tuple[int, ...]] = {
    'k': (0, 1, 1, 1, 2, 2, 2, 3, 3, 4, 4, 4, 5),
    'm': (2, 4, 6, 7, 8, 9, 11, 13, 15, 17, 20, 21, 23),
    'n': (4, 8, 10, 12, 15, 17, 20, 23, 27, 31, 34, 37, 40),
    'p': (6, 12, 15, 18, 22, 26, 32, 37, 43, 50, 56, 62, 68),
}

_FIT_RE = re.compile(
    r'^\s*(?P<nominal>\d+(?:\.\d+)?)\s*(?:mm)?\s*'
    r'(?P<hole>[A-Za-z]+)(?P<hole_grade>\d+)\s*/\s*(?P<shaft>[A-Za-z]+)(?P<shaft_grade>\d+)\s*$'
)


@dataclass(frozen=True)
class Tolerance:
    """Limits of one hole or shaft, in metres.

    ``upper`` and ``lower`` are the limit deviations from ``nominal`` (dU, dL of paper 000).
    """

    nominal: float
    upper: float
    lower: float
    designation: str = ''

    @property
    def mean(self) -> float:
        """Mean size A = A_nom + (dU + dL) / 2 [m]."""
        return self.nominal + (self.upper + self.lower) / 2.0

    @property
    def mean_deviation(self) -> float:
        """Mean deviation (dU + dL) / 2 from nominal [m]."""
        return (self.upper + self.lower) / 2.0

    @property
    def half_tolerance(self) -> float:
        """Half-tolerance dA = (dU - dL) / 2 [m]."""
        return (self.upper - self.lower) / 2.0

    @classmethod
    def from_deviations(cls, nominal: float, upper: float, lower: float,
                        designation: str = '') -> Tolerance:
        """Build a tolerance from nominal size and limit deviations, all in metres."""
        if not (math.isfinite(nominal) and math.isfinite(upper) and math.isfinite(lower)):
            msg = f'tolerance {designation or ""}: nominal and deviations must be finite numbers'
            raise FitError(msg)
        if upper < lower:
            msg = (f'tolerance {designation or ""}: upper deviation {upper * 1e3:.4f} mm is below '
                   f'lower deviation {lower * 1e3:.4f} mm')
            raise FitError(msg)
        return cls(nominal=nominal, upper=upper, lower=lower, designation=designation)


@dataclass(frozen=True)
class Clearance:
    """Clearance of a joint, in metres.

    ``mean`` is mean hole minus mean shaft; ``probable_dev`` the root-sum-square of the two
    half-tolerances; ``worst_dev`` their sum (so ``mean -+ worst_dev`` are the ISO limits).
    """

    mean: float
    probable_dev: float
    worst_dev: float

    @property
    def minimum(self) -> float:
        """Smallest clearance of the fit (worst case) [m]; negative means interference."""
        return self.mean - self.worst_dev

    @property
    def maximum(self) -> float:
        """Largest clearance of the fit (worst case) [m]."""
        return self.mean + self.worst_dev

    @property
    def probable_min(self) -> float:
        """Smallest probable clearance, mean - RSS deviation [m]."""
        return self.mean - self.probable_dev

    @property
    def probable_max(self) -> float:
        """Largest probable clearance, mean + RSS deviation [m]."""
        return self.mean + self.probable_dev


@dataclass(frozen=True)
class Fit:
    """A hole-basis ISO 286 fit such as ``240 H9/f9``."""

    nominal_mm: float
    hole_grade: int
    shaft_letter: str
    shaft_grade: int

    @property
    def designation(self) -> str:
        """The canonical text, e.g. ``'240 H9/f9'``."""
        return f'{self.nominal_mm:g} H{self.hole_grade}/{self.shaft_letter}{self.shaft_grade}'

    @property
    def hole(self) -> Tolerance:
        """Tolerance of the hole [m]."""
        return hole_tolerance(self.nominal_mm, self.hole_grade)

    @property
    def shaft(self) -> Tolerance:
        """Tolerance of the shaft [m]."""
        return shaft_tolerance(self.nominal_mm, self.shaft_letter, self.shaft_grade)

    @property
    def clearance(self) -> Clearance:
        """Clearance of the joint [m]."""
        return clearance_of(self.hole, self.shaft)

    def with_grade(self, grade: int) -> Fit:
        """The same fit with hole and shaft both at IT ``grade``."""
        return Fit(self.nominal_mm, grade, self.shaft_letter, grade)


def _check_nominal(nominal_mm: float) -> None:
    if not (isinstance(nominal_mm, (int, float)) and math.isfinite(nominal_mm)):
        msg = f'nominal size {nominal_mm!r} is not a number'
        raise FitError(msg)
    if not 0.0 < nominal_mm <= MAX_NOMINAL_MM:
        msg = (f'nominal size {nominal_mm:g} mm is outside the supported ISO 286 range '
               f'(above 0 up to {MAX_NOMINAL_MM:g} mm)')
        raise FitError(msg)


def _check_grade(grade: int) -> None:
    if grade not in _IT_UM:
        msg = f'tolerance grade IT{grade} is not supported (supported: IT{GRADES[0]}..IT{GRADES[-1]})'
        raise FitError(msg)


def _step(nominal_mm: float) -> int:
    """Index of the main size step holding ``nominal_mm`` (above lower, up to upper bound)."""
    _check_nominal(nominal_mm)
    for i, bound in enumerate(_STEPS_MM):
        if nominal_mm <= bound:
            return i
    raise AssertionError('unreachable: nominal checked against MAX_NOMINAL_MM')


def it_value(nominal_mm: float, grade: int) -> float:
    """Standard tolerance IT``grade`` for a nominal size in mm, returned in metres."""
    _check_grade(grade)
    return _IT_UM[grade][_step(nominal_mm)] * _UM


def hole_tolerance(nominal_mm: float, grade: int) -> Tolerance:
    """Tolerance of an H hole (EI = 0, ES = IT) [m]."""
    it = it_value(nominal_mm, grade)
    return Tolerance(nominal_mm * 1e-3, it, 0.0, f'{nominal_mm:g} H{grade}')


def _shaft_es_ei_um(nominal_mm: float, letter: str, grade: int) -> tuple[float, float]:
    step = _step(nominal_mm)
    it_um = _IT_UM[grade][step]
    if letter == 'c':
        es = next(v for bound, v in _C_ES_UM if nominal_mm <= bound)
        return es, es - it_um
    if letter in _ES_UM:
        es = _ES_UM[letter][step]
        return es, es - it_um
    if letter == 'js':
        # ISO 286-1: for js7..js11 an odd IT value is replaced by the even value below it.
        half = (it_um - (it_um % 2 if grade >= 7 else 0)) / 2.0
        return half, -half
    if letter in _EI_UM:
        ei = _EI_UM[letter][step]
        if letter == 'k' and grade > 7:
            ei = 0
        return ei + it_um, ei
    msg = f'shaft letter {letter!r} is not supported (supported: {", ".join(SHAFT_LETTERS)})'
    raise FitError(msg)


def shaft_tolerance(nominal_mm: float, letter: str, grade: int) -> Tolerance:
    """Tolerance of a shaft ``letter``/``grade`` (e.g. ``'f', 9``) [m]."""
    _check_grade(grade)
    if letter not in SHAFT_LETTERS:
        msg = f'shaft letter {letter!r} is not supported (supported: {", ".join(SHAFT_LETTERS)})'
        raise FitError(msg)
    es, ei = _shaft_es_ei_um(nominal_mm, letter, grade)
    return Tolerance(nominal_mm * 1e-3, es * _UM, ei * _UM, f'{nominal_mm:g} {letter}{grade}')


def clearance_of(hole: Tolerance, shaft: Tolerance) -> Clearance:
    """Clearance of a joint from its hole and shaft (paper 000) [m]."""
    mean = hole.mean - shaft.mean
    probable = math.hypot(hole.half_tolerance, shaft.half_tolerance)
    worst = hole.half_tolerance + shaft.half_tolerance
    return Clearance(mean=mean, probable_dev=probable, worst_dev=worst)


def parse_fit(text: str) -> Fit:
    """Parse a hole-basis designation such as ``'240 H9/f9'`` and check it against the tables.

    Raises :class:`FitError` naming what is wrong: the form, a shaft-basis or other hole
    letter, a grade outside IT5..IT11, a shaft letter outside the table, or a size outside
    0..500 mm.
    """
    if not isinstance(text, str):
        msg = f'fit designation must be text like "240 H9/f9", got {type(text).__name__}'
        raise FitError(msg)
    match = _FIT_RE.match(text)
    if match is None:
        msg = f'cannot read fit {text!r}: expected "<nominal mm> H<grade>/<shaft letter><grade>", e.g. "240 H9/f9"'
        raise FitError(msg)
    hole = match['hole']
    if hole != 'H':
        msg = f'fit {text!r}: only hole-basis fits (hole H) are supported, got hole {hole!r}'
        raise FitError(msg)
    shaft = match['shaft']
    if shaft not in SHAFT_LETTERS:
        msg = (f'fit {text!r}: shaft letter {shaft!r} is not supported '
               f'(supported: {", ".join(SHAFT_LETTERS)})')
        raise FitError(msg)
    fit = Fit(float(match['nominal']), int(match['hole_grade']), shaft, int(match['shaft_grade']))
    for grade in (fit.hole_grade, fit.shaft_grade):
        if grade not in _IT_UM:
            msg = f'fit {text!r}: grade IT{grade} is not supported (supported: IT{GRADES[0]}..IT{GRADES[-1]})'
            raise FitError(msg)
    _check_nominal(fit.nominal_mm)
    return fit
