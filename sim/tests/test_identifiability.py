"""Which law parameters a run observes, and its Cramer-Rao bounds (caekf_sim.identifiability)."""
import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

import caekf_sim
from caekf_sim.cli import main
from caekf_sim.identifiability import (PARAMS, analyse_run, bounds, format_table, law_params, mechanism_params,
                                      sensitivities)
from caekf_sim.mechanism import Mechanism
from caekf_sim.scenario import load_scenario, scenario_from_text
from caekf_sim.truth import continuous_states

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
VALVE = SCENARIOS / "valve.toml"


def _subset(sens, names):
    """The sensitivities of the initial state and the named law parameters only (one integration, many tests)."""
    idx = [i for i, p in enumerate(sens.params) if p.contact == 0 or p.name in names]
    return replace(sens, dy=sens.dy[:, :, idx], params=tuple(sens.params[i] for i in idx))


@pytest.fixture(scope="module")
def pressed():
    """The valve's poppet pressed onto its linear seat by a constant force: a transient, then steady state."""
    sc = load_scenario(VALVE).replace(input1_freq=0.0, input1_phase=math.pi / 2, t_end=12.0)
    return sc, sensitivities(sc, law_params(sc, PARAMS, [1]))


def test_sensitivities_are_the_truths_central_differences():
    sc = load_scenario(VALVE).replace(t_end=2.0, contact1_n=1.25)  # n > 1: room for a central difference
    ps = law_params(sc, PARAMS, [1])
    sens = sensitivities(sc, ps, initial_state=False)
    assert sens.events >= 2  # the seat closes and opens inside the window
    mech = Mechanism.from_scenario(sc)
    for j, p in enumerate(ps):
        h = 1e-3 * p.scale
        ys = []
        for sign in (1.0, -1.0):
            q, v, _ = continuous_states(sc.replace(**{p.key: p.value + sign * h}), mech=None)
            ys.append(mech.measure(q, v))
        fd = (ys[0] - ys[1]) / (2 * h) * p.scale
        dy = sens.dy[:, :, j]
        assert np.max(np.abs(fd - dy)) < 2e-3 * np.max(np.abs(dy)), p.key


def test_initial_state_sensitivities_are_the_free_chains_transition_matrix(sc):
    from scipy.linalg import expm

    quiet = sc.replace(u_amp=0.2, t_end=0.3)  # the contact stays open: x' = A0 x + B u
    sens = sensitivities(quiet, law_params(quiet, ["gamma"], [1]))
    mech = Mechanism.from_scenario(quiet)
    nq = mech.nq
    A0 = np.block([[np.zeros((nq, nq)), np.eye(nq)], [-mech.K / mech.m[:, None], -mech.C / mech.m[:, None]]])
    scales = np.array([p.scale for p in sens.params[:2 * nq]])
    for k in (0, 99, len(sens.t) - 1):
        want = mech.H @ expm(A0 * sens.t[k]) * scales[None, :]
        np.testing.assert_allclose(sens.dy[k, :, :2 * nq], want, rtol=0, atol=1e-7 * np.max(np.abs(want)))
    assert np.all(sens.dy[:, :, -1] == 0.0)  # gamma: nothing while open


def test_bounds_of_known_information():
    crb, ok = bounds(np.diag([4.0, 0.0]))
    np.testing.assert_allclose(crb, [0.5, np.inf])
    assert ok.tolist() == [True, False]
    s = np.array([[1.0, 2.0, 0.0], [2.0, 4.0, 0.0], [0.0, 0.0, 1.0]])  # columns 1, 2 collinear
    crb, ok = bounds(s.T @ s)
    assert ok.tolist() == [False, False, True]
    J = np.array([[2.0, 1.0], [1.0, 3.0]])
    np.testing.assert_allclose(bounds(J)[0], np.sqrt(np.diag(np.linalg.inv(J))))


def test_paper_gamma_alone_is_observable_and_its_bound_is_the_filters_covariance(sc, truth):
    an = analyse_run(sc, law_params(sc, ["gamma"], [1]))
    assert an.observable.tolist() == [True]
    t_contact = truth.t[truth.delta > 0][0]
    assert np.all(np.isinf(an.crb[an.t < t_contact]))  # nothing to learn before the contact closes
    assert an.rel()[-1, 0] < 0.01 and t_contact < an.time_below()[0] < sc.t_end
    crb = an.crb_post[-1, 0]
    # The switched filter without gamma's random walk is an estimate of the same information: its final
    # sqrt(P_gamma,gamma) is the posterior bound (measured ratio 1.05).
    r0 = caekf_sim.run(sc, truth.u, truth.y, experiment="switched", sigma_q_gamma=0.0)
    ratio0 = math.sqrt(r0.P_diag[-1, r0.gamma_index]) / crb
    assert 0.8 < ratio0 < 1.3, ratio0
    # With the preset's random walk (Q_gamma = 1e12 per contact step) P stays far above it (measured: 90x).
    r = caekf_sim.run(sc, truth.u, truth.y, experiment="switched")
    assert math.sqrt(r.P_diag[-1, r.gamma_index]) > 10 * crb


