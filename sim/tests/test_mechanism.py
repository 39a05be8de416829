"""The general mechanism (mechanism.py) and the step, truth and reference EKF over it.

Expectations come from the equations (hand-assembled matrices, finite differences, the implicit
equation's residual, closed forms), never from a stored run."""
from __future__ import annotations

import math

import numpy as np
import pytest

from caekf_sim.estimator import AugmentedEKF, EstimatorConfig
from caekf_sim.mechanism import InputSeries, Mechanism, MechanismError, contact_law, contact_values
from caekf_sim.model import StepSolver
from caekf_sim.truth import read_truth_csv, simulate, write_truth_csv
from mechanism_support import FIVE, Sc, assert_matches_finite_differences



@pytest.fixture
def five() -> Sc:
    return Sc(FIVE)


def link_matrix(nq, links):
    """K (or C) assembled link by link from the spring potential 1/2 k (q_a - q_b)^2."""
    out = np.zeros((nq, nq))
    for a, b, k in links:
        e = np.zeros(nq + 1)
        e[a] += 1.0
        e[b] -= 1.0
        out += k * np.outer(e[1:], e[1:])  # row/column 0 is the ground, dropped
    return out


# ---- parsing ----------------------------------------------------------------------------------
def test_paper_scenario_is_the_paper_chain(sc):
    mech = Mechanism.from_scenario(sc)
    K = link_matrix(4, [(1, 0, sc.k1), (1, 2, sc.k12), (3, 4, sc.k34), (4, 0, sc.k4)])
    np.testing.assert_array_equal(mech.K, K)
    np.testing.assert_array_equal(mech.C, link_matrix(4, [(1, 0, sc.c1), (1, 2, sc.c12), (3, 4, sc.c34),
                                                            (4, 0, sc.c4)]))
    np.testing.assert_array_equal(mech.B_c, [[0.0, 1.0, -1.0, 0.0]])
    np.testing.assert_array_equal(mech.B_u, [[1.0], [0.0], [0.0], [0.0]])
    assert mech.sensor_names() == ("y1", "y4") and mech.contact_n.tolist() == [1.5]
    np.testing.assert_array_equal(mech.H[:, :4], [[1, 0, 0, 0], [0, 0, 0, 1]])


def test_five_body_matrices(five):
    mech = Mechanism.from_scenario(five)
    links = [(1, 0), (2, 1), (3, 2), (4, 5), (0, 5)]
    np.testing.assert_array_equal(mech.K, link_matrix(5, [(a, b, five[f"spring{i}_k"])
                                                           for i, (a, b) in enumerate(links, 1)]))
    np.testing.assert_array_equal(mech.B_c, [[0, 0, 1, 0, 0], [0, 0, 0, -1, 0]])
    assert mech.sensor_names() == ("y1", "yv4", "y5")
    x = np.arange(1.0, 11.0)
    np.testing.assert_array_equal(mech.H @ x, [x[0], x[5 + 3], x[4]])
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5])
    np.testing.assert_allclose(mech.penetrations(q), [0.3 - 2e-4, -0.4 - 1e-4], rtol=1e-15)


@pytest.mark.parametrize("change, key", [
    ({"bodies": 9}, "bodies"),
    ({"bodies": 0}, "bodies"),
    ({"m3": 0.0}, "m3"),
    ({"spring2_a": 6}, "spring2_a"),  # body number > bodies
    ({"spring3_b": 3}, "spring3_b"),  # a == b
    ({"spring1_k": -1.0}, "spring1_k"),
    ({"springs": 13}, "springs"),
    ({"input2_body": 0}, "input2_body"),  # an input on the ground
    ({"sensor1_body": 0}, "sensor1_body"),  # a sensor on the ground
    ({"sensor3_body": 1}, "sensor3_body"),  # the same sensor twice
    ({"sensor2_kind": "force"}, "sensor2_kind"),
    ({"sensor2_kind": 5}, "sensor2_kind"),
    ({"contact2_b": 0}, "contact2_b"),  # ground against ground
    ({"contact1_b": 7}, "contact1_b"),
    ({"contact1_n": 0.5}, "contact1_n"),
    ({"contact1_lambda": -1.0}, "contact1_lambda"),
    ({"contact1_gap": math.inf}, "contact1_gap"),
    ({"contacts": 3}, "contacts"),
])
def test_bad_mechanisms_are_refused_naming_the_key(five, change, key):
    with pytest.raises(MechanismError) as err:
        Mechanism.from_scenario({**five, **change})
    assert err.value.key == key
    msg = str(err.value)
    assert msg.startswith(f"{key} = ") and "\n" not in msg


