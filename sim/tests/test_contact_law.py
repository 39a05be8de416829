"""The whole contact law estimated (docs/contact-law.md): n, lambda and gap as states after the gammas,
ln gamma (the setting `gamma_log`), bounds over the active set. The numpy reference and the C core are
written independently from the same equations; here they run the same measurements and must agree, and
the numpy reference's F must match central differences of its own step map.

The measurements come from the scenario's truth (caekf-truth's generator through the binding), never from
a stored run."""
from __future__ import annotations

import numpy as np
import pytest

from caekf_sim import binding
from caekf_sim import flags as fl
from caekf_sim.campaign.runner import truth_arrays
from caekf_sim.estimator import AugmentedEKF, run_estimator
from caekf_sim.experiments import scenario_config
from caekf_sim.mechanism import law_layout
from caekf_sim.scenario import default_scenario_path, load_scenario

LAW = dict(contact1_estimate_n=1, contact1_n0=1.4, contact1_sigma_n0=0.05, contact1_n_max=3.0,
           contact1_estimate_lambda=1, contact1_lambda0=100.0, contact1_sigma_lambda0=100.0,
           contact1_estimate_gap=1, contact1_gap0=1.0001e-3, contact1_sigma_gap0=2e-7)


@pytest.fixture(scope="module")
def damped():
    """The paper's mechanism with a damped contact, 14 s (the first contact closes near 12.8 s), noisy."""
    sc = load_scenario(default_scenario_path()).replace(contact1_lambda=200.0, t_end=14.0, noise_std=2e-8)
    return sc, truth_arrays(sc)


def test_layout_follows_the_estimate_flags():
    sc = load_scenario(default_scenario_path())
    assert law_layout(sc, 1) == ()
    assert law_layout(sc.replace(**LAW), 1) == ((0, "n"), (0, "lambda"), (0, "gap"))
    ekf = AugmentedEKF(sc.replace(contact1_estimate_gap=1, contact1_gap0=1e-3, contact1_sigma_gap0=1e-7),
                       scenario_config(sc))
    assert ekf.n == 10 and ekf.law_state == [{"gap": 9}]


@pytest.mark.parametrize("gamma_log", [0, 1])
def test_c_core_equals_numpy_reference_with_the_whole_law(damped, gamma_log):
    sc, tr = damped
    est = sc.replace(gamma_log=gamma_log, constraint_enabled=1, **LAW)
    c = binding.run(est, tr.u, tr.y, t=tr.t)
    ref = run_estimator(est, scenario_config(est), tr.t, tr.u, tr.y, keep_P=True)
    assert c.n == ref.x.shape[1] == 12
    assert np.any(c.flags & fl.CONTACT_ACTIVE), "the run must reach the contact"
    for k in range(8, 12):  # gamma, n, lambda, gap
        scale = np.max(np.abs(ref.x[:, k]))
        assert np.max(np.abs(c.x[:, k] - ref.x[:, k])) <= 1e-8 * scale, k
        assert np.max(np.abs(c.P_diag[:, k] - ref.P[:, k, k])) <= 1e-8 * np.max(ref.P[:, k, k]), k
    # the same flags (the innovation gate is the C core's alone) and the law really moved in contact
    same = fl.CORE_MASK & ~fl.GAMMA_GATED
    assert np.array_equal(c.flags.astype(np.int64) & same, ref.flags.astype(np.int64) & same)
    assert c.x[-1, 9] != 1.4 and c.x[-1, 10] != 100.0 and c.x[-1, 11] != 1.0001e-3


def test_numpy_transition_matches_finite_differences_in_the_law_columns():
    """F's law columns: d x_k / d theta of the step map, by central differences of the Newton solve."""
    sc = load_scenario(default_scenario_path()).replace(contact1_lambda=200.0, gamma_log=1, **LAW)
    ekf = AugmentedEKF(sc, scenario_config(sc))
    nq, nx = ekf.nq, ekf.nx
    x = np.zeros(ekf.n)
    x[:nq] = [1.2e-3, 1.0001e-3 + 1.5e-5 + 2e-6, 1.5e-5, -4e-6]
    x[nq:nx] = [3e-3, -2e-3, 1e-3, -5e-4]
    x[nx:] = [np.log(1.1e8), 1.4, 200.0, 1.0001e-3]
    ekf.x = x.copy()
    ekf.u_prev = 0.2
    xp, F, _, ok = ekf.predict(0.3)
    assert ok
    steps = {9: 1e-6, 10: 1e-3, 11: 1e-11, 8: 1e-6}
    for j, h in steps.items():
        cols = []
        for sgn in (1.0, -1.0):
            ekf.x = x.copy()
            ekf.x[j] += sgn * h
            cols.append(ekf.predict(0.3)[0])
        fd = (cols[0] - cols[1]) / (2 * h)
        assert np.allclose(F[:nx, j], fd[:nx], rtol=1e-4, atol=1e-6 * np.max(np.abs(fd[:nx]))), j
        assert np.any(F[nq:nx, j] != 0.0), j


