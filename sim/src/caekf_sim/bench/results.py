"""HIL results: estimates decoded from CAN -> the caekf-replay CSV columns, the summary table,
the figures (caekf_sim.plots) and the comparison with caekf-replay on the same inputs."""
from __future__ import annotations

import subprocess
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import flags as fl
from ..estimator import EstimateResult
from .bench import Ack, Decoded, RunRecord, StepInputs, latency_stats
from .codec import Codec, step_flags
from .profiles import DIAGNOSTICS, Profile

PathLike = Union[str, Path]
COUNTER_MOD = 1 << 24
# EST_HEALTH counters that mean something went wrong on the bus or in the estimator
ERROR_COUNTERS = ("RX_UNKNOWN_ID", "RX_BAD_DLC", "RX_BAD_CRC", "RX_COUNTER_JUMP", "RX_DUPLICATE", "RX_LOST",
                  "RX_BAD_VALUE", "RX_UNCONFIGURED", "RX_LATE", "RX_REPEATED", "RX_HAL_ERROR", "STEPS_FAILED",
                  "STEPS_TIMED_OUT", "STEPS_SUPERSEDED", "STEPS_SKIPPED", "TX_ERRORS", "TX_SATURATED")


def estimate_result(dec: Decoded, t: np.ndarray, wall_time: float = float("nan")) -> EstimateResult:
    """The complete rows of a decoded run as an EstimateResult (the caekf-replay columns). Values a profile
    carries only at some steps (production: EST_PAGE) are NaN elsewhere; Newton iterations -1."""
    m = dec.complete
    c = dec.columns
    it = c["newton_iters"][m]
    nq = sum(1 for k in c if k[:1] == "q" and k[1:].isdigit())
    gammas = ["gamma"] + [k for k in ("gamma2",) if k in c]
    x = np.column_stack([c[k][m] for k in (*[f"q{i}" for i in range(1, nq + 1)],
                                           *[f"v{i}" for i in range(1, nq + 1)], *gammas)])
    p_ggs = np.column_stack([c["p_gg"][m], c["p_gg2"][m]]) if "p_gg2" in c else None
    return EstimateResult(t=np.asarray(t, dtype=float)[m], x=x, p_norm=c["p_norm"][m], p_gg=c["p_gg"][m],
                          flags=c["flags"][m].astype(np.int64),
                          newton_iters=np.where(np.isnan(it), -1, it).astype(np.int64),
                          wall_time=wall_time, n_contacts=len(gammas), p_ggs=p_ggs)


def health_delta(before: Dict[str, int], after: Dict[str, int]) -> Dict[str, int]:
    return {k: (after[k] - before.get(k, 0)) % COUNTER_MOD for k in after if not k.startswith("_")}


def describe_flags(bits: int) -> str:
    names = fl.describe(bits & fl.CORE_MASK) + [n.lower() for n, b in step_flags().items() if bits & b]
    return ",".join(names) or "-"


@dataclass
class HilRun:
    """One experiment over CAN."""

    experiment: str
    inputs: StepInputs
    record: RunRecord
    decoded: Decoded
    health_before: Dict[str, int] = field(default_factory=dict)
    health_after: Dict[str, int] = field(default_factory=dict)
    ack: Optional[Ack] = None

    @property
    def rows(self) -> slice:
        return slice(self.record.start, self.record.stop)

    @property
    def t(self) -> np.ndarray:
        return self.inputs.t[self.rows]

    @property
    def result(self) -> EstimateResult:
        return estimate_result(self.decoded, self.t, self.record.elapsed)

    @property
    def health(self) -> Dict[str, int]:
        return health_delta(self.health_before, self.health_after) if self.health_after else {}

    @property
    def bus_errors(self) -> Dict[str, int]:
        h = self.health
        return {k: h[k] for k in ERROR_COUNTERS if h.get(k, 0)}

    @property
    def steps_per_second(self) -> float:
        return self.record.n / self.record.elapsed if self.record.elapsed > 0 else float("nan")

    @property
    def latency(self) -> Dict[str, float]:
        return latency_stats(self.record)


def _fmt_errors(d: Dict[str, int]) -> str:
    return ",".join(f"{k}={v}" for k, v in d.items()) or "none"


