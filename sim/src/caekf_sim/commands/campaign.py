"""`caekf-sim campaign`: run the estimator over a mechanism family; `caekf-sim family`: write it out."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..experiments import EXPERIMENTS


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("campaign", help="truth + estimator + metrics over a family spec or a folder of scenarios")
    p.add_argument("spec", type=Path, help="family spec (TOML, docs/family.md) or a folder of scenario files")
    p.add_argument("--experiment", action="append", choices=sorted(EXPERIMENTS) + ["default"], default=None,
                   help="estimator configuration: a preset, or default (the schema's defaults); repeatable "
                        "(default: switched)")
    p.add_argument("--out", type=Path, default=Path("out/campaign"), help="output folder (default out/campaign)")
    p.add_argument("--runs", type=int, default=None, help="override the spec's number of runs")
    p.add_argument("--seed", type=int, default=None, help="override the spec's seed")
    p.add_argument("--t-end", type=float, default=None, help="override t_end [s] of every run")
    p.add_argument("--truth", choices=("binding", "c", "numpy", "c-backward-euler"), default="binding",
                   help="caekf-truth's C generator in process (continuous model, default), the caekf-truth "
                        "program, the numpy truth, or the legacy backward Euler")
    p.add_argument("--estimator", choices=("binding", "replay", "numpy"), default="binding",
                   help="the shipped C estimator in process (binding, default), the same through caekf-replay, "
                        "or the numpy reference")
    p.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    p.add_argument("--scheduler", default=None, help="run on a Dask distributed cluster, e.g. tcp://HOST:8786")
    p.add_argument("--no-plots", action="store_true", help="no figures (tables only)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.add_argument("--observability", action="store_true",
                   help="runs estimating law parameters: also ask the observability tool (rank test and "
                        "Cramer-Rao bound on the truth, ~10 s a run) which runs can meet the whole law's targets; "
                        "runs declaring uncertain parameters (m{i}_sigma, spring{i}_k/c_sigma, input{i}_sigma): "
                        "which runs gamma's bound, every declared parameter unknown, admits (3 bounds within 2 %%)")
    p.set_defaults(func=cmd_campaign)

    p = sub.add_parser("family", help="write the scenario files and parameter table of a family spec")
    p.add_argument("spec", type=Path, help="family spec (TOML, docs/family.md)")
    p.add_argument("--out", type=Path, required=True, help="folder for run-NNNN.toml files")
    p.add_argument("--runs", type=int, default=None, help="override the spec's number of runs")
    p.add_argument("--seed", type=int, default=None, help="override the spec's seed")
    p.add_argument("--t-end", type=float, default=None, help="override t_end [s] of every run")
    p.set_defaults(func=cmd_family)


def cmd_beam_campaign(args: argparse.Namespace) -> int:
    """A family of beams hitting a stop ([family] kind = "beam"): the issue's targets as a table."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from ..structure.family import by_modes, format_targets, load_beam_family, run_family, summary

    try:
        family = load_beam_family(args.spec, runs=args.runs, seed=args.seed, t_end=args.t_end)
    except (ValueError, OSError) as exc:
        print(f"caekf-sim campaign: {exc}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    rows = run_family(family, workers=args.workers, scheduler=args.scheduler, progress=not args.no_progress)
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    keys = sorted({k for r in rows for k in r})
    pq.write_table(pa.table({k: [None if r.get(k) is None else str(r[k]) if isinstance(r.get(k), str) else r[k]
                                 for r in rows] for k in keys}), out / "runs.parquet")
    print(f"family {family.name}: {family.runs} beams, seed {family.seed}, {family.t_end:g} s at "
          f"{1 / family.dt:g} Hz each, {time.perf_counter() - t0:.0f} s")
    print(format_targets(summary(rows)))
    print(by_modes(rows))
    print(f"runs: {out / 'runs.parquet'}")
    return 0


def cmd_campaign(args: argparse.Namespace) -> int:
    import pyarrow.parquet as pq

    from ..structure.family import is_beam_spec

    if is_beam_spec(args.spec):
        return cmd_beam_campaign(args)

    from ..campaign.report import (format_admission, format_joint, format_summary, format_targets, joint_rows,
                                   summary_rows, write_plots)
    from ..campaign.metrics import MISMATCH_FLAG, mismatch_flag_mask
    from ..campaign.runner import ADMIT_SIGMAS, ADMIT_TOL, rows_table, run_family
    from ..campaign.spec import load_family

    try:
        family = load_family(args.spec, runs=args.runs, seed=args.seed, t_end=args.t_end)
    except (ValueError, OSError) as exc:
        print(f"caekf-sim campaign: {exc}", file=sys.stderr)
        return 2
    experiments = args.experiment or ["switched"]
    t0 = time.perf_counter()
    try:
        rows = run_family(family, experiments, truth=args.truth, estimator=args.estimator, workers=args.workers,
                          scheduler=args.scheduler, progress=not args.no_progress,
                          observability=args.observability)
    except ValueError as exc:  # e.g. a mechanism the truth does not simulate
        print(f"caekf-sim campaign: {exc}", file=sys.stderr)
        return 2
    except RuntimeError as exc:
        print(f"caekf-sim campaign: {exc}", file=sys.stderr)
        return 3
    wall = time.perf_counter() - t0
    out: Path = args.out
    out.mkdir(parents=True, exist_ok=True)
    pq.write_table(rows_table(rows), out / "runs.parquet")
    summary = summary_rows(rows, family, experiments)
    pq.write_table(rows_table(summary), out / "summary.parquet")
    seed = f", seed {family.seed}" if family.seed is not None else ""
    where = args.scheduler or f"local pool, {args.workers or 'all'} workers"
    t_end = family.runs[0].scenario.t_end if family.runs else 0.0
    head = (f"family {family.name}: {len(family.runs)} mechanisms{seed}, {t_end:g} s each; truth {args.truth}, "
            f"estimator {args.estimator}; {wall:.1f} s wall ({where})")
    failed = sum(1 for r in rows if r["truth_failed"]) // max(1, len(experiments))
    text = head + f"\ntruth failures: {failed}/{len(family.runs)}\n"
    if family.mismatch:
        text += ("the truth differs from the filter's model ([mismatch]: "
                 + ", ".join(f"{k} = {v:g}" for k, v in family.mismatch) + ")\n")
    if mismatch_flag_mask() is None:
        text += (f"the schema has no {MISMATCH_FLAG} flag yet: flagged = n/a, and every run outside 3 sigma "
                 "counts as silent wrong\n")
    if any(r.scenario.contacts > 1 for r in family.runs):
        text += ("mechanisms with several contacts count by their worst contact: largest |final error|, "
                 "diverged if any contact diverged, within 3 sigma if every contact is\n")
    text += "\n" + format_summary(summary) + "\n"
    admission = format_admission(summary)
    if admission:
        text += (f"\nadmitted by the Cramer-Rao bound of gamma with every declared parameter unknown "
                 f"({ADMIT_SIGMAS:g} bounds within {100 * ADMIT_TOL:g} %):\n\n" + admission + "\n")
    joint = joint_rows(rows, family, experiments)
    if joint:
        pq.write_table(rows_table(joint), out / "joint.parquet")
        sel = "the runs whose bound allows the targets" if args.observability else \
            "every run (--observability: only those the tool says can meet them)"
        text += (f"\nthe whole contact law (contact 1; targets: gamma and n within 2 %, lambda within 10 %, "
                 f"gap within 0.1 um), counted over {sel}:\n\n" + format_joint(joint) + "\n")
    verdict = format_targets(family, summary, joint)
    if verdict:
        over = (", the joint ones over the runs whose bound allows them" if args.observability else
                ", the joint ones over every run: --observability counts only those whose bound allows them")
        text += "\ntargets (the spec's [targets], over all runs" + (over if joint else "") + "):\n" + verdict + "\n"
    (out / "summary.txt").write_text(text, encoding="utf-8")
    print(text, end="")
    if not args.no_plots and rows:
        for p in write_plots(rows, family, experiments, out, family.runs[0].scenario.dt):
            print(f"wrote {p}")
    print(f"wrote {out / 'runs.parquet'}, {out / 'summary.parquet'}, {out / 'summary.txt'}")
    return 0


def cmd_family(args: argparse.Namespace) -> int:
    from ..campaign.spec import load_spec, scenario_text

    try:
        family = load_spec(args.spec, runs=args.runs, seed=args.seed, t_end=args.t_end)
    except (ValueError, OSError) as exc:
        print(f"caekf-sim family: {exc}", file=sys.stderr)
        return 2
    args.out.mkdir(parents=True, exist_ok=True)
    for r in family.runs:
        (args.out / f"run-{r.run:04d}.toml").write_text(
            f"# {family.name} run {r.run} (seed {family.seed})\n" + scenario_text(r.scenario), encoding="utf-8")
        if r.truth_factors:  # [mismatch]: the truth's own scenario, in truth/ (not a run of the folder)
            (args.out / "truth").mkdir(exist_ok=True)
            (args.out / "truth" / f"run-{r.run:04d}.toml").write_text(
                f"# {family.name} run {r.run} (seed {family.seed}): the truth ([mismatch])\n"
                + scenario_text(r.truth_scenario()), encoding="utf-8")
    print(f"wrote {len(family.runs)} scenario files to {args.out}"
          + (" (the truths' in truth/)" if any(r.truth_factors for r in family.runs) else ""))
    return 0