def test_a_contact_that_never_closes_observes_none_of_its_parameters(sc):
    quiet = sc.replace(u_amp=0.2, t_end=5.0)  # the gap is never closed
    an = analyse_run(quiet, law_params(quiet, PARAMS, [1]))
    assert np.max(an.sens.delta) < 0
    assert not an.observable.any()
    assert an.insensitive() == [p.label for p in an.params]
    assert np.all(np.isinf(an.crb))
    assert an.crb_post[-1, 0] == pytest.approx(quiet.sigma_gamma0)  # the prior alone
    assert "NO" in format_table(an)


BLIND = """
bodies = 2
m1 = 1.0
m2 = 1.0
springs = 2
spring1_a = 1
spring1_b = 0
spring1_k = 4.0e3
spring1_c = 10.0
spring2_a = 2
spring2_b = 0
spring2_k = 4.0e3
spring2_c = 10.0
input1_body = 2
input1_amp = 6.0
input1_freq = 0.5
input1_phase = 0.0
sensors = 1
sensor1_body = {body}
contact1_a = 2
contact1_b = 0
contact1_gap = 1.0e-3
contact1_n = 1.0
contact1_lambda = 300.0
contact1_gamma = 2.0e5
dt = 1.0e-3
t_end = 2.0
noise_std = 2.0e-8
truth_substeps = 10
seed = 3
contact1_gamma0 = 1.5e5
contact1_sigma_gamma0 = 5.0e4
contact1_sigma_q_gamma = 2.0e3
sigma_q0 = 1.0e-6
sigma_v0 = 1.0e-5
sigma_qx_q = 1.0e-9
sigma_qx_v = 1.0e-7
sigma_r = 1.0e-7
"""


def test_a_sensor_that_cannot_see_the_contact_observes_nothing_of_it():
    """Body 1 is not linked to body 2, which hits the stop: a sensor on 1 learns nothing of the contact."""
    for body, seen in ((1, False), (2, True)):
        sc = scenario_from_text(BLIND.format(body=body), f"blind{body}")
        an = analyse_run(sc, law_params(sc, ["gamma", "gap"], [1]))
        assert an.sens.events >= 2
        assert an.observable.tolist() == [seen, seen], body


def test_steady_state_cannot_separate_gamma_and_gap_nor_see_lambda(pressed):
    sc, sens = pressed
    late = 10.0  # the transient has decayed by e^-25
    both = analyse_run(sc, law_params(sc, ["gamma", "gap"], [1]), t_from=late, sens=_subset(sens, ["gamma", "gap"]))
    assert not both.observable.any()
    (direction,) = both.null_directions()
    # k x + gamma (x - gap) = F is one equation: d gamma / gamma = d gap / (x - gap) is invisible
    ratio = direction["contact1_gap"] / direction["contact1_gamma"]
    assert ratio == pytest.approx(sens.delta[-1, 0] / sc.contact1_gap, rel=1e-3)
    lam = analyse_run(sc, law_params(sc, ["lambda"], [1]), t_from=late, sens=_subset(sens, ["lambda"]))
    assert lam.observable.tolist() == [False]  # no penetration rate, no damping force
    alone = analyse_run(sc, law_params(sc, ["gamma"], [1]), t_from=late, sens=_subset(sens, ["gamma"]))
    assert alone.observable.tolist() == [True]  # with the gap known, the steady state gives gamma
    full = analyse_run(sc, law_params(sc, PARAMS, [1]), sens=sens)  # the transient separates all four
    assert full.observable.all()
    for b in (np.where(np.isfinite(x), x, 1e300) for x in (full.crb, full.crb_post)):
        assert np.all(np.diff(b, axis=0) <= 1e-9 * b[1:])  # more data never loosens a bound


