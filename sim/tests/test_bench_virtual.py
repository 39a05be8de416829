"""The bench against a small fake estimator on python-can's `virtual` bus (host only, no SocketCAN):
configuration with retries, status, lockstep (strict and windowed) with timeouts that never hang,
real-time pacing, bus logs written and replayed, and the `caekf-sim hil` commands end to end.

The fake follows the protocol (E2E check, CTRL_PARAM/CTRL_RESET/EST_ACK, status pages, step assembly)
and answers a step with simple functions of its inputs (gamma = u, q1 = y1, q4 = y4, ...)."""
import math
import threading
import time
import uuid
from collections import defaultdict

import numpy as np
import pytest

can = pytest.importorskip("can")
pytest.importorskip("cantools")

from caekf_sim.bench import Bench, latency_stats  # noqa: E402
from caekf_sim.bench import e2e  # noqa: E402
from caekf_sim.bench.buslog import read_log  # noqa: E402
from caekf_sim.bench.replay import replay_log, segment_results  # noqa: E402
from caekf_sim.bench.codec import Codec  # noqa: E402
from caekf_sim.scenario import default_scenario_path, load_scenario  # noqa: E402


class FakeEstimator(threading.Thread):
    def __init__(self, channel, codec, drop_param_once=False, silent_steps=()):
        super().__init__(daemon=True)
        self.bus = can.Bus(interface="virtual", channel=channel)
        self.codec = codec
        self.tx = defaultdict(int)
        self.rx = {m.frame_id: e2e.E2EReceiver(m.data_id) for m in codec.messages.values() if m.to_estimator}
        self.rx_last = defaultdict(float)
        self.counters = {name: 0 for name in codec.counter_names}
        self.drop_param_once = drop_param_once
        self.silent_steps = set(silent_steps)
        self.params = 0
        self.configured = None
        self.slot = {}
        self.stop_event = threading.Event()

    def send(self, name, values):
        data = self.codec.encode(name, values, self.tx[name])
        self.tx[name] = (self.tx[name] + 1) & 15
        self.bus.send(can.Message(arbitration_id=self.codec.messages[name].frame_id, data=data,
                                  is_extended_id=False))
        self.counters["TX_FRAMES"] += 1

    def run(self):
        while not self.stop_event.is_set():
            msg = self.bus.recv(0.02)
            if msg is not None:
                self.handle(msg)
        self.bus.shutdown()

    def handle(self, msg):
        info = self.codec.by_id.get(msg.arbitration_id)
        if info is None or not info.to_estimator:
            self.counters["RX_UNKNOWN_ID"] += 1
            return
        rx = self.rx[msg.arbitration_id]
        if time.monotonic() - self.rx_last[msg.arbitration_id] > 0.5:  # a new bench run: any counter
            rx.last = None
        st = rx.check(bytes(msg.data))
        if st not in ("bad_dlc", "bad_crc"):
            self.rx_last[msg.arbitration_id] = time.monotonic()
        if st != e2e.E2EReceiver.OK:
            key = {"bad_dlc": "RX_BAD_DLC", "bad_crc": "RX_BAD_CRC", "duplicate": "RX_DUPLICATE"}.get(
                st, "RX_COUNTER_JUMP")
            self.counters[key] += 1
            return
        d = self.codec.decode(msg.arbitration_id, bytes(msg.data))
        self.counters["RX_OK"] += 1
        if info.name == "CTRL_PARAM":
            if self.drop_param_once:
                self.drop_param_once = False
                return
            self.params += 1
        elif info.name == "CTRL_RESET":
            ok = d["N_PARAMS"] == self.params
            n, self.params = self.params, 0
            if ok:
                self.configured = n
                self.slot = {}
            self.send("EST_ACK", {"TOKEN": d["TOKEN"], "ACK_STATUS": 0 if ok else -2, "BAD_PARAM": 255,
                                  "N_PARAMS_RX": n, "STATE": 1})
        elif info.name == "CTRL_STATUS_REQ":
            self.counters["STATUS_REQUESTS"] += 1
            self.send("EST_ACK", {"TOKEN": d["TOKEN"], "ACK_STATUS": 1, "BAD_PARAM": 255,
                                  "N_PARAMS_RX": 0, "STATE": 1})
            names = self.codec.counter_names
            for page in range(self.codec.health_pages):
                self.send("EST_HEALTH", {"PAGE": page, names[2 * page]: self.counters[names[2 * page]] % (1 << 24),
                                         names[2 * page + 1]: self.counters[names[2 * page + 1]] % (1 << 24)})
        else:
            value = next(v for k, v in d.items() if k not in ("E2E_CRC", "E2E_COUNTER", "STEP"))
            if isinstance(value, float) and math.isnan(value):
                self.counters["RX_BAD_VALUE"] += 1
                return
            step = int(d["STEP"])
            if self.slot.get("step") != step:
                self.slot = {"step": step}
            self.slot[info.name] = value
            if len(self.slot) == 4:
                self.step(step, self.slot)
                self.slot = {}

    def step(self, step, s):
        self.counters["STEPS_DONE"] += 1
        if step in self.silent_steps:
            return
        u, y1, y4 = s["BENCH_U"], s["BENCH_Y1"], s["BENCH_Y4"]
        self.send("EST_GAMMA", {"STEP": step, "GAMMA": u})
        for i, q in enumerate((y1, 0.0, 0.0, y4), 1):
            self.send(f"EST_Q{i}", {"STEP": step, f"Q{i}": q})
        for i in range(1, 5):
            self.send(f"EST_V{i}", {"STEP": step, f"V{i}": 0.0})
        self.send("EST_P_NORM", {"STEP": step, "P_NORM": 1.0})
        self.send("EST_P_GG", {"STEP": step, "P_GAMMA_GAMMA": 2.0})
        self.send("EST_STEP", {"STEP": step, "FLAGS": 8, "NEWTON_ITERS": 1, "STEP_STATUS": 0})


