"""Alignment of the streams on the grid: validity, motion, missing inputs."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.can.decoder import Series
from steer_monitor.estimate.observe import GRID_NS, EstimateError, Windows, build_observations, grid_times


def _series(t_s, v):
    return Series((np.asarray(t_s) * 1e9).astype(np.int64), np.asarray(v, float))


def _signals(rate=0.05, gap=None):
    t_a = np.arange(0, 10, 0.1)
    a = rate * t_a
    t_p = np.arange(0.013, 10, 0.05)
    sig = {'rudder_angle': _series(t_a, a)}
    for k, name in enumerate(('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')):
        t = t_p + 0.004 * k
        v = np.full(t.size, 50e5 if k % 2 == 0 else 2e5)
        if gap is not None:
            keep = (t < gap[0]) | (t > gap[1])
            t, v = t[keep], v[keep]
        sig[name] = _series(t, v)
    return sig


def test_grid_is_anchored_at_the_epoch():
    t = grid_times(1_234_567_891, 1_600_000_000)
    assert t[0] % GRID_NS == 0 and t[0] >= 1_234_567_891 and np.all(np.diff(t) == GRID_NS)


def test_steady_motion_and_force():
    obs = build_observations(_signals(), 0.045)
    inner = obs.moving
    assert inner.sum() > 150 and np.all(obs.direction[inner] == 1)
    assert np.nanmax(np.abs(obs.rate[inner] - 0.05)) < 1e-9
    assert np.allclose(obs.force[inner], 0.045 * 48e5)


def test_rest_and_missing_samples_carry_no_information():
    obs = build_observations(_signals(rate=0.0), 0.045)
    assert not obs.moving.any()
    obs = build_observations(_signals(gap=(4.0, 5.0)), 0.045)
    t = (obs.t_ns - obs.t_ns[0]) / 1e9
    assert np.all(np.isnan(obs.force[(t > 4.2) & (t < 4.8)]))


@pytest.mark.parametrize('drop, match', [
    (('rudder_angle',), 'no rudder angle'),
    (('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port'), 'no cylinder pressure'),
])
def test_missing_inputs_are_named(drop, match):
    sig = _signals()
    for k in drop:
        del sig[k]
    with pytest.raises(EstimateError, match=match):
        build_observations(sig, 0.045)


def _polyfit_slope(ts, v, t, lo, hi):
    """The reference: numpy's polyfit on each window's samples."""
    out = np.full(t.size, np.nan)
    for i, ti in enumerate(t):
        m = (ts >= ti + lo) & (ts <= ti + hi)
        if np.unique(ts[m]).size >= 2:
            out[i] = np.polyfit((ts[m] - ti) / 1e9, v[m], 1)[0]
    return out


@pytest.mark.parametrize('seed', range(4))
def test_window_slopes_match_polyfit(seed):
    # irregular 10 Hz samples with gaps, samples exactly on grid points (some twice, with
    # another value), a slope that changes and noise; angles around 0.6 rad (the sums are
    # taken relative to a sample near the grid point, so a large angle costs no precision)
    from steer_monitor.estimate.observe import HALF_WINDOW_NS, angle_slopes
    rng = np.random.default_rng(seed)
    ts = np.cumsum(rng.integers(20_000_000, 180_000_000, 400)).astype(np.int64) + 1_700_000_000 * 10 ** 9
    ts[::37] = (ts[::37] // 50_000_000) * 50_000_000                 # some exactly on the grid
    ts = np.unique(ts)
    ts = np.delete(ts, np.arange(100, 130))                           # a gap of ~3 s
    v = 0.6 + 0.05 * np.sin(np.arange(ts.size) / 7.0) + 1e-4 * rng.standard_normal(ts.size)
    on_grid = np.nonzero(ts % 50_000_000 == 0)[0][::2]              # a second sample at some of them
    ts = np.insert(ts, on_grid + 1, ts[on_grid])
    v = np.insert(v, on_grid + 1, v[on_grid] + 1e-3)
    t = np.arange(ts[0] // 50_000_000 * 50_000_000, ts[-1], 50_000_000, dtype=np.int64)
    before, after, whole = angle_slopes(ts, v, t)
    for got, lo, hi in ((before, -HALF_WINDOW_NS, 0), (after, 0, HALF_WINDOW_NS),
                        (whole, -HALF_WINDOW_NS, HALF_WINDOW_NS)):
        ref = _polyfit_slope(ts, v, t, lo, hi)
        np.testing.assert_array_equal(np.isnan(got), np.isnan(ref))
        ok = ~np.isnan(ref)
        np.testing.assert_allclose(got[ok], ref[ok], rtol=1e-7, atol=1e-9)
    assert np.isin(t, ts).any() and np.isnan(before).any()


def test_the_grid_skips_long_stretches_without_data():
    """A log that resumes ten years later (a confirmed clock step): the grid covers the data,
    not the decade, and every instant that has data is aligned as without the step."""
    ten_years = np.int64(10 * 365 * 86400 * 10**9)
    sig = _signals()
    half = 5 * 10**9

    def shifted(s):
        t = s.t_ns.copy()
        t[t >= half] += ten_years
        return Series(t, s.value)
    jumped = {k: shifted(v) for k, v in sig.items()}
    a = build_observations(sig, 0.045)
    b = build_observations(jumped, 0.045)
    assert len(b) < len(a) + 100
    far = 2 * 10**9       # the windows reach across the cut up to about a second
    keep_a = np.abs(a.t_ns - half) > far
    keep_b = np.abs(np.where(b.t_ns > ten_years // 2, b.t_ns - ten_years, b.t_ns) - half) > far
    np.testing.assert_array_equal(a.direction[keep_a], b.direction[keep_b])
    np.testing.assert_array_equal(a.alpha[keep_a], b.alpha[keep_b])
    np.testing.assert_array_equal(a.force[keep_a], b.force[keep_b])


def test_data_grid_is_the_plain_grid_without_long_gaps():
    from steer_monitor.estimate.observe import data_grid
    ts = np.arange(0, 100 * 10**9, 10**8, dtype=np.int64) + 1_767_225_600 * 10**9
    np.testing.assert_array_equal(data_grid(ts, int(ts[0]), int(ts[-1]) + 1), grid_times(int(ts[0]), int(ts[-1]) + 1))


def _interp_numpy(series, t, max_gap, shift_ns=0):
    """The vectorized interpolation the compiled loop replaced: the oracle, to the bit."""
    out = np.full(t.shape, np.nan)
    if series is None or len(series) == 0:
        return out
    ts = series.t_ns - np.int64(shift_ns)
    v = series.value
    j = np.searchsorted(ts, t, side='right')
    inside = (j > 0) & (j < ts.size)
    exact = (j > 0) & (ts[np.maximum(j - 1, 0)] == t)
    jj = np.where(inside, j, 1)
    t0, t1 = ts[jj - 1], ts[np.minimum(jj, ts.size - 1)]
    ok = inside & ((t1 - t0) <= max_gap)
    w = np.where(ok, (t - t0) / np.where(t1 > t0, t1 - t0, 1), 0.0)
    val = v[jj - 1] + (v[np.minimum(jj, ts.size - 1)] - v[jj - 1]) * w
    out[ok] = val[ok]
    out[exact] = v[np.maximum(j - 1, 0)][exact]
    return out


@pytest.mark.parametrize('seed', range(6))
def test_the_compiled_interpolation_is_the_vectorized_one_to_the_bit(seed):
    """Irregular samples with gaps, repeated times and exact hits; points in order, out of
    order (the segments' ends), before, between and after the samples; shifted."""
    from steer_monitor.estimate.observe import interp_held
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 3000))
    steps = rng.choice([0, 50_000_000, 100_000_000, 400_000_000], size=n, p=[0.05, 0.45, 0.45, 0.05])
    ts = 1_767_225_600_000_000_000 + np.cumsum(steps + rng.integers(0, 3_000_000, n)).astype(np.int64)
    series = Series(ts, rng.normal(0.0, 0.3, n).cumsum())
    span = int(ts[-1] - ts[0]) + 2_000_000_000
    t = ts[0] - 1_000_000_000 + np.sort(rng.integers(0, span, 4000)).astype(np.int64)
    t = np.concatenate([t, ts[rng.integers(0, n, 500)], rng.permutation(t)[:1000]])
    for shift in (0, 250_000_000, -37_000_000):
        got = interp_held(series, t, 250_000_000, shift)
        ref = _interp_numpy(series, t, 250_000_000, shift)
        assert np.array_equal(np.isnan(got), np.isnan(ref))
        assert np.array_equal(got.view(np.int64)[~np.isnan(ref)], ref.view(np.int64)[~np.isnan(ref)])
    assert np.isnan(interp_held(Series(ts[:0], series.value[:0]), t, 250_000_000)).all()
    assert np.isnan(interp_held(None, t, 250_000_000)).all()


