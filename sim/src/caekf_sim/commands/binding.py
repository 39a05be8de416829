"""`caekf-sim bench-binding` (the C binding's speed beside caekf-bench, numpy and FilterPy) and
`caekf-sim tune` (noise settings from recorded runs, through the binding's fast run; caekf_sim.tune).

    caekf-sim bench-binding [--scenario F] [--truth CSV] [--repeats 3] [--step-calls N] [--py-steps N]

One table, one run, no assertion: steps/s and microseconds per step of
  - caekf-bench (C only, build/host-double and build/host-float), when built;
  - caekf_sim.run, double and float (the whole loop in C, with every output run() returns);
  - Estimator.step called from a Python loop, double and float (y as a numpy row, and as a tuple);
  - the numpy reference (caekf_sim.estimator) and FilterPy (caekf_sim.filterpy_check), on --py-steps.
"""
from __future__ import annotations

import argparse
import re
import subprocess
import tempfile
import time
from pathlib import Path
from typing import Any, Dict, List


from ..cli import UsageError
from ..experiments import DEFAULT, EXPERIMENTS
from ..outputs import check_output_file, write_text_atomic
from . import add_scenario_arg, scenario_from_args

REPO = Path(__file__).resolve().parents[4]


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("bench-binding",
                       help="steps/s of the C binding (run, Estimator.step) beside caekf-bench, numpy and FilterPy")
    add_scenario_arg(p)
    p.add_argument("--truth", type=Path, default=None,
                   help="truth CSV t,u,y1,y4,... (default: caekf-truth of build/host-double, else the numpy truth)")
    p.add_argument("--experiments", nargs="+", default=["switched"],
                   help="experiments for caekf_sim.run (default: switched; 'all' for the four)")
    p.add_argument("--repeats", type=int, default=3, help="best of this many runs (default 3)")
    p.add_argument("--step-calls", type=int, default=60000, help="Estimator.step calls timed (default 60000)")
    p.add_argument("--py-steps", type=int, default=3000, help="steps for numpy and FilterPy (default 3000)")
    p.add_argument("--debug", action="store_true", help="tracebacks instead of one-line errors")
    p.set_defaults(func=cmd_bench_binding)
    register_tune(sub)