def test_log_gamma_without_law_states_equals_numpy(damped):
    sc, tr = damped
    est = sc.replace(gamma_log=1)
    c = binding.run(est, tr.u, tr.y, t=tr.t)
    ref = run_estimator(est, scenario_config(est), tr.t, tr.u, tr.y, keep_P=False)
    assert np.max(np.abs(c.gamma - ref.gamma)) <= 1e-8 * np.max(ref.gamma)
    assert np.all(c.gamma > 0)


def test_replay_writes_the_law_columns(damped, tmp_path):
    """caekf-replay names the estimated law parameters after the gammas, and its values are the binding's."""
    import os
    import subprocess

    from caekf_sim.campaign.spec import scenario_text
    from caekf_sim.truth import Truth, read_truth_csv, write_truth_csv
    from test_c_tools import find_tool

    tool = find_tool("caekf-replay")
    if tool is None:
        if os.environ.get("CAEKF_BUILD_DIR"):
            pytest.fail("caekf-replay not found under $CAEKF_BUILD_DIR/host")
        pytest.skip("caekf-replay not built")
    sc, tr = damped
    est = sc.replace(contact1_estimate_n=1, contact1_n0=1.4, contact1_sigma_n0=0.05,
                     contact1_estimate_gap=1, contact1_gap0=1.0001e-3, contact1_sigma_gap0=2e-7)
    scen, meas, out = tmp_path / "s.toml", tmp_path / "in.csv", tmp_path / "out.csv"
    scen.write_text(scenario_text(est), encoding="utf-8")
    write_truth_csv(Truth(t=tr.t, u=tr.u, y=tr.y, q=tr.q, v=tr.v, delta=tr.delta), meas)
    subprocess.run([str(tool), "--scenario", str(scen), "--in", str(meas), "--out", str(out)], check=True,
                   timeout=120)
    header = out.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[9:12] == ["gamma", "n", "gap"] and header[12] == "p_norm"
    rows = np.loadtxt(out, delimiter=",", skiprows=1)
    back = read_truth_csv(meas)  # the measurements as the replay read them
    c = binding.run(est, back.u, back.y, t=back.t)
    assert rows.shape[1] == len(header)
    assert np.array_equal(rows[:, 10], c.x[:, 9]) and np.array_equal(rows[:, 11], c.x[:, 10])
    assert rows[-1, 10] != 1.4 and rows[-1, 11] != 1.0001e-3  # both moved in contact


def test_numpy_result_csv_names_the_law_columns(damped, tmp_path):
    from caekf_sim.results import read_result_csv, write_result_csv

    sc, tr = damped
    est = sc.replace(**LAW)
    k = 200
    ref = run_estimator(est, scenario_config(est), tr.t[:k], tr.u[:k], tr.y[:k], keep_P=False)
    out = tmp_path / "est.csv"
    write_result_csv(ref, out)
    header = out.read_text(encoding="utf-8").splitlines()[0].split(",")
    assert header[9:13] == ["gamma", "n", "lambda", "gap"] and len(header) == 2 + 12 + 3
    back = read_result_csv(out)
    assert np.array_equal(back.gamma, ref.gamma) and back.x.shape == (k, 9)


def test_binding_names_the_law_states(damped):
    sc, tr = damped
    est = sc.replace(**LAW)
    r = binding.run(est, tr.u[:100], tr.y[:100], t=tr.t[:100])
    assert r.gammas.shape == (100, 1) and set(r.law) == {"n", "lambda", "gap"}
    assert np.array_equal(r.law["gap"], r.x[:, 11])
    e = binding.Estimator(est)
    assert e.gammas.shape == (1,) and e.law == {"n": 1.4, "lambda": 100.0, "gap": 1.0001e-3}
