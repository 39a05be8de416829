"""Bench codec: the numpy column codec against cantools for every DBC message, input preparation and
sealing, decoding of recorded estimate frames (placement by STEP, E2E errors, wrap-around), and the
CAN-vs-replay comparison. Host only (no bus)."""
import math

import numpy as np
import pytest

from caekf_sim import schema
from caekf_sim.bench import e2e
from caekf_sim.bench.bench import Bench, RunRecord
from caekf_sim.bench.codec import ESTIMATE_MESSAGES, RECORD, Codec, make_records, records_array
from caekf_sim.bench.results import compare_with_replay, estimate_result
from caekf_sim.bench.transport import Transport
from caekf_sim.estimator import EstimateResult


class NullTransport(Transport):
    name = "null"

    def __init__(self):
        self.sent = []

    def send(self, blob):
        self.sent.append(blob)

    def recv(self, timeout):
        return b""


@pytest.fixture(scope="module")
def codec():
    return Codec()


@pytest.fixture()
def bench(codec):
    return Bench(NullTransport(), codec)


def _random_values(msg, rng, page=None):
    vals = {}
    for s in msg.signals:
        if s.name in ("E2E_CRC", "E2E_COUNTER") or s.is_multiplexer or (
                s.multiplexer_ids and (page is None or page not in s.multiplexer_ids)):
            continue
        if s.is_float:
            vals[s.name] = float(np.float32(rng.normal() * 10.0 ** int(rng.integers(-20, 20))))
        elif s.scale != 1:
            vals[s.name] = float(rng.uniform(s.minimum, s.maximum))
        else:
            vals[s.name] = int(rng.integers(s.minimum, s.maximum + 1))
    return vals


def test_numpy_codec_equals_cantools_for_every_message(codec):
    rng = np.random.default_rng(11)
    for msg in codec.db.messages:
        for i in range(40):
            if msg.name == "EST_HEALTH":
                vals = {"PAGE": 3, "RX_LOST": i, "RX_BAD_VALUE": 7 * i}
            elif msg.name == "EST_PAGE":  # one page per frame: that page's signals
                vals = {"PAGE": i % 11, **_random_values(msg, rng, page=i % 11)}
            else:
                vals = _random_values(msg, rng)
            want = codec.encode(msg.name, vals, i)
            got = codec.pack(msg.name, {k: np.array([v]) for k, v in vals.items()}, i)[0].tobytes()
            assert got == want, (msg.name, vals)
            dec = codec.decode(msg.frame_id, want)
            un = codec.unpack(msg.name, np.frombuffer(want, np.uint8))
            for k, v in dec.items():
                if k in un and not (msg.name in ("EST_HEALTH", "EST_PAGE") and k not in vals and k != "PAGE"):
                    assert un[k][0] == v or (math.isnan(v) and math.isnan(un[k][0])), (msg.name, k)


def test_scaled_values_round_half_even_and_saturate(codec):
    q = codec.quantize("BENCH_Y1", "Y1", [1.4e-12, 2.5e-12, -2.5e-12, 1.0, -1.0, 3.3e-3])
    assert q.tolist() == [1e-12, 2e-12, -2e-12, 34359738367e-12, -34359738368e-12, 3300000000 * 1e-12]
    u = codec.quantize("BENCH_U", "U", [0.1, -2.6])
    assert u.tolist() == [float(np.float32(0.1)), float(np.float32(-2.6))]


def test_layouts_and_resolution_from_the_dbc(codec):
    y1 = codec.messages["BENCH_Y1"].signals["Y1"]
    assert (y1.start, y1.length, y1.signed, y1.scale) == (28, 36, True, 1e-12)
    assert y1.resolution(np.array([0.0]))[0] == pytest.approx(0.5e-12)
    g = codec.messages["EST_GAMMA"].signals["GAMMA"]
    assert g.is_float and g.resolution(np.array([1e8]))[0] == pytest.approx(1e8 * 2.0 ** -24)
    assert codec.messages["EST_STEP"].frame_id == 0x18B and codec.messages["BENCH_U"].to_estimator
    assert len(codec.counter_names) == 24 and codec.health_pages == 12
    assert codec.param_ids == schema.param_ids()  # the DBC value table is the schema's


def test_prepare_encodes_every_step_like_cantools(bench, codec):
    rng = np.random.default_rng(5)
    n = 300
    t = np.arange(1, n + 1) * 1e-3
    u = rng.normal(size=n) * 2.6
    y = rng.normal(size=(n, 2)) * 1e-3
    inp = bench.prepare(t, u, y)
    assert inp.wire_steps.tolist() == list(range(1, n + 1))
    assert np.array_equal(inp.u_seen, u.astype(np.float32).astype(float))
    assert np.array_equal(inp.y_seen, np.rint(y / 1e-12) * 1e-12)
    for i in (0, 17, n - 1):
        want = codec.encode("BENCH_Y4", {"STEP": i + 1, "Y4": float(y[i, 1])}, 0)
        assert inp.payloads["BENCH_Y4"][i, 1:].tobytes() == want[1:]


