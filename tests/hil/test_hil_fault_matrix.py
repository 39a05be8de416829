"""Fault-injection matrix over the HIL bus: one run of the switched experiment, 0-15 s (into the first
contact, 12.8-17.2 s), strict lockstep, with faults of every class spread over the run (seeded schedule).
It runs in the profile CAEKF_HIL_PROFILE (tools/hil-tests.sh: diagnostics, production, then fd); the profile's
input frames take the roles of BENCH_U (bad CRC, NaN), BENCH_Y1 (wrong DLC, duplicate) and BENCH_Y4 (counter
jump): BENCH_YP for both positions in production, where a duplicated BENCH_YP completes its step with the step's
BENCH_U and the step's own BENCH_YP then comes late (RX_LATE instead of RX_REPEATED); BENCH_FD for all three in
the fd profile (CAN FD frames, CRC-16; one frame per step, so a duplicate completes its step by itself and a
reordered pair costs 3 RX_COUNTER_JUMP).

Fault classes (sim/src/caekf_sim/bench/faults.py builds the frames):
  non-destructive -- the estimator still gets every step's valid inputs, so it must run every step and its
  estimates must not change at all:
    bad CRC, wrong DLC, unknown ID, counter jump, duplicate, NaN/Inf U, out-of-range configuration (unknown
    PARAM_ID / newton_max_iter = 2.5, refused by EST_ACK), flood (10 unrelated frames per step, i.e. 10x the
    step rate, for 10 steps per episode)
  destructive -- inputs are lost or the estimator is re-initialised:
    reordered pair (steps k+1 and k sent swapped: with a max counter delta of 1 the receiver rejects both
    and then step k+2 as counter jumps, 3 RX_COUNTER_JUMP per input message (9 in diagnostics, 6 in
    production), 3 steps skipped), bus silence (100 steps never
    sent, 0.1 s of no traffic), reset storm (40 CTRL_RESET, then the bench re-configures and goes on).
Config validation (nonsense values over CTRL_PARAM/CTRL_RESET) at 3.5 s and during contact at 12.85 s:
refused with EST_ACK, and the estimator goes on with its previous configuration.

Checked:
- every counter of EST_HEALTH moved by exactly what was injected (nothing lost: every injected frame is
  counted, foreign IDs included: caekf-host hands every frame to the app);
- exactly the expected steps were answered; every estimate the profile carries equals caekf-replay on the
  inputs the estimator actually saw (rows it got, segments split at the resets) within its signal's
  resolution (production: gamma and the core flags every step, the rest on EST_PAGE rows), with the steps lost
  between two estimated steps bridged as the app bridges them: one prediction-only step per lost step
  (caekf_predict, the previous estimated step's decoded u held, y empty: caekf-replay --missing-y-predict);
- per destructive episode (3 sampled per class): steps until the estimates match, within the CAN
  resolution, the counterfactual run without that episode (caekf-replay), and the difference left;
  every sampled episode with room to recover (MIN_WINDOW rows before the run or its segment ends) must
  get back within |dq| <= 1e-7 m and |dgamma|/gamma <= 1 % of it and stay there, the bus silence during
  the contact (12.95 s) included: its first estimates afterwards hold gamma (GAMMA_GATED, the innovation
  gate) while positions and velocities re-converge;
- the whole run ends within the same tolerance of the undisturbed run (no fault at all).
The table is printed and written to <out>/fault-matrix.txt (tools/fault-matrix.sh).
"""
from __future__ import annotations

import time

import numpy as np
import pytest

from hilcfg import PROFILE, SCENARIO, report

from caekf_sim.schema import SCHEMA

ROWS = 15000
UNKNOWN_ID = SCHEMA.param_count  # the first CTRL_PARAM id no setting has
SEED = 20261121
N_EACH = 105  # injections per non-destructive class
N_FLOOD_EPISODES = 12
FLOOD_LEN = 10
FLOOD_PER_STEP = 10
N_REORDER = 100
SILENCE_ROWS = (4500, 9500, 12950)
SILENCE_LEN = 100
STORM_ROWS = (2500, 7500, 12300)
STORM_LEN = 40
VALIDATE_ROWS = (3500, 12850)
RECOVERY_WINDOW = 3000
MIN_WINDOW = 1000  # rows an episode needs after it for its recovery to be asserted
Q_TOL = 1e-7  # practical recovery: positions within sigma_r (1e-7 m) ...
G_TOL = 1e-2  # ... and gamma within 1 % of the run without the episode
ND_KINDS = ("bad_crc", "wrong_dlc", "unknown_id", "counter_jump", "duplicate", "nan_inf", "out_of_range")

