"""Packed state records against the one-by-one path (state_messages, the CDR encoders,
write_cdr): the same file, byte for byte, chunk boundaries and message indexes included."""

from __future__ import annotations

import io
import math
from dataclasses import replace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from steer_monitor.logfiles.mcapio import McapWriter
from steer_monitor.model.gear import Clearances
from steer_monitor.model.loadshare import ShareScalar, load_sharing_scalar
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.messages import TOPICS, state_messages
from steer_monitor.monitor.pipeline import StateOut
from steer_monitor.record.cdr import FAST_ENCODERS
from steer_monitor.record.msgdefs import msgdef
from steer_monitor.record.staterecords import pack_states

FLOATS = st.floats(allow_nan=True, allow_infinity=True, width=64)
SHARES = st.builds(ShareScalar, FLOATS, FLOATS, FLOATS, FLOATS, FLOATS, FLOATS, FLOATS, FLOATS, FLOATS,
                   FLOATS, FLOATS, st.integers(-128, 127), st.integers(0, 255))
STATES = st.builds(LiveState, st.integers(0, 2**63 - 1), FLOATS, FLOATS, st.booleans(),
                   st.none() | FLOATS, st.none() | SHARES, st.just(Clearances(0.0005, 0.0003)))


def _writer(buf: io.BytesIO, chunk_size: int) -> McapWriter:
    w = McapWriter(buf, chunk_size=chunk_size)
    for key in ('rudder', 'load_sharing'):
        datatype = TOPICS[key][1]
        w.add_schema(datatype, msgdef(datatype))
        w.add_channel(key, datatype)
    return w


def _one_by_one(states: list[LiveState], chunk_size: int) -> bytes:
    buf = io.BytesIO()
    with _writer(buf, chunk_size) as w:
        for s in states:
            for key, t_ns, fields in state_messages(StateOut(s)):
                w.write_cdr(key, FAST_ENCODERS[TOPICS[key][1]](fields), t_ns)
    return buf.getvalue()


def _packed(batches: list[list[LiveState]], chunk_size: int, gear=None) -> bytes:
    buf = io.BytesIO()
    with _writer(buf, chunk_size) as w:
        for batch in batches:
            p = pack_states(batch, w.channel_id('rudder'), w.channel_id('load_sharing'), gear)
            w.write_records(p.data, p.channels, p.log_times, p.offsets)
    return buf.getvalue()


@settings(max_examples=150, deadline=None)
@given(states=st.lists(STATES, max_size=40), cut=st.integers(0, 40), chunk_size=st.sampled_from([64, 700, 1 << 20]))
def test_packed_states_are_the_one_by_one_bytes(states, cut, chunk_size):
    """Any values (NaN, infinities, no torque, no load sharing, stamps past 2038 left unset),
    in one batch or two, whatever the chunk size."""
    assert _packed([states[:cut], states[cut:]], chunk_size) == _one_by_one(states, chunk_size)


def _state(i: int, share: bool) -> LiveState:
    sh = ShareScalar(*(float(i + k) for k in range(11)), case=-(i % 3), stages=i % 4) if share else None
    return LiveState(1_767_225_600_000_000_000 + i * 10_000_000, 0.01 * i - 0.3, -0.02, True,
                     None if i % 5 == 0 else 1e5 * i, sh, Clearances(0.0005, 0.0003))


@pytest.mark.parametrize('chunk_size', [1000, 4096, 1 << 20])
def test_a_long_run_of_states_across_many_chunks(chunk_size):
    states = [_state(i, i % 7 != 3) for i in range(3000)]
    one = _one_by_one(states, chunk_size)
    assert _packed([states[i:i + 500] for i in range(0, 3000, 500)], chunk_size) == one
    from mcap.reader import make_reader
    reader = make_reader(io.BytesIO(one), validate_crcs=True)
    assert reader.get_summary().statistics.chunk_count >= (3 if chunk_size < 1 << 20 else 1)
    times = [m.log_time for _, _, m in reader.iter_messages(log_time_order=False)]
    assert len(times) == 3000 + sum(i % 7 != 3 for i in range(3000))


def test_an_empty_batch_writes_nothing():
    assert _packed([[], []], 4096) == _one_by_one([], 4096)


def test_effort_keeps_the_angles_sign_with_no_torque():
    s = LiveState(1_767_225_600_000_000_000, -0.2, 0.0, False, None, None, Clearances(0.0, 0.0))
    (_, _, fields), = state_messages(StateOut(s))
    assert math.copysign(1.0, fields['effort'][0]) == -1.0
    assert _packed([[s]], 4096) == _one_by_one([s], 4096)


@pytest.mark.parametrize('chunk_size', [700, 1 << 20])
def test_packed_runs_and_single_messages_on_one_channel_keep_their_order(chunk_size):
    """The chunk's message index holds entries of both kinds in the order they were written."""
    states = [_state(i, i % 2 == 0) for i in range(60)]
    buf = io.BytesIO()
    with _writer(buf, chunk_size) as w:
        for k in range(0, 60, 10):
            if k % 20 == 0:
                for s in states[k:k + 10]:
                    for key, t_ns, fields in state_messages(StateOut(s)):
                        w.write_cdr(key, FAST_ENCODERS[TOPICS[key][1]](fields), t_ns)
            else:
                p = pack_states(states[k:k + 10], w.channel_id('rudder'), w.channel_id('load_sharing'))
                w.write_records(p.data, p.channels, p.log_times, p.offsets)
    assert buf.getvalue() == _one_by_one(states, chunk_size)


def test_states_left_to_solve_are_solved_as_the_live_monitor_solves_them(r18):
    """States whose load sharing was left to the caller (a replay's live monitor), mixed with
    states that carry theirs and states without a torque: packed with the gear, the bytes of
    the states with ``load_sharing_scalar``'s answer, one by one; the records of each state
    end where ``state_ends`` says."""
    rng = np.random.default_rng(5)
    full, left = [], []
    for i in range(400):
        alpha = float(rng.uniform(-0.62, 0.62))
        torque = None if i % 9 == 0 else float(r18.torque(alpha) * rng.uniform(0.0, 2.0))
        gaps = Clearances(float(rng.choice([0.0, 0.2e-3, 0.6e-3])), float(rng.choice([0.0, 0.25e-3])))
        share = None if torque is None else load_sharing_scalar(r18, alpha, torque, gaps.two_z, gaps.z_gb)
        s = LiveState(1_767_225_600_000_000_000 + i * 10_000_000, alpha, 0.01, True, torque, share, gaps)
        full.append(s)
        left.append(s if i % 4 == 0 else replace(s, share=None))
    one = _one_by_one(full, 4096)
    assert _packed([left[:150], left[150:]], 4096, r18) == one
    assert _packed([left], 4096) != one            # without the gear they are states with no load sharing
    p = pack_states(left, 1, 2, r18)
    assert p.state_ends.tolist() == np.cumsum([1 if s.torque_measured is None else 2 for s in left]).tolist()
