"""The sensors of real rigs (issue 27 point 3; docs/sensors.md): an accelerometer, a strain gauge across a link
(relative position), a load cell in a link (link force) and a position sensor with an offset, in the numpy twin
(AugmentedEKF.sensor_rows against central differences), the two truths (C and scipy), and the C filter against
the twin; then what the rig estimates on the paper's mechanism.

The rig: the paper's chain (sim/scenarios/paper.toml) with body 2's acceleration, body 3 relative to body 2, the
force in link 2 (bodies 1-2) and body 1's position carrying a 0.5 um offset, the offset declared
(sensor4_bias_sigma) and link 2's stiffness and damper and body 2's mass declared uncertain where a test says so.
"""
from __future__ import annotations

import copy
from dataclasses import replace

import numpy as np
import pytest

from caekf_sim import binding
from caekf_sim.estimator import AugmentedEKF
from caekf_sim.experiments import scenario_config
from caekf_sim.mechanism import ACCELERATION, LINK_FORCE, RELATIVE, Mechanism, MechanismError
from caekf_sim.scenario import Scenario, default_scenario_path, load_scenario

RIG = dict(sensors=4, sensor1_kind=ACCELERATION, sensor1_body=2, sensor1_sigma=1e-5, sensor1_noise=1e-5,
           sensor2_kind=RELATIVE, sensor2_body=3, sensor2_ref=2,
           sensor3_kind=LINK_FORCE, sensor3_link=2, sensor3_body=1, sensor3_sigma=1e-3, sensor3_noise=1e-3,
           sensor4_kind=0, sensor4_body=1, sensor4_bias_sigma=1e-6, sensor4_bias=5e-7)
UNCERTAIN = dict(m2_sigma=0.03, spring2_k_sigma=0.03, spring2_c_sigma=0.03)


@pytest.fixture(scope="module")
def paper() -> Scenario:
    return load_scenario(default_scenario_path()).replace(noise_std=1e-7)


@pytest.fixture(scope="module")
def rig(paper: Scenario) -> Scenario:
    return paper.replace(**RIG)


def test_names_and_noise_free_readings(rig):
    """Each kind reads what docs/sensors.md says, named y<body>, ya<body>, yr<body>_<ref>, yf<link>."""
    mech = Mechanism.from_scenario(rig)
    assert mech.sensor_names() == ("ya2", "yr3_2", "yf2", "y1")
    rng = np.random.default_rng(3)
    q, v, u = rng.normal(size=(5, 4)) * 1e-4, rng.normal(size=(5, 4)) * 1e-3, rng.normal(size=(5, 1))
    a = mech.accelerations(q, v, u, [rig.gamma])
    y = mech.measure(q, v, a)
    np.testing.assert_array_equal(y[:, 0], a[:, 1])
    np.testing.assert_array_equal(y[:, 1], q[:, 2] - q[:, 1])
    k, c = rig.spring2_k, rig.spring2_c
    np.testing.assert_allclose(y[:, 2], k * (q[:, 0] - q[:, 1]) + c * (v[:, 0] - v[:, 1]), rtol=1e-12)
    np.testing.assert_array_equal(y[:, 3], q[:, 0])


@pytest.mark.parametrize("change, key, setting", [
    ({"sensor2_ref": 3}, "sensor2_ref", r"sensor_ref\[1\]"),         # relative to itself
    ({"sensor3_link": 9}, "sensor3_link", r"sensor_link\[2\]"),      # no such link
    ({"sensor1_sigma": 0.0}, "sensor1_sigma", r"sensor_sigma\[0\]"),  # an accelerometer needs its own noise
])
def test_bad_sensors_are_refused_naming_the_key(rig, change, key, setting):
    """The twin names the scenario key, the C core's validation the setting and element."""
    with pytest.raises((MechanismError, ValueError), match=key):
        AugmentedEKF(rig.replace(**change), scenario_config(rig))
    with pytest.raises(ValueError, match=setting):
        binding.Estimator(rig.replace(**change))


def test_twin_rows_match_central_differences(rig):
    """sensor_rows' H against (h(x + d e_j) - h(x - d e_j)) / 2d over every state, in contact, with the
    mechanism's parameters and the offset as states (their moves applied to the model)."""
    sc = rig.replace(**UNCERTAIN)
    ekf = AugmentedEKF(sc, replace(scenario_config(sc), contact_slr_p=0.0))
    x = ekf.x.copy()
    x[:4] = [1.2e-3, 1.5e-5 + sc.gap + 2e-6, 1.5e-5, -4e-6]
    x[4:8] = [3e-3, -2e-3, 1e-3, -5e-4]
    x[ekf.im] = [0.02, -0.03, 0.05]
    x[ekf.ib] = [3e-7]
    u = 0.3

    def h_at(z: np.ndarray) -> np.ndarray:
        e = copy.deepcopy(ekf)
        e._set_mechanism(z)
        return e.sensor_rows(z, u)[0]

    e = copy.deepcopy(ekf)
    e._set_mechanism(x)
    _, H = e.sensor_rows(x, u)
    step = np.r_[np.full(4, 1e-12), np.full(4, 1e-9), 1e-8 if ekf.cfg.gamma_log else 1.0, np.full(3, 1e-7), 1e-13]
    FD = np.empty_like(H)
    for j in range(ekf.n):
        d = np.zeros(ekf.n)
        d[j] = step[j]
        FD[:, j] = (h_at(x + d) - h_at(x - d)) / (2 * step[j])
    scale = np.max(np.abs(H) * step, axis=1, keepdims=True) / step  # each row's size per state's step
    assert np.all(np.abs(H - FD) <= 1e-6 * scale + 1e-7 * np.abs(FD)), np.max(np.abs(H - FD) / scale)
    assert np.all(H[:, ekf.im[0]] != 0) or H[0, ekf.im[0]] != 0  # the mass column of the accelerometer


