"""Helpers of the mechanism tests: a dict scenario, the example scenarios, the 5-body mechanism FIVE and
a finite-difference check of F."""
from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from caekf_sim.scenario import default_scenario_path, load_scenario

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"


class Sc(dict):
    """A {key: value} scenario with the attributes the estimator and truth read directly (the
    general format's keys or the paper's aliases; absent keys take the format's defaults)."""

    def __getattr__(self, key: str) -> Any:
        try:
            return self[key]
        except KeyError:
            raise AttributeError(key) from None

    @property
    def n_steps(self) -> int:
        return int(round(self["t_end"] / self["dt"]))

    def replace(self, **kw: Any) -> "Sc":
        return Sc({**self, **kw})

    def values(self):  # type: ignore[override]
        return dict(self)


def example_scenario(name: str) -> Any:
    """sim/scenarios/<name>.toml as a Scenario."""
    return load_scenario(SCENARIOS / f"{name}.toml")


def paper_path() -> Path:
    return default_scenario_path()


# A 5-body mechanism exercising everything: a body-ground contact (n = 1, Hunt-Crossley), a
# body-body contact with the ground on side a, two inputs, a velocity sensor.
FIVE = {
    "dt": 1e-3, "t_end": 1.0, "bodies": 5, "m1": 1.0, "m2": 2.0, "m3": 0.5, "m4": 1.5, "m5": 1.0,
    "springs": 5, "spring1_a": 1, "spring1_b": 0, "spring1_k": 3e3, "spring1_c": 4.0,
    "spring2_a": 2, "spring2_b": 1, "spring2_k": 1e4, "spring2_c": 1.0,
    "spring3_a": 3, "spring3_b": 2, "spring3_k": 5e3, "spring3_c": 0.0,
    "spring4_a": 4, "spring4_b": 5, "spring4_k": 8e3, "spring4_c": 2.0,
    "spring5_a": 0, "spring5_b": 5, "spring5_k": 2e3, "spring5_c": 3.0,
    "inputs": 2, "input1_body": 1, "input1_amp": 1.0, "input1_freq": 1.0, "input1_phase": 0.0,
    "input2_body": 4, "input2_amp": 2.0, "input2_freq": 0.5, "input2_phase": 1.0,
    "sensors": 3, "sensor1_body": 1, "sensor1_kind": "position", "sensor2_body": 4, "sensor2_kind": "velocity",
    "sensor3_body": 5, "sensor3_kind": 0,
    "contacts": 2, "contact1_a": 3, "contact1_b": 0, "contact1_gap": 2e-4, "contact1_n": 1.0,
    "contact1_lambda": 30.0, "contact1_gamma": 3e5, "contact2_a": 0, "contact2_b": 4, "contact2_gap": 1e-4,
    "contact2_n": 2.3, "contact2_lambda": 0.0, "contact2_gamma": 1e12,
    "contact1_gamma0": 2e5, "contact1_sigma_gamma0": 1e5, "contact1_sigma_q_gamma": 1e3, "contact1_gamma_min": 1e3,
    "contact2_gamma0": 8e11, "contact2_sigma_gamma0": 3e11, "contact2_sigma_q_gamma": 1e9,
    "contact2_gamma_min": 1e9, "sigma_q0": 1e-6, "sigma_v0": 1e-5, "sigma_qx_q": 1e-9, "sigma_qx_v": 1e-7,
    "sigma_r": 1e-7, "sigma_rv": 1e-5, "noise_std": 0.0, "noise_std_v": 0.0, "seed": 1, "truth_substeps": 2,
}


def assert_matches_finite_differences(ekf: Any, x0: np.ndarray, u: Any, F: np.ndarray) -> None:
    """F = d x_k^- / d x_{k-1} of ekf.predict(u) at x0 (FIVE's states), by central differences."""
    step = np.r_[np.full(5, 1e-10), np.full(5, 1e-8), 1e-1, 1e5]
    Fd = np.empty_like(F)
    for j in range(ekf.n):
        cols = []
        for s in (+1, -1):
            ekf.x = x0.copy()
            ekf.x[j] += s * step[j]
            cols.append(ekf.predict(u)[0])
        Fd[:, j] = (cols[0] - cols[1]) / (2 * step[j])
    assert np.all(np.abs(F - Fd) <= 1e-6 * np.abs(F).max(axis=1, keepdims=True))
