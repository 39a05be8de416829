"""Subcommands that run the models: truth, estimate, experiments."""
from __future__ import annotations

import argparse
import sys
import time
from dataclasses import replace

import numpy as np
from pathlib import Path
from typing import Any, Dict, Tuple

from .. import flags
from ..cli import UsageError
from ..estimator import EstimateResult
from ..experiments import (DEFAULT, EXPERIMENTS, experiment_config, format_table, run_experiment, scenario_config,
                           summarize)
from ..mechanism import Mechanism, read_input_csv
from ..model import DISCRETISATIONS
from ..results import write_result_csv
from ..truth import (CONTINUOUS, TRUTH_METHODS, contact_episodes, simulate,
                     write_truth_csv)
from ..measurements import MeasurementError, Measurements, columns_of, read_candump, read_measurements_csv
from ..outputs import atomic_output, check_output_dir, check_output_file, write_text_atomic
from ..plots import PLOT_FORMATS
from . import add_progress_arg, add_scenario_arg, scenario_from_args, want_progress


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("truth", help="simulate the truth model and write its CSV")
    add_scenario_arg(p, t_end=True)
    p.add_argument("--out", type=Path, required=True, help="truth CSV to write")
    p.add_argument("--method", choices=TRUTH_METHODS, default=CONTINUOUS,
                   help="continuous model with located contact events (default) or backward Euler")
    p.add_argument("--inputs", type=Path, default=None, metavar="CSV",
                   help="input forces from a CSV with columns t,u1[,u2] (linear interpolation, end values "
                        "held) instead of the scenario's sines")
    p.set_defaults(func=cmd_truth)

    p = sub.add_parser("estimate", help="run the estimator over measurements: a CSV (t, the inputs, the sensors: "
                                        "t,u,y1,y4 for the paper) or a candump log")
    add_scenario_arg(p)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--measurements", type=Path, metavar="CSV",
                     help="CSV at the scenario's dt with t, the mechanism's inputs (u, or u1..) and one column per "
                          "sensor (y<body>, yv<body>): t,u,y1,y4 for the paper (more columns allowed, e.g. a truth "
                          "CSV; every sensor empty: a lost sample)")
    src.add_argument("--candump", type=Path, metavar="LOG", help="candump -L log of the bus (decoded with the DBC)")
    p.add_argument("--run", type=int, default=None, metavar="N",
                   help="run N (1..) of a log holding several (one per configuration)")
    p.add_argument("--experiment", choices=sorted(EXPERIMENTS) + [DEFAULT], default=DEFAULT,
                   help="preset of the estimator (default: none, the recommended estimator with the scenario's "
                        "settings, as caekf-replay runs without --experiment)")
    p.add_argument("--engine", choices=["c", "numpy"], default="c",
                   help="the shipped C estimator through the binding (default) or the numpy reference")
    p.add_argument("--precision", choices=["double", "float"], default="double", help="C engine's scalar")
    p.add_argument("--variant", choices=["consistent", "paper"], default=None,
                   help="switch-off variant (default: consistent)")
    p.add_argument("--joseph", action="store_true", help="Joseph-form covariance updates")
    p.add_argument("--discretisation", choices=DISCRETISATIONS, default=None,
                   help="the filter's step map (default: the preset's, backward Euler for the paper's experiments, "
                        "else the scenario's)")
    p.add_argument("--contact-substeps", type=int, choices=range(1, 9), default=None, metavar="S",
                   help="model substeps per step while a contact is closed, 1..8 (default: the preset's, 1 for the "
                        "paper's experiments)")
    p.add_argument("--out", type=Path, required=True, help="estimate CSV (caekf-replay's columns)")
    add_progress_arg(p)
    p.set_defaults(func=cmd_estimate)

    p = sub.add_parser("experiments", help="truth + the four experiments + summary table")
    add_scenario_arg(p, t_end=True)
    p.add_argument("--outdir", type=Path, required=True,
                   help="folder for truth.csv, one CSV per experiment and summary.txt (made if needed)")
    p.add_argument("--plots", action="store_true", help="also write the figures into OUTDIR")
    p.add_argument("--format", choices=PLOT_FORMATS, default="png", help="figure format (default png)")
    add_progress_arg(p)
    p.set_defaults(func=cmd_experiments)


def cmd_truth(args: argparse.Namespace) -> int:
    sc = scenario_from_args(args)
    check_output_file(args.out)
    mech = Mechanism.from_scenario(sc)
    inputs = read_input_csv(args.inputs, mech.n_inputs) if args.inputs is not None else None
    t0 = time.perf_counter()
    truth, stats = simulate(sc, return_stats=True, method=args.method, inputs=inputs, mech=mech)
    wall = time.perf_counter() - t0
    with atomic_output(args.out) as tmp:
        write_truth_csv(truth, tmp)
    print(f"wrote {args.out}: {len(truth)} samples in {wall:.1f} s")
    for c in range(truth.deltas.shape[1]):
        eps = contact_episodes(truth.t, truth.deltas[:, c], merge_gap=0.1)
        label = "contact episodes" if truth.deltas.shape[1] == 1 else f"contact {c + 1} episodes"
        print(f"{label}: " + ", ".join(f"{a:.3f}-{b:.3f} s" for a, b in eps))
    if args.method == CONTINUOUS:
        print(f"max penetration {truth.deltas.max(initial=-np.inf):.4g} m; contact events located {stats.events}, "
              f"right-hand side evaluations {stats.rhs_evals}")
    else:
        n_sub = len(truth) * sc.truth_substeps
        print(f"max penetration {truth.deltas.max(initial=-np.inf):.4g} m; Newton iterations per substep "
              f"mean {stats.newton_iters_total / n_sub:.3f} max {stats.newton_iters_max}")
    return 0