# tolerance of "equal to the reference": the CAN resolution of each estimate
LSB = {"q": 1e-12, "v": 1e-10}


def _schedule():
    rng = np.random.default_rng(SEED)
    ev = [(k, i) for k in ND_KINDS for i in range(N_EACH)]
    ev += [("flood", i) for i in range(N_FLOOD_EPISODES)] + [("reorder", i) for i in range(N_REORDER)]
    order = rng.permutation(len(ev))
    pos = np.linspace(150, ROWS - 250, len(ev)).astype(int)
    out = [(int(pos[j]), ev[o][0], ev[o][1]) for j, o in enumerate(order)]
    out += [(r, "silence", i) for i, r in enumerate(SILENCE_ROWS)]
    out += [(r, "storm", i) for i, r in enumerate(STORM_ROWS)]
    out += [(r, "validate", i) for i, r in enumerate(VALIDATE_ROWS)]
    prio = {"storm": 0, "validate": 1, "silence": 2}
    return sorted(out, key=lambda e: (e[0], prio.get(e[1], 3)))


def _await_acks(bench, tokens, timeout=10.0):
    want = set(tokens)
    got = {}
    ack_id = bench.codec.messages["EST_ACK"].frame_id
    end = time.perf_counter() + timeout
    while want - set(got) and time.perf_counter() < end:
        blob = bench.recv(0.2)
        if not blob:
            continue
        recs = bench.records(blob)
        for r in recs[recs["id"] == ack_id]:
            a = bench._decode_ack(bytes(r["data"][:8]))
            if a.token in want:
                got[a.token] = a
    return got


def _validation_cases(bench, sc):
    """(name, CTRL_PARAM frames as (param, value) or raw, expected ACK status name, expected BAD_PARAM)."""
    g0 = float(sc.gamma0)
    return [
        ("negative mass m1 = -1", [("m1", -1.0)], "REFUSED_SETTINGS", "m1"),
        ("dt = 0", [("dt", 0.0)], "REFUSED_SETTINGS", "dt"),
        ("dt = -1e-3", [("dt", -1e-3)], "REFUSED_SETTINGS", "dt"),
        ("non-finite sigma_r (PARAM_EXP10 = 31: not a finite exact value)", "exp10", "REFUSED_PARAM", "sigma_r"),
        (f"gamma_min = {2 * g0:g} > gamma0 (constrained)", [("constraint_enabled", 1.0), ("gamma_min", 2 * g0)],
         "REFUSED_SETTINGS", "contact1_gamma0"),
        ("unknown mode 7", [("mode", 7.0)], "REFUSED_SETTINGS", "mode"),
        (f"unknown parameter id {UNKNOWN_ID}", "unknown-id", "REFUSED_PARAM", str(UNKNOWN_ID)),
    ]


def _validate(bench, sc, row):
    from caekf_sim.bench import faults

    out = []
    for name, params, want, want_bad in _validation_cases(bench, sc):
        bench.drain()
        if params == "exp10":
            pid = bench.codec.param_ids["sigma_r"]
            blob = faults.unchecked_frame(bench, "CTRL_PARAM", {"PARAM_ID": pid, "PARAM_EXP10": 31,
                                                                 "PARAM_MANTISSA": 1})
            n = 1
        elif params == "unknown-id":
            blob = faults.unchecked_frame(bench, "CTRL_PARAM", {"PARAM_ID": UNKNOWN_ID, "PARAM_EXP10": 0,
                                                                 "PARAM_MANTISSA": 1})
            n = 1
        else:
            blob = b"".join(bench.param_frame(p, v) for p, v in params)
            n = len(params)
        token = bench._next_token()
        blob += bench.frame("CTRL_RESET", {"N_PARAMS": n, "TOKEN": token})
        bench.send(blob)
        ack, _ = bench._await_ack(token, 5.0)
        bad = None
        if ack is not None:
            bad = {v: k for k, v in bench.codec.param_ids.items()}.get(ack.bad_param, str(ack.bad_param))
        out.append({"row": row, "case": name, "want": want, "want_bad": want_bad, "ack": ack, "bad_param": bad})
    return out