def test_a_missing_required_key_is_named(five):
    values = dict(five)
    del values["m4"]
    with pytest.raises(MechanismError, match=r"^m4 = \(missing\): required"):
        Mechanism.from_scenario(values)


# ---- the contact law --------------------------------------------------------------------------
@pytest.mark.parametrize("n", [1.0, 1.5, 2.3])
@pytest.mark.parametrize("lam", [0.0, 40.0])
def test_contact_law_derivatives(n, lam):
    d, dd, g = 3e-5, -4e-3, 2e7
    f, fd, fdd, fg = contact_law(d, dd, g, n, lam)
    assert f == pytest.approx(g * d**n * (1 + lam * dd), rel=1e-14)
    for i, (x, dx) in enumerate(((d, 1e-10), (dd, 1e-8), (g, 1e2))):
        args = [d, dd, g]
        args[i] = x + dx
        fp = contact_law(*args, n, lam)[0]
        args[i] = x - dx
        fm = contact_law(*args, n, lam)[0]
        assert (fp - fm) / (2 * dx) == pytest.approx((fd, fdd, fg)[i], rel=1e-6, abs=1e-12)


def test_contact_law_is_zero_open_and_clamped():
    assert contact_law(0.0, 1.0, 1e8, 1.5, 0.0) == (0.0, 0.0, 0.0, 0.0)
    assert contact_law(-1e-6, 1.0, 1e8, 1.0, 5.0) == (0.0, 0.0, 0.0, 0.0)
    assert contact_law(1e-6, -0.3, 1e8, 1.0, 5.0) == (0.0, 0.0, 0.0, 0.0)  # 1 + lambda ddelta < 0: no pull
    assert contact_law(1e-6, -0.1, 1e8, 1.0, 5.0)[0] > 0.0


# ---- the step ---------------------------------------------------------------------------------
def closed_state(mech):
    """Positions with both contacts of FIVE closed by a few micrometres, moving."""
    q = np.array([1e-4, 2e-4, 2e-4 + 3e-6, 1e-4 - 2e-6, -5e-5])  # delta1 = q3 - gap, delta2 = -q4 - gap
    q[3] = -(1e-4 + 2e-5)
    v = np.array([1e-3, -2e-3, 1e-3, 3e-3, -1e-3])
    assert np.all(mech.penetrations(q) > 0)
    return q, v


def test_newton_step_solves_the_implicit_equation(five):
    mech = Mechanism.from_scenario(five)
    solver = StepSolver(mech, five["dt"])
    q0, v0 = closed_state(mech)
    u = np.array([0.7, -1.1])
    gamma = contact_values(five, "gamma", 2)
    q, v, iters, ok = solver.solve(q0, v0, u, gamma)
    assert ok and iters > 1
    assert np.all(mech.penetrations(q) > 0)
    np.testing.assert_allclose((q - q0) / five["dt"], v, rtol=1e-12)
    # The residual, written from the equation with the vectorised law (not the solver's own code).
    f = mech.forces(q, v, gamma)
    r = mech.M @ (v - v0) / five["dt"] + mech.C @ v + mech.K @ q - mech.B_u @ u + mech.B_c.T @ f
    scale = np.abs(mech.M @ (v - v0) / five["dt"]).max() + np.abs(mech.B_c.T @ f).max()
    assert np.max(np.abs(r)) < 1e-12 * scale