@pytest.fixture(scope="module")
def codec():
    return Codec()


@pytest.fixture(scope="module")
def sc():
    return load_scenario(default_scenario_path())


@pytest.fixture()
def rig(codec, request):
    kwargs = getattr(request, "param", {})
    channel = f"caekf-test-{uuid.uuid4().hex[:8]}"
    fake = FakeEstimator(channel, codec, **kwargs)
    fake.start()
    bench = Bench.open("virtual", channel, codec=codec)
    yield bench, fake, channel
    bench.close()
    fake.stop_event.set()
    fake.join(2)


def _inputs(bench, n=120):
    rng = np.random.default_rng(1)
    return bench.prepare(np.arange(1, n + 1) * 1e-3, rng.normal(size=n), rng.normal(size=(n, 2)) * 1e-3)


def test_configure_status_and_lockstep(rig, sc):
    bench, fake, _ = rig
    params = bench.params_from_scenario(sc, "switched-highq")
    assert ("q_gamma_scale", 1000.0) in params and ("mode", 1.0) in params  # the preset travels as settings
    ack = bench.configure("switched-highq", params)
    assert ack.status == 0 and ack.n_params_rx == len(params) and fake.configured == len(params)
    st = bench.status()
    assert st["STATUS_REQUESTS"] == 1 and st["_state"] == 1 and set(bench.codec.counter_names) <= set(st)
    inp = _inputs(bench)
    for window in (1, 8):
        rec = bench.run_lockstep(inp, window=window, timeout=2.0, progress=False)
        dec = bench.decode_run(rec, inp)
        assert rec.timeouts == 0 and dec.complete.all()
        assert np.array_equal(dec.columns["gamma"], inp.u_seen)
        assert np.array_equal(dec.columns["q1"], inp.y_seen[:, 0])
        assert np.array_equal(dec.columns["q4"], inp.y_seen[:, 1])
        assert dec.bad_crc == dec.counter_jumps == dec.counter_duplicates == 0