@pytest.fixture(scope="module")
def fault_run(bench, sc, inputs):
    from caekf_sim.bench import RunRecord, faults

    y_a, y_b = faults.position_frames(bench)
    params = bench.params_from_scenario(sc, "switched")
    bench.configure("switched", params)
    before = bench.status()
    rec = RunRecord(0, ROWS)
    sched = _schedule()
    n = {k: 0 for k in (*ND_KINDS, "flood", "reorder", "silence", "storm")}
    lost = np.zeros(ROWS, dtype=bool)
    seg_starts = [0]
    episodes = []  # destructive: (kind, first row affected, rows lost or None, row where the run resumes)
    storm_acks = {}
    validations = []
    inject_rows = {k: [] for k in n}
    cur = 0
    flood_blob = faults.flood(bench, FLOOD_PER_STEP)
    t0 = time.perf_counter()

    def run(a, b, extra=b""):
        if b > a:
            bench.run_lockstep(inputs, a, b, record=rec, extra_per_step=extra, timeout=2.0, progress=False)

    for row, kind, i in sched:
        row = max(row, cur)
        if row >= ROWS - 120:
            continue
        run(cur, row)
        cur = row
        if kind in ND_KINDS:
            if kind == "bad_crc":
                blob = faults.bad_crc(bench, inputs, row)
            elif kind == "wrong_dlc":
                blob = faults.wrong_dlc(bench, inputs, row, y_a)
            elif kind == "unknown_id":
                blob = faults.unknown_ids(bench, inputs, row)
            elif kind == "counter_jump":
                blob = faults.counter_jump(bench, inputs, row, y_b)
            elif kind == "duplicate":
                blob = faults.duplicate(bench, inputs, row, y_a)
            elif kind == "nan_inf":
                blob = faults.nonfinite_u(bench, inputs, row, i)
            else:
                blob = faults.out_of_range_param(bench, i)
            run(row, row + 1, blob)
            cur = row + 1
        elif kind == "flood":
            run(row, row + FLOOD_LEN, flood_blob)
            cur = row + FLOOD_LEN
        elif kind == "reorder":
            blobs = bench.seal_steps(inputs, row, row + 3)
            bench.send(blobs[1] + blobs[0] + blobs[2])
            lost[row:row + 3] = True
            episodes.append(("reorder", row, (row, row + 3), row + 3))
            cur = row + 3
        elif kind == "silence":
            time.sleep(SILENCE_LEN * float(sc.dt))
            lost[row:row + SILENCE_LEN] = True
            episodes.append(("silence", row, (row, row + SILENCE_LEN), row + SILENCE_LEN))
            cur = row + SILENCE_LEN
        elif kind == "storm":
            tokens = faults.reset_storm(bench, STORM_LEN)
            got = _await_acks(bench, tokens)
            for a in got.values():
                storm_acks[a.status_name] = storm_acks.get(a.status_name, 0) + 1
            storm_acks["missing"] = storm_acks.get("missing", 0) + len(set(tokens) - set(got))
            bench.configure("switched", params)  # re-configure, then go on
            seg_starts.append(row)
            episodes.append(("storm", row, None, row))
        elif kind == "validate":
            validations += _validate(bench, sc, row)
            continue
        n[kind] += 1
        inject_rows[kind].append(row)
    run(cur, ROWS)
    elapsed = time.perf_counter() - t0
    time.sleep(0.02)
    after = bench.status()
    from caekf_sim.bench.results import health_delta

    dec = bench.decode_run(rec, inputs)
    return dict(rec=rec, dec=dec, h=health_delta(before, after), n=n, lost=lost, seg_starts=seg_starts,
                episodes=episodes, storm_acks=storm_acks, acks_in_run=faults.count_acks(bench, rec.chunks),
                validations=validations, inject_rows=inject_rows, elapsed=elapsed, params=params,
                yp=faults.duplicate_completes_step(bench), inputs_per_step=len(bench.profile.input_messages),
                # STEP_GAP is an app flag (the DBC's): every step in diagnostics (EST_STEP) and fd (EST_FD); production
                # carries it on EST_PAGE page 10 only (EST_PROD has the estimator's bits 0..11)
                gap_every_step=_flags_bits(bench) > 13, closing=bench.profile.closing)


def _flags_bits(bench):
    """Width of the FLAGS signal the profile carries every step (16: EST_STEP, EST_FD; 12: EST_PROD)."""
    src = bench.profile.results["flags"]
    return bench.codec.messages[src.message].signals[src.signal].length if src.page is None else 0


# --- references (caekf-replay) ------------------------------------------------------------------------------

