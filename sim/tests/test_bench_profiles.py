"""Profiles on the bench side: the production profile's input frames, its estimate frames decoded into rows
(EST_PROD's 8-bit STEP unwrapped across its wrap, EST_PAGE pages placed at their steps), and the paced
real-time matcher on the 8-bit STEP. Frames are made with the DBC codec (checked against cantools
elsewhere), the expected rows from the values put in."""
import numpy as np
import pytest

from caekf_sim.bench import Bench
from caekf_sim.bench.bench import RunRecord
from caekf_sim.bench.codec import Codec, make_records, records_array
from caekf_sim.bench.profiles import PAGE_COUNT, PRODUCTION, get_profile
from caekf_sim.bench.realtime import _first_by_step
from caekf_sim.bench.transport import Transport


class NullTransport(Transport):
    name = "null"

    def send(self, blob):
        pass

    def recv(self, timeout):
        return b""


@pytest.fixture(scope="module")
def codec():
    return Codec()


N = 600  # rows: EST_PROD's STEP (mod 256) wraps twice


def _production_run(codec, first_wire=200, period=20):
    """EST_PROD of every row and the EST_PAGE pages as the app sends them (row % period < 11)."""
    rows = np.arange(N)
    wire = (first_wire + rows) & 0xFFFF
    gamma = 1e8 + 1e3 * rows
    flags = rows % 4096
    prod = codec.pack("EST_PROD", {"STEP": wire & 0xFF, "FLAGS": flags, "GAMMA": gamma}, rows & 15)
    paged = rows[rows % period < PAGE_COUNT]
    page = paged % period
    cols = {"PAGE": page, "STEP": wire[paged]}
    q1 = np.where(page == 0, 1e-3 + 1e-9 * paged, 0.0)
    pages = codec.pack("EST_PAGE", {**cols, "Q1": q1}, np.arange(len(paged)) & 15)
    recs = np.concatenate([make_records(codec.messages["EST_PROD"].frame_id, prod),
                           make_records(codec.messages["EST_PAGE"].frame_id, pages)])
    return wire, gamma, flags, paged, page, q1, recs


def test_production_rows_follow_the_8_bit_step_across_its_wraps(codec):
    bench = Bench(NullTransport(), codec, profile="production")
    wire, gamma, flags, paged, page, q1, recs = _production_run(codec)
    inputs = bench.prepare(np.arange(N) * 1e-3, np.zeros(N), np.zeros((N, 2)), check=False)
    inputs.wire_steps[:] = wire
    rec = RunRecord(0, N, chunks=[recs.tobytes()])
    dec = bench.decode_run(rec, inputs)
    assert dec.complete.all()
    assert (dec.bad_crc, dec.counter_jumps, dec.foreign_steps) == (0, 0, 0)
    np.testing.assert_array_equal(dec.columns["gamma"], gamma.astype(np.float32).astype(float))
    np.testing.assert_array_equal(dec.columns["flags"], flags)
    assert dec.carried["gamma"].all()
    # page 0 (Q1) at its rows only, with its value; the other columns of the page rows stay NaN
    q_rows = paged[page == 0]
    assert np.flatnonzero(dec.carried["q1"]).tolist() == q_rows.tolist()
    np.testing.assert_array_equal(dec.columns["q1"][q_rows], q1[page == 0].astype(np.float32).astype(float))
    assert np.isnan(dec.columns["q1"][~dec.carried["q1"]]).all()
    assert np.flatnonzero(dec.carried["p_gg"]).tolist() == paged[page == 9].tolist()


