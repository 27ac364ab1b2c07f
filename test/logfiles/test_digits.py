"""Eight characters at a time: the word arithmetic against Python's int() on every byte value
in every position."""

from __future__ import annotations

import numpy as np
import pytest

from steer_monitor.logfiles import digits

DEC = set(b'0123456789')
HEX = set(b'0123456789abcdefABCDEF')


def _words(texts: list[bytes]) -> np.ndarray:
    assert all(len(t) == 8 for t in texts)
    return np.frombuffer(b''.join(texts), '<u8').copy()


def _cases() -> list[bytes]:
    """Valid words, and each with every byte value in every position."""
    rng = np.random.default_rng(7)
    base = [b'00000000', b'99999999', b'12345678', b'fFaA09bE', b'DEADBEEF', b'01234567']
    base += [rng.choice(list(b'0123456789abcdefABCDEF'), 8).astype(np.uint8).tobytes() for _ in range(20)]
    out = list(base)
    for b in base[:6]:
        for pos in range(8):
            for v in range(256):
                out.append(b[:pos] + bytes([v]) + b[pos + 1:])
    out += [rng.integers(0, 256, 8, dtype=np.uint8).tobytes() for _ in range(2000)]
    return out


CASES = _cases()


def test_dec8():
    got, ok = digits.dec8(_words(CASES))
    for text, v, k in zip(CASES, got.tolist(), ok.tolist()):
        expect = set(text) <= DEC
        assert k == expect, text
        if expect:
            assert v == int(text, 10), text


def test_hex8_and_its_bytes():
    w = _words(CASES)
    got, ok = digits.hex8(w)
    raw, ok2 = digits.hex8_bytes(w)
    np.testing.assert_array_equal(ok, ok2)
    for text, v, b, k in zip(CASES, got.tolist(), raw.view(np.uint8).reshape(-1, 4), ok.tolist()):
        expect = set(text) <= HEX
        assert k == expect, text
        if expect:
            assert v == int(text, 16), text
            assert bytes(b) == bytes.fromhex(text.decode()), text


@pytest.mark.parametrize('k', range(9))
def test_keep_first_and_last(k):
    w = _words([b'ABCDEFGH'])
    assert bytes(digits.keep_first(w, k).view(np.uint8)) == b'ABCDEFGH'[:k] + b'0' * (8 - k)
    assert bytes(digits.keep_last(w, k).view(np.uint8)) == b'0' * (8 - k) + b'ABCDEFGH'[8 - k:]


@pytest.mark.parametrize('k', [-1, 9])
def test_a_word_holds_eight(k):
    with pytest.raises(ValueError, match=f'0 to 8 characters, not {k}'):
        digits.keep_first(_words([b'12345678']), k)
