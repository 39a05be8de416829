"""The numpy reference's two step maps (the setting `discretisation`): the trapezoidal rule's order, its F
against finite differences, the inputs at the step's start, the contact substeps (`contact_substeps`: the
rule, when they apply, their F), and where the settings come from.

Expectations come from the equations (the exact solution of a linear system by the matrix exponential,
central differences of the step map), never from a stored run; the C core is compared in
test_binding_mechanism.py."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import expm

from caekf_sim.estimator import AugmentedEKF, EstimatorConfig
from caekf_sim.experiments import EXPERIMENTS, experiment_config, scenario_config
from caekf_sim.mechanism import Mechanism, contact_values
from caekf_sim.model import BACKWARD_EULER, TRAPEZOIDAL, StepSolver
from caekf_sim.scenario import default_scenario_path, load_scenario
from caekf_sim.schema import setting_of
from mechanism_support import FIVE, Sc, assert_matches_finite_differences

# Two bodies on a line, body 1 tied to the ground, lightly damped (modes at 5 and 17 rad/s: omega dt small at
# the steps below, so the errors are in their asymptotic range); one input on body 1; no contact.
TWO = {"bodies": 2, "m1": 1.0, "m2": 0.5, "springs": 2,
       "spring1_a": 1, "spring1_b": 0, "spring1_k": 40.0, "spring1_c": 0.5,
       "spring2_a": 1, "spring2_b": 2, "spring2_k": 90.0, "spring2_c": 0.2,
       "inputs": 1, "input1_body": 1, "input1_amp": 0.0, "input1_freq": 0.0, "input1_phase": 0.0,
       "sensors": 1, "sensor1_body": 1, "contacts": 0}
U_AMP, U_OMEGA = 2.0, 7.0  # u(t) = U_AMP sin(U_OMEGA t) [N]


def _exact(mech: Mechanism, x0: np.ndarray, t: float) -> np.ndarray:
    """x(t) of M q'' + C q' + K q = B_u u(t), u a sine: the matrix exponential of the system extended by
    the sine's own oscillator s' = w c, c' = -w s (s(0) = 0, c(0) = 1, u = U_AMP s)."""
    nq = mech.nq
    Minv = np.diag(1.0 / mech.m)
    A = np.zeros((2 * nq + 2, 2 * nq + 2))
    A[:nq, nq : 2 * nq] = np.eye(nq)
    A[nq : 2 * nq, :nq] = -Minv @ mech.K
    A[nq : 2 * nq, nq : 2 * nq] = -Minv @ mech.C
    A[nq : 2 * nq, 2 * nq] = U_AMP * (Minv @ mech.B_u)[:, 0]
    A[2 * nq, 2 * nq + 1] = U_OMEGA
    A[2 * nq + 1, 2 * nq] = -U_OMEGA
    return (expm(A * t) @ np.r_[x0, 0.0, 1.0])[: 2 * nq]


def _error_after_one_second(scheme: str, h: float) -> float:
    """Largest state error at t = 1 s of the step map with step h, u sampled at the steps' ends."""
    mech = Mechanism.from_scenario(TWO)
    solver = StepSolver(mech, h, scheme=scheme)
    q, v = np.array([1e-3, -2e-3]), np.array([0.05, 0.0])
    x_ref = _exact(mech, np.r_[q, v], 1.0)
    steps = int(round(1.0 / h))
    u_prev = 0.0  # u(0)
    for k in range(1, steps + 1):
        u = U_AMP * np.sin(U_OMEGA * k * h)
        q, v, it, ok = solver.solve(q, v, u, (), u_prev)
        assert ok and it == 1
        u_prev = u
    q_ref, v_ref = x_ref[:2], x_ref[2:]
    return max(np.max(np.abs(q - q_ref)) / np.max(np.abs(q_ref)), np.max(np.abs(v - v_ref)) / np.max(np.abs(v_ref)))


@pytest.mark.parametrize("scheme, ratio", [(TRAPEZOIDAL, 4.0), (BACKWARD_EULER, 2.0)])
def test_order_of_the_step_map(scheme, ratio):
    """Halving dt cuts the one-second error by ~4 (trapezoidal: second order) or ~2 (backward Euler)."""
    errs = [_error_after_one_second(scheme, h) for h in (4e-3, 2e-3, 1e-3)]
    for coarse, fine in zip(errs, errs[1:]):
        assert coarse / fine == pytest.approx(ratio, rel=0.1), errs
    if scheme == TRAPEZOIDAL:
        assert errs[-1] < 0.05 * _error_after_one_second(BACKWARD_EULER, 1e-3)


