"""What only the CAN FD profile has, in the fd pass (CAEKF_HIL_PROFILE=fd; tools/hil-tests.sh runs the bad-traffic
tests and the full fault matrix in this pass too, with BENCH_FD in every role). vcan0 carries CAN FD frames
(MTU 72, set up by tools/with-vcan.sh); the session's caekf-host runs `--profile fd` and the session's bench
moves every frame as a struct canfd_frame (`Bench.open(profile="fd")`: python-can fd=True, CAN_RAW_FD_FRAMES).

- PACED_ROWS steps of the switched experiment paced at 1 kHz with the whole bus recorded (`Bench.run_paced`,
  kernel timestamps): the candump log (out/.../fd-bus.log) holds one BENCH_FD (20 bytes) and one EST_FD (64 bytes)
  per step, both CAN FD frames with bit-rate switch; its bus load is measured as `caekf-sim busload --log fd=LOG`
  does and reported; every answered step equals caekf-replay in every value (the FD frames carry the diagnostics
  profile's resolutions), lost steps bridged as the app bridges them;
- frames of the wrong kind or length for BENCH_FD, one burst before step K of a fresh switched run: a classic
  8-byte frame with BENCH_FD's ID and a 64-byte CAN FD one (RX_BAD_DLC +2), and a CAN FD frame with an unknown
  ID (RX_UNKNOWN_ID +1): counted exactly, every step run once and equal to caekf-replay.
"""
from __future__ import annotations

import numpy as np
import pytest

from hilcfg import PROFILE, SCENARIO, report

PACED_ROWS = 2000
BT_ROWS = 3000
K = 1500


@pytest.fixture(scope="module", autouse=True)
def _fd_profile():
    if PROFILE != "fd":
        pytest.fail(f"test_hil_fd.py runs in the fd profile (CAEKF_HIL_PROFILE=fd), not {PROFILE}: "
                    "tools/hil-tests.sh runs it in its fd pass", pytrace=False)


def test_fd_paced_log_has_two_can_fd_frames_per_step_and_equals_replay(bench, iface, out_dir, sc, inputs, binaries):
    from caekf_sim.bench.busload import fd_log_seconds, log_load, read_candump, read_candump_fd
    from caekf_sim.bench.profiles import DATA_BITRATE
    from caekf_sim.bench.realtime import write_candump
    from caekf_sim.bench.results import aligned_result, compare_with_replay, estimated_rows, replay_estimated

    codec = bench.codec
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    rec = bench.run_paced(inputs, float(sc.dt), 0, PACED_ROWS)
    dec = bench.decode_run(rec, inputs)
    log = out_dir / "fd-bus.log"
    write_candump(log, iface, rec.paced.frames_t_ns, rec.paced.frames)
    t, ids, dlc, data = read_candump(log)
    t_fd, ids_fd, len_fd = read_candump_fd(log)
    n_in = int(np.sum(ids_fd == codec.messages["BENCH_FD"].frame_id))
    n_out = int(np.sum(ids_fd == codec.messages["EST_FD"].frame_id))
    t_all = np.concatenate([t, t_fd])
    seconds = float(t_all.max() - t_all.min())
    classic = log_load(t, ids, dlc, data, 1e6, seconds)
    per_step = (classic.bits_worst / 1e6 + fd_log_seconds(len_fd, 1e6, DATA_BITRATE)) / PACED_ROWS
    report(f"[fd] paced {PACED_ROWS} steps at 1 kHz: answered {int(dec.complete.sum())}, bench sends late "
           f"{rec.late_sends}; log {log.name}: {n_in} BENCH_FD + {n_out} EST_FD + {len(t)} classic frames over "
           f"{seconds:.2f} s: {1e6 * per_step:.1f} us/step worst case = {100 * per_step * 1000:.1f} % of 1 Mbit/s "
           f"(5 Mbit/s data) at 1 kHz")
    assert n_in == PACED_ROWS and n_out == int(dec.complete.sum()) >= 0.95 * PACED_ROWS
    assert set(len_fd[ids_fd == codec.messages["BENCH_FD"].frame_id].tolist()) == {20}
    assert set(len_fd[ids_fd == codec.messages["EST_FD"].frame_id].tolist()) == {64}
    assert (dec.bad_crc, dec.counter_duplicates, dec.counter_jumps) == (0, 0, 0)
    res, src, pred = replay_estimated(binaries["replay"], SCENARIO, "switched", inputs, estimated_rows(dec),
                                      out_dir / "fd-paced-replay.csv")
    agr = compare_with_replay(dec, aligned_result(res, src, pred, inputs.t[:PACED_ROWS]), codec, bench.profile)
    report(f"[fd] paced: CAN vs caekf-replay ({int(pred.sum())} prediction-only steps bridged): {agr.text()}")
    assert not any(agr.mismatched.values()) and agr.flags_mismatch == 0 and agr.newton_mismatch == 0, agr.text()


def test_fd_wrong_frame_kinds_are_counted_and_estimates_equal_replay(bench, sc, inputs, replay):
    from caekf_sim.bench import RunRecord, faults
    from caekf_sim.bench.results import compare_with_replay, health_delta
    from caekf_sim.estimator import EstimateResult

    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    before = bench.status()
    rec = RunRecord(0, BT_ROWS)
    bench.run_lockstep(inputs, 0, K, window=32, record=rec)
    good = bench.frame("BENCH_FD", faults.step_values(bench, "BENCH_FD", inputs, K), advance=False)[8:8 + 20]
    bad = (bench.record("BENCH_FD", good[:8], fd=False)  # a classic frame with BENCH_FD's ID
           + bench.record("BENCH_FD", good.ljust(64, b"\0"))  # a CAN FD frame of 64 bytes with it
           + bench.record(0x7FF, bytes(range(64)), fd=True))  # a CAN FD frame with an unknown ID
    bench.run_lockstep(inputs, K, K + 1, record=rec, extra_per_step=bad)
    bench.run_lockstep(inputs, K + 1, BT_ROWS, window=32, record=rec)
    h = health_delta(before, bench.status())
    want = {"RX_BAD_DLC": 2, "RX_UNKNOWN_ID": 1, "RX_BAD_CRC": 0, "RX_BAD_VALUE": 0, "RX_COUNTER_JUMP": 0,
            "RX_DUPLICATE": 0, "STEPS_DONE": BT_ROWS, "STEPS_SKIPPED": 0, "RX_LATE": 0, "RX_REPEATED": 0}
    report("[fd] wrong frame kinds: estimator counter changes: "
           + ", ".join(f"{k}={v}" for k, v in h.items() if v and k not in ("TX_FRAMES", "RX_OK")))
    assert {k: h[k] for k in want} == want
    dec = bench.decode_run(rec, inputs)
    assert rec.timeouts == 0 and dec.complete.all()
    ref = replay("switched")
    head = EstimateResult(t=ref.t[:BT_ROWS], x=ref.x[:BT_ROWS], p_norm=ref.p_norm[:BT_ROWS], p_gg=ref.p_gg[:BT_ROWS],
                          flags=ref.flags[:BT_ROWS], newton_iters=ref.newton_iters[:BT_ROWS])
    agr = compare_with_replay(dec, head, bench.codec, bench.profile)
    assert agr.ok, agr.text()
