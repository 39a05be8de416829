"""Estimator claims of the paper (Sec. 3.2, 3.3, 4) on the full scenario, plus form checks."""
import numpy as np
import pytest

from caekf_sim import flags as fl
from caekf_sim.estimator import IG, AugmentedEKF, EstimatorConfig
from caekf_sim.experiments import run_experiment
from caekf_sim.results import read_result_csv, write_result_csv
from caekf_sim.truth import contact_episodes


def final_error(res, sc):
    return res.gamma[-1] / sc.gamma - 1.0


def inactive_steps(res):
    return (res.flags & fl.CONTACT_ACTIVE) == 0


def corr_max(P):
    d = np.sqrt(np.abs(np.einsum("kii->ki", P)))
    with np.errstate(invalid="ignore", divide="ignore"):
        c = np.abs(P / (d[:, :, None] * d[:, None, :]))
    return np.nanmax(c)


def test_canonical_covariance_grows_while_unobservable(sc, truth, results):
    """Fig. 3: out of contact gamma is unobservable, so Table 1 piles Q_gamma onto P_gg."""
    can, sw = results["canonical"], results["switched"]
    off = inactive_steps(can).astype(np.int8)
    edges = np.diff(off, prepend=0, append=0)
    runs = [(a, b) for a, b in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1))
            if b - a > 1.0 / sc.dt]  # non-contact phases longer than 1 s
    assert len(runs) >= 3
    for a, b in runs:  # P_gg gains about Q_gamma per step, whatever the x-correlations remove
        assert can.p_gg[b - 1] - can.p_gg[a] > 0.5 * (b - 1 - a) * sc.sigma_q_gamma**2
    assert np.nanmax(can.p_norm) > 10 * np.nanmax(sw.p_norm)
    # The switched filter's norm settles: its last non-contact plateau is not above the previous one.
    eps = contact_episodes(truth.t, truth.delta, merge_gap=0.1)
    plateaus = [sw.p_norm[np.searchsorted(sw.t, b + 1.0)] for _, b in eps[:-1]] + [sw.p_norm[-1]]
    assert plateaus[-1] <= plateaus[0] * (1 + 1e-9)


def test_switched_converges_and_canonical_does_not(sc, results):
    """Fig. 4: the AEKF for contact estimates gamma; the canonical AEKF wanders off."""
    assert abs(final_error(results["switched"], sc)) < 0.01
    assert abs(final_error(results["canonical"], sc)) > 0.10


def test_switch_off_freezes_gamma_and_p_gg(results):
    """Eqs. 21-27: while contact is inactive neither gamma nor P_gg may change."""
    for name in ("switched", "switched-highq", "switched-highq-constrained"):
        r = results[name]
        np.testing.assert_array_equal((r.flags & fl.GAMMA_FROZEN) != 0, inactive_steps(r))
        off = inactive_steps(r)[1:]
        assert off.sum() > 0.5 * len(off)
        np.testing.assert_array_equal(np.diff(r.gamma)[off], 0.0)
        np.testing.assert_array_equal(np.diff(r.p_gg)[off], 0.0)


def test_consistent_switch_off_keeps_p_a_covariance(results):
    """The Schmidt switch-off keeps |correlation| <= 1 throughout (a valid covariance)."""
    for name in ("switched", "switched-highq-constrained"):
        assert corr_max(results[name].P) <= 1 + 1e-9


def test_literal_paper_switch_off_breaks_the_covariance(sc, truth, results):
    """Eqs. 23-27 read literally freeze P_xg while P_xx shrinks: |corr| > 1 appears, yet gamma agrees."""
    lit = run_experiment(sc, truth, "switched", switch_variant="paper")
    assert corr_max(lit.P) > 2.0
    assert lit.gamma[-1] == pytest.approx(results["switched"].gamma[-1], rel=1e-3)


def test_switched_improves_q2_at_a_contact_entered_with_drifted_gamma(truth, results):
    """Fig. 5: the canonical filter enters the second contact with a wrong gamma."""
    eps = contact_episodes(truth.t, truth.delta, merge_gap=0.1)
    a, b = eps[1]
    s = (truth.t >= a) & (truth.t <= b)
    rms = {n: np.sqrt(np.mean((results[n].x[s, 1] - truth.q[s, 1]) ** 2)) for n in ("canonical", "switched")}
    assert rms["switched"] < rms["canonical"]