def test_cli_table_csv_and_png(tmp_path, capsys):
    csv, png = tmp_path / "crb.csv", tmp_path / "crb.png"
    rc = main(["observability", "--scenario", str(VALVE), "--t-end", "2", "--params", "gamma,gap", "--crb",
               "--prior", "gap=1e-5", "--csv", str(csv), "--png", str(png)])
    out = capsys.readouterr().out
    assert rc == 0
    assert "contact1_gamma" in out and "contact1_gap" in out and "yes" in out
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:3] == ["t", "crb_contact1_gamma", "rel_contact1_gamma"]
    assert png.stat().st_size > 0


@pytest.mark.parametrize("argv, code, text", [
    (["--params", "stiffness"], 3, "choose from gamma, n, lambda, gap"),
    (["--params", "gamma", "--contact", "2"], 3, "contacts 1..1"),
    (["--params", "gamma,gamma"], 3, "chosen twice"),
    (["--crb", "--t-from", "1"], 2, "--t-from"),
    (["--params", "gamma", "--contact", "x"], 2, "--contact"),
    (["--params", "gamma", "--prior", "mu=1"], 2, "--prior"),
    (["--params", "gamma", "--prior", "n=-1"], 2, "> 0"),
    (["--csv", "x.csv"], 2, "go with --params"),
])
def test_cli_errors_are_one_line(argv, code, text, capsys):
    rc = main(["observability", "--scenario", str(VALVE), "--t-end", "0.01", *argv])
    err = capsys.readouterr().err
    assert rc == code and text in err and err.count("\n") == 1


# ---- declared mechanism parameters and a measured force (issue 27 point 1) ------------------------------------


@pytest.fixture(scope="module")
def declared(sc):
    """The paper to just past its first contact (12.8 s), 10 nm sensors, with a mass (m2: the contact's
    body), a stiffness to the ground (spring1_k) and a damper between two bodies (spring2_c) declared
    uncertain by 3 %, and the sensitivities of gamma with those three."""
    d = sc.replace(t_end=14.0, sigma_r=1e-8, m2_sigma=0.03, spring1_k_sigma=0.03, spring2_c_sigma=0.03)
    params = law_params(d, ["gamma"], [1]) + mechanism_params(d)
    return d, sensitivities(d, params)


def test_mechanism_parameters_follow_the_filters_state_order_and_declaration(declared):
    d, _ = declared
    ps = mechanism_params(d)
    assert [(p.key, p.mech, p.element) for p in ps] == [("m2", "m", 1), ("spring1_k", "k", 0),
                                                       ("spring2_c", "c", 1)]
    assert [p.value for p in ps] == [d.m2, d.spring1_k, d.spring2_c] == [p.scale for p in ps]
    assert [p.prior for p in ps] == pytest.approx([0.03 * p.value for p in ps])
    assert mechanism_params(d.replace(m2_sigma=0.0, spring1_k_sigma=0.0, spring2_c_sigma=0.0)) == []


def test_mechanism_sensitivities_are_the_truths_central_differences(declared):
    """dy/d ln(value) of a mass, a grounded stiffness and a damper between two bodies, through a contact
    episode, against central differences of the continuous truth."""
    d, sens = declared
    assert sens.events >= 1
    mech = Mechanism.from_scenario(d)
    cols = {p.key: j for j, p in enumerate(sens.params)}
    for p in mechanism_params(d):
        h = 1e-4 * p.value
        ys = []
        for sign in (1.0, -1.0):
            q, v, _ = continuous_states(d.replace(**{p.key: p.value + sign * h}), mech=None)
            ys.append(mech.measure(q, v))
        fd = (ys[0] - ys[1]) / (2 * h) * p.scale
        dy = sens.dy[:, :, cols[p.key]]
        assert np.max(np.abs(fd - dy)) < 2e-3 * np.max(np.abs(dy)), p.key