def test_trapezoidal_step_with_the_inputs_held_is_first_order():
    """The input at the step's start matters: u_k used at both ends costs the second order."""
    mech = Mechanism.from_scenario(TWO)
    errs = []
    for h in (2e-3, 1e-3):
        solver = StepSolver(mech, h, scheme=TRAPEZOIDAL)
        q, v = np.array([1e-3, -2e-3]), np.array([0.05, 0.0])
        x_ref = _exact(mech, np.r_[q, v], 1.0)
        for k in range(1, int(round(1.0 / h)) + 1):
            q, v, _, _ = solver.solve(q, v, U_AMP * np.sin(U_OMEGA * k * h), ())  # u_prev None: u_k
        errs.append(np.max(np.abs(np.r_[q, v] - x_ref)))
    assert errs[0] / errs[1] == pytest.approx(2.0, rel=0.15)





@pytest.mark.parametrize("v3, closed_at_end", [(1e-3, (True, True)), (-1.2e-2, (False, True))])
def test_trapezoidal_transition_matrix_matches_finite_differences(v3, closed_at_end):
    """F = d x_k / d x_{k-1} of the trapezoidal step with both contacts closed at x_{k-1}: at x_k too, or
    contact 1 opening during the step (its gamma then moves x_k through the step's start alone)."""
    five = Sc(FIVE)
    ekf = AugmentedEKF(five, EstimatorConfig(discretisation=TRAPEZOIDAL))
    q0 = np.array([1e-4, 2e-4, 2e-4 + 3e-6, -(1e-4 + 2e-5), -5e-5])
    v0 = np.array([1e-3, -2e-3, v3, 3e-3, -1e-3])
    assert np.all(ekf.plant.penetrations(q0) > 0)
    x0 = np.r_[q0, v0, contact_values(five, "gamma", 2)]
    u, u_prev = [0.3, 0.1], [0.25, 0.2]
    ekf.x, ekf.u_prev = x0.copy(), u_prev
    xp, F, _, ok = ekf.predict(u)
    assert ok and tuple(ekf.plant.penetrations(xp[:5]) > 0) == closed_at_end
    assert_matches_finite_differences(ekf, x0, u, F)
    assert np.any(F[:10, 10] != 0) and np.any(F[:10, 11] != 0)


def test_inputs_at_the_step_start():
    """The first step holds its own u over the interval; later steps start from the previous step's u;
    `correct` (a sample at t0) records its u without moving the state in time."""
    five = Sc(FIVE)
    cfg = EstimatorConfig(discretisation=TRAPEZOIDAL)
    y = np.zeros(3)
    u0, u1, u2 = [0.5, -0.2], [0.3, 0.1], [0.1, 0.4]

    def solved(ekf, u, u_prev):
        q, v, _, _ = ekf.solver.solve(ekf.x[:5], ekf.x[5:10], u, ekf.x[10:], u_prev)
        return np.r_[q, v]

    a = AugmentedEKF(five, cfg)
    assert a.u_prev is None
    assert np.array_equal(a.predict(u1)[0][:10], solved(a, u1, u1))
    a.step(u1, y)
    assert a.u_prev == u1
    assert np.array_equal(a.predict(u2)[0][:10], solved(a, u2, u1))

    b = AugmentedEKF(five, cfg)
    x_before, P_before = b.x.copy(), b.P.copy()
    b.correct(u0, y)
    assert b.u_prev == u0
    # the correction alone: positions pulled towards y with P^- = P (no Q added), the gammas unmoved
    # (their contacts are open, so frozen)
    assert np.array_equal(b.x[10:], x_before[10:]) and np.all(np.diag(b.P) <= np.diag(P_before))
    assert np.array_equal(b.P[10:, 10:], P_before[10:, 10:])
    assert np.array_equal(b.predict(u1)[0][:10], solved(b, u1, u0))


def test_the_setting_comes_from_the_schema():
    """Presets (the paper's experiments) run backward Euler; no preset: the scenario's value, whose
    default is the trapezoidal rule; the numpy config's own default stays backward Euler."""
    sc = load_scenario(default_scenario_path())
    assert {c.discretisation for c in EXPERIMENTS.values()} == {BACKWARD_EULER}
    assert experiment_config("switched").discretisation == BACKWARD_EULER
    assert scenario_config(sc).discretisation == scenario_config(sc, "default").discretisation == TRAPEZOIDAL
    assert scenario_config(sc, "canonical").discretisation == BACKWARD_EULER
    assert scenario_config(sc.replace(discretisation=0)).discretisation == BACKWARD_EULER
    assert EstimatorConfig().discretisation == BACKWARD_EULER
    with pytest.raises(ValueError, match="unknown discretisation"):
        EstimatorConfig(discretisation="rk4")
    with pytest.raises(ValueError, match="unknown discretisation"):
        StepSolver(Mechanism.from_scenario(TWO), 1e-3, scheme="euler")


