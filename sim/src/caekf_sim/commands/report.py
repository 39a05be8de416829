"""Subcommands that analyse: plot, observability, filterpy-check, truth-diff."""
from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any, Dict, List, Tuple

import numpy as np

from ..cli import UsageError
from ..measurements import MeasurementError, check_input_file
from ..outputs import check_output_dir, check_output_file
from ..plots import PLOT_FORMATS
from ..results import read_result_csv
from ..truth import read_truth_csv, simulate
from . import add_scenario_arg, scenario_from_args


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("plot", help="figures of any runs (estimate CSVs), or Figs 3-6 of an experiments folder")
    add_scenario_arg(p)
    p.add_argument("runs", type=Path, nargs="*", metavar="RESULT_CSV",
                   help="estimate CSVs (caekf-sim estimate, caekf-replay) drawn in one figure, written to --out")
    p.add_argument("--label", action="append", default=None,
                   help="legend label of each RESULT_CSV, in order (default: the file names)")
    p.add_argument("--out", type=Path, default=None, help="figure of the runs: FILE.png, FILE.svg or FILE.pdf")
    p.add_argument("--results-dir", type=Path, default=None,
                   help="an experiments folder (canonical.csv, switched.csv, ...): Figs 3-6 into --outdir")
    p.add_argument("--outdir", type=Path, default=None, help="folder for Figs 3-6")
    p.add_argument("--format", choices=PLOT_FORMATS, default="png", help="format of Figs 3-6 (default png)")
    p.add_argument("--truth", type=Path, default=None,
                   help="truth CSV (caekf-truth, caekf-sim truth): contact bands, position errors (optional)")
    p.set_defaults(func=cmd_plot)

    p = sub.add_parser("observability",
                       help="PBH test (eq. 20); with --params/--crb: which law parameters the run observes, "
                            "their Cramer-Rao bounds along it")
    add_scenario_arg(p, t_end=True)
    p.add_argument("--penetration", type=float, default=2e-6, help="PBH test: delta while active [m]")
    p.add_argument("--params", default=None, metavar="LIST",
                   help="rank test along the truth run of these law parameters, comma-separated from "
                        "gamma,n,lambda,gap (default with --crb: gamma)")
    p.add_argument("--contact", default=None, metavar="LIST",
                   help="contacts whose parameters are tested, comma-separated numbers (default: all)")
    p.add_argument("--crb", action="store_true",
                   help="also the Fisher information's Cramer-Rao bound and the posterior bound along the run")
    p.add_argument("--prior", action="append", default=[], metavar="NAME=STD",
                   help="prior std of a parameter for the posterior bound (n=0.1, lambda=100, gap=1e-5; "
                        "gamma's default: contact{i}_sigma_gamma0); applies to every chosen contact")
    p.add_argument("--known-initial-state", action="store_true",
                   help="the initial state is known (default: an unknown, with sigma_q0/sigma_v0 as its prior)")
    p.add_argument("--known-mechanism", action="store_true",
                   help="leave out the scenario's declared mechanism parameters (m{i}_sigma, spring{i}_k_sigma, "
                        "spring{i}_c_sigma > 0) and input noise (input{i}_sigma); by default each declared "
                        "parameter is an unknown with its own bound, the force noise process noise")
    p.add_argument("--t-from", type=float, default=0.0,
                   help="use only the samples at t >= T [s] (e.g. steady-state data only)")
    p.add_argument("--target", type=float, default=0.01,
                   help="relative bound whose first crossing is timed (default 0.01 = 1 %%)")
    p.add_argument("--csv", type=Path, default=None, help="write the bounds along the run to this CSV")
    p.add_argument("--png", type=Path, default=None, help="plot the relative bounds along the run")
    p.set_defaults(func=cmd_observability)

    p = sub.add_parser("filterpy-check", help="canonical AEKF vs FilterPy's EKF")
    add_scenario_arg(p, t_end=True)
    p.set_defaults(func=cmd_filterpy)

    p = sub.add_parser("truth-diff", help="max |difference| between two truth CSVs (e.g. C vs numpy)")
    p.add_argument("a", type=Path, help="truth CSV")
    p.add_argument("b", type=Path, help="the other truth CSV")
    p.add_argument("--tol", type=float, default=2e-10, help="max allowed |dq| [m] (default: twice the truths' bound)")
    p.set_defaults(func=cmd_truth_diff)


def cmd_plot(args: argparse.Namespace) -> int:
    from ..mechanism import contact_values
    from ..plots import EXPERIMENT_FILES, load_results, make_all, plot_runs

    if bool(args.runs) == (args.results_dir is not None):
        raise UsageError("give RESULT_CSV files (with --out) or --results-dir (with --outdir), not both")
    if args.runs and (args.out is None or args.outdir is not None):
        raise UsageError("RESULT_CSV files make one figure: give --out FILE.png|svg|pdf (not --outdir)")
    if args.results_dir is not None and (args.outdir is None or args.out is not None):
        raise UsageError("--results-dir makes Figs 3-6: give --outdir (not --out)")
    if args.label is not None and len(args.label) != len(args.runs):
        raise UsageError(f"{len(args.label)} --label for {len(args.runs)} RESULT_CSV files")
    sc = scenario_from_args(args)
    if args.out is not None:
        check_output_file(args.out)
        if args.out.suffix.lstrip(".").lower() not in PLOT_FORMATS:
            raise UsageError(f"--out {args.out}: the figure format comes from the suffix: "
                             + ", ".join("." + f for f in PLOT_FORMATS))
    else:
        check_output_dir(args.outdir)
    truth = None
    if args.truth is not None:
        check_input_file(args.truth)
        try:
            truth = read_truth_csv(args.truth)  # any mechanism's columns, by name
        except ValueError:
            raise MeasurementError(f"{args.truth}: not a truth CSV (no t, q1.., v1.., delta columns: caekf-truth "
                                   "writes them)") from None
    if args.runs:
        labels = args.label or [p.stem for p in args.runs]
        runs = {lab: read_result_csv(p) for lab, p in zip(labels, args.runs)}
        nc = int(sc.contacts)
        refs, exponents = contact_values(sc, "gamma", nc).tolist(), contact_values(sc, "n", nc).tolist()
        print(f"wrote {plot_runs(runs, truth, refs, args.out, exponents)}")
        return 0
    d: Path = args.results_dir
    if not d.is_dir():
        raise (NotADirectoryError if d.exists() else FileNotFoundError)(
            f"{d}: {'not a directory' if d.exists() else 'no such directory'} (--results-dir)")
    results = load_results(d)
    if not results:
        raise MeasurementError(f"{d}: no experiment results ({', '.join(EXPERIMENT_FILES)})")
    for p in make_all(results, truth, sc.gamma, sc.gamma_min, args.outdir, fmt=args.format):
        print(f"wrote {p}")
    return 0


