"""Reduced fault matrix, for the protocol profile CAEKF_HIL_PROFILE (tools/hil-tests.sh runs it in the
production pass; the full matrix, test_hil_fault_matrix.py, runs in diagnostics).

One run of the switched experiment, 0-14 s (through the first contact at 12.8 s), lockstep, with N_EACH
injections of each NON-DESTRUCTIVE fault class spread over it (seeded): bad CRC, wrong DLC, unknown IDs,
counter jump, duplicate, NaN/Inf U, out-of-range configuration (refused by EST_ACK), flood (FLOOD_PER_STEP
unrelated frames in front of FLOOD_LEN steps). The position frame of the profile takes the roles of BENCH_Y1
(wrong DLC, duplicate) and BENCH_Y4 (counter jump): BENCH_YP in production.
Not here (full matrix only, diagnostics): the destructive classes (reordered steps, bus silence, reset
storm) with their recovery analysis, and the config-validation cases during contact; that keeps the CI HIL
stage (both profile passes) within its 3 min budget.

Checked: every EST_HEALTH counter moved by exactly what was injected; every step answered once; every value
the profile carries equals caekf-replay's undisturbed run within the signal's resolution (the faults never
reach the estimator).
"""
from __future__ import annotations

import numpy as np
import pytest

from hilcfg import PROFILE, report

ROWS = 14000
SEED = 20261125
N_EACH = 15
FLOOD_LEN = 10
FLOOD_PER_STEP = 10
KINDS = ("bad_crc", "wrong_dlc", "unknown_id", "counter_jump", "duplicate", "nan_inf", "out_of_range", "flood")


def _position_frames(bench):
    names = bench.profile.input_messages
    if "BENCH_YP" in names:
        return "BENCH_YP", "BENCH_YP"
    return "BENCH_Y1", "BENCH_Y4"


@pytest.fixture(scope="module")
def reduced_run(bench, sc, inputs):
    from caekf_sim.bench import RunRecord, faults
    from caekf_sim.bench.results import health_delta

    y_a, y_b = _position_frames(bench)
    bench.configure("switched", bench.params_from_scenario(sc, "switched"))
    before = bench.status()
    rec = RunRecord(0, ROWS)
    rng = np.random.default_rng(SEED)
    events = [(k, i) for k in KINDS for i in range(N_EACH)]
    order = rng.permutation(len(events))
    rows = np.linspace(100, ROWS - 200, len(events)).astype(int)
    flood_blob = faults.flood(bench, FLOOD_PER_STEP)
    cur = 0

    def run(a, b, extra=b""):
        if b > a:
            bench.run_lockstep(inputs, a, b, record=rec, extra_per_step=extra, timeout=2.0, progress=False)

    for row, j in zip(rows, order):
        kind, i = events[j]
        row = max(int(row), cur)
        run(cur, row)
        if kind == "flood":
            run(row, row + FLOOD_LEN, flood_blob)
            cur = row + FLOOD_LEN
            continue
        blob = {
            "bad_crc": lambda: faults.bad_crc(bench, inputs, row),
            "wrong_dlc": lambda: faults.wrong_dlc(bench, inputs, row, y_a),
            "unknown_id": lambda: faults.unknown_ids(bench, inputs, row),
            "counter_jump": lambda: faults.counter_jump(bench, inputs, row, y_b),
            "duplicate": lambda: faults.duplicate(bench, inputs, row, y_a),
            "nan_inf": lambda: faults.nonfinite_u(bench, inputs, row, i),
            "out_of_range": lambda: faults.out_of_range_param(bench, i),
        }[kind]()
        run(row, row + 1, blob)
        cur = row + 1
    run(cur, ROWS)
    after = bench.status()
    return rec, bench.decode_run(rec, inputs), health_delta(before, after), y_a


def test_reduced_fault_matrix_counts_exactly(reduced_run):
    from caekf_sim.bench.faults import UNKNOWN_IDS_PER_INJECTION

    rec, dec, h, y_a = reduced_run
    report(f"[{PROFILE}] reduced fault matrix ({len(KINDS)} classes x {N_EACH}): counter changes: "
           + ", ".join(f"{k}={v}" for k, v in h.items() if v and k not in ("TX_FRAMES", "RX_OK")))
    yp = y_a == "BENCH_YP"
    want = {
        "RX_BAD_CRC": N_EACH,
        "RX_BAD_DLC": N_EACH,
        "RX_UNKNOWN_ID": N_EACH * UNKNOWN_IDS_PER_INJECTION + N_EACH * FLOOD_LEN * FLOOD_PER_STEP,
        "RX_COUNTER_JUMP": N_EACH,
        "RX_DUPLICATE": N_EACH,
        "RX_REPEATED": 0 if yp else N_EACH,
        "RX_LATE": N_EACH if yp else 0,
        "RX_BAD_VALUE": N_EACH + (N_EACH + 1) // 2,  # NaN/Inf U, and the even out-of-range: unknown PARAM_ID
        "CFG_REFUSED": N_EACH,
        "STEPS_DONE": ROWS,
    }
    for name in ("RX_LOST", "RX_HAL_ERROR", "STEPS_FAILED", "STEPS_TIMED_OUT", "STEPS_SUPERSEDED",
                 "STEPS_SKIPPED", "TX_ERRORS", "CFG_ACCEPTED"):
        want[name] = 0
    got = {k: h[k] for k in want}
    assert got == want


def test_reduced_fault_matrix_estimates_equal_replay(reduced_run, replay, bench):
    from caekf_sim.bench.results import compare_with_replay
    from caekf_sim.estimator import EstimateResult

    rec, dec, h, _ = reduced_run
    assert rec.timeouts == 0
    assert dec.complete.all()
    assert (dec.bad_crc, dec.counter_jumps, dec.counter_duplicates) == (0, 0, 0)
    ref = replay("switched")
    head = EstimateResult(t=ref.t[:ROWS], x=ref.x[:ROWS], p_norm=ref.p_norm[:ROWS], p_gg=ref.p_gg[:ROWS],
                          flags=ref.flags[:ROWS], newton_iters=ref.newton_iters[:ROWS])
    agr = compare_with_replay(dec, head, bench.codec, bench.profile)
    report(f"[{PROFILE}] reduced fault matrix: CAN vs caekf-replay over {ROWS} steps: {agr.text()}")
    assert agr.ok, agr.text()