@pytest.mark.parametrize("scheme", [BACKWARD_EULER, TRAPEZOIDAL])
@pytest.mark.parametrize("v3, closed_at_end", [(1e-3, (True, True)), (-1.2e-2, (False, True))])
def test_substeps_follow_the_rule_and_their_f_matches_finite_differences(scheme, v3, closed_at_end):
    """contact_substeps = 4 with both contacts closed at x_{k-1}: x_k^- is four steps of dt/4 with the
    inputs linear from u_{k-1} to u_k (a loop over StepSolver written here), the iterations are the
    substeps' (a contact closed at x_{k-1} needs no one-step solve), and F (the product of the substep
    maps) is d x_k^- / d x_{k-1}."""
    five = Sc(FIVE)
    ekf = AugmentedEKF(five, EstimatorConfig(discretisation=scheme, contact_substeps=4))
    q0 = np.array([1e-4, 2e-4, 2e-4 + 3e-6, -(1e-4 + 2e-5), -5e-5])
    v0 = np.array([1e-3, -2e-3, v3, 3e-3, -1e-3])
    assert np.all(ekf.plant.penetrations(q0) > 0)
    x0 = np.r_[q0, v0, contact_values(five, "gamma", 2)]
    u, u_prev = np.array([0.3, 0.1]), np.array([0.25, 0.2])
    ekf.x, ekf.u_prev = x0.copy(), u_prev
    xp, F, iters, ok = ekf.predict(u)
    assert ok and tuple(ekf.plant.penetrations(xp[:5]) > 0) == closed_at_end

    sub = StepSolver(ekf.plant, FIVE["dt"] / 4, scheme=scheme)
    q, v, its = q0, v0, 0
    for j in range(4):
        q, v, it, conv = sub.solve(q, v, u_prev + (u - u_prev) * (j + 1) / 4, x0[10:],
                                   u_prev + (u - u_prev) * j / 4)
        assert conv
        its += it
    np.testing.assert_allclose(xp[:10], np.r_[q, v], rtol=1e-13, atol=1e-18)
    assert iters == its and not np.array_equal(xp[:10], np.r_[ekf.solver.solve(q0, v0, u, x0[10:], u_prev)[:2]])

    assert_matches_finite_differences(ekf, x0, u, F)
    # contact 1 opening: backward Euler's substeps see it at their ends only, and it opens in the first
    assert np.any(F[:10, 10] != 0) == (scheme == TRAPEZOIDAL or closed_at_end[0]) and np.any(F[:10, 11] != 0)


def test_substeps_only_while_a_contact_is_closed():
    """contact_substeps > 1 changes nothing while every contact is open at both ends of the step; a contact
    closed at x_{k-1} alone (opening during the step) already calls for the substeps."""
    five = Sc(FIVE)
    one, four = (AugmentedEKF(five, EstimatorConfig(discretisation=TRAPEZOIDAL, contact_substeps=s)) for s in (1, 4))
    u, u_prev = [0.3, 0.1], [0.25, 0.2]
    for ekf in (one, four):
        ekf.u_prev = u_prev
    a, b = one.predict(u), four.predict(u)  # the initial state: both contacts open
    assert not any(d > 0 for d in one.plant.penetrations(a[0][:5]))
    assert np.array_equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2]
    q0 = np.array([0.0, 0.0, 2e-4 + 1e-7, 0.0, 0.0])  # contact 1 just closed, body 3 leaving fast
    v0 = np.array([0.0, 0.0, -1e-1, 0.0, 0.0])
    for ekf in (one, four):
        ekf.x[:10] = np.r_[q0, v0]
    a, b = one.predict(u), four.predict(u)
    assert one.plant.penetrations(q0)[0] > 0 and not any(d > 0 for d in one.plant.penetrations(a[0][:5]))
    assert not np.array_equal(a[0], b[0]) and b[2] > a[2]


def test_contact_substeps_setting_from_the_schema():
    """The scenario's contact_substeps (the schema's default, more than 1) reaches scenario_config; the paper's
    presets run 1."""
    sc = load_scenario(default_scenario_path())
    default = setting_of("contact_substeps").default
    assert default > 1
    assert scenario_config(sc).contact_substeps == sc.contact_substeps == default
    assert scenario_config(sc.replace(contact_substeps=2)).contact_substeps == 2
    assert scenario_config(sc, "switched").contact_substeps == 1
    assert all(cfg.contact_substeps == 1 for cfg in EXPERIMENTS.values())
    assert experiment_config("switched", contact_substeps=3).contact_substeps == 3
    with pytest.raises(ValueError, match="contact_substeps"):
        EstimatorConfig(contact_substeps=0)
