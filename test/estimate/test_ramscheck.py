"""The one rams check: windows, the level's hysteresis, stretches and their ends, fed in pieces
as the node and report feed it or at once as analyze does."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.estimate.rams import EVEN, IDLE, UNEVEN, UNJUDGED, ram_share
from steer_monitor.estimate.ramscheck import EDGE_STEP, RamsCheck, uneven_spans, within
from test.support.rams import AREA, ram_forces


def test_a_stretch_of_a_log_where_one_ram_was_bypassed():
    n = 6000
    t = np.arange(n, dtype=np.int64) * 50_000_000 + 1_700_000_000_000_000_000
    f = ram_forces(0.5, n=n)
    bad = slice(2400, 3600)                      # 60 s of motion, ram 2 carrying nothing
    f[bad] = ram_forces(1.0, n=n)[bad]
    spans = uneven_spans(t, f, 0.15, AREA)
    assert len(spans) == 1
    sp = spans[0]
    assert (sp.ram, sp.idle) == (1, True)
    assert (sp.start_ns, sp.end_ns) == (t[2400], t[3599])
    assert sp.share == pytest.approx(0.0, abs=0.01) and sp.instants == 1200
    assert uneven_spans(t, ram_forces(0.5, n=n), 0.15, AREA) == []
    assert uneven_spans(t[:100], f[:100], 0.15, AREA) == []         # too short to judge
    exact = ram_forces(0.5, n=n, noise_bar=0.0)
    exact[bad] = ram_forces(1.0, n=n, noise_bar=0.0)[bad]
    spans = uneven_spans(t, exact, 0.15, AREA)                      # no noise: the windows' own ends
    assert [(sp.start_ns, sp.end_ns, sp.ram, sp.share) for sp in spans] == [(t[2400], t[3599], 1, 0.0)]


def _log_with_stretches(n=9000, seed=4):
    """Instants 50 ms apart (n,) and the rams' forces (n, 2) [N]: even, ram 2 idle over
    [2100, 3450), even, ram 1 carrying a quarter over [5230, 7390), even."""
    t = np.arange(n, dtype=np.int64) * 50_000_000 + 1_700_000_000_000_000_000
    sweep = 0.05 * n           # a load cycle every 6 s of steady motion (an autopilot's to and fro)
    f = ram_forces(0.5, n=n, seed=seed, sweep=sweep)
    f[2100:3450] = ram_forces(1.0, n=n, seed=seed + 1, sweep=sweep)[2100:3450]
    f[5230:7390] = ram_forces(0.25, n=n, seed=seed + 2, sweep=sweep)[5230:7390]
    return t, f


def test_the_check_fed_in_pieces_is_the_check_fed_at_once():
    """The node feeds a few instants a second, report a block at a time, analyze the whole log:
    the same stretches, the same windows, to the bit."""
    t, f = _log_with_stretches()
    whole = RamsCheck(0.15, AREA)
    whole.feed(t, f)
    want = whole.finish()
    assert [(sp.ram, sp.idle) for sp in want] == [(1, True), (0, False)]
    rng = np.random.default_rng(8)
    for _ in range(5):
        check, k, seen = RamsCheck(0.15, AREA), 0, []
        while k < t.size:
            step = int(rng.integers(1, 1500))
            check.feed(t[k:k + step], f[k:k + step])
            seen.append(check.last)
            k += step
        assert check.finish() == want
        assert check.last == whole.last


def test_a_stretch_s_share_is_that_of_its_instants():
    """The share of a stretch over many windows, merged window by window, against the share fitted
    over its instants at once (the pairwise merge is exact in exact arithmetic: to 1e-12)."""
    t, f = _log_with_stretches()
    for sp in uneven_spans(t, f, 0.15, AREA):
        inside = (t >= sp.start_ns) & (t <= sp.end_ns)
        direct = ram_share(f[inside])
        assert sp.instants == direct.instants
        assert sp.share == pytest.approx(direct.share[sp.ram], abs=1e-12)


def test_a_stretch_s_ends_are_found_to_a_step():
    """Ends inside windows: each found within one EDGE_STEP of where the fault began and ended."""
    t, f = _log_with_stretches()
    got = [(int((sp.start_ns - t[0]) // 50_000_000), int((sp.end_ns - t[0]) // 50_000_000))
           for sp in uneven_spans(t, f, 0.15, AREA)]
    for (a, b), (a0, b0) in zip(got, [(2100, 3449), (5230, 7389)]):
        assert abs(a - a0) <= EDGE_STEP and abs(b - b0) <= EDGE_STEP, got


def test_rows_the_check_has_settled_never_change_side():
    """What ``report`` relies on: rows before ``unsettled_from`` are in a stretch (or not) as the
    finished check has them."""
    t, f = _log_with_stretches()
    final = within(t, uneven_spans(t, f, 0.15, AREA))
    for step in (600, 700, 450):
        check = RamsCheck(0.15, AREA)
        for k in range(0, t.size, step):
            check.feed(t[k:k + step], f[k:k + step])
            cut = check.unsettled_from()
            settled = t < cut if cut is not None else np.ones(t.size, bool)
            settled[k + step:] = False
            np.testing.assert_array_equal(check.excluded(t)[settled], final[settled])


def test_a_bypass_for_the_whole_log_is_one_stretch():
    t, _ = _log_with_stretches(3000)
    f = ram_forces(1.0, n=3000)
    spans = uneven_spans(t, f, 0.15, AREA)
    assert [(sp.start_ns, sp.end_ns, sp.ram, sp.idle, sp.instants) for sp in spans] == [(t[0], t[-1], 1, True, 3000)]


def test_the_check_says_how_it_stands():
    t, f = _log_with_stretches()
    check = RamsCheck(0.15, AREA)
    assert (check.level, check.last, check.unsettled_from(), check.open_span()) == (UNJUDGED, None, None, None)
    check.feed(t[:599], f[:599])
    assert (check.level, check.pending, check.unsettled_from()) == (UNJUDGED, 599, t[0])
    check.feed(t[599:2400], f[599:2400])
    assert check.level == UNEVEN and check.open_span().start_ns == t[2100] and not check.spans   # half idle
    check.feed(t[2400:3000], f[2400:3000])
    assert check.level == IDLE and check.open_span().ram == 1
    check.feed(t[3000:4800], f[3000:4800])
    assert check.level == EVEN and check.open_span() is None and len(check.spans) == 1
    check.finish()
    with pytest.raises(ValueError, match='the rams check is finished: it takes no more instants'):
        check.feed(t[:1], f[:1])


def test_a_stretch_with_a_window_judged_idle_is_idle_as_the_level_was():
    """A ram idle for a window, then carrying a quarter: the level went to IDLE (the node's ERROR),
    so the stretch says idle too, though its share over all of it is above a tenth."""
    n = 3000
    t = np.arange(n, dtype=np.int64) * 50_000_000 + 1_700_000_000_000_000_000
    sweep = 0.05 * n
    f = ram_forces(0.5, n=n, seed=7, sweep=sweep)
    f[600:1200] = ram_forces(1.0, n=n, seed=8, sweep=sweep)[600:1200]      # ram 2 idle
    f[1200:2400] = ram_forces(0.75, n=n, seed=9, sweep=sweep)[1200:2400]   # ram 2 carries a quarter
    check = RamsCheck(0.15, AREA)
    levels = []
    for k in range(0, n, 600):
        check.feed(t[k:k + 600], f[k:k + 600])
        levels.append(check.level)
    assert levels == [EVEN, IDLE, UNEVEN, UNEVEN, EVEN]
    (sp,) = check.finish()
    assert sp.ram == 1 and sp.share > 0.1 and sp.idle
