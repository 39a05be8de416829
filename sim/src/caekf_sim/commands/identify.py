"""`caekf-sim identify`: the maximum-likelihood values of chosen scenario keys from recordings, with 95 %
intervals (Fisher information and profile likelihood), through the shipped C filter (caekf_sim.identify).

    caekf-sim identify --scenario F --runs RUN.csv ... [--candump LOG ...] --params contact1_gamma,contact1_n
                       [--bounds KEY=LOW:HIGH ...] [--starts 4] [--workers N | --scheduler tcp://HOST:PORT]
                       [--truth-scenario F] [--plot FIG.png] --out identified.toml
"""
from __future__ import annotations

import argparse
import time
from pathlib import Path

from ..cli import UsageError
from ..experiments import DEFAULT, EXPERIMENTS
from ..outputs import check_output_file
from . import add_scenario_arg, scenario_from_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("identify", help="maximum-likelihood contact law, mechanism and noise values from "
                                        "recordings, with 95 %% intervals; writes a scenario file")
    add_scenario_arg(p)
    p.add_argument("--runs", type=Path, nargs="*", default=[], metavar="CSV",
                   help="recordings of the mechanism: CSVs with t, the inputs and one column per sensor "
                        "(t,u,y1,y4 for the paper; extra columns, e.g. a truth CSV's, ignored)")
    p.add_argument("--candump", type=Path, nargs="*", default=[], metavar="LOG",
                   help="candump -L logs of the CAN bench (one run per configuration in each log)")
    p.add_argument("--params", required=True,
                   help="scenario keys to identify, comma-separated: contact{i}_gamma, contact{i}_n, "
                        "contact{i}_lambda, contact{i}_gap, m{i}, spring{i}_k, spring{i}_c, noise settings "
                        "(sigma_r, sigma_qx_v, ...)")
    p.add_argument("--bounds", nargs="*", default=[], metavar="KEY=LOW:HIGH",
                   help="bounds of the search (SI; defaults: gamma, lambda start/3..start*3; n 1..n_max or 3; "
                        "gap start +-2 um; mechanism start/1.5..start*1.5; noise three decades either way)")
    p.add_argument("--starts", type=int, default=4,
                   help="searches: from the scenario's values and from Sobol points of the bounds' middle half "
                        "(default 4)")
    p.add_argument("--seed", type=int, default=0, help="seed of the Sobol starts (default 0)")
    p.add_argument("--max-evals", type=int, default=600, help="filter runs per search at most (default 600)")
    p.add_argument("--burn-in", type=float, default=0.0,
                   help="seconds of each record left out of the likelihood (default 0)")
    p.add_argument("--experiment", choices=sorted(EXPERIMENTS) + [DEFAULT], default=DEFAULT,
                   help="preset of the filter used as the predictor (default: the recommended estimator)")
    p.add_argument("--precision", choices=["double", "float"], default="double",
                   help="scalar type of the C filter (default double)")
    p.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: all cores; 1 runs in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run the evaluations on a Dask cluster (tcp://HOST:PORT) instead of a local pool")
    p.add_argument("--truth-scenario", type=Path, default=None, metavar="FILE",
                   help="the scenario a simulated record came from: its values of the keys are reported as "
                        "the truth (and drawn in --plot)")
    p.add_argument("--plot", type=Path, default=None, metavar="FIG",
                   help="draw each parameter's profile likelihood with its interval (png, svg or pdf)")
    p.add_argument("--out", type=Path, default=None,
                   help="write the identified scenario here: the estimates as the filter's initial values "
                        "(contact1_gamma0, contact1_n0, ...), the intervals as its P0")
    p.set_defaults(func=cmd_identify)


def _truth_values(path: Path, keys) -> dict:
    from ..scenario import load_scenario

    values = load_scenario(path).values()
    return {k: float(values[k]) for k in keys if k in values}


def cmd_identify(args: argparse.Namespace) -> int:
    from ..identify import identify, parse_bounds, report_text, write_scenario
    from ..measurements import read_candump_runs
    from .binding import _records

    sc = scenario_from_args(args)
    params = [p.strip() for p in args.params.split(",") if p.strip()]
    bounds = parse_bounds(args.bounds)
    if args.workers is not None and args.workers < 1:
        raise UsageError(f"--workers {args.workers}: must be >= 1")
    if args.workers is not None and args.scheduler is not None:
        raise UsageError("--workers and --scheduler do not go together")
    records = _records(args.runs, sc)
    for log in args.candump:
        records += read_candump_runs(log, sc.dt, sc)
    if not records:
        raise UsageError("nothing to identify from: give --runs CSV... and/or --candump LOG...")
    for path in (args.out, args.plot):
        if path is not None:
            check_output_file(path)
    if args.plot is not None:
        from ..plots import PLOT_FORMATS

        if args.plot.suffix.lstrip(".").lower() not in PLOT_FORMATS:
            raise UsageError(f"--plot {args.plot}: unknown figure format '{args.plot.suffix}': use one of "
                             + ", ".join("." + f for f in PLOT_FORMATS))
    truth = None
    if args.truth_scenario is not None:
        from ..identify import unknowns

        truth = _truth_values(args.truth_scenario, [u.key for u in unknowns(sc, params, bounds)])
    t0 = time.perf_counter()
    res = identify(sc, records, params, bounds, None if args.experiment == DEFAULT else args.experiment,
                   args.precision, args.burn_in, args.starts, args.seed, args.max_evals, args.workers,
                   args.scheduler, truth=truth, profile_points=9 if args.plot is not None else 0)
    print(f"identified {', '.join(params)} from {len(records)} record(s), {sum(len(r) for r in records)} samples, "
          f"{args.experiment} {args.precision}, in {time.perf_counter() - t0:.1f} s")
    text = report_text(res)
    print(text)
    if args.out is not None:
        src = args.scenario or "the reference scenario"
        header = (f"Identified by caekf-sim identify from {Path(str(src)).name} on "
                  f"{', '.join(r.name for r in records)}\n(maximum likelihood of the innovations, "
                  f"{args.experiment}, {args.precision}).\n\n" + text)
        write_scenario(res, args.out, header)
        print(f"wrote {args.out}")
    if args.plot is not None:
        from ..identify_plot import plot_profiles

        plot_profiles(res, args.plot)
        print(f"wrote {args.plot}")
    return 0