def cmd_estimate(args: argparse.Namespace) -> int:
    sc = scenario_from_args(args)
    check_output_file(args.out)
    if args.run is not None and args.candump is None:
        raise UsageError("--run selects a run of a --candump log")
    meas = (read_candump(args.candump, sc.dt, args.run, sc) if args.candump is not None
            else read_measurements_csv(args.measurements, sc.dt, columns_of(sc)))
    overrides: Dict[str, Any] = {}
    if args.variant:
        overrides["switch_variant" if args.engine == "numpy" else "switchoff"] = args.variant
    if args.joseph:
        overrides.update({"joseph": True} if args.engine == "numpy" else {"cov_update": "joseph"})
    if args.discretisation:
        overrides["discretisation"] = args.discretisation  # the same name in both engines
    if args.contact_substeps is not None:
        overrides["contact_substeps"] = args.contact_substeps  # likewise
    progress = want_progress(args)
    variances: Dict[str, np.ndarray] = {}
    if args.engine == "numpy":
        res = _estimate_numpy(sc, meas, args.experiment, overrides, progress)
    else:
        res, variances = estimate_c(sc, meas, args.experiment, args.precision, overrides, progress)
    with atomic_output(args.out) as tmp:
        write_result_csv(res, tmp, variances)
    print(f"wrote {args.out}: {len(res.t)} samples of {meas.name} ({args.engine} estimator"
          f"{', ' + args.precision if args.engine == 'c' else ''})")
    print(format_table([summarize(args.experiment, res, sc.gamma)]))
    words = flags.mismatch_words(res.t, res.flags)
    if words is not None:
        print(words)
    return 0


def estimate_c(sc: Any, meas: Measurements, experiment: str, precision: str = "double",
               overrides: Any = None, progress: bool = False, chunk: int = 5000
               ) -> Tuple[EstimateResult, Dict[str, np.ndarray]]:
    """The shipped C estimator (caekf_sim.run's loop, chunk by chunk for the progress bar) over a run:
    the columns of caekf-replay's output (p_norm, the gamma variance, flags, Newton iterations; the
    estimated law and mechanism parameters after the gammas), and the mechanism parameters' variances by
    caekf-replay's column names (p_m2, p_spring1_k, ...)."""
    from ..binding import Estimator

    est = Estimator(sc, precision, None if experiment == DEFAULT else experiment, **(overrides or {}))
    n = len(meas.t)
    bar = None
    if progress:
        from tqdm import tqdm

        bar = tqdm(total=n, unit="step", mininterval=0.5, desc=meas.name)
    t0 = time.perf_counter()
    parts = []
    for a in range(0, n, chunk):
        b = min(n, a + chunk)
        parts.append(est.run(meas.u[a:b], meas.y[a:b], t=meas.t[a:b], p_norm=True))
        if bar is not None:
            bar.update(b - a)
    if bar is not None:
        bar.close()
    wall = time.perf_counter() - t0
    pd = np.concatenate([r.P_diag for r in parts])
    ig, nc = parts[0].gamma_index, int(parts[0].settings.contacts)  # the gammas, then the law parameters
    law = tuple(parts[0].law) + tuple(parts[0].mech)  # the parameter states after the gammas, by column name
    variances = {k: np.concatenate([r.p_mech[k] for r in parts]) for k in parts[0].p_mech}
    return EstimateResult(
        t=np.concatenate([r.t for r in parts]), x=np.concatenate([r.x for r in parts]),
        p_norm=np.concatenate([r.p_norm for r in parts]), p_gg=pd[:, ig] if nc else np.zeros(n),
        flags=np.concatenate([r.flags for r in parts]).astype(np.int64),
        newton_iters=np.concatenate([r.newton_iters for r in parts]).astype(np.int64), wall_time=wall,
        n_contacts=nc, p_ggs=pd[:, ig:ig + nc], n_law=len(law), law_names=law), variances


def _estimate_numpy(sc: Any, meas: Measurements, experiment: str, overrides: Dict[str, Any],
                    progress: bool) -> EstimateResult:
    from ..estimator import run_estimator

    if np.isnan(meas.y).any():
        raise MeasurementError(f"{meas.name}: lost samples (empty sensor columns): the numpy engine needs every "
                               "measurement (use --engine c)")
    cfg = scenario_config(sc) if experiment == DEFAULT else experiment_config(experiment)
    return run_estimator(sc, replace(cfg, **overrides), meas.t, meas.u, meas.y, keep_P=False, progress=progress)


def cmd_experiments(args: argparse.Namespace) -> int:
    sc = scenario_from_args(args)
    out: Path = check_output_dir(args.outdir)
    progress = want_progress(args)
    truth = simulate(sc)
    out.mkdir(parents=True, exist_ok=True)
    with atomic_output(out / "truth.csv") as tmp:
        write_truth_csv(truth, tmp)
    results, rows = {}, []
    for name in EXPERIMENTS:
        if progress:
            print(f"experiment {name}", file=sys.stderr)
        res = run_experiment(sc, truth, name, keep_P=False, progress=progress)
        with atomic_output(out / f"{name}.csv") as tmp:
            write_result_csv(res, tmp)
        results[name] = res
        rows.append(summarize(name, res, sc.gamma))
    table = format_table(rows)
    write_text_atomic(out / "summary.txt", table + "\n")
    print(table)
    if args.plots:
        from ..plots import make_all

        for path in make_all(results, truth, sc.gamma, sc.gamma_min, out, fmt=args.format):
            print(f"wrote {path}")
    return 0