def test_seal_steps_continue_counters_and_are_valid(bench, codec):
    n = 40
    inp = bench.prepare(np.arange(n) * 1e-3, np.zeros(n), np.zeros((n, 2)))
    bench.tx_counter["BENCH_U"] = 14
    first = bench.seal_steps(inp, 0, 10)
    second = bench.seal_steps(inp, 10, n)
    blobs = first + second
    assert len(blobs) == n and all(len(b) == 48 for b in blobs)
    recs = records_array(b"".join(blobs))
    for name, off in (("BENCH_U", 0), ("BENCH_Y1", 1), ("BENCH_Y4", 2)):
        info = codec.messages[name]
        sel = recs[off::3]
        assert np.all(sel["id"] == info.frame_id) and np.all(sel["dlc"] == 8)
        assert np.all(e2e.e2e_crc_np(info.data_id, sel["data"]) == sel["data"][:, 0])
        counters = sel["data"][:, 1] & 15
        start = 14 if name == "BENCH_U" else 0
        assert counters.tolist() == [(start + k) & 15 for k in range(n)]
    assert bench.tx_counter["BENCH_U"] == (14 + n) & 15


def _estimate_frames(codec, steps, values, counters_start=0, drop=(), corrupt=()):
    """Records the estimator would send for the given wire STEPs; values: column -> array."""
    n = len(steps)
    per_msg = {}
    for j, name in enumerate(ESTIMATE_MESSAGES):
        info = codec.messages[name]
        cols = {"STEP": np.asarray(steps)}
        for s in info.signals:
            if s in values:
                cols[s] = values[s]
        if name == "EST_STEP":
            cols.update(FLAGS=values["FLAGS"], NEWTON_ITERS=values["NEWTON_ITERS"], STEP_STATUS=np.zeros(n, int))
        p = codec.pack(name, cols, (counters_start + np.arange(n)) & 15)
        per_msg[name] = make_records(info.frame_id, p)
    out = []
    for k in range(n):
        for name in ESTIMATE_MESSAGES:
            if (k, name) in drop:
                continue
            rec = per_msg[name][k].copy()
            if (k, name) in corrupt:
                rec[8] ^= 0xFF
            out.append(rec.tobytes())
    return b"".join(out)


def _values(n, rng):
    v = {f"Q{i}": rng.normal(size=n) * 1e-3 for i in range(1, 5)}
    v.update({f"V{i}": rng.normal(size=n) * 1e-2 for i in range(1, 5)})
    v.update(GAMMA=rng.normal(size=n) * 1e8, P_NORM=np.abs(rng.normal(size=n)) * 1e14,
             P_GAMMA_GAMMA=np.abs(rng.normal(size=n)) * 1e14, FLAGS=rng.integers(0, 512, n),
             NEWTON_ITERS=rng.integers(1, 4, n))
    return v


def test_decode_run_places_frames_by_step_and_counts_e2e_errors(bench, codec):
    rng = np.random.default_rng(9)
    n = 50
    inp = bench.prepare(np.arange(1, n + 1) * 1e-3, np.zeros(n), np.zeros((n, 2)))
    vals = _values(n, rng)
    blob = _estimate_frames(codec, inp.wire_steps, vals, drop={(7, "EST_Q2")}, corrupt={(9, "EST_GAMMA")})
    health = RECORD.pack(codec.messages["EST_HEALTH"].frame_id, 8, bytes(8))  # ignored
    rec = RunRecord(0, n, chunks=[blob[: 16 * 100], health, blob[16 * 100:]])
    dec = bench.decode_run(rec, inp)
    assert dec.bad_crc == 1 and dec.counter_jumps == 2  # one dropped, one rejected frame
    assert not dec.complete[7] and not dec.complete[9] and dec.complete.sum() == n - 2
    ok = dec.complete
    assert np.array_equal(dec.columns["q1"][ok], codec.quantize("EST_Q1", "Q1", vals["Q1"])[ok])
    assert np.array_equal(dec.columns["gamma"][ok], vals["GAMMA"].astype(np.float32)[ok].astype(float))
    assert np.array_equal(dec.columns["flags"][ok], vals["FLAGS"][ok])
    res = estimate_result(dec, inp.t)
    assert len(res.t) == n - 2 and res.x.shape == (n - 2, 9)


def test_decode_run_unwraps_step_beyond_65536(bench, codec):
    rng = np.random.default_rng(2)
    start, n = 65530, 20  # wire STEP 65531 .. 65535, 0 .. 14
    total = start + n
    inp = bench.prepare(np.arange(1, total + 1) * 1e-3, np.zeros(total), np.zeros((total, 2)))
    vals = _values(n, rng)
    blob = _estimate_frames(codec, inp.wire_steps[start:], vals)
    dec = bench.decode_run(RunRecord(start, total, chunks=[blob]), inp)
    assert dec.complete.all() and dec.foreign_steps == 0
    assert np.array_equal(dec.columns["newton_iters"], vals["NEWTON_ITERS"])