@pytest.mark.parametrize('seed', range(4))
def test_sorted_positions_and_in_sorted_are_numpys(seed):
    """The compiled walk gives numpy's searchsorted positions (both sides) and isin's
    booleans: keys in order, out of order, repeated, before and after every sample."""
    from steer_monitor.estimate.observe import in_sorted, sorted_positions
    rng = np.random.default_rng(seed)
    ts = np.sort(rng.integers(0, 10_000, int(rng.integers(0, 500)))).astype(np.int64)
    t = np.concatenate([np.sort(rng.integers(-100, 10_100, 800)), rng.integers(-100, 10_100, 200),
                        ts[:50]]).astype(np.int64)
    for right in (False, True):
        assert np.array_equal(sorted_positions(ts, t, right=right),
                              np.searchsorted(ts, t, side='right' if right else 'left'))
    assert np.array_equal(in_sorted(t, ts), np.isin(t, ts))
    assert np.array_equal(in_sorted(ts, np.unique(t)), np.isin(ts, t))


def _slow_signals(angle_hz: float, pressure_hz: float, seconds: float = 120.0, pause=None, seed: int = 0):
    """A rudder sweeping at 2 deg/s (``pause``: standing over (start, end) [s] instead), its angle
    at ``angle_hz`` and each pressure at ``pressure_hz`` on its own phase, white noise of 0.25
    bar on the pressures; the pressures hold 50 bar against 2 bar while the rudder moves."""
    rng = np.random.default_rng(seed)
    rate = np.radians(2.0)

    def angle(t):
        t = np.asarray(t, float)
        if pause is None:
            return rate * t
        a, b = pause
        return rate * (np.minimum(t, a) + np.maximum(t - b, 0.0))

    t_a = np.arange(0.0, seconds, 1.0 / angle_hz) + 0.011
    sig = {'rudder_angle': _series(t_a, angle(t_a))}
    for k, name in enumerate(('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')):
        t = np.arange(0.0, seconds, 1.0 / pressure_hz) + 0.013 + 0.37 * k / pressure_hz
        v = np.full(t.size, 50e5 if k % 2 == 0 else 2e5) + rng.normal(0, 0.25e5, t.size)
        if pause is not None:
            still = (t >= pause[0]) & (t <= pause[1])
            v[still] = 30e5 if k % 2 == 0 else 20e5
        sig[name] = _series(t, v)
    return sig


