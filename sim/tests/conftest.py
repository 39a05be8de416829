"""Shared fixtures: the paper scenario, its full 60 s truth and the four experiments (run once)."""
from __future__ import annotations

from typing import Dict

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
