"""`caekf-sim` command line: a thin dispatcher over subcommands registered by modules.

To add subcommands (e.g. the CAN bench), write a module with
    def register(subparsers: argparse._SubParsersAction) -> None
that adds parsers and sets `func=handler` (handler(args) -> int), then list it in
COMMAND_MODULES. Modules whose optional dependencies are missing are skipped quietly.
"""
from __future__ import annotations

import argparse
import importlib
import sys
from typing import List, Optional

COMMAND_MODULES = (
    "caekf_sim.commands.run",  # truth, estimate, experiments
    "caekf_sim.commands.report",  # plot, observability, filterpy-check, truth-diff
    "caekf_sim.commands.bench",  # hil run, hil replay-log, bench (CAN HIL bench)
    "caekf_sim.commands.campaign",  # campaign, family
    "caekf_sim.commands.truthcheck",  # truth-check
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="caekf-sim",
        description="Truth model, numpy AEKF, figures and checks for the caekf project.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ImportError as exc:  # e.g. a bench module without python-can installed
            print(f"caekf-sim: skipping {name}: {exc}", file=sys.stderr)
            continue
        module.register(sub)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    return int(args.func(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