def test_c_truth_equals_the_numpy_truth_for_every_kind(rig):
    """host/common/truth.c and the scipy truth read the rig the same way (noise-free, offset included)."""
    from caekf_sim.truth import simulate

    sc = rig.replace(t_end=4.0, noise_std=0.0, sensor1_noise=0.0, sensor3_noise=0.0)
    c, py = binding.truth(sc), simulate(sc)
    assert c.columns() == py.columns()
    assert c.y_names == ("ya2", "yr3_2", "yf2", "y1")
    scale = np.max(np.abs(py.y), axis=0)
    assert np.max(np.abs(c.y - py.y) / scale) < 1e-6
    assert np.allclose(c.y[:, 3] - c.q[:, 0], 5e-7, rtol=0, atol=1e-15)  # the offset


@pytest.fixture(scope="module")
def record(rig):
    return binding.truth(rig.replace(t_end=20.0))


def test_c_filter_equals_the_numpy_twin(rig, record):
    """Two implementations of the rows of H, the offset state and the scaled correction: the same estimate to
    rounding over 20 s (the contact closes in it), flags identical."""
    sc = rig.replace(**UNCERTAIN, t_end=20.0)
    cfg = scenario_config(sc)
    c = binding.run(sc, record.u, record.y)
    ekf = AugmentedEKF(sc, cfg)
    x = np.empty_like(c.x)
    flags = np.empty(len(record.y), dtype=np.int64)
    for k in range(len(record.y)):
        flags[k] = ekf.step(float(record.u[k]), record.y[k])[0]
        x[k] = ekf.physical()[0]
    assert np.any(record.delta > 0)
    np.testing.assert_array_equal(flags, np.asarray(c.flags, dtype=np.int64))
    scale = np.maximum(np.max(np.abs(x), axis=0), 1e-300)
    assert np.max(np.abs(c.x - x) / scale) < 1e-6


def test_rig_estimates_gamma_and_the_offset(rig, paper):
    """The whole paper run read by the rig's sensors: gamma within 2 % and the offset within 3 sigma of the
    truth's 0.5 um; the same record without the offset declared ends with it in the innovations: the mismatch
    flag or a wrong gamma (never a silent pass)."""
    tr = binding.truth(rig)
    r = binding.run(rig, tr.u, tr.y)
    assert abs(r.x[-1, 8] / rig.gamma - 1.0) < 0.02
    bias, sd = r.x[-1, -1], np.sqrt(r.P_diag[-1, -1])
    assert abs(bias - 5e-7) < 3 * sd and sd < 2e-7


def test_sensitivities_of_every_kind_are_the_truths_central_differences(rig):
    """The Cramer-Rao bound's dy/dp (identifiability.sensitivities) for the rig's four kinds, with gamma, a mass,
    the load cell's own stiffness and damper and the offset unknown, through the first contact episode: against
    central differences of the scipy truth's noise-free readings."""
    from caekf_sim.identifiability import law_params, mechanism_params, sensitivities
    from caekf_sim.truth import simulate

    d = rig.replace(t_end=13.5, noise_std=0.0, sensor1_noise=0.0, sensor3_noise=0.0, **UNCERTAIN)
    params = law_params(d, ["gamma"], [1]) + mechanism_params(d)
    assert [p.key for p in params] == ["contact1_gamma", "m2", "spring2_k", "spring2_c", "sensor4_bias"]
    sens = sensitivities(d, params, initial_state=False)
    assert sens.events >= 1
    for j, p in enumerate(params):
        h = 1e-4 * (abs(p.value) if p.value else 1e-6)
        ys = [simulate(d.replace(**{p.key if p.mech != "b" else "sensor4_bias": p.value + s * h})).y
              for s in (1.0, -1.0)]
        fd = (ys[0] - ys[1]) / (2 * h) * p.scale
        big = np.max(np.abs(sens.dy[:, :, j]), axis=0)
        assert np.all(np.max(np.abs(fd - sens.dy[:, :, j]), axis=0) <= 2e-3 * big + 1e-12), p.key


def test_a_position_or_velocity_sensor_takes_its_own_sigma(paper):
    """sensor{i}_sigma on a sensor that reads one state (no rows of H): the C filter's R is that sigma, as the
    twin's (it once kept sigma_rv, 0 here)."""
    sc = paper.replace(t_end=2.0, sensor2_kind=1, sigma_rv=0.0, sensor2_sigma=1e-5, noise_std_v=1e-5)
    tr = binding.truth(sc)
    c = binding.run(sc, tr.u, tr.y)
    ekf = AugmentedEKF(sc, scenario_config(sc))
    x = np.empty_like(c.x)
    for k in range(len(tr.y)):
        ekf.step(float(tr.u[k]), tr.y[k])
        x[k] = ekf.physical()[0]
    scale = np.maximum(np.max(np.abs(x), axis=0), 1e-300)
    assert np.max(np.abs(c.x - x) / scale) < 1e-6
