"""An estimate of the JSON vocabulary in words: every shape, the decimals as the JSON gives them."""

from __future__ import annotations

import pytest

from steer_monitor.estimate.intervals import Interval
from steer_monitor.jsonvocab import estimate_text


@pytest.mark.parametrize(('d', 'unit', 'text'), [
    # the value rounded to fewer decimals than its ends reads with as many as they have
    ({'value': 0.27, 'ci95': [0.2629, 0.2836], 'bounded': True}, 'mm', '0.2700 mm [0.2629 .. 0.2836]'),
    ({'value': 0.1379, 'ci95': [0.1363, 0.139], 'bounded': True}, '', '0.1379 [0.1363 .. 0.1390]'),
    ({'value': 9510.0, 'ci95': [9484.0, 9541.0], 'bounded': True}, 'N', '9510 N [9484 .. 9541]'),
    ({'value': -0.5, 'ci95': [-0.75, -0.25], 'bounded': True}, '', '-0.50 [-0.75 .. -0.25]'),
    ({'value': None, 'ci95': [0.197, None], 'bounded': False}, 'mm', '>= 0.197 mm (lower bound only)'),
    ({'value': None, 'ci95': [None, 0.1], 'bounded': False}, '', '<= 0.1 (upper bound only)'),
    ({'value': None, 'ci95': [None, None], 'bounded': False}, 'mm', 'not determined'),
])
def test_estimate_text(d: dict, unit: str, text: str) -> None:
    assert estimate_text(d, unit) == text


def test_digits_given_are_kept() -> None:
    d = {'value': 0.27, 'ci95': [0.2629, 0.2836], 'bounded': True}
    assert estimate_text(d, 'mm', 3) == '0.270 mm [0.263 .. 0.284]'


def test_an_interval_in_words_as_its_json() -> None:
    """The words read the JSON an interval writes (``Interval.scaled``): 0.27 mm, rounded to
    four decimals, beside ends of four."""
    d = Interval(0.27000004e-3, 0.26290001e-3, 0.28360002e-3).scaled(1e3)
    assert d['value'] == 0.27
    assert estimate_text(d, 'mm') == '0.2700 mm [0.2629 .. 0.2836]'
