"""config/r18.yaml and the parameter table: every bad value is named."""

from __future__ import annotations

import math

import pytest
import yaml

from steer_monitor.errors import ParameterError
from steer_monitor.params import PARAMETERS, gaps_from_params, gear_from_params, load_params_file
from test.conftest import R18_YAML


def test_r18_file_loads_with_design_values(r18_params, r18):
    assert r18_params['gear.name'] == 'R-18'
    assert r18.stock_to_ram == 0.600
    assert r18.bushing_span == 1.600
    assert r18.guide_beam_inertia == pytest.approx(284_981_668e-12)
    assert r18.rams == 2
    assert math.degrees(r18.max_rudder) == pytest.approx(35.0)
    assert r18.euler_amplification is False
    assert float(r18.torque(math.radians(27.5))) == pytest.approx(930e3)
    assert r18.torque.service_speed == pytest.approx(16 * 1852 / 3600)
    gaps = gaps_from_params(r18_params)
    assert (gaps.two_z, gaps.z_gb) == (pytest.approx(0.6e-3), pytest.approx(0.25e-3))


def test_every_spec_has_a_unit_or_is_unitless_by_nature():
    units = (
        '_m',
        '_mm',
        '_pa',
        '_mm4',
        '_deg',
        '_knm',
        '_kn',
        '_mm_s',
        '_hz',
        '_s',
        '_bar',
        '_n',
        '_mb',
        '_gb',
        '_minutes',
        '_share',
        '_h',
        '_ms',
        '_pct',
    )
    unitless = ('.name', '.rams', '.euler_amplification', '.pumps', '.new_fit', '.interface',
                '.channel', '.bitrate', '.dbc_file', '.pgn', '.field', '.instance', '.source',
                '.hardware_id', '.mu_bushing', '.mu_guide', '.enabled', '.directory', '.prefix',
                '.state_file', '.address', '.device_name', '.timestamps')
    for spec in PARAMETERS:
        assert spec.name.endswith(unitless + units), spec.name


def _write(tmp_path, mutate):
    doc = yaml.safe_load(R18_YAML.read_text())
    mutate(doc['steer_monitor']['ros__parameters'])
    path = tmp_path / 'p.yaml'
    path.write_text(yaml.safe_dump(doc))
    return path


def _set(section, key, value):
    def mutate(p):
        p[section][key] = value
    return mutate


def _drop(section, key):
    def mutate(p):
        del p[section][key]
    return mutate


@pytest.mark.parametrize(
    'mutate,msg',
    [
        (_set('gear', 'stock_to_ram_m', -0.6), 'parameter gear.stock_to_ram_m: must be > 0, got -0.6'),
        (
            _set('gear', 'bushing_span_m', 1600),
            r'parameter gear.bushing_span_m: expected a floating-point number, got 1600 \(write 1600.0',
        ),
        (_set('gear', 'rams', 2.0), 'parameter gear.rams: expected a whole number, got 2.0'),
        (
            _set('gear', 'euler_amplification', 'no'),
            "parameter gear.euler_amplification: expected true or false, got 'no'",
        ),
        (_set('gear', 'stock_to_ramm_m', 0.6), 'unknown parameter gear.stock_to_ramm_m'),
        (_drop('gear', 'bushing_span_m'), 'missing parameter gear.bushing_span_m'),
        (
            _set('torque', 'torque_knm', [0.0, 330.0, 584.0]),
            'parameter torque.torque_knm: has 3 values but torque.angle_deg has 6',
        ),
        (
            _set('torque', 'torque_knm', [0.0, 330, 584.0, 766.0, 930.0, 1000.0]),
            r'parameter torque.torque_knm\[1\]: expected a finite floating-point number',
        ),
        (
            _set('torque', 'torque_knm', [0.0, 330.0, 584.0, 500.0, 930.0, 1000.0]),
            'torque curve torques must not decrease with angle',
        ),
        (
            _set('torque', 'angle_deg', [1.0, 5.0, 10.0, 21.0, 27.5, 35.0]),
            r'torque curve must start at \(0 deg, 0 kN m\)',
        ),
        (
            _set('clearances', 'new_fit', '240 H9/q9'),
            "parameter clearances.new_fit: fit '240 H9/q9': shaft letter 'q' is not supported",
        ),
        (_set('clearances', 'gap_2z_mm', -0.1), 'parameter clearances.gap_2z_mm: must be >= 0, got -0.1'),
        (_set('gear', 'ram_inner_diameter_m', 0.3), 'ram_inner_diameter must lie in'),
        (_set('gear', 'max_rudder_deg', 55.0), 'max_rudder 55.0 deg moves the crosshead'),
        (
            _set('gear', 'bushing_length_m', 2.0),
            r'bushing_length must be shorter than bushing_span \(the bushings at A and E '
            r'would overlap\), got 2.0 with span 1.6',
        ),
        (
            _set('recording', 'max_total_gb', 1.0),
            r'parameter recording.max_total_gb: 1 GB does not hold two files of '
            r'recording.max_file_mb \(512 MB\)',
        ),
        (_set('recording', 'keep_free_gb', -1.0), 'parameter recording.keep_free_gb: must be >= 0, got -1.0'),
    ],
)
def test_bad_values_are_named(tmp_path, mutate, msg):
    with pytest.raises(ParameterError, match=msg):
        load_params_file(_write(tmp_path, mutate))


@pytest.mark.parametrize('text,msg', [
    ('steer_monitor: [1, 2]', 'must hold a "ros__parameters" mapping'),
    ('other_node:\n  ros__parameters: {}', 'no entry for node "steer_monitor"'),
    ('steer_monitor: {ros__parameters: {gear: {x: 1}', 'is not valid YAML'),
    ('- 1', 'expected "steer_monitor: ros__parameters:" at the top'),
])
def test_bad_files(tmp_path, text, msg):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ParameterError, match=msg):
        load_params_file(path)


def test_missing_file(tmp_path):
    with pytest.raises(ParameterError, match='cannot read parameters file'):
        load_params_file(tmp_path / 'nope.yaml')


def test_wildcard_node_entry_is_merged(tmp_path):
    doc = yaml.safe_load(R18_YAML.read_text())
    doc['/**'] = {'ros__parameters': {'clearances': {'gap_2z_mm': 0.3}}}
    doc['steer_monitor']['ros__parameters']['clearances'].pop('gap_2z_mm')
    path = tmp_path / 'w.yaml'
    path.write_text(yaml.safe_dump(doc))
    assert load_params_file(path)['clearances.gap_2z_mm'] == 0.3


def test_gear_record_matches_params(r18_params):
    gear = gear_from_params(r18_params)
    assert gear.ram_area == pytest.approx(0.045239, rel=1e-4)


def test_an_unknown_parameter_suggests_the_known_one():
    """The node and every command say the same line: the name given, and the closest known."""
    from steer_monitor.params import unknown_parameter_message
    assert unknown_parameter_message(['can.chanel']) == 'unknown parameter can.chanel (did you mean can.channel?)'
    assert unknown_parameter_message(['x.y', 'z']) == 'unknown parameter x.y (and 1 more)'
