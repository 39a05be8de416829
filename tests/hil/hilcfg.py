"""Paths and settings of the HIL suite (see conftest.py), and its report of measured numbers."""
from __future__ import annotations

import os
from pathlib import Path
from typing import List

from caekf_sim.schema import preset_names

REPO = Path(__file__).resolve().parents[2]
BUILD = Path(os.environ.get("CAEKF_BUILD_DIR", REPO / "build" / "host-double"))
HOST_BIN = BUILD / "host" / "caekf_host" / "caekf-host"
REPLAY_BIN = BUILD / "host" / "caekf-replay"
TRUTH_BIN = BUILD / "host" / "caekf-truth"
SCENARIO = REPO / "sim" / "scenarios" / "paper.toml"
IFACE = os.environ.get("CAEKF_HIL_IFACE", "vcan0")
HOST_STEP_TIMEOUT_MS = os.environ.get("CAEKF_HIL_STEP_TIMEOUT_MS", "1000")  # see conftest.estimator
# Protocol profile of caekf-host and the bench (caekf_sim.bench.profiles). tools/hil-tests.sh runs the suite
# in diagnostics (test_hil_fd.py aside), test_hil_experiments.py, test_hil_bad_traffic.py and the fault matrix in
# production, and test_hil_bad_traffic.py, the fault matrix and test_hil_fd.py in fd.
PROFILE = os.environ.get("CAEKF_HIL_PROFILE", "diagnostics")

EXPERIMENTS = tuple(preset_names())  # the paper's four experiments: presets of the settings schema

REPORT: List[str] = []  # measured numbers, printed at the end of the session (pytest_terminal_summary)


def report(line: str) -> None:
    REPORT.append(line)
    print(line)