def test_declared_parameters_and_force_noise_never_shrink_gammas_bound(declared):
    """Every unknown added (the declared mechanism parameters) and the force's declared noise (process noise
    through the linearised model) can only lose information: gamma's bound with them is never below the bound
    without, at every checkpoint, and here strictly above at the end."""
    d, sens = declared
    g = sens.params.index(law_params(d, ["gamma"], [1])[0])
    n_x0 = 2 * Mechanism.from_scenario(d).nq
    gamma_only = replace(sens, dy=sens.dy[:, :, :n_x0 + 1], params=sens.params[:n_x0 + 1])
    assert g == n_x0
    base = analyse_run(d, law_params(d, ["gamma"], [1]), sens=gamma_only)
    full = analyse_run(d, law_params(d, ["gamma"], [1]) + mechanism_params(d), sens=sens)
    noisy = analyse_run(d.replace(input1_sigma=0.01 * d.u_amp), law_params(d, ["gamma"], [1]), sens=gamma_only)
    both = analyse_run(d.replace(input1_sigma=0.01 * d.u_amp), law_params(d, ["gamma"], [1]) + mechanism_params(d),
                       sens=sens)
    finite = np.isfinite(base.crb[:, 0])
    assert finite[-1] and full.observable.all() and both.observable.all()
    for an in (full, noisy, both):
        assert np.all(an.crb[finite, 0] >= base.crb[finite, 0] * (1 - 1e-9))
        assert an.crb[-1, 0] > base.crb[-1, 0] * (1 + 1e-6)
    assert np.all(both.crb[finite, 0] >= full.crb[finite, 0] * (1 - 1e-9))
    assert np.all(both.crb[finite, 0] >= noisy.crb[finite, 0] * (1 - 1e-9))
    # the posterior bound of a declared parameter is below its declared prior
    assert np.all(full.crb_post[-1, 1:] < full.prior[1:])


def test_force_noise_information_is_the_explicit_output_covariances():
    """The Kalman-filter whitening (information_input_noise) against S^T Sigma^-1 S with Sigma built
    explicitly (R plus the force noise's response through the same F_k, G_k), on a short window."""
    from caekf_sim.identifiability import information_input_noise, noise_dynamics, sensor_sigmas

    sc = load_scenario(SCENARIOS / "paper.toml")
    d = sc.replace(t_end=0.25, dt=1e-3, spring1_k_sigma=0.03, input1_sigma=0.05)
    sens = sensitivities(d, law_params(d, ["gamma"], [1]) + mechanism_params(d))
    sig = sensor_sigmas(d, Mechanism.from_scenario(d))
    _, J = information_input_noise(d, sens, sig, np.array([0.05]))
    F, G = noise_dynamics(d, sens)
    H = Mechanism.from_scenario(d).H
    n, ns, m = sens.dy.shape
    n2 = F.shape[1]
    # the noise model e_0 = G_0 w_0, e_k = F_{k-1} e_{k-1} + G_{k-1} w_k: e_k as a linear map of w_0 .. w_{n-1}
    states = np.zeros((n, n2, n))  # e_k as a linear map of (w_0 .. w_{n-1}), w_0 the first sample's own
    states[0, :, 0] = G[0][:, 0]
    for k in range(1, n):
        states[k] = F[k - 1] @ states[k - 1]
        states[k, :, k] += G[k - 1][:, 0]
    Y = np.einsum("sx,kxj->ksj", H, states).reshape(n * ns, n)
    Sigma = Y @ Y.T * 0.05 ** 2 + np.diag(np.tile(sig ** 2, n))
    S = sens.dy.reshape(n * ns, m)
    want = S.T @ np.linalg.solve(Sigma, S)
    np.testing.assert_allclose(J[-1], want, rtol=1e-6, atol=1e-9 * np.max(np.abs(want)))


def test_cli_prints_each_declared_parameters_bound(tmp_path, capsys):
    """`observability --crb` on a scenario declaring a stiffness, a damper and the force's noise: a row with the
    bound of each declared parameter (its CSV columns too), gamma's bound above the one with --known-mechanism."""
    scen, csv = tmp_path / "declared.toml", tmp_path / "crb.csv"
    scen.write_text(VALVE.read_text() + "spring1_k_sigma = 0.05\nspring1_c_sigma = 0.05\ninput1_sigma = 0.05\n")
    assert main(["observability", "--scenario", str(scen), "--t-end", "2", "--crb", "--csv", str(csv)]) == 0
    out = capsys.readouterr().out
    rows = {ln.split()[0]: ln.split() for ln in out.splitlines() if ln.split()}
    assert {"contact1_gamma", "spring1_k", "spring1_c"} <= set(rows) and "input1_sigma = 0.05 N" in out
    assert rows["spring1_k"][2] == "yes" and float(rows["spring1_k"][3]) > 0
    header = csv.read_text().splitlines()[0].split(",")
    assert {"crb_spring1_k", "rel_spring1_c", "post_spring1_k"} <= set(header)
    assert main(["observability", "--scenario", str(scen), "--t-end", "2", "--crb", "--known-mechanism"]) == 0
    known = {ln.split()[0]: ln.split() for ln in capsys.readouterr().out.splitlines() if ln.split()}
    assert "spring1_k" not in known
    assert float(rows["contact1_gamma"][3]) > float(known["contact1_gamma"][3])