def test_production_inputs_are_two_frames_per_step_on_the_yp_grid(codec):
    bench = Bench(NullTransport(), codec, profile="production")
    y = np.array([[1.23456789e-3, -3.7e-5], [0.0, 1e-8 + 4e-9]])
    inputs = bench.prepare(np.array([0.001, 0.002]), np.array([0.1, -2.6]), y)
    assert list(inputs.payloads) == ["BENCH_U", "BENCH_YP"]
    lsb = codec.messages["BENCH_YP"].signals["Y1"].scale
    np.testing.assert_array_equal(inputs.y_seen, np.rint(y / lsb) * lsb)
    blobs = bench.seal_steps(inputs, 0, 2)
    assert [len(b) // 16 for b in blobs] == [2, 2]
    ids = records_array(b"".join(blobs))["id"].tolist()
    assert ids == [0x100, 0x103, 0x100, 0x103]


def test_paced_matcher_unwraps_the_narrow_step(codec):
    """EST_PROD's STEP is the low byte of the 16-bit step."""
    rows = np.arange(N)
    wire = ((300 + rows) & 0xFFFF).tolist()
    assert PRODUCTION.closing_step_bits == codec.messages["EST_PROD"].signals["STEP"].length < 16
    prod = codec.pack("EST_PROD", {"STEP": np.array(wire) & PRODUCTION.step_mask, "GAMMA": np.ones(N)}, rows & 15)
    frames = records_array(make_records(codec.messages["EST_PROD"].frame_id, prod).tobytes())
    t_ns = 1000 * rows.astype(np.int64) + 7
    got = _first_by_step(t_ns, frames, codec.messages["EST_PROD"].frame_id, wire, PRODUCTION.closing_step_bits)
    np.testing.assert_array_equal(got, t_ns)


def test_unknown_profile_is_refused():
    with pytest.raises(ValueError, match="unknown profile"):
        get_profile("can-xl")


# --- a mechanism's diagnostics frames (Bench.use_mechanism) -------------------------------------------------

def _scenario(name):
    from pathlib import Path

    from caekf_sim.scenario import load_scenario

    return load_scenario(Path(__file__).resolve().parents[2] / "sim" / "scenarios" / f"{name}.toml")


def test_the_paper_mechanism_keeps_the_paper_frames(codec):
    from caekf_sim.bench.profiles import DIAGNOSTICS, diagnostics_for

    assert diagnostics_for(1, [0, 0], 4, 1) is DIAGNOSTICS
    b = Bench(NullTransport(), codec)
    assert b.use_mechanism(_scenario("paper")) is DIAGNOSTICS and b.names == ("u", "y1", "y4")


def test_shuttle_sends_its_inputs_and_sensors_by_kind_and_reads_every_body_and_contact(codec):
    b = Bench(NullTransport(), codec)
    prof = b.use_mechanism(_scenario("shuttle"))  # 2 inputs; sensors: q1, v1, q4, q5; 6 bodies, 2 contacts
    assert prof.input_messages == ("BENCH_U", "BENCH_U2", "BENCH_Y1", "BENCH_S2_VEL", "BENCH_S3_POS", "BENCH_S4_POS")
    assert b.names == ("u1", "u2", "y1", "yv1", "y4", "y5")
    want = {f"q{i}" for i in range(1, 7)} | {f"v{i}" for i in range(1, 7)} | {"gamma", "gamma2", "p_norm", "p_gg",
                                                                                  "p_gg2"}
    assert want <= set(prof.results) and not {"q7", "v7"} & set(prof.results)
    for col, src in prof.results.items():  # every frame and signal is in the DBC
        assert src.signal in codec.messages[src.message].signals, col
    n = 5
    u = np.column_stack([np.linspace(-2.6, 2.6, n), np.full(n, 0.05)])
    y = np.column_stack([np.full(n, 1e-3), np.linspace(-0.4, 0.4, n), np.full(n, -2e-4), np.full(n, 3e-4)])
    inp = b.prepare(np.arange(1, n + 1) * 1e-3, u, y)
    assert inp.u_seen.shape == (n, 2) and inp.y_seen.shape == (n, 4)
    np.testing.assert_array_equal(inp.u_seen, u.astype(np.float32).astype(float))
    assert np.max(np.abs(inp.y_seen[:, 1] - y[:, 1])) <= 0.5e-10  # velocity: LSB 1e-10 m/s
    assert np.max(np.abs(inp.y_seen[:, [0, 2, 3]] - y[:, [0, 2, 3]])) <= 0.5e-12  # positions: LSB 1e-12 m


def test_production_refuses_a_mechanism_it_cannot_carry(codec):
    from caekf_sim.bench.bench import BenchError

    b = Bench(NullTransport(), codec, profile="production")
    assert b.match_scenario(_scenario("paper")) is PRODUCTION
    with pytest.raises(BenchError, match="diagnostics"):
        b.match_scenario(_scenario("valve"))


def test_a_complete_configuration_resets_enumerated_settings(codec):
    sent = dict(Bench(NullTransport(), codec).params_from_scenario(_scenario("paper")))
    # the defaults travel too: a valve's velocity sensor 2 or the canonical preset's mode cannot carry over
    assert sent["sensor2_kind"] == 0.0 and sent["mode"] == 1.0 and "discretisation" in sent