SUMMARY_HEADER = ["experiment", "steps ok", "final gamma err", "min gamma", "max ||P||", "newton mean", "max",
                  "flags seen", "timeouts", "estimator error counters", "steps/s"]


def summary_row(run: HilRun, gamma_true: float) -> List[str]:
    r = run.result
    g = r.gamma
    fin = g[np.isfinite(g)]
    pn = r.p_norm[np.isfinite(r.p_norm)]
    it = r.newton_iters[r.newton_iters >= 0]
    return [
        run.experiment,
        f"{int(run.decoded.complete.sum())}/{run.record.n}",
        f"{100 * (g[-1] / gamma_true - 1):+.3f} %" if len(g) else "-",
        f"{fin.min():.4g}" if fin.size else "-",
        f"{pn.max():.3g}" if pn.size else "-",
        f"{it.mean():.3f}" if len(it) else "-",
        str(int(it.max())) if len(it) else "-",
        describe_flags(int(np.bitwise_or.reduce(r.flags))) if len(g) else "-",
        str(run.record.timeouts),
        _fmt_errors(run.bus_errors) if run.health_after else "?",
        f"{run.steps_per_second:.0f}",
    ]


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    cells = [list(header)] + [list(r) for r in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def format_summary(runs: Sequence[HilRun], gamma_true: float) -> str:
    lines = [format_table(SUMMARY_HEADER, [summary_row(r, gamma_true) for r in runs])]
    for r in runs:
        d = r.decoded
        bench_side = (f"bench-side E2E of {d.frames} received frames: bad CRC {d.bad_crc}, bad DLC {d.bad_dlc}, "
                      f"counter duplicates {d.counter_duplicates}, jumps {d.counter_jumps}")
        lines.append(f"{r.experiment}: {r.record.mode}"
                     + (f" (window {r.record.window})" if r.record.mode == "lockstep" else "")
                     + f", {r.record.elapsed:.1f} s; {bench_side}")
        lat = r.latency
        if lat:
            lines.append(format_latency(r.experiment, lat, r.record.dt))
    return "\n".join(lines)


def format_latency(name: str, lat: Dict[str, float], dt: float) -> str:
    if "p50" not in lat:
        return f"{name}: no estimate came back"
    return (f"{name}: latency inputs sent -> EST_STEP read: p50 {1e6 * lat['p50']:.0f} us, "
            f"p99 {1e6 * lat['p99']:.0f} us, max {1e6 * lat['max']:.0f} us; deadline (dt = "
            f"{1e3 * dt:g} ms) misses {int(lat['misses'])} of {int(lat['steps'])}; answered "
            f"{int(lat['answered'])}; bench sends later than dt: {int(lat['late_sends'])} (held back by flow control: "
            f"{int(lat.get('held', 0))})")


def write_outputs(runs: Sequence[HilRun], outdir: PathLike, gamma_true: float, gamma_min: float, truth=None,
                  header: str = "", figures: bool = True) -> Tuple[str, List[Path]]:
    """<experiment>.csv per run, summary.txt, and the figures whose experiments are present."""
    from ..results import write_result_csv

    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    results = {}
    for r in runs:
        res = r.result
        write_result_csv(res, out / f"{r.experiment}.csv")
        results[r.experiment] = res
    text = (header + "\n" if header else "") + format_summary(runs, gamma_true)
    (out / "summary.txt").write_text(text + "\n", encoding="utf-8")
    pngs: List[Path] = []
    if figures and truth is not None:
        from ..plots import make_all

        pngs = make_all(results, truth, gamma_true, gamma_min, out)
    return text, pngs


# --- comparison with caekf-replay ------------------------------------------------------------

def write_seen_inputs(path: PathLike, inputs: StepInputs, start: int = 0, stop: Optional[int] = None) -> Path:
    """t,u,y1,y4 (a mechanism's: t, its inputs, its sensors; StepInputs.names) exactly as the estimator decoded
    them from the frames (float32 u, y on the LSB)."""
    stop = len(inputs) if stop is None else stop
    arr = np.column_stack([inputs.t[start:stop], inputs.u_seen[start:stop], inputs.y_seen[start:stop]])
    np.savetxt(path, arr, fmt="%.17g", delimiter=",", header=",".join(("t", *inputs.names)), comments="")
    return Path(path)


def run_c_replay(replay_bin: PathLike, scenario: PathLike, in_csv: PathLike, experiment: Optional[str],
                 out_csv: PathLike, missing_y_predict: bool = False) -> EstimateResult:
    """caekf-replay on in_csv (experiment None: the schema's defaults over the scenario); missing_y_predict:
    rows with empty y1,y4 are prediction-only steps."""
    from ..results import read_result_csv

    cmd = [str(replay_bin), "--scenario", str(scenario), "--in", str(in_csv), "--out", str(out_csv)]
    if experiment is not None:
        cmd += ["--experiment", experiment]
    if missing_y_predict:
        cmd.append("--missing-y-predict")
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return read_result_csv(out_csv)


# --- steps the estimator never got: the app bridges them with prediction-only steps ------------------

MAX_GAP_PREDICT = 1000  # CAEKF_APP_MAX_GAP_PREDICT (firmware/app/include/caekf/caekf_app.h)
STEP_MOD = 1 << 16


def bridged_rows(inputs: StepInputs, estimated: Sequence[int],
                 max_gap: int = MAX_GAP_PREDICT) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The steps the estimator ran for the input rows it estimated (`estimated`: increasing row indices, one
    configuration, i.e. a fresh estimator at the first of them). Between two estimated rows whose STEPs
    (mod 2^16) are not consecutive, the app runs one prediction-only step per missing step (at most max_gap
    per gap), with the input of the previous estimated step held. Returns (src, pred, u_row) per step run:
    the input row it stands for, whether it is prediction-only, and the row whose u it uses."""
    rows = np.asarray(estimated, dtype=np.int64)
    if len(rows) < 2:
        return rows, np.zeros(len(rows), dtype=bool), rows
    ws = np.asarray(inputs.wire_steps, dtype=np.int64)[rows]
    nb = np.minimum((np.diff(ws) - 1) % STEP_MOD, max_gap)
    if not nb.any():
        return rows, np.zeros(len(rows), dtype=bool), rows
    n_in = len(inputs.t)
    src, pred, urow = [], [], []
    prev = 0
    for g in np.flatnonzero(nb):
        src.append(rows[prev:g + 1])
        pred.append(np.zeros(g + 1 - prev, dtype=bool))
        urow.append(rows[prev:g + 1])
        k = int(nb[g])
        src.append(np.minimum(rows[g] + 1 + np.arange(k), n_in - 1))
        pred.append(np.ones(k, dtype=bool))
        urow.append(np.full(k, rows[g]))
        prev = int(g) + 1
    src.append(rows[prev:])
    pred.append(np.zeros(len(rows) - prev, dtype=bool))
    urow.append(rows[prev:])
    return np.concatenate(src), np.concatenate(pred), np.concatenate(urow)


def write_bridged_inputs(path: PathLike, inputs: StepInputs, src: np.ndarray, pred: np.ndarray,
                         u_row: np.ndarray) -> Path:
    """caekf-replay input (for --missing-y-predict) of the steps from bridged_rows: t of the row, u as the
    estimator decoded it (held over a gap), y1,y4 as decoded, empty on the prediction-only steps."""
    t = inputs.t[src]
    u = inputs.u_seen[u_row]
    y = inputs.y_seen[src]
    lines = ["t,u,y1,y4"]
    for i in range(len(src)):
        if pred[i]:
            lines.append(f"{t[i]:.17g},{u[i]:.17g},,")
        else:
            lines.append(f"{t[i]:.17g},{u[i]:.17g},{y[i, 0]:.17g},{y[i, 1]:.17g}")
    Path(path).write_text("\n".join(lines) + "\n")
    return Path(path)


def replay_estimated(replay_bin: PathLike, scenario: PathLike, experiment: str, inputs: StepInputs,
                     estimated: Sequence[int], path: PathLike) -> Tuple[EstimateResult, np.ndarray, np.ndarray]:
    """caekf-replay (fresh state) on the estimated rows with the app's gap bridging: (result per step run,
    src, pred) as bridged_rows; <path>.in.csv is the input, path the output."""
    src, pred, u_row = bridged_rows(inputs, estimated)
    path = Path(path)
    inp = write_bridged_inputs(path.with_suffix(".in.csv"), inputs, src, pred, u_row)
    res = run_c_replay(replay_bin, scenario, inp, experiment, path, missing_y_predict=bool(pred.any()))
    return res, src, pred


def aligned_result(res: EstimateResult, src: np.ndarray, pred: np.ndarray, t: np.ndarray,
                   offset: int = 0) -> EstimateResult:
    """The estimated (not prediction-only) steps of a bridged replay placed on rows [offset, offset + len(t)),
    NaN elsewhere (rows not estimated)."""
    n = len(t)
    k = src[~pred] - offset
    keep = (k >= 0) & (k < n)
    k = k[keep]
    sel = np.flatnonzero(~pred)[keep]
    x = np.full((n, 9), np.nan)
    x[k] = res.x[sel]
    pn = np.full(n, np.nan)
    pn[k] = res.p_norm[sel]
    pg = np.full(n, np.nan)
    pg[k] = res.p_gg[sel]
    flags = np.zeros(n, dtype=np.int64)
    flags[k] = res.flags[sel]
    it = np.zeros(n, dtype=np.int64)
    it[k] = res.newton_iters[sel]
    return EstimateResult(t=np.asarray(t, dtype=float), x=x, p_norm=pn, p_gg=pg, flags=flags, newton_iters=it)


def estimated_rows(dec: Decoded) -> np.ndarray:
    """Rows (relative to the run) the estimator ran, from its answers: the answered ones, plus unanswered rows
    between two answers when the next answer carries no STEP_GAP (estimated, answer not read); unanswered rows
    before a STEP_GAP answer were never estimated (bridged by the app). Unanswered rows before the first
    answer count as not estimated."""
    have = np.asarray(dec.complete, dtype=bool)
    ans = np.flatnonzero(have)
    if len(ans) == 0:
        return ans
    est = have.copy()
    gap = (np.asarray(dec.columns["flags"])[ans].astype(np.int64) & step_flags()["STEP_GAP"]) != 0
    for j in range(1, len(ans)):
        a, b = ans[j - 1], ans[j]
        if b > a + 1 and not gap[j]:
            est[a + 1:b] = True
    return np.flatnonzero(est)


@dataclass
class Agreement:
    """CAN estimates vs caekf-replay's on the same inputs, column by column."""

    rows: int
    worst: Dict[str, float]  # max |can - replay| / allowed resolution (<= 1 passes)
    mismatched: Dict[str, int]  # rows outside the resolution per column
    flags_mismatch: int
    newton_mismatch: int
    missing: int
    carried: Dict[str, int] = field(default_factory=dict)  # rows compared per column

    @property
    def ok(self) -> bool:
        return (self.missing == 0 and not any(self.mismatched.values()) and self.flags_mismatch == 0
                and self.newton_mismatch == 0)

    def text(self) -> str:
        worst = ", ".join(f"{k} {v:.2f}" for k, v in self.worst.items())
        bad = {k: v for k, v in self.mismatched.items() if v}
        return (f"{self.rows} rows, missing {self.missing}; worst |CAN - replay| / resolution: {worst}; "
                f"outside: {bad or 'none'}; flags differ {self.flags_mismatch}, Newton iterations differ "
                f"{self.newton_mismatch}")


