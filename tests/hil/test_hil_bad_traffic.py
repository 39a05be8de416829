"""(b) Bad traffic on the bus while the estimator runs the switched experiment through the first contact.

Injected (all in one burst, just before the inputs of step K, so the step's 20 ms assembly timeout
cannot interfere), then the valid frames of step K:
  bad CRC (BENCH_U), wrong DLC (BENCH_Y1, 6 bytes), unknown/foreign IDs (0x123, 0x7FF, and EST_GAMMA's
  ID sent by the bench), a NaN input (BENCH_U with U = float32 NaN, valid E2E), a counter jump (BENCH_Y4
  with its counter +5: rejected, the receiver resynchronises on it), a duplicate (a valid BENCH_Y1 sent
  twice with the same counter); the valid BENCH_Y1 of step K then arrives a second time (a repeated
  signal in the open step: the first value is kept).
Then, for FLOOD_STEPS steps during contact, each step's inputs go after FLOOD_PER_STEP unrelated frames
and FLOOD_BAD_CRC corrupted BENCH_Y4 copies.

Checks: the estimator counted each kind exactly (EST_HEALTH via a status request), ran every step once,
and its estimates over the whole run equal caekf-replay's on the valid inputs: finite and correct after
valid data resumes. caekf-host runs without kernel acceptance filters (its default), so every foreign
frame reaches the app and is counted in RX_UNKNOWN_ID: the 3 unknown IDs and every flood frame. A remote
(RTR) frame with BENCH_U's ID is refused by the host HAL (no caekf message is a remote frame), as the MCU
HAL refuses it: RX_HAL_ERROR +1.

Runs in the profile CAEKF_HIL_PROFILE (tools/hil-tests.sh: diagnostics, production, then fd). In production the
position frame BENCH_YP takes the roles of BENCH_Y1 (wrong DLC, duplicate) and BENCH_Y4 (counter jump,
flood copies); the duplicate's first copy then brings y1 and y4, so step K completes with its BENCH_U and
its own BENCH_YP, sent after it, is late (RX_LATE +1) instead of a repeated signal (RX_REPEATED +1). In the fd
profile BENCH_FD (a CAN FD frame, CRC-16) takes every role, BENCH_U's too: the duplicate's first copy completes
step K by itself and the step's own frame is late, as in production.
"""
import math

import numpy as np
import pytest

from hilcfg import PROFILE, report

ROWS = 14000  # through the first contact episode (12.8-13.6 s ...)
K = 12700  # injection just before the first contact
FLOOD_STEPS = 500  # contact from 12.8 s: the flood runs while gamma is being estimated
FLOOD_PER_STEP = 10
FLOOD_BAD_CRC = 2


@pytest.fixture(scope="module")
def bad_traffic_run(bench, sc, inputs):
    from caekf_sim.bench import RunRecord, faults

    y_a, y_b = faults.position_frames(bench)  # wrong DLC, duplicate, repeated; counter jump, flood copies
    u_msg = faults.input_message(bench, "u")

    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    before = bench.status()
    rec = RunRecord(0, ROWS)
    bench.run_lockstep(inputs, 0, K, record=rec)

    c = bench.tx_counter

    def values(name, row=K):
        return faults.step_values(bench, name, inputs, row)

    bad = []
    # bad CRC: a valid BENCH_U of step K with byte 0 flipped; its counter is not used up
    good_u = bench.frame(u_msg, values(u_msg), advance=False)
    bad.append(good_u[:8] + bytes([good_u[8] ^ 0xFF]) + good_u[9:])
    # wrong DLC: BENCH_Y1 cut to 6 bytes
    bad.append(bench.frame(y_a, values(y_a), advance=False, dlc=6))
    # IDs the estimator does not receive
    bad.append(bench.record(0x123, bytes(range(8))))
    bad.append(bench.record(0x7FF, bytes(8)))
    bad.append(bench.record("EST_GAMMA", bytes(8)))
    # a remote frame with an ID the estimator receives
    bad.append(bench.record(bench.codec.messages[u_msg].frame_id | faults.CAN_RTR_FLAG, b"", dlc=8, fd=False))
    # NaN input, valid E2E: rejected as a bad value
    bad.append(bench.frame(u_msg, {**values(u_msg), "U": math.nan}))
    # counter jump: BENCH_Y4 with counter +5 (the estimator resynchronises on it)
    jumped = (c[y_b] + 5) & 15
    bad.append(bench.frame(y_b, values(y_b), counter=jumped))
    # duplicate: a valid BENCH_Y1 twice with the same counter (the first copy opens step K)
    y1_frame = bench.frame(y_a, values(y_a))
    bad += [y1_frame, y1_frame]
    bench.run_lockstep(inputs, K, K + 1, record=rec, extra_per_step=b"".join(bad))

    flood = b"".join(bench.record(0x200 + i, bytes([i] * 8)) for i in range(FLOOD_PER_STEP))
    bad_y4 = bench.frame(y_b, {**values(y_b), "STEP": 0}, advance=False)
    flood += (bad_y4[:8] + bytes([bad_y4[8] ^ 0x55]) + bad_y4[9:]) * FLOOD_BAD_CRC
    bench.run_lockstep(inputs, K + 1, K + 1 + FLOOD_STEPS, record=rec, extra_per_step=flood)
    bench.run_lockstep(inputs, K + 1 + FLOOD_STEPS, ROWS, record=rec)
    after = bench.status()
    from caekf_sim.bench.results import health_delta

    return rec, bench.decode_run(rec, inputs), health_delta(before, after), faults.duplicate_completes_step(bench)


