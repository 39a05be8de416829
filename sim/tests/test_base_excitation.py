"""Base excitation (issue 27 point 3; docs/mechanism.md "Base excitation"): an input that is the displacement [m] of a
link's ground end (a shaker table, a piezo stage), k (u - q_b) + c (du/dt - v_b) on the link's body.

The run: sim/scenarios/shaker.toml, the paper's chain whose link 1 (body 1 - ground) a table shakes at 0.1 mm and
5 Hz (5 kHz samples), body 2 striking body 3 on most cycles. Checked: the two truths (C and scipy; the sines'
derivative and a recorded series' central differences), the numpy step (a body riding the table stays on it),
the C filter against the numpy twin (trapezoidal with substeps, and backward Euler; the driven link's stiffness
and damper and body 1's mass estimated; an accelerometer and a load cell that read the table), gamma on the
shaker run, the refusals, and `caekf-sim estimate` against `caekf-replay`.
"""
from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from caekf_sim import binding
from caekf_sim import flags as fl
from caekf_sim.estimator import AugmentedEKF
from caekf_sim.experiments import scenario_config
from caekf_sim.mechanism import ACCELERATION, BASE_DISPLACEMENT, LINK_FORCE, InputSeries, Mechanism, MechanismError
from caekf_sim.model import BACKWARD_EULER, TRAPEZOIDAL, StepSolver
from caekf_sim.scenario import Scenario, load_scenario
from caekf_sim.truth import read_truth_csv, simulate

SHAKER = Path(__file__).resolve().parents[2] / "sim" / "scenarios" / "shaker.toml"
# the rig's sensors besides the two positions: body 1's acceleration and the load cell in the driven link
RIG = dict(sensors=4, sensor3_kind=ACCELERATION, sensor3_body=1, sensor3_sigma=1e-3, sensor3_noise=1e-3,
           sensor4_kind=LINK_FORCE, sensor4_link=1, sensor4_body=1, sensor4_sigma=1e-4, sensor4_noise=1e-4)
UNCERTAIN = dict(m1_sigma=0.03, spring1_k_sigma=0.03, spring1_c_sigma=0.03)


@pytest.fixture(scope="module")
def shaker() -> Scenario:
    return load_scenario(SHAKER)


def test_the_scenario_is_a_shaker(shaker):
    mech = Mechanism.from_scenario(shaker)
    assert mech.input_kind.tolist() == [BASE_DISPLACEMENT] and mech.input_link.tolist() == [0]
    assert mech.input_body.tolist() == [0]  # link 1's body end
    assert mech.B_u[0, 0] == shaker.spring1_k and mech.B_du[0, 0] == shaker.spring1_c
    assert 1e-4 <= shaker.input1_amp <= 1e-3 and 5.0 <= shaker.input1_freq <= 20.0


def test_c_truth_equals_the_scipy_truth(shaker):
    """host/common/truth.c and the scipy truth drive the chain alike: q, v and every sensor (the accelerometer's
    k (u - q_1) + c (du/dt - v_1), the load cell's k (q_1 - u) + c (v_1 - du/dt)) over 1 s of impacts."""
    sc = shaker.replace(t_end=1.0, noise_std=0.0, **{**RIG, "sensor3_noise": 0.0, "sensor4_noise": 0.0})
    # the C truth's tolerance: impacts amplify the integrators' differences (rtol 1e-11: 6e-9 at 1 s, 2e-5 at 3 s)
    c, py = binding.truth(sc), simulate(sc, rtol=1e-13)
    assert np.count_nonzero(np.diff((py.delta > 0).astype(int)) == 1) >= 5  # impacts
    assert c.columns() == py.columns() and c.y_names == ("y1", "y4", "ya1", "yf1")
    for name, a, b in (("q", c.q, py.q), ("v", c.v, py.v), ("y", c.y, py.y)):
        scale = np.max(np.abs(b), axis=0)
        assert np.max(np.abs(a - b) / scale) < 1e-8, name
    np.testing.assert_allclose(c.u, shaker.input1_amp * np.sin(2 * np.pi * shaker.input1_freq * c.t), atol=1e-18)


def test_a_recorded_table_drives_both_truths_alike(shaker, tmp_path):
    """A recorded table displacement (caekf-truth --inputs, simulate(inputs=...)): linear between samples, du/dt
    from the samples' central differences, in both truths."""
    from test_binding import tool

    t = np.arange(0.0, 1.0005, 1e-3)
    u = 1e-4 * np.sin(2 * np.pi * 5.0 * t) * (1.0 + 0.3 * np.sin(2 * np.pi * 0.7 * t))
    rec, scenario = tmp_path / "table.csv", tmp_path / "shaker.toml"
    np.savetxt(rec, np.column_stack([t, u]), delimiter=",", header="t,u", comments="", fmt="%.17g")
    scenario.write_text(SHAKER.read_text().replace("t_end = 10.0", "t_end = 1.0").replace("noise_std = 1.0e-8",
                                                                                          "noise_std = 0.0"))
    sc = load_scenario(scenario)
    out = tmp_path / "truth.csv"
    subprocess.run([str(tool("caekf-truth", "double")), "--scenario", str(scenario), "--inputs", str(rec), "--out",
                    str(out)], check=True, capture_output=True, timeout=120)
    c = read_truth_csv(out)
    py = simulate(sc, inputs=(t, u.reshape(-1, 1)), rtol=1e-13)
    assert np.any(py.delta > 0)
    scale = np.max(np.abs(py.q), axis=0)
    assert np.max(np.abs(c.q - py.q) / scale) < 1e-6  # the integrators step across the samples' kinks (7e-8)
    # the series' rate reached the chain: its rate taken as the exact derivative of the sampled sine changes it
    exact = np.column_stack([u, 1e-4 * 2 * np.pi * (5.0 * np.cos(2 * np.pi * 5.0 * t) * (1.0 + 0.3 * np.sin(
        2 * np.pi * 0.7 * t)) + 0.3 * 0.7 * np.sin(2 * np.pi * 5.0 * t) * np.cos(2 * np.pi * 0.7 * t))])
    assert np.max(np.abs(InputSeries(t, u).rate(t[1:-1])[:, 0] - exact[1:-1, 1])) < 1e-3 * np.max(np.abs(exact[:, 1]))


