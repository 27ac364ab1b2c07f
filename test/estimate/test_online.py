"""The online estimator: the batch answer on the same data, bounded memory, idle safety,
restart from disk, and the errors of a bad state file."""

from __future__ import annotations

from pathlib import Path

import pytest

from steer_monitor.can.decoder import Decoder, Sample
from steer_monitor.errors import OutputError
from steer_monitor.estimate.batch import estimate_clearances, make_rows
from steer_monitor.estimate.observe import EstimateError, build_observations
from steer_monitor.estimate.online import KEEP_NS, OnlineEstimator
from steer_monitor.model.gear import GearParams
from test.conftest import fill


def _feed(est, sim, db, smap, every=100):
    dec = Decoder(db, smap)
    updates = 0
    for i in range(len(sim.frames)):
        for s in dec.decode(sim.frames.frame(i)):
            est.add(s)
        if i % every == 0:
            updates += est.update()
    return updates


@pytest.fixture(scope='module')
def hard_over(simulate_signals):
    return simulate_signals('hard_over_2,hold:20,zigzag_20', 0.6, 0.25, max_s=160.0)


def test_online_converges_to_the_batch_estimate(r18, db, smap, hard_over):
    signals, sim = hard_over
    est = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    updates = _feed(est, sim, db, smap)
    # an estimate after every processed second with motion in it, once 5 s of motion are in
    assert updates >= 0.9 * (est.motion_s - 6)
    est.refit(full=True)
    obs = build_observations(signals, r18.ram_area, end_ns=est._done_ns)
    batch = estimate_clearances(r18, obs, make_rows(obs), grid_2z=est.grid_2z)
    assert est.moments.samples == batch.rows
    assert est.estimate.z_gb.value == batch.z_gb.value and est.estimate.two_z.value == batch.two_z.value
    assert est.estimate.z_gb.lo == pytest.approx(batch.z_gb.lo, abs=2e-6)
    # bounded memory: raw samples are kept for a few seconds only
    for buf in est._buf.values():
        if len(buf) > 2:
            assert buf[-1][0] - buf[1][0] <= KEEP_NS + 2_000_000_000 + 1


@pytest.mark.parametrize('effect', [None, 'ram_bypass:ram=1,start_s=200,end_s=500'])
def test_nothing_is_learned_while_a_ram_does_not_carry_its_share(r18, db, smap, simulate_signals, effect):
    """A programme and seed of their own (zig-zags then an autopilot, seed 23): ram 1's chambers
    joined from 200 to 500 s. The estimator folds the motion before and after, not the
    fault's: to the half minute of motion its window takes to see the fault come, and go."""
    program = 'zigzag_10,zigzag_20,autopilot:300,zigzag_15,zigzag_10'
    signals, s = simulate_signals(program, 0.5, 0.2, (effect,) if effect else (), seed=23)
    est = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    _feed(est, s, db, smap, every=400)
    obs = build_observations(signals, r18.ram_area)
    t = (obs.t_ns[obs.moving] - s.plant.start_ns) / 1e9
    in_fault = float(((t >= 200) & (t < 500)).sum()) * 0.05       # seconds of steady motion in it
    if effect is None:
        assert est.uneven_s == 0.0
        return
    assert in_fault - 30 <= est.uneven_s <= in_fault + 30
    clean = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    _feed(clean, simulate_signals(program, 0.5, 0.2, (), seed=23)[1], db, smap, every=400)
    assert est.motion_s == pytest.approx(clean.motion_s - est.uneven_s, abs=1.0)


def test_no_update_while_the_rudder_rests(r18, db, smap, simulate_signals):
    _, sim = simulate_signals('hold:60', 0.6, 0.25)
    est = OnlineEstimator(r18)
    assert _feed(est, sim, db, smap) == 0
    assert len(est.moments) == 0 and est.estimate is None and est.motion_s == 0.0


def test_state_survives_a_restart(r18, db, smap, hard_over, tmp_path):
    _, sim = hard_over
    est = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    _feed(est, sim, db, smap)
    path = est.save(tmp_path / 'state.npz')
    again = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    again.load(path)
    assert again.moments.samples == est.moments.samples
    assert again.estimate is not None and again.estimate.z_gb.value == pytest.approx(est.estimate.z_gb.value, abs=5e-6)
    assert not list(tmp_path.glob('*.tmp*'))   # written atomically


