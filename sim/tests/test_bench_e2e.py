"""Bench E2E protection and CTRL_PARAM value encoding, against the protocol's Python reference
(tests/protocol/e2e_ref.py, what the DBC cross-check trusts) and against the receiver rules."""
import importlib.util
import random
from pathlib import Path

import numpy as np
import pytest

from caekf_sim import schema
from caekf_sim.bench import e2e
from caekf_sim.scenario import default_scenario_path, load_scenario

REF_PATH = Path(__file__).resolve().parents[2] / "tests" / "protocol" / "e2e_ref.py"


@pytest.fixture(scope="module")
def ref():
    spec = importlib.util.spec_from_file_location("e2e_ref", REF_PATH)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_crc_check_value():
    assert e2e.crc8_sae_j1850(b"123456789") == 0x4B


def test_seal_and_crc_match_reference(ref):
    rng = random.Random(7)
    for _ in range(500):
        payload = bytes(rng.randrange(256) for _ in range(8))
        did, ctr = rng.randrange(1 << 16), rng.randrange(16)
        assert e2e.seal(did, ctr, payload) == ref.seal(did, ctr, payload)
        assert e2e.e2e_crc(did, payload) == ref.e2e_crc(did, payload)
        data = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 20)))
        assert e2e.crc8_sae_j1850(data) == ref.crc8_sae_j1850(data)


def test_vectorised_seal_and_crc_match_scalar():
    rng = np.random.default_rng(3)
    p = rng.integers(0, 256, (300, 8), dtype=np.uint8)
    ids = rng.integers(0, 1 << 16, 300)
    ctr = rng.integers(0, 16, 300)
    sealed = e2e.seal_np(ids, ctr, p)
    for i in range(300):
        assert sealed[i].tobytes() == e2e.seal(int(ids[i]), int(ctr[i]), p[i].tobytes())
    assert np.array_equal(e2e.e2e_crc_np(ids, sealed), sealed[:, 0])
    one_id = e2e.seal_np(0xCA00, 5, p)  # scalar data ID and counter broadcast
    assert one_id[7].tobytes() == e2e.seal(0xCA00, 5, p[7].tobytes())


def test_crc_ok_rejects_any_single_bit_flip():
    frame = e2e.seal(0xCA01, 3, bytes(range(8)))
    assert e2e.crc_ok(0xCA01, frame)
    assert not e2e.crc_ok(0xCA02, frame)  # same bytes, other message
    for bit in range(64):
        b = bytearray(frame)
        b[bit // 8] ^= 1 << (bit % 8)
        assert not e2e.crc_ok(0xCA01, bytes(b))
    assert not e2e.crc_ok(0xCA01, frame[:7])


def test_receiver_rules_duplicate_jump_resync_and_lost():
    rx = e2e.E2EReceiver(0xCA00, max_delta=1)
    f = lambda c: e2e.seal(0xCA00, c, bytes(8))  # noqa: E731
    assert rx.check(f(9)) == rx.OK  # first frame: any counter
    assert rx.check(f(10)) == rx.OK
    assert rx.check(f(10)) == rx.DUPLICATE
    assert rx.check(f(13)) == rx.JUMP  # rejected, but resynchronised on 13
    assert rx.check(f(14)) == rx.OK
    assert rx.check(f(15)) == rx.OK and rx.check(f(0)) == rx.OK  # wraps 15 -> 0
    bad = bytearray(f(1))
    bad[0] ^= 1
    assert rx.check(bytes(bad)) == rx.BAD_CRC and rx.check(f(1)) == rx.OK  # CRC errors leave the state
    assert rx.check(f(1)[:6]) == rx.BAD_DLC
    rx3 = e2e.E2EReceiver(0xCA00, max_delta=3)
    assert rx3.check(f(0)) == rx3.OK and rx3.check(f(3)) == rx3.OK and rx3.lost == 2


def test_counter_errors_of_a_sequence():
    assert e2e.counter_errors_np([]) == (0, 0, 0)
    assert e2e.counter_errors_np(np.arange(40) & 15) == (0, 0, 0)
    assert e2e.counter_errors_np([1, 2, 2, 3, 7, 8]) == (1, 1, 3)


def test_mantissa_exp10_matches_reference_and_is_exact(ref):
    sc = load_scenario(default_scenario_path())
    sent = [v for _, v in schema.wire_values(sc.values(), "switched-highq-constrained")]  # what the bench sends
    values = sent + [0.0, -1.5e-3, 1e-22, 123456789012.0, 2.0 / 3.0, -7.25e21, 1000.0]
    for v in values:
        m, x = e2e.to_mantissa_exp10(v)
        assert (m, x) == ref.to_mantissa_exp10(v)
        assert abs(m) < 1 << 37 and -22 <= x <= 22, v
        if len(str(abs(m))) <= 11 and repr(float(v)) == repr(e2e.from_mantissa_exp10(m, x)):
            assert e2e.from_mantissa_exp10(m, x) == float(v)
    assert e2e.to_mantissa_exp10(1.0e-3) == (1, -3)
    assert e2e.to_mantissa_exp10(7.5e7) == (75, 6)
    assert e2e.from_mantissa_exp10(*e2e.to_mantissa_exp10(2.0 / 3.0)) == pytest.approx(2.0 / 3.0, rel=1e-11)