def value_ratios(dec: Decoded, ref_cols: Dict[str, np.ndarray], codec: Codec,
                 profile: Optional[Profile] = None) -> Dict[str, np.ndarray]:
    """Per column of ref_cols and per row: |CAN - ref| in units of the signal's resolution (half an LSB for
    the scaled integers, after clipping the reference to the signal range: the estimator saturates and
    flags; half a float32 ULP for the float signals); 0 where both are NaN or the same infinity, inf for a
    NaN on one side only, NaN on rows that did not carry the column (incomplete, or EST_PAGE not sent)."""
    profile = profile or DIAGNOSTICS
    rows = min(len(dec.complete), min(len(v) for v in ref_cols.values()))
    have = dec.complete[:rows]
    out = {}
    for col, want in ref_cols.items():
        src = profile.results[col]
        lay = codec.messages[src.message].signals[src.signal]
        w = np.asarray(want[:rows], dtype=float)
        got = dec.columns[col][:rows]
        if not lay.is_float:
            lo = -(2 ** (lay.length - 1)) * lay.scale
            hi = (2 ** (lay.length - 1) - 1) * lay.scale
            w = np.clip(w, lo, hi)
        else:
            big = float(np.finfo(np.float32).max)
            w = np.where(np.isfinite(w), np.clip(w, -big, big), w)
        tol = lay.resolution(w)
        both_nan = np.isnan(w) & np.isnan(got)
        same_inf = np.isinf(w) & (w == got)
        with np.errstate(invalid="ignore"):
            ratio = np.where(both_nan | same_inf, 0.0, np.abs(got - w) / tol)
        ratio = np.where(np.isnan(ratio), np.inf, ratio)
        c = dec.carried.get(col)
        sel = have if c is None else have & np.asarray(c[:rows], dtype=bool)
        out[col] = np.where(sel, ratio, np.nan)
    return out