@pytest.mark.parametrize("rig", [{"drop_param_once": True}], indirect=True)
def test_configure_retries_an_incomplete_configuration(rig, sc):
    bench, fake, _ = rig
    ack = bench.configure("canonical", bench.params_from_scenario(sc, "canonical"))
    assert ack.status == 0 and ack.n_params_rx == len(bench.params_from_scenario(sc, "canonical"))
    assert fake.counters["RX_OK"] >= 2 * len(bench.params_from_scenario(sc, "canonical"))  # sent twice


@pytest.mark.parametrize("rig", [{"silent_steps": {10, 11}}], indirect=True)
def test_lockstep_counts_timeouts_and_goes_on(rig, sc):
    bench, fake, _ = rig
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    inp = _inputs(bench, 40)
    rec = bench.run_lockstep(inp, timeout=0.1, progress=False)
    dec = bench.decode_run(rec, inp)
    assert rec.timeouts == 2
    assert dec.complete.sum() == 38 and not dec.complete[9] and not dec.complete[10]


def test_status_without_an_estimator_raises_not_hangs(codec):
    bench = Bench.open("virtual", f"caekf-empty-{uuid.uuid4().hex[:8]}", codec=codec)
    try:
        from caekf_sim.bench import BenchError

        with pytest.raises(BenchError, match="no status reply"):
            bench.status(timeout=0.05, retries=2)
    finally:
        bench.close()


def test_realtime_answers_every_step(rig, sc):
    bench, fake, _ = rig
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    inp = _inputs(bench, 60)
    rec = bench.run_realtime(inp, 0.005, progress=False, grace=1.0)
    lat = latency_stats(rec)
    assert lat["answered"] == 60 and lat["p50"] > 0 and lat["max"] >= lat["p99"] >= lat["p50"]
    assert bench.decode_run(rec, inp).complete.all()


def test_bus_log_written_read_and_replayed(rig, sc, tmp_path):
    bench, fake, channel = rig
    bench.journal = []
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    inp = _inputs(bench, 50)
    rec = bench.run_lockstep(inp, progress=False)
    bad = bench.frame("BENCH_Y1", {"STEP": 1, "Y1": 0.0}, advance=False)
    bench.send(bad[:8] + bytes([bad[8] ^ 1]) + bad[9:])
    bench.status()  # answered after the fake handled the bad frame: its counters are settled
    path = tmp_path / "bus.log"
    n = bench.write_log(path)
    lines = path.read_text().splitlines()
    assert len(lines) == n and lines[0].startswith("(") and f" {channel} " in lines[0]
    assert lines[0].endswith(" T") and any(line.endswith(" R") for line in lines)
    frames = read_log(path, bench.codec.from_estimator_ids)
    assert sum(f.sent_by_bench for f in frames) == 50 * 3 + len(bench.params_from_scenario(sc, "switched")) + 3
    before = fake.counters["RX_BAD_CRC"]
    rep = replay_log(bench, path, timeout=2.0)
    assert rep.ok, rep.text()
    bench.status()
    assert rep.matched == 50 * 12 + 2 and fake.counters["RX_BAD_CRC"] == before + 1
    (name, res), = segment_results(bench, rep, 1e-3)
    assert name == "switched"
    assert np.array_equal(res.gamma, bench.decode_run(rec, inp).columns["gamma"])


def test_log_without_direction_markers_uses_the_ids(codec, tmp_path):
    path = tmp_path / "plain.log"
    path.write_text("(1.000000) vcan0 100#0011223344556677\n(1.000100) vcan0 18B#0011223344556677\n")
    frames = read_log(path, codec.from_estimator_ids)
    assert [f.sent_by_bench for f in frames] == [True, False]