def test_linear_step_is_the_closed_form(five):
    """One body on a spring, no contact: v_k = (m/h v - k q + u) / (m/h + c + h k)."""
    one = {"bodies": 1, "m1": 2.0, "springs": 1, "spring1_a": 1, "spring1_b": 0, "spring1_k": 500.0,
           "spring1_c": 3.0, "inputs": 1, "input1_body": 1, "input1_amp": 0.0, "input1_freq": 0.0,
           "input1_phase": 0.0, "sensors": 1, "sensor1_body": 1, "contacts": 0}
    mech = Mechanism.from_scenario(one)
    h = 1e-3
    solver = StepSolver(mech, h)
    q, v, it, ok = solver.solve(np.array([1e-3]), np.array([0.2]), 0.4, ())
    v_ref = (2.0 / h * 0.2 - 500.0 * 1e-3 + 0.4) / (2.0 / h + 3.0 + h * 500.0)
    assert ok and it == 1
    assert v[0] == pytest.approx(v_ref, rel=1e-14) and q[0] == pytest.approx(1e-3 + h * v_ref, rel=1e-14)


def test_transition_matrix_matches_finite_differences(five):
    """Eq. (10) with two closed contacts (Hunt-Crossley on one): F = d x_k / d x_{k-1}."""
    ekf = AugmentedEKF(five, EstimatorConfig())
    q0, v0 = closed_state(ekf.plant)
    x0 = np.r_[q0, v0, contact_values(five, "gamma", 2)]
    u = [0.3, 0.1]
    ekf.x = x0.copy()
    _, F, _, _ = ekf.predict(u)
    assert_matches_finite_differences(ekf, x0, u, F)
    assert np.any(F[:10, 10] != 0) and np.any(F[:10, 11] != 0)


# ---- truth ------------------------------------------------------------------------------------
def test_truth_columns_and_csv_round_trip(tmp_path, five):
    tr = simulate(five.replace(t_end=0.2))
    assert tr.columns() == ("t", "u1", "u2", "y1", "yv4", "y5", "q1", "q2", "q3", "q4", "q5",
                            "v1", "v2", "v3", "v4", "v5", "delta1", "delta2")
    np.testing.assert_array_equal(tr.y, np.column_stack([tr.q[:, 0], tr.v[:, 3], tr.q[:, 4]]))
    p = tmp_path / "five.csv"
    write_truth_csv(tr, p)
    back = read_truth_csv(p)
    np.testing.assert_array_equal(back.as_array(), tr.as_array())
    assert back.columns() == tr.columns()


def test_input_series_interpolates_and_holds():
    s = InputSeries(np.array([0.0, 1.0, 3.0]), np.array([[0.0, 1.0], [2.0, 1.0], [0.0, -1.0]]))
    np.testing.assert_array_equal(s(np.array([-1.0, 0.5, 2.0, 5.0])), [[0, 1], [1, 1], [1, 0], [0, -1]])


def test_truth_from_sampled_inputs_equals_the_sines(five):
    """The sines sampled every 0.1 ms and interpolated give the same motion to interpolation error."""
    s = five.replace(t_end=0.3)
    mech = Mechanism.from_scenario(s)
    tt = np.arange(0.0, 0.31, 1e-4)
    a = simulate(s, inputs=(tt, mech.inputs(tt)))
    b = simulate(s)
    np.testing.assert_allclose(a.q, b.q, rtol=0, atol=1e-6 * np.abs(b.q).max())
    np.testing.assert_allclose(a.u, b.u, rtol=0, atol=1e-6)


def test_noise_uses_each_sensors_std(five):
    s = five.replace(t_end=2.0, noise_std=1e-6, noise_std_v=1e-3)
    tr = simulate(s)
    e = tr.y - Mechanism.from_scenario(s).measure(tr.q, tr.v)
    np.testing.assert_allclose(np.std(e, axis=0), [1e-6, 1e-3, 1e-6], rtol=0.1)