def compare_with_replay(dec: Decoded, ref: EstimateResult, codec: Codec,
                        profile: Optional[Profile] = None) -> Agreement:
    """Each CAN value must be the replay's value as the signal encodes it (`value_ratios` <= 1); NaN only
    where the replay has NaN; flags (core bits) and Newton iterations equal. A profile that carries a value
    only at some steps (production: EST_PAGE) is compared at those steps (dec.carried)."""
    profile = profile or DIAGNOSTICS
    n = len(ref.t)
    cols = dec.columns
    rows = min(n, len(dec.complete))
    nc = ref.n_contacts
    nq = (ref.x.shape[1] - nc) // 2
    ref_all = {**{f"q{i + 1}": ref.x[:, i] for i in range(nq)}, **{f"v{i + 1}": ref.x[:, nq + i] for i in range(nq)},
               "gamma": ref.x[:, 2 * nq], "p_norm": ref.p_norm, "p_gg": ref.p_gg}
    if nc > 1:
        ref_all["gamma2"] = ref.x[:, 2 * nq + 1]
        if ref.p_ggs is not None:
            ref_all["p_gg2"] = ref.p_ggs[:, 1]
    # every value the profile carries: the paper's q1..q4, v1..v4, gamma, p_norm, p_gg; a mechanism's every body
    # and contact (a column the replay lacks fails below as missing)
    ref_cols = {c: ref_all.get(c, np.full(n, np.nan)) for c in profile.results
                if c not in ("flags", "newton_iters", "step_status")}
    lacking = [c for c in ref_cols if c not in ref_all]
    have = dec.complete[:rows]
    worst, mism, carried_rows = {}, {}, {}
    for col, r in value_ratios(dec, ref_cols, codec, profile).items():
        sel = ~np.isnan(r)
        carried_rows[col] = int(sel.sum())
        worst[col] = float(r[sel].max()) if sel.any() else 0.0
        mism[col] = int(np.sum(r[sel] > 1.0))

    def rows_of(col: str) -> np.ndarray:
        c = dec.carried.get(col)
        return have if c is None else have & np.asarray(c[:rows], dtype=bool)

    fsel, isel = rows_of("flags"), rows_of("newton_iters")
    carried = fl.CORE_MASK & profile.flags_mask  # the core bits the flags column carries
    fl_can = cols["flags"][:rows][fsel].astype(np.int64) & carried
    fl_ref = ref.flags[:rows][fsel] & carried
    it_can = cols["newton_iters"][:rows][isel].astype(np.int64)
    it_ref = np.clip(ref.newton_iters[:rows][isel], 0, 255)
    for c in lacking:  # the replay has no such column: every CAN row of it counts as a mismatch
        mism[c] = max(mism.get(c, 0), carried_rows.get(c, 0), 1)
    return Agreement(rows, worst, mism, int(np.sum(fl_can != fl_ref)), int(np.sum(it_can != it_ref)),
                     int(rows - have.sum()) + (n - rows), carried_rows)