@pytest.mark.parametrize("scheme", [BACKWARD_EULER, TRAPEZOIDAL])
def test_a_body_riding_the_table_stays_on_it(scheme):
    """The numpy step (model.StepSolver): a body on a spring-damper to the table at q = u, v = the table's speed,
    stays there exactly by either rule (as the C suite tests/unit/test_base_excitation.c checks the C step)."""
    mech = Mechanism.from_scenario(dict(bodies=1, m1=0.5, springs=1, spring1_a=0, spring1_b=1, spring1_k=1e3,
                                        spring1_c=2.0, inputs=1, input1_kind=BASE_DISPLACEMENT, input1_link=1,
                                        input1_amp=0.0, input1_freq=0.0, input1_phase=0.0, sensors=1, contacts=0))
    w, t0, dt = 1e-2, 0.37, 1e-3
    q, v, _, ok = StepSolver(mech, dt, scheme=scheme).solve(np.array([w * t0]), np.array([w]), w * (t0 + dt), [],
                                                            w * t0)
    assert ok
    assert abs(v[0] - w) < 1e-12 * w and abs(q[0] - w * (t0 + dt)) < 1e-12 * w * t0


@pytest.fixture(scope="module")
def record(shaker):
    return binding.truth(shaker.replace(t_end=1.5, **RIG))


@pytest.mark.parametrize("discretisation, substeps", [(TRAPEZOIDAL, 3), (BACKWARD_EULER, 1)])
def test_c_filter_equals_the_numpy_twin(shaker, record, discretisation, substeps):
    """Two implementations of the base input's step, its F columns for the driven link's stiffness and damper
    and body 1's mass, its process noise (input1_sigma) and the sensors that read the table: the same estimate to
    rounding over 1.5 s of impacts, flags identical."""
    sc = shaker.replace(t_end=1.5, **RIG, **UNCERTAIN, input1_sigma=1e-8,
                        discretisation=["backward_euler", "trapezoidal"].index(discretisation),
                        contact_substeps=substeps)
    c = binding.run(sc, record.u, record.y)
    ekf = AugmentedEKF(sc, scenario_config(sc))
    x = np.empty_like(c.x)
    flags = np.empty(len(record.y), dtype=np.int64)
    for k in range(len(record.y)):
        flags[k] = ekf.step(float(record.u[k]), record.y[k])[0]
        x[k] = ekf.physical()[0]
    assert np.count_nonzero(flags & fl.CONTACT_ACTIVE) > 50
    np.testing.assert_array_equal(flags, np.asarray(c.flags, dtype=np.int64))
    scale = np.maximum(np.max(np.abs(x), axis=0), 1e-300)
    # backward Euler: one impact step's velocities differ by 1e-6 (the Newton stopping test; gone a step later)
    assert np.max(np.abs(c.x - x) / scale) < (1e-8 if discretisation == TRAPEZOIDAL else 1e-5)


def test_the_filter_estimates_gamma_on_the_shaker(shaker):
    """The shaker run (10 s, 120 impacts), the recommended estimator: gamma within 2 % of the truth from 25 %
    below it, never flagged as a model mismatch."""
    tr = binding.truth(shaker)
    r = binding.run(shaker, tr.u, tr.y)
    err = r.gamma[-1] / shaker.gamma - 1.0
    assert abs(err) < 0.02, err
    assert not np.any(np.asarray(r.flags) & fl.MODEL_MISMATCH)


@pytest.mark.parametrize("change, key, setting", [
    ({"input1_link": 2}, "input1_link", r"input_link\[0\]"),   # bodies 1 and 2: no ground end
    ({"input1_link": 9}, "input1_link", r"input_link\[0\]"),   # no such link
])
def test_a_link_without_a_ground_end_is_refused_naming_the_key(shaker, change, key, setting):
    """The numpy side names the scenario key, the C core's validation the setting and its element."""
    with pytest.raises(MechanismError, match=key):
        Mechanism.from_scenario(shaker.replace(**change))
    with pytest.raises(ValueError, match=setting):
        binding.Estimator(shaker.replace(**change))


def test_estimate_runs_the_shaker_as_caekf_replay_does(tmp_path):
    """`caekf-sim estimate` (the C estimator through the binding) and `caekf-replay` over a shaker recording: the
    same numbers, column by column."""
    from test_binding import read_csv, tool

    from caekf_sim.cli import main

    t = tmp_path / "truth.csv"
    assert main(["truth", "--scenario", str(SHAKER), "--t-end", "1", "--out", str(t)]) == 0
    est, ref = tmp_path / "est.csv", tmp_path / "replay.csv"
    assert main(["estimate", "--scenario", str(SHAKER), "--measurements", str(t), "--out", str(est)]) == 0
    subprocess.run([str(tool("caekf-replay", "double")), "--scenario", str(SHAKER), "--in", str(t), "--out",
                    str(ref)], check=True, capture_output=True, timeout=120)
    mine, theirs = read_csv(est), read_csv(ref)
    for column, values in mine.items():
        np.testing.assert_array_equal(values, theirs[column], err_msg=column)
    assert np.count_nonzero(mine["flags"].astype(int) & fl.CONTACT_ACTIVE) > 50