@pytest.mark.parametrize('angle_hz, pressure_hz', [(10.0, 20.0), (10.5, 19.0), (8.5, 17.0)])
def test_at_the_design_rates_nothing_is_scaled(angle_hz, pressure_hz):
    w = Windows.of(_slow_signals(angle_hz, pressure_hz, 20.0))
    assert w.design and w.step_ns == GRID_NS
    assert w.angle_period_ns == pytest.approx(1e9 / angle_hz, rel=2e-3)


@pytest.mark.parametrize('angle_hz, pressure_hz', [(2.0, 20.0), (10.0, 5.0), (2.0, 5.0), (0.5, 0.5), (1.0, 2.0)])
def test_a_slow_input_is_read_over_its_own_period(angle_hz, pressure_hz):
    """Steady motion through slowly sampled inputs: rows one pressure period apart, the angle
    at each row the sweep's, the force the pressures' (their noise within 4 sigma of a mean
    of interpolated samples)."""
    obs = build_observations(_slow_signals(angle_hz, pressure_hz), 0.045)
    w = Windows.of(_slow_signals(angle_hz, pressure_hz))
    rows = obs.t_ns[obs.moving]
    step = obs.step_ns
    if pressure_hz < 20.0:      # a row per period, on the ladder: at most a fifth more
        assert 1e9 / pressure_hz <= step <= 1.2e9 / pressure_hz + GRID_NS
    else:
        assert step == GRID_NS
    assert np.all(np.diff(rows) % step == 0)
    assert rows.size >= 0.7 * 120.0 / (step / 1e9)
    t = (obs.t_ns[obs.moving] - 0) / 1e9
    assert np.allclose(obs.alpha[obs.moving], np.radians(2.0) * t, atol=1e-9)
    assert np.all(np.abs(obs.force[obs.moving] - 0.045 * 48e5) < 0.045 * 4 * 0.25e5 * np.sqrt(2))
    assert w.angle_gap_ns >= 2.5e9 / angle_hz - 1 and w.pressure_gap_ns >= 2.5e9 / pressure_hz - 1