def test_a_stream_restarted_at_an_earlier_time_keeps_what_was_learned_and_learns_on(r18, db, smap, hard_over):
    """The node's restart in place after its clock was set back: the learned moments and the
    estimate stay; the stream's samples and time are forgotten, so the same manoeuvres an
    hour earlier are learned again (before, every sample earlier than the last was ignored)."""
    import types

    from steer_monitor.can import FrameArrays
    _, sim = hard_over
    est = OnlineEstimator(r18, min_clearance_2z=0.05e-3)
    _feed(est, sim, db, smap)
    samples, motion, estimate = est.moments.samples, est.motion_s, est.estimate
    est.restart_stream()
    assert est.moments.samples == samples and est.motion_s == motion and est.estimate is estimate
    assert all(not buf for buf in est._buf.values())
    earlier = FrameArrays(sim.frames.t_ns - 3600 * 10**9, sim.frames.can_id, sim.frames.dlc, sim.frames.data,
                          sim.frames.flags)
    _feed(est, types.SimpleNamespace(frames=earlier), db, smap)
    assert est.moments.samples == 2 * samples and est.motion_s == pytest.approx(2 * motion)


def test_a_state_the_disk_cannot_take_is_refused_whole(r18, db, smap, hard_over, small_tmpfs):
    """A full disk: OutputError naming the path and the reason; the state saved before stays
    as it was, and no temporary file is left beside it."""
    _, sim = hard_over
    est = OnlineEstimator(r18)
    path = est.save(small_tmpfs / 'state.npz')
    before = path.read_bytes()
    _feed(est, sim, db, smap)          # learned more: a larger state than the one on disk
    fill(small_tmpfs)
    with pytest.raises(OutputError, match=r'cannot write .*state\.npz: No space left on device'):
        est.save(path)
    assert path.read_bytes() == before
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ['filler.bin', 'state.npz']


def test_state_of_another_gear_is_refused_and_nothing_is_lost(r18, db, smap, hard_over, tmp_path):
    _, sim = hard_over
    est = OnlineEstimator(r18)
    _feed(est, sim, db, smap)
    path = est.save(tmp_path / 'state.npz')
    import dataclasses
    other = OnlineEstimator(dataclasses.replace(r18, stock_to_ram=0.7))
    with pytest.raises(EstimateError, match='another gear geometry'):
        other.load(path)
    assert len(other.moments) == 0
    (tmp_path / 'broken.npz').write_bytes(b'not a state')
    with pytest.raises(EstimateError, match='cannot read it'):
        est.load(tmp_path / 'broken.npz')
    assert est.moments.samples > 0


@pytest.fixture(scope='module')
def saved_state(r18, db, smap, hard_over, tmp_path_factory):
    _, sim = hard_over
    est = OnlineEstimator(r18)
    _feed(est, sim, db, smap)
    return est.save(tmp_path_factory.mktemp('state') / 'state.npz')


def test_a_state_file_damaged_on_disk_is_refused(r18, saved_state, tmp_path):
    """Bytes flipped anywhere in the file (zipfile's BadZipFile, numpy's header errors...
    came out of load raw, and stopped the node at start): EstimateError every time."""
    import random
    data = saved_state.read_bytes()
    for seed in range(60):
        b = bytearray(data)
        rng = random.Random(seed)
        for _ in range(3):
            b[rng.randrange(len(b))] ^= 0xFF
        (tmp_path / 'flipped.npz').write_bytes(bytes(b))
        est = OnlineEstimator(r18)
        with pytest.raises(EstimateError, match=r'estimator state .*flipped\.npz: (cannot read it|damaged)'):
            est.load(tmp_path / 'flipped.npz')
        assert len(est.moments) == 0 and est.estimate is None


def _rewritten(saved: Path, out: Path, **changes) -> Path:
    import json
    import numpy as np
    with np.load(saved) as d:
        arrays = {k: d[k] for k in d.files}
    meta = json.loads(str(arrays['meta']))
    for k, v in changes.items():
        if k.startswith('meta_'):
            meta[k[5:]] = v
        else:
            arrays[k] = v
    arrays['meta'] = np.array(json.dumps(meta))
    np.savez(out, **arrays)
    return out


