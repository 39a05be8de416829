"""Subcommand modules of `caekf-sim`; each exposes register(subparsers)."""
from __future__ import annotations

import argparse
from pathlib import Path

from ..scenario import Scenario, ScenarioError, default_scenario_path, load_scenario


def add_scenario_arg(p: argparse.ArgumentParser, t_end: bool = False) -> None:
    p.add_argument("--scenario", type=Path, default=None,
                   help="scenario file (default: sim/scenarios/paper.toml)")
    if t_end:
        p.add_argument("--t-end", type=float, default=None,
                       help="override t_end [s] (shorter runs)")


def scenario_from_args(args: argparse.Namespace) -> Scenario:
    path = args.scenario or default_scenario_path()
    if not Path(path).exists():
        raise ScenarioError(f"scenario file not found: {path} (use --scenario)")
    sc = load_scenario(path)
    if getattr(args, "t_end", None) is not None:
        try:
            sc = sc.replace(t_end=args.t_end)
        except ScenarioError as exc:
            raise ScenarioError(f"--t-end {args.t_end:g}: {str(exc).rsplit(': ', 1)[-1]}") from None
    return sc