def cmd_observability(args: argparse.Namespace) -> int:
    from ..observability import analyse, format_report

    sc = scenario_from_args(args)
    if args.params is not None or args.crb:
        return _observability_run(args, sc)
    if args.csv is not None or args.png is not None or args.prior or args.contact is not None:
        raise UsageError("--contact, --prior, --csv and --png go with --params or --crb")
    from ..binding import paper_mismatch

    diff = paper_mismatch(sc)
    if diff is not None:  # the paper's two claims are about its own chain and sensors
        raise UsageError(f"observability without --params tests the paper's claims on its mechanism, and this "
                         f"scenario's differs ({diff}): give --params or --crb for this mechanism's rank test")
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


def _names(text: str, what: str) -> List[str]:
    items = [x.strip() for x in text.split(",")]
    if not all(items):
        raise UsageError(f"{what} {text!r}: a comma-separated list without empty items")
    return items


def _observability_run(args: argparse.Namespace, sc: Any) -> int:
    """Rank test and Cramer-Rao bounds of chosen law parameters along the scenario's truth run."""
    sc.require_truth()  # the run is simulated: before --t-from is checked against t_end
    from ..identifiability import (PARAMS, IdentifiabilityError, analyse_run, format_table, input_sigmas,
                                   law_params, mechanism_params, plot, sensor_sigmas, write_csv)
    from ..mechanism import Mechanism

    params = _names(args.params, "--params") if args.params is not None else ["gamma"]
    nc = Mechanism.from_scenario(sc).n_contacts
    if nc == 0:
        raise IdentifiabilityError(f"{args.scenario or 'the scenario'}: no contacts, no law parameters to test")
    if args.contact is None:
        contacts = list(range(1, nc + 1))
    else:
        try:
            contacts = [int(c) for c in _names(args.contact, "--contact")]
        except ValueError:
            raise UsageError(f"--contact {args.contact!r}: contact numbers, e.g. 1 or 1,2") from None
    priors: Dict[Tuple[int, str], float] = {}
    for item in args.prior:
        name, sep, val = item.partition("=")
        name = name.strip()
        if not sep or name not in PARAMS:
            raise UsageError(f"--prior {item!r}: NAME=STD with NAME one of {', '.join(PARAMS)}")
        try:
            std = float(val)
        except ValueError:
            raise UsageError(f"--prior {item!r}: STD must be a number") from None
        if not std > 0.0 or not np.isfinite(std):
            raise UsageError(f"--prior {item!r}: STD must be > 0 and finite")
        priors.update({(c, name): std for c in contacts})
    if not 0.0 <= args.t_from < sc.t_end:
        raise UsageError(f"--t-from {args.t_from:g}: must be in [0, t_end = {sc.t_end:g}) s")
    if not 0.0 < args.target < 1.0:
        raise UsageError(f"--target {args.target:g}: must be in (0, 1)")
    for out in (args.csv, args.png):
        if out is not None:
            check_output_file(out)
    chosen = law_params(sc, params, contacts)
    declared = [] if args.known_mechanism else mechanism_params(sc)
    an = analyse_run(sc, chosen + declared, priors=priors, initial_state=not args.known_initial_state,
                     t_from=args.t_from, input_noise=not args.known_mechanism)
    mech = Mechanism.from_scenario(sc)
    sigma_u = input_sigmas(sc, mech)
    print(f"{sc.t_end:g} s run, {an.sens.events} contact events, samples t >= {args.t_from:g} s, "
          f"R = diag({', '.join(f'{s:g}^2' for s in sensor_sigmas(sc, mech))}), "
          f"initial state {'known' if args.known_initial_state else 'unknown (nuisance)'}")
    if declared:
        print("declared mechanism parameters, unknowns with their declared sigma as the posterior's prior: "
              + ", ".join(f"{p.key} ({p.prior / p.value:g})" for p in declared))
    if np.any(sigma_u > 0) and not args.known_mechanism:
        print("force read with white noise (process noise through the linearised model): "
              + ", ".join(f"input{i + 1}_sigma = {s:g} N" for i, s in enumerate(sigma_u) if s > 0))
    print(format_table(an, target=args.target))
    if args.csv is not None:
        write_csv(an, args.csv)
        print(f"wrote {args.csv}")
    if args.png is not None:
        plot(an, args.png, target=args.target)
        print(f"wrote {args.png}")
    return 0


def cmd_filterpy(args: argparse.Namespace) -> int:
    from ..filterpy_check import check

    from ..binding import require_paper_mechanism

    sc = scenario_from_args(args)
    require_paper_mechanism(sc, "filterpy-check (the paper's canonical AEKF against FilterPy's EKF)")
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
