"""The rams' shares of the driving force: the closed form against a least-squares fit of
each ram's force on the mean force, offsets and noise, moments merged, the judgement."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.estimate.rams import (
    AT_EDGE,
    EVEN,
    IDLE,
    MIN_SHARE_INSTANTS,
    OPPOSED,
    UNEVEN,
    UNJUDGED,
    RamShare,
    ShareMoments,
    judge,
    opposed_cause,
    ram_share,
    share_moments,
    share_of_moments,
    weak_ram_cause,
    working_against,
)
from test.support.rams import AREA, BAR, ram_forces


@pytest.mark.parametrize('share1', [0.0, 0.1, 0.35, 0.5, 0.62, 1.0])
@pytest.mark.parametrize('offset_bar', [0.0, 3.5, -20.0])
def test_the_closed_form_is_the_least_squares_fit(share1, offset_bar):
    """Independently: f1 - f2 fitted on [1, (f1 + f2) / 2] by numpy's lstsq (SVD); the share is
    1/2 + slope/4, its standard error from the same fit."""
    f = ram_forces(share1, offset_bar=offset_bar)
    sh = ram_share(f)
    m, d = f.mean(axis=1), f[:, 0] - f[:, 1]
    x = np.stack([np.ones_like(m), m], axis=1)
    coef, rss, *_ = np.linalg.lstsq(x, d, rcond=None)
    cov = rss[0] / (m.size - 2) * np.linalg.inv(x.T @ x)
    assert sh.share[0] == pytest.approx(0.5 + coef[1] / 4, abs=1e-12)
    assert sum(sh.share) == pytest.approx(1.0, abs=1e-15)
    assert sh.offset == pytest.approx(coef[0], rel=1e-9, abs=1e-6 * BAR)
    assert sh.se == pytest.approx(np.sqrt(cov[1, 1]) / 4, rel=1e-8)
    assert sh.instants == m.size and sh.spread == pytest.approx(m.std(), rel=1e-12)
    # and it finds the share, whatever the offset: a constant is not a share
    assert sh.share[0] == pytest.approx(share1, abs=4 * sh.se + 1e-9)
    # the intercept: f1 - f2 where their mean is 0, which the offset moves too
    assert sh.offset / BAR == pytest.approx(offset_bar * (2 - 2 * share1), abs=0.1)


def test_the_noise_does_not_bias_the_share():
    """Over 200 noisy logs of an even share with small loads (3 bar against 0.35 bar of noise per
    transducer) the mean share is 1/2 within its standard error, and the stated standard error
    is the scatter's."""
    shares = []
    for seed in range(200):
        f = ram_forces(0.5, n=400, seed=seed) * (3 / 40)    # the load scaled; the noise too, so add it again
        rng = np.random.default_rng(1000 + seed)
        f += AREA * 0.35e5 * (rng.normal(size=(400, 2)) * np.sqrt(2))
        shares.append(ram_share(f))
    s = np.array([x.share[0] for x in shares])
    se = np.mean([x.se for x in shares])
    assert abs(s.mean() - 0.5) < 3 * s.std() / np.sqrt(s.size)
    assert s.std() == pytest.approx(se, rel=0.15)


@pytest.mark.parametrize('force, why', [
    (np.zeros((2, 2)), 'two rows'),
    (np.full((50, 2), 1e5), 'a load that does not vary'),
    (np.full((50, 2), np.nan), 'no finite row'),
])
def test_no_share_without_rows_that_say(force, why):
    assert ram_share(force) is None, why


def test_rows_with_a_missing_force_are_left_out():
    f = ram_forces(0.3, n=500)
    g = f.copy()
    g[::7, 1] = np.nan
    assert ram_share(g).share[0] == pytest.approx(ram_share(f[np.isfinite(g).all(axis=1)]).share[0], abs=1e-15)
    assert ram_share(g).instants == np.isfinite(g).all(axis=1).sum()


