"""Cross-check the canonical AEKF against FilterPy's ExtendedKalmanFilter.

FilterPy runs its own predict/update loop; we only hand it the model: predict_x is
overridden with our Newton solve of eq. (19) and sets F (eq. 10) for FilterPy's
P = F P F^T + Q (eq. 12); update() gets H and h(x) = H x (eqs. 13-14). FilterPy's update
uses the Joseph form of eq. (15), so the natural partner is our canonical run with
joseph=True; the standard-form run is compared as well.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Dict, Tuple

import numpy as np

from .estimator import AugmentedEKF, EstimateResult, EstimatorConfig, NA
from .experiments import experiment_config, run_experiment
from .scenario import Scenario
from .truth import Truth


def _filterpy_ekf_class():
    from filterpy.kalman import ExtendedKalmanFilter  # optional dependency ([dev])

    class NewtonEKF(ExtendedKalmanFilter):
        """FilterPy EKF whose state prediction is our implicit backward-Euler step."""

        x: np.ndarray  # FilterPy's state column (n, 1)

        def __init__(self, model: AugmentedEKF) -> None:
            super().__init__(dim_x=NA, dim_z=2)
            self.model = model
            self.u_k = 0.0

        def predict_x(self, u=0) -> None:  # called first by predict(); F must be set here
            self.model.x = self.x.ravel().copy()
            xp, F, _, _ = self.model.predict(self.u_k)
            self.model.u_prev = self.u_k  # the trapezoidal rule's next start (backward Euler ignores it)
            self.F = F
            self.x = xp.reshape(NA, 1)

    return NewtonEKF


def run_filterpy(sc: Scenario, truth: Truth, cfg: EstimatorConfig) -> Tuple[np.ndarray, np.ndarray]:
    """Canonical AEKF through FilterPy; returns the posterior states (N, 9) and P (N, 9, 9)."""
    model = AugmentedEKF(sc, cfg)
    ekf = _filterpy_ekf_class()(model)
    ekf.x = model.x.reshape(NA, 1).copy()
    ekf.P = model.P.copy()
    ekf.Q = model.Q.copy()
    ekf.R = model.R.copy()
    H = model.H

    def hjac(_x: np.ndarray) -> np.ndarray:
        return H

    def hx(x: np.ndarray) -> np.ndarray:
        return H @ x

    n = len(truth.t)
    xs = np.empty((n, NA))
    Ps = np.empty((n, NA, NA))
    for k in range(n):
        ekf.u_k = float(truth.u[k])
        ekf.predict()
        ekf.update(truth.y[k].reshape(2, 1), hjac, hx)
        xs[k] = ekf.x.ravel()
        Ps[k] = ekf.P
    return xs, Ps


@dataclass(frozen=True)
class Agreement:
    state_rel: float  # max over steps and states of |dx| / max_k |x_ref|, per state column
    gamma_rel: float  # max_k |d gamma| / gamma_true
    p_rel: float  # max_k ||dP||_F / ||P_ref||_F


def compare(xs: np.ndarray, Ps: np.ndarray, ref: EstimateResult, gamma_true: float) -> Agreement:
    if ref.P is None:
        raise ValueError("the reference run must keep P (keep_P=True)")
    dx = np.abs(xs - ref.x)
    col_scale = np.max(np.abs(ref.x), axis=0)
    state_rel = float(np.max(dx.max(axis=0) / col_scale))
    gamma_rel = float(dx[:, -1].max() / gamma_true)
    p_rel = float(np.max(np.linalg.norm(Ps - ref.P, axis=(1, 2)) / np.linalg.norm(ref.P, axis=(1, 2))))
    return Agreement(state_rel, gamma_rel, p_rel)


def check(sc: Scenario, truth: Truth) -> Dict[str, Agreement]:
    """FilterPy vs our canonical run, Joseph form and standard form."""
    xs, Ps = run_filterpy(sc, truth, experiment_config("canonical"))
    out = {}
    for label, jos in (("joseph", True), ("standard", False)):
        ref = run_experiment(sc, truth, "canonical", keep_P=True, joseph=jos)
        out[label] = compare(xs, Ps, ref, sc.gamma)
    return out
