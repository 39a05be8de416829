"""Shared fixtures: the paper scenario, its full 60 s truth and the four experiments (run once), and
caekf-truth's record of it as the C tools write it (truth_csv, truth_cols: the binding and FMU suites)."""
from __future__ import annotations

import subprocess
from pathlib import Path
from typing import Dict

import numpy as np

import pytest

from caekf_sim.estimator import EstimateResult
from caekf_sim.experiments import EXPERIMENTS, run_experiment
from caekf_sim.scenario import Scenario, default_scenario_path, load_scenario
from caekf_sim.truth import Truth, simulate


@pytest.fixture(scope="session")
def sc() -> Scenario:
    return load_scenario(default_scenario_path())


@pytest.fixture(scope="session")
def truth(sc: Scenario) -> Truth:
    return simulate(sc)


@pytest.fixture(scope="session")
def results(sc: Scenario, truth: Truth) -> Dict[str, EstimateResult]:
    """All four experiments over the full 60 s, with P kept for covariance checks."""
    return {name: run_experiment(sc, truth, name, keep_P=True) for name in EXPERIMENTS}


@pytest.fixture(scope="session")
def truth_csv(tmp_path_factory) -> Path:
    """The paper scenario's truth as caekf-truth (double) writes it."""
    from test_binding import tool

    out = tmp_path_factory.mktemp("c-truth") / "truth.csv"
    subprocess.run([str(tool("caekf-truth", "double")), "--scenario", str(default_scenario_path()), "--out",
                    str(out), "--quiet"], check=True, timeout=300)
    return out


@pytest.fixture(scope="session")
def truth_cols(truth_csv: Path) -> Dict[str, np.ndarray]:
    from test_binding import read_csv

    return read_csv(truth_csv)