def test_estimator_counts_each_kind_of_bad_frame(bad_traffic_run):
    rec, dec, h, late_dup = bad_traffic_run
    report(f"[{PROFILE}] bad traffic: estimator counter changes: "
           + ", ".join(f"{k}={v}" for k, v in h.items() if v and k not in ("TX_FRAMES", "RX_OK")))
    assert h["RX_BAD_CRC"] == 1 + FLOOD_STEPS * FLOOD_BAD_CRC
    assert h["RX_BAD_DLC"] == 1
    assert h["RX_BAD_VALUE"] == 1
    assert h["RX_COUNTER_JUMP"] == 1
    assert h["RX_DUPLICATE"] == 1
    assert h["RX_REPEATED"] == (0 if late_dup else 1)
    assert h["RX_LATE"] == (1 if late_dup else 0)
    assert h["RX_UNKNOWN_ID"] == 3 + FLOOD_STEPS * FLOOD_PER_STEP  # nothing unseen (see the docstring)
    assert h["RX_HAL_ERROR"] == 1  # the remote frame
    for name in ("RX_LOST", "STEPS_FAILED", "STEPS_TIMED_OUT", "STEPS_SUPERSEDED",
                 "STEPS_SKIPPED", "TX_ERRORS"):
        assert h[name] == 0, (name, h[name])
    assert h["STEPS_DONE"] == ROWS
    assert h["STATUS_REQUESTS"] == 1


def test_estimates_stay_finite_and_equal_replay(bad_traffic_run, replay, bench):
    from caekf_sim.bench.results import compare_with_replay

    rec, dec, h, _ = bad_traffic_run
    assert rec.timeouts == 0
    assert dec.complete.all()
    for col, v in dec.columns.items():  # every value carried (production: paged ones at their steps)
        sel = dec.carried.get(col, np.ones(len(v), dtype=bool))
        assert sel.any() and np.all(np.isfinite(v[sel])), col
    ref = replay("switched")
    from caekf_sim.estimator import EstimateResult

    head = EstimateResult(t=ref.t[:ROWS], x=ref.x[:ROWS], p_norm=ref.p_norm[:ROWS], p_gg=ref.p_gg[:ROWS],
                          flags=ref.flags[:ROWS], newton_iters=ref.newton_iters[:ROWS])
    agr = compare_with_replay(dec, head, bench.codec, bench.profile)
    report(f"[{PROFILE}] bad traffic: CAN vs caekf-replay over {ROWS} steps: {agr.text()}")
    assert agr.ok, agr.text()
    # gamma moved during the flood (contact): the comparison covered real estimation
    g = dec.columns["gamma"]
    assert g[K + FLOOD_STEPS] != g[K]
