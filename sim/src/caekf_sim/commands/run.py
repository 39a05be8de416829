"""Subcommands that run the models: truth, estimate, experiments."""
from __future__ import annotations

import argparse
import time

import numpy as np
from pathlib import Path

from ..experiments import EXPERIMENTS, format_table, run_experiment, summarize
from ..mechanism import Mechanism, read_input_csv
from ..results import write_result_csv
from ..truth import (CONTINUOUS, TRUTH_METHODS, contact_episodes, read_truth_csv, simulate,
                     write_truth_csv)
from . import add_scenario_arg, scenario_from_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("truth", help="simulate the truth model and write its CSV")
    add_scenario_arg(p, t_end=True)
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--method", choices=TRUTH_METHODS, default=CONTINUOUS,
                   help="continuous model with located contact events (default) or backward Euler")
    p.add_argument("--inputs", type=Path, default=None, metavar="CSV",
                   help="input forces from a CSV with columns t,u1[,u2] (linear interpolation, end values "
                        "held) instead of the scenario's sines")
    p.set_defaults(func=cmd_truth)

    p = sub.add_parser("estimate", help="run one experiment's estimator over a measurements CSV")
    add_scenario_arg(p)
    p.add_argument("--measurements", type=Path, required=True, help="truth CSV (t,u,y1,y4,...)")
    p.add_argument("--experiment", choices=sorted(EXPERIMENTS), default="switched")
    p.add_argument("--variant", choices=["consistent", "paper"], default=None,
                   help="switch-off variant (default: consistent)")
    p.add_argument("--joseph", action="store_true", help="Joseph-form covariance updates")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--progress", action="store_true")
    p.set_defaults(func=cmd_estimate)

    p = sub.add_parser("experiments", help="truth + the four experiments + summary table")
    add_scenario_arg(p, t_end=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--plots", action="store_true", help="also write the figures into OUTDIR")
    p.add_argument("--progress", action="store_true")
    p.set_defaults(func=cmd_experiments)


def cmd_truth(args: argparse.Namespace) -> int:
    sc = scenario_from_args(args)
    mech = Mechanism.from_scenario(sc)
    inputs = read_input_csv(args.inputs, mech.n_inputs) if args.inputs is not None else None
    t0 = time.perf_counter()
    truth, stats = simulate(sc, return_stats=True, method=args.method, inputs=inputs, mech=mech)
    wall = time.perf_counter() - t0
    write_truth_csv(truth, args.out)
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
    truth = read_truth_csv(args.measurements)
    overrides = {"joseph": args.joseph} if args.joseph else {}
    if args.variant:
        overrides["switch_variant"] = args.variant
    res = run_experiment(sc, truth, args.experiment, keep_P=False, progress=args.progress,
                         **overrides)
    write_result_csv(res, args.out)
    print(format_table([summarize(args.experiment, res, sc.gamma)]))
    return 0


def cmd_experiments(args: argparse.Namespace) -> int:
    sc = scenario_from_args(args)
    out: Path = args.outdir
    out.mkdir(parents=True, exist_ok=True)
    truth = simulate(sc)
    write_truth_csv(truth, out / "truth.csv")
    results, rows = {}, []
    for name in EXPERIMENTS:
        res = run_experiment(sc, truth, name, keep_P=False, progress=args.progress)
        write_result_csv(res, out / f"{name}.csv")
        results[name] = res
        rows.append(summarize(name, res, sc.gamma))
    table = format_table(rows)
    (out / "summary.txt").write_text(table + "\n", encoding="utf-8")
    print(table)
    if args.plots:
        from ..plots import make_all

        for path in make_all(results, truth, sc.gamma, sc.gamma_min, out):
            print(f"wrote {path}")
    return 0
