"""Subcommand modules of `caekf-sim`; each exposes register(subparsers)."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..scenario import Scenario, ScenarioError, default_scenario_path, load_scenario


def add_scenario_arg(p: argparse.ArgumentParser, t_end: bool = False) -> None:
    p.add_argument("--scenario", type=Path, default=None,
                   help="scenario file (default: the reference scenario, sim/scenarios/paper.toml)")
    if t_end:
        p.add_argument("--t-end", type=float, default=None,
                       help="override t_end [s] (shorter runs)")


def scenario_from_args(args: argparse.Namespace) -> Scenario:
    """The --scenario file (default: the reference scenario), checked, with --t-end applied. Truth-only keys
    may be left out; commands that simulate a truth refuse that (Scenario.require_truth, in the truth's code)."""
    path = args.scenario or default_scenario_path()
    if not Path(path).exists():
        raise FileNotFoundError(f"{path}: cannot open: No such file or directory (the scenario; use --scenario)")
    sc = load_scenario(path)
    if getattr(args, "t_end", None) is not None:
        try:
            sc = sc.replace(t_end=args.t_end)
        except ScenarioError as exc:
            raise ScenarioError(f"--t-end {args.t_end:g}: {str(exc).rsplit(': ', 1)[-1]}") from None
    return sc


def add_progress_arg(p: argparse.ArgumentParser) -> None:
    """--progress / --no-progress: a progress bar on stderr (tqdm); default: when stderr is a terminal."""
    g = p.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="show a progress bar on stderr (default: when stderr is a terminal)")
    g.add_argument("--no-progress", dest="progress", action="store_false", help="no progress bar")


def want_progress(args: argparse.Namespace) -> bool:
    import sys

    p = getattr(args, "progress", None)
    return sys.stderr.isatty() if p is None else bool(p)