@pytest.mark.parametrize('share1, n, spread_bar, se, verdict', [
    (0.50, 2000, 10.0, 0.002, EVEN),
    (0.40, 2000, 10.0, 0.002, EVEN),       # 10 points off: within the 15
    (0.30, 2000, 10.0, 0.002, UNEVEN),
    (0.72, 2000, 10.0, 0.002, UNEVEN),     # ram 2 the weaker
    (0.05, 2000, 10.0, 0.002, IDLE),
    (0.12, 2000, 10.0, 0.002, UNEVEN),     # under a tenth only within its interval: not idle
    (0.95, 2000, 10.0, 0.002, IDLE),
    (0.05, MIN_SHARE_INSTANTS - 1, 10.0, 0.002, UNJUDGED),
    (0.05, 2000, 0.9, 0.002, UNJUDGED),    # the load hardly varied
    (0.05, 2000, 10.0, 0.02, UNJUDGED),    # +-8 points: wider than half the warning
    (0.33, 2000, 10.0, 0.006, AT_EDGE),    # 17 points off, but 2.4 of them uncertain: straddles 15
    (0.37, 2000, 10.0, 0.006, AT_EDGE),    # 13 points off, 2.4 uncertain: straddles it the other way
    (0.38, 2000, 10.0, 0.006, EVEN),       # 12 points, 2.4 uncertain: wholly within 15
    (0.33, 2000, 10.0, 0.004, UNEVEN),     # 1.6 of them: past 15
])
def test_judgement_on_the_interval(share1, n, spread_bar, se, verdict):
    sh = RamShare((share1, 1 - share1), se, spread_bar * BAR, 0.0, n)
    assert judge(sh, 0.15, AREA) == verdict
    assert judge(None, 0.15, AREA) == UNJUDGED


NAMES = ('pressure_r1_stbd', 'pressure_r1_port', 'pressure_r2_stbd', 'pressure_r2_port')


def _chambers(weak: int, kind: str, n: int = 1200, seed: int = 3):
    """The four pressures [Pa] (n, 4) of a gear under a load sweeping +-40 bar per ram, the
    ram ``weak`` (0 or 1) at fault: 'joined' (its chambers at the return line), 'stuck'
    (its starboard chamber's transducer reading 0.2 bar), 'half' (carrying half its force)."""
    rng = np.random.default_rng(seed)
    load = 40e5 * np.sin(np.linspace(0, 9, n))       # each ram's pressure difference on an even share
    dp = [load.copy(), load.copy()]
    if kind == 'joined':
        dp[weak], dp[1 - weak] = 0 * load, 2 * load
    elif kind == 'half':
        dp[weak], dp[1 - weak] = 0.5 * load, 1.5 * load
    p = np.empty((n, 4))
    for r in (0, 1):
        p[:, 2 * r] = 2e5 + np.maximum(dp[r], 0)
        p[:, 2 * r + 1] = 2e5 + np.maximum(-dp[r], 0)
    if kind == 'stuck':
        p[:, 2 * weak] = 0.2e5
    return p + rng.normal(0, 0.35e5, p.shape)


@pytest.mark.parametrize('weak', [0, 1])
@pytest.mark.parametrize('kind, text', [
    ('joined', 'its two chambers read the same pressure ({ret} and {ret} bar): joined, a bypass or isolating '
               'valve open on ram {ram}'),
    ('stuck', 'pressure_r{ram}_stbd stays at 0.2 bar while the load moves the other chamber: that transducer, or '
              'its wiring, not reading'),
    ('half', 'a bypass or isolating valve open on ram {ram}, or a pressure transducer of either ram not reading '
             'its chamber'),
])
def test_what_the_weak_ram_s_chambers_say(weak, kind, text):
    p = _chambers(weak, kind)
    f = np.stack([AREA * (p[:, 0] - p[:, 1]), AREA * (p[:, 2] - p[:, 3])], axis=1)
    sh = ram_share(f)
    assert sh.weaker == weak
    assert weak_ram_cause(p, weak, NAMES) == text.format(ram=weak + 1, ret='2.0')