def _replay_rows(binaries, inputs, rows, path):
    """caekf-replay (switched, fresh initial state) on the given rows of the decoded inputs, in order, with the
    steps missing between them bridged as the app does (prediction-only, last decoded u held, y empty,
    --missing-y-predict). Returns (result per step run, input row of each, prediction-only mask)."""
    from caekf_sim.bench.results import replay_estimated

    return replay_estimated(binaries["replay"], SCENARIO, "switched", inputs, rows, path)


def _placed(rep):
    """(ROWS, 11) with the replay's estimated (not prediction-only) steps on their rows, NaN elsewhere."""
    res, src, pred = rep
    x = np.full((ROWS, 11), np.nan)
    x[src[~pred]] = _x(res)[~pred]
    return x


def _x(res):
    return np.column_stack([res.x, res.p_norm, res.p_gg])


def _seen_reference(fr, binaries, inputs, out_dir):
    """Replay of every segment (split at the resets) on the rows the estimator got: (n_rows, 11) with NaN
    on lost rows, plus flags and Newton iterations."""
    lost = fr["lost"]
    bounds = list(fr["seg_starts"]) + [ROWS]
    x = np.full((ROWS, 11), np.nan)
    flags = np.zeros(ROWS, dtype=np.int64)
    iters = np.zeros(ROWS, dtype=np.int64)
    n_pred = 0
    for s, (a, b) in enumerate(zip(bounds[:-1], bounds[1:])):
        rows = np.arange(a, b)[~lost[a:b]]
        res, src, pred = rep = _replay_rows(binaries, inputs, rows, out_dir / f"fault-matrix-seg{s}.csv")
        x[rows] = _placed(rep)[rows]
        flags[src[~pred]] = res.flags[~pred]
        iters[src[~pred]] = res.newton_iters[~pred]
        n_pred += int(pred.sum())
    return x, flags, iters, n_pred


def _diff_ratio(a, b):
    """Per row, the largest |a - b| in CAN resolutions over q (1e-12 m), v (1e-10 m/s), gamma (float32)."""
    d = np.abs(a[:, :9] - b[:, :9])
    tol = np.empty_like(d)
    tol[:, :4] = 0.5 * LSB["q"]
    tol[:, 4:8] = 0.5 * LSB["v"]
    tol[:, 8] = np.maximum(np.abs(b[:, 8]) * 2.0**-24, 1e-30)
    return np.nanmax(d / tol, axis=1)


def _counterfactual(fr, binaries, inputs, out_dir, ep_index):
    """Replay of the segment holding episode ep_index as if that episode had not happened (its lost rows
    given, or for a storm, no reset there), everything else as in the run."""
    kind, row, span, resume = fr["episodes"][ep_index]
    lost = fr["lost"].copy()
    starts = list(fr["seg_starts"])
    if span is not None:
        lost[span[0]:span[1]] = False
    else:
        starts.remove(row)
    bounds = starts + [ROWS]
    seg = max(i for i, a in enumerate(bounds[:-1]) if a <= row)
    a, b = bounds[seg], bounds[seg + 1]
    rows = np.arange(a, b)[~lost[a:b]]
    return _placed(_replay_rows(binaries, inputs, rows, out_dir / f"fault-matrix-cf{ep_index}.csv"))