@pytest.mark.parametrize('angle_hz, pressure_hz', [(2.0, 5.0), (0.5, 0.5), (10.0, 1.0)])
def test_no_row_where_a_slowly_sampled_rudder_may_have_stopped(angle_hz, pressure_hz):
    """The rudder stands from 49.5 s to 59.5 s: no steady row from a slow sample's reach before
    the stop to after the start (the pressures interpolated there would mix the two)."""
    obs = build_observations(_slow_signals(angle_hz, pressure_hz, pause=(49.5, 59.5)), 0.045)
    t = obs.t_ns[obs.moving] / 1e9
    reach = 1.0 / min(angle_hz, pressure_hz)
    assert not np.any((t > 49.5 - reach) & (t < 59.5 + reach))
    assert np.any(t < 49.5 - reach) and np.any(t > 59.5 + reach)


def test_the_sensor_noise_of_slow_rows_is_not_read_as_systematic():
    """White noise on pressures at 5 Hz, interpolated to rows one period apart: neighbouring
    rows share a sample, so their noise correlates; read two periods apart it does not, and the
    smooth part of a pure-noise residual is nil."""
    from steer_monitor.estimate.batch import residual_parts
    obs = build_observations(_slow_signals(10.0, 5.0, 600.0, seed=3), 0.045)
    m = obs.moving
    resid = np.where(m[:, None], obs.force - 0.045 * 48e5, np.nan)
    noise, smooth = residual_parts(resid[m], obs.t_ns[m], obs.step_ns)
    assert smooth < 0.1 * noise


def test_what_one_slow_angle_sample_puts_into_several_rows_is_not_read_as_systematic():
    """The angle at 2 Hz, the pressures at 5 Hz: rows 200 ms apart, each angle sample's error
    (its noise, how stale a gateway sent it) interpolated into the rows of a second. A residual
    made only of that is noise: read two angle periods apart its smooth part is nil, where two
    pressure periods apart (400 ms, the rows still sharing a sample) it would pass for half of
    it and more."""
    from steer_monitor.estimate.batch import residual_parts
    w = Windows.of(_slow_signals(2.0, 5.0))
    assert w.shared_ns == w.angle_period_ns and w.shared_ns > w.step_ns
    assert Windows.of(_slow_signals(10.0, 20.0)).shared_ns == GRID_NS
    rng = np.random.default_rng(11)
    t_rows = np.arange(0, 3600 * 10**9, w.step_ns, dtype=np.int64)
    knots = np.arange(0, 3601 * 10**9, w.angle_period_ns, dtype=np.int64)
    resid = np.stack([np.interp(t_rows, knots, rng.normal(0.0, 1.0, knots.size)) for _ in range(2)], axis=1)
    noise, smooth = residual_parts(resid, t_rows, w.step_ns, w.shared_ns)
    assert smooth < 0.1 * noise
    noise_p, smooth_p = residual_parts(resid, t_rows, w.step_ns)
    assert smooth_p > 0.5 * noise_p