@pytest.mark.parametrize('changes,message', [
    ({'keys': [[1, 2], [3, 4]]}, r'keys has shape \(2, 2\)'),
    ({'count': [1.0, 2.0]}, r'count has shape \(2,\), expected'),
    ({'scatter': [0.0]}, r'scatter has shape \(1,\)'),
    ({'z_names': ['torque']}, r"moments of columns \['torque'\]"),
    ({'coef': [1.0, 2.0]}, r'fitted coefficients of shape \(2,\)'),
    ({'meta_point': [0.1, 0.0]}, r'best point 2Z 100 mm, Z_gb 0 mm outside the grid'),
    ({'meta_steps': [0.0, 1e-6]}, r'local steps \[0.0, 1e-06\] m must be positive'),
    ({'meta_steps': [1e-3, 1e-6]}, r'at most the grid steps'),
    ({'meta_version': 2, 'meta_best': [99999, 0]}, r'best grid point \(99999, 0\) outside the grid'),
    ({'meta_version': 1}, r'format version 1, this build reads 2 or 3'),
    ({'meta_vif': -1.0}, r'must be finite and not negative'),
    ({'meta_motion_s': 'a lot'}, r'could not convert string to float'),
    ({'meta_estimate': {'two_z': 1}}, r'damaged'),
])
def test_a_state_file_that_parses_but_does_not_fit_is_refused(r18, saved_state, tmp_path, changes, message):
    """Loaded before, these failed later, in a refit on the node's estimator thread."""
    import numpy as np
    changes = {k: (np.asarray(v) if not k.startswith('meta_') else v) for k, v in changes.items()}
    path = _rewritten(saved_state, tmp_path / 'odd.npz', **changes)
    est = OnlineEstimator(r18)
    with pytest.raises(EstimateError, match=message):
        est.load(path)
    assert len(est.moments) == 0 and est.estimate is None
    est.load(saved_state)                      # the file as saved loads
    assert len(est.moments) > 0 and est.estimate is not None


def test_a_state_of_the_last_format_is_taken(r18, saved_state, tmp_path):
    """A node upgraded from a build that kept the best point as grid indices (format 2)
    keeps what it learned: the point is the grid's, the local steps the grid's steps."""
    import numpy as np
    from steer_monitor.estimate import fit as F
    new = OnlineEstimator(r18)
    new.load(saved_state)
    i, j = int(np.argmin(np.abs(F.GRID_2Z - new._point[0]))), int(np.argmin(np.abs(F.GRID_ZGB - new._point[1])))
    path = _rewritten(saved_state, tmp_path / 'v2.npz', meta_version=2, meta_best=[i, j], meta_point=None,
                      meta_steps=None)
    old = OnlineEstimator(r18)
    old.load(path)
    assert old._point == (float(F.GRID_2Z[i]), float(F.GRID_ZGB[j]))
    assert old._steps == pytest.approx((0.02e-3, 0.005e-3))
    assert old.estimate == new.estimate and old.moments.samples == new.moments.samples
    assert old.refit(full=False) in (True, False)           # a local step from there runs


def test_out_of_order_and_unused_samples_are_ignored(r18: GearParams):
    est = OnlineEstimator(r18)
    est.add(Sample(2_000_000_000, 'rudder_angle', 0.1))
    est.add(Sample(1_000_000_000, 'rudder_angle', 0.2))
    est.add(Sample(3_000_000_000, 'rudder_order', 0.2))
    assert [t for t, _ in est._buf['rudder_angle']] == [2_000_000_000]
    assert not est.update()


def test_the_point_stays_inside_its_interval(r18_params, r18, can_db):
    """A local step that leaves the last full profile's interval profiles again: the point
    the node shows is never outside the interval it shows with it (a 52 s hard-over had
    Z_gb 0.19 mm against [0.229, 0.282] before)."""
    from steer_monitor import sim as simulator
    from steer_monitor.params import min_clearance_2z_from_params
    db, smap = can_db
    frames = simulator.run(r18_params, simulator.SimConfig(program='hard_over_2', max_duration_s=52.0),
                           db, smap, seed=3).frames.frames()
    dec = Decoder(db, smap)
    est = OnlineEstimator(r18, min_clearance_2z=min_clearance_2z_from_params(r18_params))
    nxt = (frames[0].t_ns // 10**9 + 1) * 10**9
    checked = 0
    for f in frames:
        while f.t_ns >= nxt:
            if est.update():
                e = est.estimate
                for iv in (e.two_z, e.z_gb):
                    assert (iv.lo is None or iv.value >= iv.lo - 1e-12) and (iv.hi is None or iv.value <= iv.hi + 1e-12)
                checked += 1
            nxt += 10**9
        for s in dec.decode(f):
            est.add(s)
    assert checked > 10
    assert est.estimate.z_gb.contains(0.25e-3)
    # local steps wander on the flat profile of 52 s of data; the full profile lands near
    est.refit(full=True)
    assert est.estimate.z_gb.value == pytest.approx(0.25e-3, abs=0.03e-3)