def test_cli_hil_run_and_replay_log(rig, tmp_path, capsys):
    from caekf_sim.cli import main

    bench, fake, channel = rig
    bench.close()  # the CLI opens its own
    truth = tmp_path / "truth.csv"
    n = 150
    t = np.arange(1, n + 1) * 1e-3
    cols = np.column_stack([t, np.sin(t), 1e-4 * t, -1e-4 * t] + [np.zeros(n)] * 9)
    np.savetxt(truth, cols, delimiter=",", fmt="%.17g", comments="",
               header="t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta")
    out = tmp_path / "hil"
    log = tmp_path / "run.log"
    rc = main(["hil", "run", "--interface", "virtual", "--iface", channel, "--truth", str(truth), "--outdir",
               str(out), "--experiments", "canonical", "switched", "--duration", "0.1", "--log", str(log),
               "--no-figures", "--no-progress"])
    text = capsys.readouterr().out
    assert rc == 0, text
    assert "100/100" in text and (out / "summary.txt").exists()
    from caekf_sim.results import read_result_csv

    res = read_result_csv(out / "switched.csv")
    assert len(res.t) == 100 and np.array_equal(res.gamma, np.sin(t[:100]).astype(np.float32).astype(float))
    header = (out / "canonical.csv").read_text().splitlines()[0]
    assert header == "t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters"
    rc = main(["hil", "replay-log", "--interface", "virtual", "--iface", channel, "--log", str(log),
               "--outdir", str(tmp_path / "replay"), "--no-progress"])
    assert rc == 0, capsys.readouterr().out
    assert sorted(p.name for p in (tmp_path / "replay").glob("*.csv")) == ["replay-0-canonical.csv",
                                                                          "replay-1-switched.csv"]


@pytest.mark.parametrize("rig", [{"silent_steps": set(range(6, 1000))}], indirect=True)
def test_lockstep_gives_up_when_the_estimator_is_gone(rig, sc):
    bench, fake, _ = rig
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    inp = _inputs(bench, 400)
    t0 = time.monotonic()
    rec = bench.run_lockstep(inp, timeout=0.05, progress=False, max_timeouts_in_a_row=4)
    assert time.monotonic() - t0 < 3.0
    assert rec.aborted and rec.timeouts == 400 - 5
    assert bench.decode_run(rec, inp).complete.sum() == 5


def test_cli_hil_run_deferred_then_report(rig, tmp_path, capsys):
    from caekf_sim.bench.results import load_runs
    from caekf_sim.cli import main
    from caekf_sim.results import read_result_csv

    bench, fake, channel = rig
    bench.close()
    truth = tmp_path / "truth.csv"
    n = 80
    t = np.arange(1, n + 1) * 1e-3
    np.savetxt(truth, np.column_stack([t, np.cos(t), 1e-4 * t, -1e-4 * t] + [np.zeros(n)] * 9), delimiter=",",
               fmt="%.17g", comments="", header="t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta")
    out = tmp_path / "hil"
    assert main(["hil", "run", "--interface", "virtual", "--iface", channel, "--truth", str(truth), "--outdir",
                 str(out), "--experiments", "switched", "--defer-outputs", "--no-progress"]) == 0
    assert (out / "runs.npz").exists() and not (out / "switched.csv").exists()
    runs, header = load_runs(out / "runs.npz")
    assert header.startswith("caekf HIL over CAN") and runs[0].decoded.complete.all()
    assert runs[0].health["STEPS_DONE"] == n and runs[0].record.n == n
    capsys.readouterr()
    assert main(["hil", "report", "--outdir", str(out), "--no-figures"]) == 0
    assert "switched" in capsys.readouterr().out
    res = read_result_csv(out / "switched.csv")
    assert np.array_equal(res.gamma, np.cos(t).astype(np.float32).astype(float))
    assert "80/80" in (out / "summary.txt").read_text()


@pytest.mark.parametrize("rig", [{"silent_steps": set(range(5, 41))}], indirect=True)
def test_realtime_flow_control_holds_sends_instead_of_piling_up(rig, sc):
    bench, fake, _ = rig
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    inp = _inputs(bench, 60)
    t0 = time.monotonic()
    rec = bench.run_realtime(inp, 0.002, progress=False, grace=0.05, max_in_flight=4)
    lat = latency_stats(rec)
    assert time.monotonic() - t0 < 5.0
    assert rec.held > 0 and lat["answered"] == 60 - 36 and fake.counters["STEPS_DONE"] == 60
