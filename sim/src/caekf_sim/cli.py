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
from typing import List, NoReturn, Optional

COMMAND_MODULES = (
    "caekf_sim.commands.run",  # truth, estimate, experiments
    "caekf_sim.commands.report",  # plot, observability, filterpy-check, truth-diff
    "caekf_sim.commands.bench",  # hil run, hil replay-log, bench (CAN HIL bench)
    "caekf_sim.commands.binding",  # bench-binding (the C binding's speed), tune (noise from data)
    "caekf_sim.commands.campaign",  # campaign, family
    "caekf_sim.commands.truthcheck",  # truth-check
    "caekf_sim.commands.identify",  # identify (maximum-likelihood parameters from recordings)
)


# One exit-code table for every tool, C and Python (docs: README, Host tools).
EXIT_USAGE, EXIT_BAD_INPUT, EXIT_IO, EXIT_NUMERIC = 2, 3, 4, 5


class UsageError(Exception):
    """Options that do not go together (argparse checks the rest): exit 2."""


class _Parser(argparse.ArgumentParser):
    """argparse with one-line usage errors (exit 2), like every other error of the tools."""

    def error(self, message: str) -> NoReturn:
        self.exit(EXIT_USAGE, f"{self.prog}: {' '.join(message.split())} (see --help)\n")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog="caekf-sim",
        description="Truth model, numpy AEKF, figures and checks for the caekf project.",
    )
    parser.add_argument("--debug", action="store_true", help="show the Python traceback of an error")
    parser.add_argument("--version", action="version", version=f"caekf-sim {_version()}")
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


def _version() -> str:
    from . import __version__

    return __version__


def exit_code(exc: BaseException) -> int:
    """The exit-code table: bad input 3 (scenario, settings, measurements), I/O 4, numerical failure 5."""
    from .scenario import ScenarioError

    if isinstance(exc, UsageError):
        return EXIT_USAGE
    if isinstance(exc, (ScenarioError, ValueError, KeyError, TypeError)):
        return EXIT_BAD_INPUT
    if isinstance(exc, (OSError, EOFError)):
        return EXIT_IO
    if isinstance(exc, (ArithmeticError, FloatingPointError, RuntimeError)):
        return EXIT_NUMERIC
    return 1


def main(argv: Optional[List[str]] = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("caekf-sim: interrupted", file=sys.stderr)
        return 130
    except Exception as exc:  # one line, never a traceback, unless --debug
        if args.debug:
            raise
        text = " ".join(str(exc).split()) or type(exc).__name__
        print(f"caekf-sim: {text}", file=sys.stderr)
        return exit_code(exc)


if __name__ == "__main__":
    sys.exit(main())
