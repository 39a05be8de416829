"""Subcommands that analyse: plot, observability, filterpy-check, truth-diff."""
from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from ..truth import read_truth_csv, simulate
from . import add_scenario_arg, scenario_from_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plot", help="Figs 3-6 as PNG from an experiments directory")
    add_scenario_arg(p)
    p.add_argument("--results-dir", type=Path, required=True)
    p.add_argument("--truth", type=Path, required=True)
    p.add_argument("--outdir", type=Path, required=True)
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("observability", help="PBH test (eq. 20), contact active and inactive")
    add_scenario_arg(p)
    p.add_argument("--penetration", type=float, default=2e-6, help="delta while active [m]")
    p.set_defaults(func=cmd_observability)

    p = sub.add_parser("filterpy-check", help="canonical AEKF vs FilterPy's EKF")
    add_scenario_arg(p, t_end=True)
    p.set_defaults(func=cmd_filterpy)

    p = sub.add_parser("truth-diff", help="max |difference| between two truth CSVs (e.g. C vs numpy)")
    p.add_argument("a", type=Path)
    p.add_argument("b", type=Path)
    p.add_argument("--tol", type=float, default=2e-10, help="max allowed |dq| [m] (default: twice the truths' bound)")
    p.set_defaults(func=cmd_truth_diff)


def cmd_plot(args: argparse.Namespace) -> int:
    from ..plots import make_all_from_files

    sc = scenario_from_args(args)
    paths = make_all_from_files(args.results_dir, args.truth, sc.gamma, sc.gamma_min, args.outdir)
    for p in paths:
        print(f"wrote {p}")
    return 0 if paths else 1


def cmd_observability(args: argparse.Namespace) -> int:
    from ..observability import analyse, format_report

    sc = scenario_from_args(args)
    res = analyse(sc, penetration=args.penetration)
    print(format_report(res))
    both = ("q1", "q4")
    active_ok = all(r.observable for (case, _), r in res.items() if case == "active")
    inactive = res[("inactive", both)]
    gamma_mode = any(abs(r.eigenvalue) < 1e-12 for r in inactive.deficient)
    print(f"paper claim 1 (contact active: observable, even with one position sensor): "
          f"{'confirmed' if active_ok else 'NOT confirmed'}")
    print(f"paper claim 2 (contact inactive: unobservable, gamma's mode at lambda = 0): "
          f"{'confirmed' if not inactive.observable and gamma_mode else 'NOT confirmed'}")
    return 0 if active_ok and not inactive.observable else 1


def cmd_filterpy(args: argparse.Namespace) -> int:
    from ..filterpy_check import check

    sc = scenario_from_args(args)
    res = check(sc, simulate(sc))
    for form, a in res.items():
        print(f"FilterPy vs numpy canonical ({form} form): state rel {a.state_rel:.2e}, "
              f"gamma rel {a.gamma_rel:.2e}, P rel {a.p_rel:.2e}")
    return 0


def cmd_truth_diff(args: argparse.Namespace) -> int:
    a, b = read_truth_csv(args.a), read_truth_csv(args.b)
    if len(a) != len(b) or np.max(np.abs(a.t - b.t)) > 1e-9:
        print(f"time bases differ ({len(a)} vs {len(b)} samples)")
        return 1
    dq = float(np.max(np.abs(a.q - b.q)))
    dv = float(np.max(np.abs(a.v - b.v)))
    dy = float(np.max(np.abs(a.y - b.y)))
    du = float(np.max(np.abs(a.u - b.u)))
    print(f"max |dq| {dq:.3e} m, |dv| {dv:.3e} m/s, |dy| {dy:.3e} m, |du| {du:.3e} N")
    return 0 if dq <= args.tol else 1
