"""The CAN FD profile over vcan0 (MTU 72, set up by tools/with-vcan.sh): a second caekf-host with
`--profile fd`, moved by ID_OFFSET (`--id-offset`) so that it shares the bus with the session's estimator,
and the bench's CAN FD stepper (`caekf_sim.bench.fd`, python-can with fd=True): one BENCH_FD (20 bytes) in
and one EST_FD (64 bytes, CRC-16 E2E) out per step, bit-rate switch.

- the switched experiment over its first LOCKSTEP_ROWS steps (through the first contact, 12.8-17.2 s) in
  lockstep: every step answered, the bench's E2E check of every EST_FD clean, and every value of every step
  equal to caekf-replay on the inputs the estimator decoded (the FD frames carry the diagnostics profile's
  resolutions; the paper's claims over the full 60 s are checked in the classic profiles);
- PACED_ROWS steps paced at 1 kHz with the whole bus recorded: the candump log (out/.../fd-bus.log) holds one BENCH_FD and
  one EST_FD per step, and its bus load (computed from the frames, reported) is measured the way
  `caekf-sim busload --log fd=LOG` does;
- bad traffic in the FD profile, one burst before step K of a fresh switched run: a BENCH_FD with a bad
  CRC-16, a classic 8-byte and a 64-byte frame with BENCH_FD's ID (wrong length), an unknown CAN FD ID, a
  NaN force (valid E2E), a counter jump (+5: rejected, the receiver resynchronises on it), and step K's
  frame twice with the same counter (duplicate): each counted exactly, every step run once, every estimate
  equal to caekf-replay's.
"""
from __future__ import annotations

import math
import struct

import numpy as np
import pytest

from conftest import host_process
from hilcfg import report

ID_OFFSET = 0x400
LOCKSTEP_ROWS = 20000  # the CI HIL stage stays within 3 min
PACED_ROWS = 2000
BT_ROWS = 3000
K = 1500


def _head(ref, b, a=0):
    """Rows [a, b) of a caekf-replay result."""
    from caekf_sim.estimator import EstimateResult

    return EstimateResult(t=ref.t[a:b], x=ref.x[a:b], p_norm=ref.p_norm[a:b], p_gg=ref.p_gg[a:b],
                          flags=ref.flags[a:b], newton_iters=ref.newton_iters[a:b])


@pytest.fixture(scope="module")
def fd_pair(iface, binaries, out_dir, sc):
    from caekf_sim.bench import Bench
    from caekf_sim.bench.codec import Codec
    from caekf_sim.bench.fd import FdStepper

    with host_process(iface, binaries, out_dir / "caekf-host-fd.log", "--id-offset", hex(ID_OFFSET), profile="fd"):
        bench = Bench.open("socketcan", iface, codec=Codec(id_offset=ID_OFFSET))
        fd = FdStepper(bench, iface)
        try:
            bench.wait_for_estimator(timeout=10.0)
            yield bench, fd
        finally:
            fd.close()
            bench.close()