def test_a_gateway_s_copies_of_a_reading_do_not_make_a_moving_rudder_stand():
    """A gateway holding the last reading of a 10 Hz rudder sensor and sending it at 15 Hz (the
    pressures at 5 Hz): every other reading goes out twice, a staircase whose treads read as
    standing. Its copies dropped, the steady motion is the 10 Hz log's; a rudder at rest
    repeating one reading keeps a sample every design period at least."""
    sig = _slow_signals(10.0, 5.0)
    src = sig['rudder_angle']
    ticks = np.arange(int(src.t_ns[0]) + 7_000_000, int(src.t_ns[-1]), 66_666_667, dtype=np.int64)
    k = np.searchsorted(src.t_ns, ticks, 'right') - 1
    held = dict(sig, rudder_angle=_series(ticks / 1e9, src.value[k]))
    direct = build_observations(sig, 0.045).moving.sum()
    assert build_observations(held, 0.045).moving.sum() >= 0.9 * direct
    from steer_monitor.estimate.observe import DESIGN_ANGLE_PERIOD_NS, fresh_readings
    # each reading once (a run at either end of the log, with nothing beyond it, is kept)
    assert np.unique(k).size <= fresh_readings(held['rudder_angle']).t_ns.size <= np.unique(k).size + 2
    rest = _series(np.cumsum(np.random.default_rng(2).uniform(0.09, 0.11, 600)), np.full(600, 0.1))
    assert fresh_readings(rest) is rest
    # stops where the rudder turns back, or stands longer than a period, keep their samples
    t = np.arange(12) * 0.1
    for v in ([0, 1, 2, 2, 1, 0, 0, 0, 0, 0, 0, 1], [0, 1, 2, 2, 2, 2, 2, 3, 4, 5, 6, 7]):
        s = _series(t, np.asarray(v, float))
        assert fresh_readings(s, DESIGN_ANGLE_PERIOD_NS) is s
    copies = _series(np.array([0.0, 0.1, 0.166, 0.2, 0.3]), np.array([0.0, 1.0, 1.0, 2.0, 3.0]))
    assert np.array_equal(fresh_readings(copies).value, [0.0, 1.0, 2.0, 3.0])


@pytest.mark.parametrize('angle_hz, pressure_hz, excluded', [(2.0, 5.0, True), (10.0, 20.0, False)])
def test_rows_a_slow_sample_time_cannot_resolve_are_left_out(angle_hz, pressure_hz, excluded):
    """The starboard pressures climbing 10 bar/s from 30 s to 60 s: a timing error of one
    period (0.5 s at 2 Hz: 5 bar) is more than TIMING_PA, so no row there; where the force
    holds, rows. At the design rates the stamps are trusted and nothing is left out."""
    from steer_monitor.estimate.observe import TIMING_PA
    sig = _slow_signals(angle_hz, pressure_hz)
    for name in ('pressure_r1_stbd', 'pressure_r2_stbd'):
        s = sig[name]
        t = s.t_ns / 1e9
        sig[name] = _series(t, s.value + 10e5 * np.clip(t - 30.0, 0.0, 30.0))
    obs = build_observations(sig, 0.045)
    t = obs.t_ns[obs.moving] / 1e9
    climbing = (t > 31.0) & (t < 59.0)
    assert TIMING_PA < 10e5 * 0.5
    assert climbing.any() != excluded and (t < 29.0).any() and (t > 61.0).any()