def test_no_cause_without_a_load_to_judge_by():
    p = np.full((100, 4), 2e5)
    assert weak_ram_cause(p, 0, NAMES).startswith('a bypass or isolating valve open on ram 1, or')
    assert weak_ram_cause(p[:2], 1, NAMES).startswith('a bypass or isolating valve open on ram 2, or')


@pytest.mark.parametrize('share1', [0.0, 0.35, 0.5, 1.0])
@pytest.mark.parametrize('offset_bar', [0.0, 3.5])
def test_the_correlation_is_numpy_s(share1, offset_bar):
    f = ram_forces(share1, offset_bar=offset_bar)
    assert ram_share(f).correlation == pytest.approx(np.corrcoef(f[:, 0], f[:, 1])[0, 1], abs=1e-12)


@pytest.mark.parametrize('share1', [0.5, 0.3, 0.7])
def test_a_ram_read_the_wrong_way_round_is_opposed_not_a_share(share1):
    """One ram's starboard and port pressures swapped: its force is the negative of what it
    does; before, the shares read -79 % / 179 % of nothing in particular (the mean force
    hardly varies) and no judgement was made. Two sound rams, one idle, or uneven, never."""
    f = ram_forces(share1)
    for ram in (0, 1):
        g = f.copy()
        g[:, ram] *= -1
        sh = ram_share(g)
        assert sh.correlation < -0.95 and judge(sh, 0.15, AREA) == OPPOSED
        assert judge(ram_share(g[:MIN_SHARE_INSTANTS - 1]), 0.15, AREA) == UNJUDGED
    for s in (0.0, 0.1, 0.35, 0.5, 1.0):
        assert judge(ram_share(ram_forces(s)), 0.15, AREA) != OPPOSED


def test_the_ram_working_against_the_motion_is_named():
    """Friction makes each sound ram do positive work over motion to and fro: the reversed
    one's is negative."""
    n = 4000
    t = np.linspace(0, 40 * np.pi, n)
    rate = np.cos(t)                                   # to and fro
    load = 30 * BAR * np.sin(t) + 8 * BAR * np.sign(rate)  # a spring (the rudder's torque) and friction
    f = np.stack([load, load], axis=1) + np.random.default_rng(3).normal(0, 0.5 * BAR, (n, 2))
    assert working_against(f, rate) is None
    for ram in (0, 1):
        g = f.copy()
        g[:, ram] *= -1
        assert working_against(g, rate) == ram
    assert working_against(-f, rate) is None           # both: not one ram's map
    words = opposed_cause(ram_share(f * [1, -1]), 0, ('r1s', 'r1p', 'r2s', 'r2p'))
    assert words.startswith('the rams push against each other (their forces correlate at -1.00 over 4000 instants')
    assert 'of ram 1 are read the wrong way round: r1s and r1p swapped in the signals map' in words
    assert 'of one ram are read the wrong way round: r1s and r1p or r2s and r2p swapped' in \
        opposed_cause(ram_share(f * [1, -1]), None, ('r1s', 'r1p', 'r2s', 'r2p'))


def test_moments_merged_are_the_moments_of_the_whole():
    """Chan, Golub and LeVeque's pairwise merge against the moments of all the rows at once
    (each centred sum to about n epsilons of its terms: 1e-9 relative here)."""
    f = ram_forces(0.3, n=5000, offset_bar=3.5)
    whole = share_moments(f)
    rng = np.random.default_rng(2)
    cuts = np.sort(rng.choice(np.arange(1, 5000), 6, replace=False))
    merged = ShareMoments.empty()
    for part in np.split(f, cuts):
        merged = merged + share_moments(part)
    for name in ('m', 'd', 'f1', 'f2', 'smm', 'smd', 'sdd', 's11', 's22', 's12'):
        want = getattr(whole, name)
        assert getattr(merged, name) == pytest.approx(want, rel=1e-9, abs=1e-9 * abs(whole.smm) ** 0.5), name
    assert merged.n == whole.n == 5000
    assert share_of_moments(merged).share[0] == pytest.approx(ram_share(f).share[0], abs=1e-12)