def test_fd_profile_equals_replay_and_its_log_has_two_frames_per_step(fd_pair, iface, out_dir, sc, inputs, replay):
    from caekf_sim.bench.busload import fd_log_seconds, log_load, read_candump, read_candump_fd
    from caekf_sim.bench.profiles import DATA_BITRATE, FD
    from caekf_sim.bench.results import compare_with_replay

    bench, fd = fd_pair
    codec = bench.codec
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    run = fd.run(inputs, LOCKSTEP_ROWS, window=32, timeout=2.0)
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    paced = fd.run(inputs, PACED_ROWS, dt=float(sc.dt), timeout=2.0, record=True)
    dec = run.decoded
    agr = compare_with_replay(dec, _head(replay("switched"), LOCKSTEP_ROWS), codec, FD)
    report(f"[fd] switched, lockstep (window 32): {run.rows} steps in {run.elapsed:.1f} s = {run.steps_per_second:.0f} "
           f"steps/s; CAN vs caekf-replay: {agr.text()}")
    assert run.timeouts == 0 and dec.complete.all()
    assert (dec.bad_crc, dec.counter_duplicates, dec.counter_jumps) == (0, 0, 0)
    assert agr.ok, agr.text()

    log = out_dir / "fd-bus.log"
    paced.recorder.write_candump(log, iface)
    t, ids, dlc, data = read_candump(log)
    t_fd, ids_fd, len_fd = read_candump_fd(log)
    n_in = int(np.sum(ids_fd == codec.messages["BENCH_FD"].frame_id))
    n_out = int(np.sum(ids_fd == codec.messages["EST_FD"].frame_id))
    t_all = np.concatenate([t, t_fd])
    seconds = float(t_all.max() - t_all.min())
    classic = log_load(t, ids, dlc, data, 1e6, seconds)
    per_step = (classic.bits_worst / 1e6 + fd_log_seconds(len_fd, 1e6, DATA_BITRATE)) / PACED_ROWS
    report(f"[fd] paced {PACED_ROWS} steps at 1 kHz: answered {int(paced.decoded.complete.sum())}, bench sends late "
           f"{paced.late_sends}; log {log.name}: {n_in} BENCH_FD + {n_out} EST_FD + {len(t)} classic frames over "
           f"{seconds:.2f} s: {1e6 * per_step:.1f} us/step worst case = {100 * per_step * 1000:.1f} % of 1 Mbit/s "
           f"(5 Mbit/s data) at 1 kHz")
    assert n_in == PACED_ROWS and n_out == int(paced.decoded.complete.sum())
    assert set(len_fd[ids_fd == codec.messages["BENCH_FD"].frame_id].tolist()) == {20}
    assert set(len_fd[ids_fd == codec.messages["EST_FD"].frame_id].tolist()) == {64}


def test_fd_bad_traffic_is_counted_and_estimates_equal_replay(fd_pair, sc, inputs, replay):
    from caekf_sim.bench import e2e
    from caekf_sim.bench.fd import CAN_FRAME
    from caekf_sim.bench.profiles import FD
    from caekf_sim.bench.results import compare_with_replay, health_delta

    bench, fd = fd_pair
    info = bench.codec.messages["BENCH_FD"]
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    before = bench.status()
    head = fd.run(inputs, K, window=32)
    c = bench.tx_counter["BENCH_FD"]
    good = bytes(fd.payloads(inputs, K, K + 1)[0])  # step K with counter c (the bench's counter moves on)
    nan = bytearray(good)
    nan[5:9] = struct.pack("<f", math.nan)  # U: bits 40..71
    nan = e2e.seal_fd(info.data_id, c, bytes(nan))
    jumped = e2e.seal_fd(info.data_id, c + 5, good)
    after_jump = e2e.seal_fd(info.data_id, c + 6, good)
    bad_crc = bytes([good[0] ^ 0xFF]) + good[1:]
    fd.send_records([fd.frame(bad_crc), fd.frame(bytes(64)), fd.frame(bytes(range(64)), 0x7FF), fd.frame(nan),
                     fd.frame(jumped), fd.frame(after_jump), fd.frame(after_jump)])
    fd.sock.send(CAN_FRAME.pack(info.frame_id, 8, good[:8]))  # a classic frame with BENCH_FD's ID
    bench.tx_counter["BENCH_FD"] = (c + 7) & e2e.COUNTER_MASK
    tail = fd.run(inputs, BT_ROWS, window=32, start=K + 1)
    after = bench.status()
    h = health_delta(before, after)
    want = {"RX_BAD_CRC": 1, "RX_BAD_DLC": 2, "RX_UNKNOWN_ID": 1, "RX_BAD_VALUE": 1, "RX_COUNTER_JUMP": 1,
            "RX_DUPLICATE": 1, "STEPS_DONE": BT_ROWS, "STEPS_SKIPPED": 0, "RX_LATE": 0, "RX_REPEATED": 0}
    report("[fd] bad traffic: estimator counter changes: "
           + ", ".join(f"{k}={v}" for k, v in h.items() if v and k not in ("TX_FRAMES", "RX_OK")))
    assert {k: h[k] for k in want} == want
    assert head.decoded.complete.all() and tail.decoded.complete.all()
    ref = replay("switched")
    for run, a, b in ((head, 0, K), (tail, K + 1, BT_ROWS)):
        agr = compare_with_replay(run.decoded, _head(ref, b, a), bench.codec, FD)
        assert agr.ok, agr.text()