# --- runs saved for later (bus work in the VM, reports on the host) -----------------------------

RUNS_FILE = "runs.npz"
_RECORD_FIELDS = ("start", "stop", "mode", "window", "timeouts", "elapsed", "late_sends", "held", "aborted", "dt")
_DECODED_COUNTS = ("bad_crc", "bad_dlc", "counter_duplicates", "counter_jumps", "counter_lost", "duplicated_steps",
                   "foreign_steps", "frames")


def save_runs(runs: Sequence[HilRun], path: PathLike, header: str = "") -> Path:
    """Decoded runs in one binary file (no raw frames): what `load_runs` needs to write the CSVs,
    the summary, the figures and the replay comparison elsewhere."""
    import json

    arrays: Dict[str, np.ndarray] = {}
    meta: Dict[str, Any] = {"header": header, "runs": []}
    if runs:
        inp = runs[0].inputs
        arrays.update(t=inp.t, u_seen=inp.u_seen, y_seen=inp.y_seen, wire_steps=inp.wire_steps)
    for i, r in enumerate(runs):
        rec, dec = r.record, r.decoded
        meta["runs"].append({
            "experiment": r.experiment,
            "record": {k: getattr(rec, k) for k in _RECORD_FIELDS},
            "decoded": {k: getattr(dec, k) for k in _DECODED_COUNTS},
            "health_before": r.health_before, "health_after": r.health_after,
        })
        for col, v in dec.columns.items():
            arrays[f"{i}.col.{col}"] = v
        arrays[f"{i}.complete"] = dec.complete
        arrays[f"{i}.step_status"] = dec.step_status
        if rec.t_sent is not None and rec.t_rx is not None:  # realtime runs record both
            arrays[f"{i}.t_sent"] = rec.t_sent
            arrays[f"{i}.t_rx"] = rec.t_rx
    arrays["meta"] = np.array(json.dumps(meta))
    path = Path(path)
    np.savez(path, **arrays)  # type: ignore[arg-type]  # numpy's stub types **kwds like its allow_pickle flag
    return path