def _ref_from(codec, vals, n):
    x = np.column_stack([vals[f"Q{i}"] for i in range(1, 5)] + [vals[f"V{i}"] for i in range(1, 5)]
                        + [vals["GAMMA"]])
    return EstimateResult(t=np.arange(n) * 1e-3, x=x, p_norm=vals["P_NORM"], p_gg=vals["P_GAMMA_GAMMA"],
                          flags=vals["FLAGS"].astype(np.int64), newton_iters=vals["NEWTON_ITERS"].astype(np.int64))


def test_compare_with_replay_accepts_the_encoding_and_nothing_more(bench, codec):
    rng = np.random.default_rng(4)
    n = 200
    inp = bench.prepare(np.arange(1, n + 1) * 1e-3, np.zeros(n), np.zeros((n, 2)))
    vals = _values(n, rng)
    vals["Q3"][5] = 0.5  # beyond the +/-34 mm range: saturated on the wire
    vals["P_NORM"][6] = np.nan
    dec = bench.decode_run(RunRecord(0, n, chunks=[_estimate_frames(codec, inp.wire_steps, vals)]), inp)
    ref = _ref_from(codec, vals, n)
    agr = compare_with_replay(dec, ref, codec)
    assert agr.ok, agr.text()
    assert max(agr.worst.values()) <= 1.0
    off = _ref_from(codec, vals, n)
    off.x[3, 1] += 0.6e-12 + (dec.columns["q2"][3] - vals["Q2"][3])  # 0.6 LSB away from the wire value
    off.x[4, 8] *= 1 + 2.0 ** -22  # gamma 4 float32 half-ULPs away
    off.flags[8] ^= 1
    agr = compare_with_replay(dec, off, codec)
    assert not agr.ok
    assert agr.mismatched["q2"] == 1 and agr.mismatched["gamma"] == 1 and agr.flags_mismatch == 1


def test_id_offset_moves_every_frame_id_and_keeps_the_data_ids(codec):
    moved = Codec(id_offset=0x400)
    for name, info in codec.messages.items():
        m = moved.messages[name]
        assert m.frame_id == info.frame_id + 0x400 and m.data_id == info.data_id
        assert moved.by_id[m.frame_id] is m
    body = moved.encode("BENCH_U", {"STEP": 7, "U": 1.5}, 3)
    assert body == codec.encode("BENCH_U", {"STEP": 7, "U": 1.5}, 3)  # same bytes, same E2E
    assert moved.decode(0x500, body)["U"] == 1.5
    assert moved.from_estimator_ids == [i + 0x400 for i in codec.from_estimator_ids]
    for bad in (0x7FF - 0x191 + 1, -0x0C1):
        with pytest.raises(ValueError, match="out of 0..0x7FF"):
            Codec(id_offset=bad)
    assert Codec(id_offset=-0x0C0).messages["CTRL_RESET"].frame_id == 0


def test_step_is_taken_modulo_its_signal_width(codec):
    """BENCH_YP and EST_PROD carry STEP mod 2^8: encode (cantools) and pack (numpy) agree on any step."""
    for step in (5, 255, 256, 261, 65535):
        vals = {"STEP": step, "Y1": 1e-6, "Y4": -2e-6}
        body = codec.encode("BENCH_YP", vals, 2)
        assert codec.decode(codec.messages["BENCH_YP"].frame_id, body)["STEP"] == step % 256
        assert codec.pack("BENCH_YP", {k: np.array([v]) for k, v in vals.items()}, 2)[0].tobytes() == body


def test_fd_frames_pack_and_unpack_like_cantools_with_a_crc16_seal(codec):
    """CAN FD messages (BENCH_FD 20 bytes, EST_FD 64): numpy pack/unpack through the bit matrix equal
    cantools' encode/decode, and the CRC-16 seal (bytes 0..1, counter bits 16..19) equals the scalar one."""
    assert e2e.crc16_ccitt_false(b"123456789") == 0x29B1
    rng = np.random.default_rng(11)
    n = 50
    for name in ("BENCH_FD", "EST_FD"):
        info = codec.messages[name]
        assert info.is_fd and info.length in (20, 64)
        msg = codec.db.get_message_by_name(name)
        cols = {}
        for s in msg.signals:
            if s.name in ("E2E_CRC", "E2E_COUNTER"):
                continue
            if s.is_float:
                cols[s.name] = (rng.normal(size=n) * 1e3).astype(np.float32).astype(float)
            elif s.scale != 1:
                cols[s.name] = rng.integers(-(1 << (s.length - 1)), 1 << (s.length - 1), n) * s.scale
            else:
                cols[s.name] = rng.integers(s.minimum, s.maximum + 1, n)
        counters = rng.integers(0, 16, n)
        packed = codec.pack(name, cols, counters)
        for i in range(n):
            want = codec.encode(name, {k: (v[i].item()) for k, v in cols.items()}, int(counters[i]))
            assert packed[i].tobytes() == want, (name, i)
            assert e2e.crc16_ok(info.data_id, want) and e2e.counter_of_fd(want) == counters[i]
        back = codec.unpack(name, packed)
        for k, v in cols.items():
            np.testing.assert_array_equal(back[k], v)