def test_high_q_unconstrained_goes_negative(sc, truth, results):
    """Fig. 6: with Q_gamma x 1000 the unconstrained estimate becomes physically inconsistent."""
    un = results["switched-highq"]
    assert np.nanmin(un.gamma) < 0
    rms_un = np.sqrt(np.nanmean((un.x[:, 1] - truth.q[:, 1]) ** 2))
    rms_sw = np.sqrt(np.mean((results["switched"].x[:, 1] - truth.q[:, 1]) ** 2))
    assert rms_un > 10 * rms_sw  # the state estimate is compromised too


def test_constraint_always_satisfied_and_converges(sc, results):
    """Sec. 3.3 / Fig. 6: the perfect-measurement constraint keeps gamma >= gamma_min."""
    co = results["switched-highq-constrained"]
    assert np.all(np.isfinite(co.gamma))
    assert np.min(co.gamma) >= sc.gamma_min * (1 - 1e-9)
    hit = (co.flags & fl.CONSTRAINT_APPLIED) != 0
    assert hit.any()  # it was needed (the unconstrained run goes negative)
    np.testing.assert_allclose(co.gamma[hit], sc.gamma_min, rtol=1e-9)  # active constraint: on the bound
    assert abs(final_error(co, sc)) < 0.05
    assert not np.any(co.flags & fl.NEWTON_NOT_CONVERGED)


def test_newton_iteration_statistics(results):
    for name in ("canonical", "switched", "switched-highq-constrained"):
        it = results[name].newton_iters
        assert 1.0 <= it.mean() < 1.5
        assert it.max() <= 6
        assert not np.any(results[name].flags & (fl.NEWTON_NOT_CONVERGED | fl.NON_FINITE))


def test_joseph_form_agrees_with_standard_form(sc, truth):
    s = sc.replace(t_end=20.0)  # through the first contact episode
    n = s.n_steps
    for name in ("switched", "switched-highq-constrained"):
        std = run_experiment(s, truth_slice(truth, n), name)
        jos = run_experiment(s, truth_slice(truth, n), name, joseph=True)
        np.testing.assert_allclose(jos.gamma, std.gamma, rtol=1e-6)
        np.testing.assert_allclose(jos.x[:, :8], std.x[:, :8], rtol=0, atol=1e-9)
        # Right after a perfect-measurement correction P is ~0 up to round-off of P_gg (~1e14).
        np.testing.assert_allclose(jos.p_norm, std.p_norm, rtol=1e-5, atol=1e-12 * std.p_norm.max())


def truth_slice(truth, n):
    from caekf_sim.truth import Truth

    return Truth(truth.t[:n], truth.u[:n], truth.y[:n], truth.q[:n], truth.v[:n], truth.delta[:n])


def test_constrained_correction_lands_on_the_bound(sc):
    """Eqs. 28-30 alone: a correction that would undershoot is redone onto gamma_min."""
    ekf = AugmentedEKF(sc, EstimatorConfig(constrained=True))
    xp = np.r_[np.zeros(8), 2 * sc.gamma_min]
    P = ekf.P.copy()
    P[0, IG] = P[IG, 0] = 0.9 * np.sqrt(P[0, 0] * P[IG, IG])  # y1 informs gamma strongly
    y = np.array([-5 * np.sqrt(P[0, 0]), 0.0])  # pulls gamma far below the bound
    full = slice(0, ekf.n)
    x_free, _, _ = ekf._correct(xp, P, y, full, [], False)
    assert x_free[IG] < sc.gamma_min
    x_c, P_c, used_pinv = ekf._correct(xp, P, y, full, [], False, [(IG, sc.gamma_min)])
    assert not used_pinv
    assert x_c[IG] == pytest.approx(sc.gamma_min, rel=1e-12)
    assert P_c[IG, IG] == pytest.approx(0.0, abs=1e-9 * P[IG, IG])  # perfectly known after it
    # Singular case: P_gg = 0 makes S^c singular; the pinv fallback must still return finite values.
    P0 = ekf.P.copy()
    P0[IG, IG] = 0.0
    x_s, P_s, used = ekf._correct(xp, P0, y, full, [], False, [(IG, sc.gamma_min)])
    assert used and np.all(np.isfinite(x_s)) and np.all(np.isfinite(P_s))


def test_canonical_never_freezes_gamma(results):
    assert not np.any(results["canonical"].flags & fl.GAMMA_FROZEN)


def test_result_csv_round_trip(tmp_path, results):
    r = results["switched"]
    p = tmp_path / "switched.csv"
    write_result_csv(r, p)
    assert p.read_text().splitlines()[0] == (
        "t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters")
    back = read_result_csv(p)
    np.testing.assert_array_equal(back.x, r.x)
    np.testing.assert_array_equal(back.p_norm, r.p_norm)
    np.testing.assert_array_equal(back.flags, r.flags)
    np.testing.assert_array_equal(back.newton_iters, r.newton_iters)