def load_runs(path: PathLike) -> Tuple[List[HilRun], str]:
    """(runs, header) saved by `save_runs`."""
    import json

    z = np.load(path, allow_pickle=False)
    meta = json.loads(str(z["meta"]))
    runs: List[HilRun] = []
    if not meta["runs"]:
        return runs, meta["header"]
    n = len(z["t"])
    inputs = StepInputs(z["t"], np.full(n, np.nan), np.full((n, 2), np.nan), z["wire_steps"], {}, z["u_seen"],
                        z["y_seen"])
    for i, m in enumerate(meta["runs"]):
        rec = RunRecord(**m["record"])
        if f"{i}.t_sent" in z:
            rec.t_sent, rec.t_rx = z[f"{i}.t_sent"], z[f"{i}.t_rx"]
        cols = {k.split(".", 2)[2]: z[k] for k in z.files if k.startswith(f"{i}.col.")}
        dec = Decoded(cols, z[f"{i}.complete"], z[f"{i}.step_status"], **m["decoded"])
        runs.append(HilRun(m["experiment"], inputs, rec, dec, m["health_before"], m["health_after"]))
    return runs, meta["header"]


def compare_runs_with_replay(runs: Sequence[HilRun], replay_bin: PathLike, scenario: PathLike, outdir: PathLike,
                             codec: Codec, profile: Optional[Profile] = None) -> Tuple[str, bool]:
    """caekf-replay of each run's experiment on the inputs the estimator decoded, compared (text, all ok)."""
    out = Path(outdir)
    lines, ok = [], True
    if not runs:
        return "", True
    inp = None
    for r in runs:
        start, stop = r.record.start, r.record.stop
        est = estimated_rows(r.decoded)
        bridged = ""
        if len(est) == stop - start:
            if inp is None:
                inp = write_seen_inputs(out / "inputs-seen.csv", runs[0].inputs, start, stop)
            ref = run_c_replay(replay_bin, scenario, inp, r.experiment, out / f"replay-{r.experiment}.csv")
        else:
            # steps lost on the bus: replay the steps the estimator ran, gaps bridged as the app does
            res, src, pred = replay_estimated(replay_bin, scenario, r.experiment, r.inputs, list(est + start),
                                              out / f"replay-{r.experiment}.csv")
            ref = aligned_result(res, src, pred, r.inputs.t[start:stop], start)
            bridged = (f" ({stop - start - len(est)} steps never estimated (lost on the bus, not counted as missing "
                       f"here), {int(pred.sum())} bridged by prediction-only steps in the replay as in the app)")
        agr = compare_with_replay(r.decoded, ref, codec, profile)
        # steps the estimator never ran (bridged) are not answers missing: they show as STEPS_SKIPPED
        agr.missing -= stop - start - len(est)
        lines.append(f"{r.experiment}: CAN == caekf-replay within resolution: {'yes' if agr.ok else 'NO'}; "
                     + agr.text() + bridged)
        ok &= agr.ok
    return "\n".join(lines), ok