def _sampled(idx_list):
    if len(idx_list) <= 3:
        return idx_list
    return [idx_list[0], idx_list[len(idx_list) // 2], idx_list[-1]]


COLUMNS = ("q1", "q2", "q3", "q4", "v1", "v2", "v3", "v4", "gamma", "p_norm", "p_gg")


@pytest.fixture(scope="module")
def matrix(fault_run, binaries, inputs, out_dir, bench):
    from caekf_sim import flags
    from caekf_sim.bench.codec import step_flags
    from caekf_sim.bench.results import value_ratios

    fr = fault_run
    dec = fr["dec"]
    ref_x, ref_flags, ref_iters, n_pred = _seen_reference(fr, binaries, inputs, out_dir)
    answered = dec.complete
    # |CAN - replay| per row in the resolution of each signal the profile carries (0 where not carried)
    vr = value_ratios(dec, {c: ref_x[:, j] for j, c in enumerate(COLUMNS)}, bench.codec, bench.profile)
    r = np.nan_to_num(np.column_stack([vr[c] for c in COLUMNS]), nan=0.0)
    r = np.where((answered & ~fr["lost"])[:, None], r, 0.0)
    ratio, pr = r[:, :9].max(axis=1), r[:, 9:]
    fl = dec.columns["flags"].astype(np.int64)
    carried = flags.CORE_MASK & bench.profile.flags_mask  # production's EST_PROD leaves MODEL_MISMATCH to pages
    flags_bad = int(np.sum((fl[answered] & carried) != (ref_flags[answered] & carried)))
    it_rows = answered & dec.carried.get("newton_iters", answered)
    iters_bad = int(np.sum(dec.columns["newton_iters"][it_rows].astype(np.int64)
                           != np.clip(ref_iters[it_rows], 0, 255)))
    gap_rows = answered & ((fl & step_flags()["STEP_GAP"]) != 0)
    gap_flagged = int(gap_rows.sum())
    # STEP_GAP belongs on the first estimate after each run of lost steps (adjacent episodes merge into one
    # run), unless a reset came in between (the app then forgets the step history)
    after_loss = np.zeros(ROWS, dtype=bool)
    after_loss[1:] = fr["lost"][:-1] & ~fr["lost"][1:]
    after_loss[list(fr["seg_starts"])] = False
    gap_expected = after_loss & answered
    gated = answered & ((fl & flags.GAMMA_GATED) != 0)

    # per destructive episode, sampled: recovery against the counterfactual without it
    rec_rows = {}
    by_kind = {}
    for e, ep in enumerate(fr["episodes"]):
        by_kind.setdefault(ep[0], []).append(e)
    eps = fr["episodes"]
    storms = [ep[1] for ep in eps if ep[0] == "storm"]

    def settle(bad, n_rows):
        """Steps after which the difference stays within tolerance to the end of the window (None: never)."""
        idx = np.nonzero(bad)[0]
        if len(idx) == 0:
            return 0
        return int(idx[-1]) + 1 if idx[-1] + 1 < n_rows else None

    for kind, idx in by_kind.items():
        for e in _sampled(idx):
            _, row, span, resume = eps[e]
            cf = _counterfactual(fr, binaries, inputs, out_dir, e)
            # the counterfactual keeps every other episode, so compare up to the next reset (both restart there)
            nxt = min([r for r in storms if r > row] + [ROWS])
            hi = min(ROWS, resume + RECOVERY_WINDOW, nxt)
            rows = np.arange(resume, hi)
            rows = rows[answered[rows] & ~fr["lost"][rows]]
            # ref_x: the replay on the inputs seen, which the CAN estimates equal (asserted); in double, so
            # that "within CAN resolution" means the same value on the wire up to rounding
            r = _diff_ratio(ref_x[rows], cf[rows])
            dq_rows = np.nanmax(np.abs(ref_x[rows, :4] - cf[rows, :4]), axis=1)
            dg_rows = np.abs(ref_x[rows, 8] - cf[rows, 8]) / np.abs(cf[rows, 8])
            last = len(rows) - 1
            rec_rows.setdefault(kind, []).append(dict(
                row=row, window=len(rows), steps=settle(r > 1.0, len(rows)),
                steps_prac=settle((dq_rows > Q_TOL) | (dg_rows > G_TOL), len(rows)),
                dq=float(dq_rows[last]), dg=float(dg_rows[last]), peak_q=float(dq_rows.max()),
                peak_g=float(dg_rows.max())))
    # the whole run against the undisturbed one (caekf-replay on every input, no fault at all)
    und = _placed(_replay_rows(binaries, inputs, np.arange(ROWS), out_dir / "fault-matrix-undisturbed.csv"))
    ok = answered & ~fr["lost"]
    dq_u = np.where(ok, np.nanmax(np.abs(ref_x[:, :4] - und[:, :4]), axis=1), np.nan)
    dg_u = np.where(ok, np.abs(ref_x[:, 8] - und[:, 8]) / np.abs(und[:, 8]), np.nan)
    whole = dict(final_dq=float(dq_u[ROWS - 1]), final_dg=float(dg_u[ROWS - 1]), max_dq=float(np.nanmax(dq_u)),
                 max_dg=float(np.nanmax(dg_u)), first=int(np.argmax(ok & (_diff_ratio(ref_x, und) > 1.0))),
                 g_run=float(ref_x[ROWS - 1, 8]), g_und=float(und[ROWS - 1, 8]))
    return dict(ratio=ratio, pr=pr, flags_bad=flags_bad, iters_bad=iters_bad, gap_flagged=gap_flagged, gated=gated,
                gap_rows=gap_rows, gap_expected=gap_expected,
                recovery=rec_rows, answered=answered, whole=whole, n_pred=n_pred)


def _expected(fr):
    from caekf_sim.bench import faults

    n = fr["n"]
    nv = len(fr["validations"])
    # the frames the app cannot decode into a setting: EXP10 beyond an exact double, PARAM_ID beyond the table
    n_exp10 = sum(1 for v in fr["validations"] if "EXP10" in v["case"] or "unknown parameter id" in v["case"])
    oor_bad_value = (n["out_of_range"] + 1) // 2  # even injections: unknown PARAM_ID
    return {
        "RX_BAD_CRC": n["bad_crc"],
        "RX_BAD_DLC": n["wrong_dlc"],
        "RX_UNKNOWN_ID": faults.UNKNOWN_IDS_PER_INJECTION * n["unknown_id"] + n["flood"] * FLOOD_LEN * FLOOD_PER_STEP,
        "RX_COUNTER_JUMP": n["counter_jump"] + 3 * fr["inputs_per_step"] * n["reorder"],
        "RX_DUPLICATE": n["duplicate"],
        "RX_REPEATED": 0 if fr["yp"] else n["duplicate"],
        "RX_LATE": n["duplicate"] if fr["yp"] else 0,
        "RX_BAD_VALUE": n["nan_inf"] + oor_bad_value + n_exp10,
        "RX_LOST": 0, "RX_HAL_ERROR": 0, "RX_UNCONFIGURED": 0,
        "STEPS_DONE": ROWS - 3 * n["reorder"] - SILENCE_LEN * n["silence"],
        "STEPS_SKIPPED": 3 * n["reorder"] + SILENCE_LEN * n["silence"],
        "STEPS_FAILED": 0, "STEPS_TIMED_OUT": 0, "STEPS_SUPERSEDED": 0, "TX_ERRORS": 0,
        "CFG_ACCEPTED": (STORM_LEN + 1) * n["storm"],
        "CFG_REFUSED": n["out_of_range"] + nv,
        "STATUS_REQUESTS": 1,
    }


def _fmt_rec(items):
    if not items:
        return "-", "-"

    def worst(key):
        v = [it[key] for it in items]
        ok = [x for x in v if x is not None]
        out = f"<= {max(ok)} steps in {len(ok)}/{len(v)}" if ok else f"0/{len(v)}"
        return out + (" (others not within their window)" if len(ok) < len(v) else "")

    rec = (f"to CAN resolution: {worst('steps')}; to |dq| <= {Q_TOL:g} m & |dg|/g <= {G_TOL:g}: "
           f"{worst('steps_prac')} (sampled episodes: first, middle, last)")
    st = lambda v: "not in window" if v is None else str(v)  # noqa: E731
    d = "; ".join(f"@{it['row']} (window {it['window']}, recovered {st(it['steps'])} / {st(it['steps_prac'])}): "
                  f"end |dq| {it['dq']:.1e} m, |dg|/g {it['dg']:.1e} (peak {it['peak_q']:.1e} m, {it['peak_g']:.1e})"
                  for it in items)
    return rec, d


def _spans(mask):
    """'a-b, c-d' for the runs of True in mask."""
    idx = np.nonzero(mask)[0]
    if len(idx) == 0:
        return "none"
    cuts = np.nonzero(np.diff(idx) > 1)[0]
    starts = np.r_[idx[0], idx[cuts + 1]]
    ends = np.r_[idx[cuts], idx[-1]]
    return ", ".join(f"{a}-{b}" if b > a else f"{a}" for a, b in zip(starts, ends))


def _table(fr, m):
    from caekf_sim.bench import faults

    n, h, ir = fr["n"], fr["h"], fr["inject_rows"]
    ratio = m["ratio"]

    def nd_worst(kind, span=1):
        rows = [r + j for r in ir[kind] for j in range(span + 5) if r + j < ROWS]
        return float(np.max(ratio[rows])) if rows else 0.0

    rows = []
    nd = [
        ("bad CRC", "bad_crc", f"RX_BAD_CRC +{h['RX_BAD_CRC']}"),
        ("wrong DLC", "wrong_dlc", f"RX_BAD_DLC +{h['RX_BAD_DLC']}"),
        ("unknown ID (4 frames each)", "unknown_id",
         f"RX_UNKNOWN_ID +{faults.UNKNOWN_IDS_PER_INJECTION * n['unknown_id']} (of +{h['RX_UNKNOWN_ID']} incl. flood)"),
        ("counter jump", "counter_jump",
         f"RX_COUNTER_JUMP +{h['RX_COUNTER_JUMP']} (incl. {3 * fr['inputs_per_step']}/reorder)"),
        ("duplicate", "duplicate", f"RX_DUPLICATE +{h['RX_DUPLICATE']}, RX_REPEATED +{h['RX_REPEATED']}, "
                                   f"RX_LATE +{h['RX_LATE']}"),
        ("NaN/Inf U", "nan_inf", f"RX_BAD_VALUE +{h['RX_BAD_VALUE']} (incl. unknown PARAM_ID, EXP10)"),
        ("out-of-range config", "out_of_range",
         f"CFG_REFUSED +{h['CFG_REFUSED']} (incl. validation); EST_ACK REFUSED_PARAM x"
         f"{fr['acks_in_run'].get('REFUSED_PARAM', 0)}"),
    ]
    for label, kind, det in nd:
        rows.append([label, str(n[kind]), det, "0 steps: inputs unchanged",
                     f"none: <= {nd_worst(kind) / 2:.2f} LSB from replay in the 5 steps after"])
    rows.append([f"flood {FLOOD_PER_STEP}/step x {FLOOD_LEN} steps", f"{n['flood']} episodes "
                 f"({n['flood'] * FLOOD_LEN * FLOOD_PER_STEP} frames)", f"RX_UNKNOWN_ID "
                 f"+{n['flood'] * FLOOD_LEN * FLOOD_PER_STEP} (of +{h['RX_UNKNOWN_ID']})", "0 steps: inputs unchanged",
                 f"none: <= {nd_worst('flood', FLOOD_LEN) / 2:.2f} LSB from replay"])
    rec = m["recovery"]
    s, d = _fmt_rec(rec.get("reorder"))
    rows.append(["reordered pair", f"{n['reorder']} (3 steps lost each)",
                 f"RX_COUNTER_JUMP {3 * fr['inputs_per_step']} each, STEPS_SKIPPED +{h['STEPS_SKIPPED']} "
                 "(incl. silence), "
                 + (f"{m['gap_flagged']} {fr['closing']} with STEP_GAP (one per run of lost steps; episodes that "
                    "touch merge)" if fr["gap_every_step"] else "STEP_GAP on EST_PAGE page 10 only in this profile"),
                 s, d])
    s, d = _fmt_rec(rec.get("silence"))
    rows.append([f"bus silence {SILENCE_LEN} steps", f"{n['silence']} episodes ({n['silence'] * SILENCE_LEN} steps)",
                 "STEPS_SKIPPED +100 each, STEP_GAP on the next estimate (bridged: 100 prediction-only steps); "
                 f"GAMMA_GATED on {int(m['gated'].sum())} estimates (rows {_spans(m['gated'])})",
                 s, d])
    s, d = _fmt_rec(rec.get("storm"))
    sa = fr["storm_acks"]
    rows.append([f"reset storm ({STORM_LEN} CTRL_RESET) + re-config", f"{n['storm']} storms "
                 f"({n['storm'] * STORM_LEN} resets)", f"CFG_ACCEPTED +{h['CFG_ACCEPTED']}, EST_ACK ACCEPTED x"
                 f"{sa.get('ACCEPTED', 0)} (missing {sa.get('missing', 0)})", s, d])
    hdr = ["fault class", "injected", "detected", "recovered (steps, vs the same run without it)",
           "estimate difference at the end of the window vs the run without it (sampled episodes)"]
    from caekf_sim.bench.faults import format_table

    vt = format_table(["at row", "nonsense configuration", "EST_ACK", "BAD_PARAM", "state after"],
                      [[str(v["row"]), v["case"], v["ack"].status_name if v["ack"] else "NO ACK", str(v["bad_param"]),
                        (f"{v['ack'].state}" if v["ack"] else "-")] for v in fr["validations"]])
    agree = (f"every answered step vs caekf-replay on the inputs seen: worst {float(ratio.max()):.2f} resolution "
             f"(q,v,gamma), P {float(np.nanmax(m['pr'])):.2f}, flags differ {m['flags_bad']}, Newton differ "
             f"{m['iters_bad']}; answered {int(m['answered'].sum())}/{ROWS}; lost steps bridged in the replay by "
             f"{m['n_pred']} prediction-only steps (u held, --missing-y-predict) as the app does")
    w = m["whole"]
    agree += (f"\nwhole run vs undisturbed (caekf-replay on all {ROWS} inputs, no faults): equal (<= half an LSB) "
              f"up to row {w['first']}, max |dq| {w['max_dq']:.1e} m, max |dg|/g {w['max_dg']:.1e}; at the end "
              f"(t = {ROWS * 1e-3:.1f} s) |dq| {w['final_dq']:.1e} m, |dg|/g {w['final_dg']:.1e} "
              f"(gamma {w['g_run']:.4g} vs {w['g_und']:.4g} N/m^1.5)")
    return (f"[{PROFILE}] fault matrix: switched experiment, rows 0..{ROWS} ({ROWS * 1e-3:.1f} s, "
            f"first contact 12.8 s), lockstep, {fr['elapsed']:.1f} s on the bus\n" + format_table(hdr, rows)
            + "\n" + agree + "\nconfig validation over CAN (estimator keeps its configuration):\n" + vt
            + "\nEST_HEALTH deltas: " + ", ".join(f"{k}={v}" for k, v in fr["h"].items() if v))


def test_fault_matrix_counts(fault_run, matrix, out_dir):
    fr = fault_run
    text = _table(fr, matrix)
    (out_dir / "fault-matrix.txt").write_text(text + "\n")
    report(text)
    for k in ND_KINDS:
        assert fr["n"][k] >= 100, k
    assert fr["n"]["reorder"] >= 100 and fr["n"]["flood"] * FLOOD_LEN >= 100
    assert fr["n"]["storm"] * STORM_LEN >= 100 and fr["n"]["silence"] * SILENCE_LEN >= 100
    exp = _expected(fr)
    wrong = {k: (fr["h"].get(k), v) for k, v in exp.items() if fr["h"].get(k) != v}
    assert not wrong, f"EST_HEALTH (got, expected): {wrong}"
    assert fr["storm_acks"].get("ACCEPTED", 0) == fr["n"]["storm"] * STORM_LEN
    assert fr["acks_in_run"].get("REFUSED_PARAM", 0) == fr["n"]["out_of_range"]
    if fr["gap_every_step"]:  # else (production) the STEPS_SKIPPED count above stands for it
        np.testing.assert_array_equal(np.nonzero(matrix["gap_rows"])[0], np.nonzero(matrix["gap_expected"])[0])
    # the replay bridged exactly the steps the app counted as skipped (each one prediction-only step)
    assert matrix["n_pred"] == exp["STEPS_SKIPPED"]


def test_fault_matrix_estimates_equal_replay_on_seen_inputs(fault_run, matrix):
    fr = fault_run
    assert fr["rec"].timeouts == 0
    np.testing.assert_array_equal(matrix["answered"], ~fr["lost"])
    assert float(matrix["ratio"].max()) <= 1.0
    assert float(np.nanmax(matrix["pr"])) <= 1.0
    assert matrix["flags_bad"] == 0 and matrix["iters_bad"] == 0
    for c, v in fr["dec"].columns.items():  # finite wherever the profile carried it
        assert np.all(np.isfinite(v[matrix["answered"] & fr["dec"].carried.get(c, True)])), c
    g = fr["dec"].columns["gamma"]
    assert g[ROWS - 1] != g[12700]  # gamma was estimated during contact


def test_fault_matrix_config_validation(fault_run, matrix):
    fr = fault_run
    assert len(fr["validations"]) == len(VALIDATE_ROWS) * 7
    for v in fr["validations"]:
        assert v["ack"] is not None, v["case"]
        assert v["ack"].status_name == v["want"], (v["case"], v["ack"].status_name)
        assert v["bad_param"] == v["want_bad"], (v["case"], v["bad_param"])
        assert v["ack"].state & 1, v["case"]  # still configured (the running settings untouched: below)
    # estimates go on unchanged: the steps after each refusal equal the replay without any refusal
    for r in VALIDATE_ROWS:
        assert float(matrix["ratio"][r:r + 200].max()) <= 1.0


def test_fault_matrix_recovers(fault_run, matrix):
    """Every sampled destructive episode with room to recover gets back to the run without it and stays,
    the bus silence in contact included; the whole run ends where the undisturbed one does."""
    rec = matrix["recovery"]
    judged = []
    for kind, items in rec.items():
        for it in items:
            if it["window"] >= MIN_WINDOW:
                judged.append((kind, it["row"]))
                assert it["steps_prac"] is not None, (kind, it)
    assert ("silence", SILENCE_ROWS[-1]) in judged, "the silence during the contact must be judged"
    # the gate is what carries that episode: gamma held on the first estimates after it
    assert matrix["gated"][SILENCE_ROWS[-1] + SILENCE_LEN:SILENCE_ROWS[-1] + SILENCE_LEN + 50].any()
    w = matrix["whole"]
    assert w["final_dq"] <= Q_TOL and w["final_dg"] <= G_TOL, w
