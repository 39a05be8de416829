"""Model pieces: Hertz law, the eq. (19) Newton step, and eq. (10)'s F against finite differences."""
import numpy as np
import pytest

from caekf_sim.estimator import AugmentedEKF, EstimatorConfig
from caekf_sim.model import Plant, StepSolver, contact_force


def test_hertz_law_and_derivatives():
    assert contact_force(-1e-6, 1e8) == (0.0, 0.0, 0.0)
    assert contact_force(0.0, 1e8) == (0.0, 0.0, 0.0)
    d, g = 2e-6, 1e8
    fc, dfd, dfg = contact_force(d, g)
    assert fc == pytest.approx(g * d**1.5, rel=1e-15)
    eps = 1e-12
    assert dfd == pytest.approx((contact_force(d + eps, g)[0] - contact_force(d - eps, g)[0]) / (2 * eps), rel=1e-6)
    assert dfg == pytest.approx(d**1.5, rel=1e-15)


def _contact_state(plant: Plant, pen: float):
    q = np.array([1.0e-3, plant.gap + pen, 0.0, 0.0])  # q2 - q3 - gap = pen
    v = np.array([1e-4, 2e-4, -1e-4, 0.5e-4])
    return q, v


@pytest.mark.parametrize("pen", [-5e-6, 2e-6])
def test_step_solves_eq19(sc, pen):
    plant = Plant.from_scenario(sc)
    solver = StepSolver(plant, sc.dt)
    q0, v0 = _contact_state(plant, pen)
    q, v, iters, ok = solver.solve(q0, v0, 1.3, sc.gamma)
    assert ok and iters >= 1
    np.testing.assert_allclose((q - q0) / sc.dt, v, rtol=0, atol=1e-15)  # first row of eq. (19)
    fc = contact_force(plant.penetration(q), sc.gamma)[0]
    r = plant.m * (v - v0) / sc.dt + plant.C @ v + plant.K @ q + fc * np.array([0, 1, -1, 0]) - np.r_[1.3, 0, 0, 0]
    assert np.max(np.abs(r)) < 1e-9  # N; row terms are O(10 N)


def test_linear_fast_path_equals_newton(sc):
    plant = Plant.from_scenario(sc)
    solver = StepSolver(plant, sc.dt)
    q0, v0 = _contact_state(plant, -5e-5)
    q_a, v_a, it_a, _ = solver.solve(q0, v0, 0.7, sc.gamma)
    q_b, v_b, it_b, ok = solver.newton(q0, v0, 0.7, sc.gamma)
    assert ok and it_a == it_b == 1
    np.testing.assert_allclose(v_a, v_b, rtol=1e-13, atol=1e-18)


@pytest.mark.parametrize("pen", [-5e-6, 2e-6])
def test_transition_matrix_matches_finite_differences(sc, pen):
    """Eq. (10): F = d x_k / d x_{k-1} of the implicit step, checked by central differences."""
    ekf = AugmentedEKF(sc, EstimatorConfig())
    q0, v0 = _contact_state(ekf.plant, pen)
    x0 = np.r_[q0, v0, sc.gamma]
    ekf.x = x0.copy()
    _, F, _, _ = ekf.predict(0.9)
    scale = np.r_[np.full(4, 1e-9), np.full(4, 1e-7), 1e2]
    Fd = np.empty((9, 9))
    for j in range(9):
        cols = []
        for s in (+1, -1):
            ekf.x = x0.copy()
            ekf.x[j] += s * scale[j]
            cols.append(ekf.predict(0.9)[0])
        Fd[:, j] = (cols[0] - cols[1]) / (2 * scale[j])
    tol = 1e-6 * np.abs(F).max(axis=1, keepdims=True) + 1e-300
    assert np.all(np.abs(F - Fd) <= tol)
    if pen < 0:
        assert np.all(F[:8, 8] == 0.0)  # gamma does not act out of contact (eq. 23's F_xg = 0)
    else:
        assert np.any(F[:8, 8] != 0.0)