def _truth(args, sc, tmp: Path):
    from ..truth import read_truth_csv, simulate, write_truth_csv

    if args.truth is not None:
        return read_truth_csv(args.truth), args.truth
    tool = REPO / "build" / "host-double" / "host" / "caekf-truth"
    path = tmp / "truth.csv"
    if tool.exists():
        subprocess.run([str(tool), "--scenario", str(args.scenario or _default()), "--out", str(path), "--quiet"],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    else:
        write_truth_csv(simulate(sc), path)
    return read_truth_csv(path), path


def _default() -> Path:
    from ..scenario import default_scenario_path

    return default_scenario_path()


def _row(impl: str, precision: str, experiment: str, steps: int, seconds: float, note: str = "") -> Dict:
    return {"implementation": impl, "precision": precision, "experiment": experiment, "steps": steps,
            "steps_per_s": steps / seconds if seconds > 0 else None, "note": note}


def _c_bench_rows(scenario: Path, truth_csv: Path, repeats: int, experiments: List[str]) -> List[Dict[str, Any]]:
    rows: List[Dict[str, Any]] = []
    for precision in ("double", "float"):
        tool = REPO / "build" / f"host-{precision}" / "host" / "caekf-bench"
        if not tool.exists():
            rows.append({"implementation": "caekf-bench (C, no Python)", "precision": precision, "experiment": "-",
                         "steps": 0, "steps_per_s": None, "note": f"{tool} not built"})
            continue
        out = subprocess.run([str(tool), str(scenario), str(truth_csv), str(repeats)], check=True,
                             capture_output=True, text=True).stdout
        for line in out.splitlines():
            m = re.match(r"(\S+)\s+(\S+)\s+(\d+)\s+(\d+)\s+([\d.]+)", line)
            if m and m.group(1) in experiments:
                rows.append({"implementation": "caekf-bench (C, no Python)", "precision": m.group(2),
                             "experiment": m.group(1), "steps": int(m.group(3)), "steps_per_s": float(m.group(4)),
                             "note": f"caekf_step only, best of {repeats}"})
    return rows


def _best(fn, repeats: int) -> float:
    best = float("inf")
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def cmd_bench_binding(args: argparse.Namespace) -> int:
    """Errors go to caekf-sim's one-line handler (the exit-code table; --debug shows the traceback)."""
    return _bench_binding(args)


def _bench_binding(args: argparse.Namespace) -> int:
    import caekf_sim

    from ..bench.results import format_table

    sc = scenario_from_args(args)
    # the truth CSV, caekf-bench, the numpy reference and FilterPy run the paper's mechanism only
    from ..binding import require_paper_mechanism

    require_paper_mechanism(sc, "bench-binding")
    experiments = ["canonical", "switched", "switched-highq", "switched-highq-constrained"] \
        if args.experiments == ["all"] else args.experiments
    rows: List[Dict] = []
    with tempfile.TemporaryDirectory() as td:
        truth, truth_csv = _truth(args, sc, Path(td))
        n = len(truth.t)
        rows += _c_bench_rows(Path(args.scenario or _default()), truth_csv, args.repeats, experiments)
    u, y = truth.u, truth.y
    for precision in ("double", "float"):
        for e in experiments:
            s = caekf_sim.settings_for(sc, e, precision)
            caekf_sim.run(s, u[:100], y[:100])  # modules loaded before the clock starts
            dt = _best(lambda: caekf_sim.run(s, u, y), args.repeats)
            rows.append(_row("caekf_sim.run", precision, e, n, dt,
                             f"x, P diag, flags, nis, iters; best of {args.repeats}"))
    m = min(args.step_calls, n)
    for precision in ("double", "float"):
        est = caekf_sim.Estimator(sc, precision=precision)
        step = est.step

        def rows_loop() -> None:
            for k in range(m):
                step(u[k], y[k])

        yl, ul = y[:m].tolist(), u[:m].tolist()

        def tuple_loop() -> None:
            for k in range(m):
                step(ul[k], yl[k])

        est.reset()
        rows.append(_row("Estimator.step, y = numpy row", precision, "switched", m, _best(rows_loop, 1),
                         "Python loop: for k: est.step(u[k], y[k])"))
        est.reset()
        rows.append(_row("Estimator.step, y = list", precision, "switched", m, _best(tuple_loop, 1),
                         "Python loop over lists"))
    k = min(args.py_steps, n)
    from ..experiments import experiment_config, run_experiment
    from ..truth import Truth

    short = Truth(truth.t[:k], truth.u[:k], truth.y[:k], truth.q[:k], truth.v[:k], truth.delta[:k])
    res = run_experiment(sc, short, "switched", keep_P=False)
    rows.append(_row("numpy AEKF (caekf_sim.estimator)", "double", "switched", k, res.wall_time))
    try:
        from ..filterpy_check import _filterpy_ekf_class, run_filterpy

        _filterpy_ekf_class()  # imports filterpy (and scipy) before the clock starts
        t0 = time.perf_counter()
        run_filterpy(sc, short, experiment_config("canonical"))
        rows.append(_row("FilterPy EKF (caekf_sim.filterpy_check)", "double", "canonical", k,
                         time.perf_counter() - t0))
    except ImportError as exc:
        rows.append({"implementation": "FilterPy EKF", "precision": "double", "experiment": "canonical", "steps": 0,
                     "steps_per_s": None, "note": f"filterpy missing: {exc}"})
    print(f"caekf estimator speed on {Path(args.scenario or _default()).name} ({n} samples, dt = {sc.dt:g} s: "
          f"real time is {1 / sc.dt:,.0f} steps/s)")
    print(format_table(["implementation", "precision", "experiment", "steps", "steps/s", "us/step", "note"],
                       [[r["implementation"], r["precision"], r["experiment"], str(r["steps"]),
                         f"{r['steps_per_s']:,.0f}" if r["steps_per_s"] else "-",
                         f"{1e6 / r['steps_per_s']:.3f}" if r["steps_per_s"] else "-", r["note"]] for r in rows]))
    return 0



# --- tune ------------------------------------------------------------------------------------------

def register_tune(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("tune", help="maximum-likelihood Q_x, Q_gamma, R from recorded runs; writes a scenario file")
    add_scenario_arg(p)
    p.add_argument("--runs", type=Path, nargs="*", default=[], metavar="CSV",
                   help="recorded runs to tune on: CSVs with the mechanism's columns (t, the inputs, one column per "
                        "sensor: t,u,y1,y4 for the paper; extra columns ignored; empty y = lost sample)")
    p.add_argument("--candump", type=Path, nargs="*", default=[], metavar="LOG",
                   help="candump -L logs of the CAN bench (one run per configuration in each log; the "
                        "scenario's mechanism)")
    p.add_argument("--holdout", type=Path, nargs="*", default=[], metavar="CSV_OR_LOG",
                   help="held-out runs for the before/after report (*.log: candump, else CSV)")
    p.add_argument("--params", default=None,
                   help="noise settings to tune, comma-separated scenario keys (default: every noise standard "
                        "deviation of the schema, kind noise, that the mechanism uses and sets > 0)")
    p.add_argument("--experiment", choices=sorted(EXPERIMENTS) + [DEFAULT], default=DEFAULT,
                   help="preset of the estimator tuned (default: none, the recommended estimator with the "
                        "scenario's settings, as estimate and caekf-replay run it)")
    p.add_argument("--precision", choices=["double", "float"], default="double",
                   help="scalar type of the C estimator tuned (default double)")
    p.add_argument("--gamma-true", type=float, default=None,
                   help="true gamma for the reported error (default: the scenario's gamma)")
    p.add_argument("--burn-in", type=float, default=0.5, help="seconds of each run left out of the NIS (default 0.5)")
    p.add_argument("--max-evals", type=int, default=400, help="objective evaluations at most (default 400)")
    p.add_argument("--out", type=Path, default=None, help="write the tuned scenario here (same format as --scenario)")
    p.add_argument("--debug", action="store_true", help="tracebacks instead of one-line errors")
    p.set_defaults(func=cmd_tune)


def _records(paths, sc):
    """Records of CSVs with the mechanism's columns (checked like caekf-replay checks them:
    caekf_sim.measurements) and *.log candump logs."""
    from ..measurements import Measurements, check_input_file, columns_of, read_candump_runs, read_measurements_csv

    out: List[Measurements] = []
    for path in paths:
        check_input_file(path)
        if str(path).endswith(".log"):
            out += read_candump_runs(path, sc.dt, sc)
        else:
            out.append(read_measurements_csv(path, sc.dt, columns_of(sc)))
    return out


def cmd_tune(args: argparse.Namespace) -> int:
    from ..measurements import read_candump_runs
    from ..settings_adapter import scenario_toml
    from ..settings_adapter import tunable_noise
    from ..tune import report_text, tune

    # Errors go to caekf-sim's one-line handler: bad input 3, I/O 4 (--debug shows the traceback).
    sc = scenario_from_args(args)
    params = list(tunable_noise(sc)) if args.params is None else \
        [p.strip() for p in args.params.split(",") if p.strip()]
    records = _records(args.runs, sc)
    for log in args.candump:  # the scenario's mechanism's frames
        records += read_candump_runs(log, sc.dt, sc)
    if not records:
        raise UsageError("nothing to tune on: give --runs CSV... and/or --candump LOG...")
    holdout = _records(args.holdout, sc)
    if args.out is not None:
        check_output_file(args.out)
    t0 = time.perf_counter()
    res = tune(sc, records, params, holdout, None if args.experiment == DEFAULT else args.experiment,
               args.precision, args.gamma_true, args.burn_in, args.max_evals)
    print(f"tuned {', '.join(params)} on {len(records)} run(s), {sum(len(r) for r in records)} samples, "
          f"{args.experiment} {args.precision}, in {time.perf_counter() - t0:.1f} s"
          + (f"; {len(holdout)} held-out run(s)" if holdout else ""))
    text = report_text(res, params)
    print(text)
    if args.out is not None:
        src = args.scenario or _default()
        header = (f"Tuned by caekf-sim tune from {Path(src).name} on {', '.join(r.name for r in records)}\n"
                  f"(maximum likelihood of the innovations, {args.experiment}, {args.precision}).\n\n" + text)
        write_text_atomic(args.out, scenario_toml(res.scenario, header))
        print(f"wrote {args.out}")
    return 0
