"""Uncertain mechanism parameters and measured inputs (issue 27 points 1-2; docs/mechanism.md, "Uncertain
parameters and measured inputs"): the numpy twin (estimator.AugmentedEKF) against the C filter, its F columns
against finite differences of its own Newton step, what the estimates do, and the unchanged path without them.

The record: the paper's chain (sim/scenarios/paper.toml, the schema's default estimator: trapezoidal, 3
contact substeps, statistical linearisation, gate, mismatch monitor) whose masses, springs and dampers are 2-4 %
off the scenario's values, simulated by the C truth (binding.truth) for 10 s with measurement noise at the
filter's sigma_r; all 12 parameters declared uncertain (0.03), input1_sigma = 0.01 N and the force read with
white noise of that std (0.4 % of its amplitude).
"""
from __future__ import annotations

import copy
import importlib.util
import math
import shutil
import subprocess
import sys
from dataclasses import replace
from pathlib import Path
from typing import Dict, Tuple

import numpy as np
import pytest

from caekf_sim import binding
from caekf_sim.estimator import AugmentedEKF, EstimatorConfig, run_estimator
from caekf_sim.experiments import scenario_config
from caekf_sim.model import BACKWARD_EULER
from caekf_sim.scenario import Scenario, default_scenario_path, load_scenario
from caekf_sim.truth import Truth

REPO = Path(__file__).resolve().parents[2]
NAMES = ("m1", "m2", "m3", "m4", "k1", "k12", "k34", "k4", "c1", "c12", "c34", "c4")  # state order
KEYS = tuple(f"m{i}_sigma" for i in range(1, 5)) + tuple(f"spring{i}_k_sigma" for i in range(1, 5)) \
    + tuple(f"spring{i}_c_sigma" for i in range(1, 5))
SIGMA = 0.03
SIGMA_U = 0.01  # N
T_END = 10.0
# The truth: every value a few per cent off the scenario's (signs mixed, within 1.5 declared sigma).
TRUE_FACTOR = dict(m1=1.03, m2=0.98, m3=1.02, m4=0.97, k1=1.03, k12=0.97, k34=1.03, k4=0.96, c1=1.02, c12=0.98,
                   c34=1.03, c4=0.97)
NX = 8  # q, v of the 4 bodies; then gamma, then the 12 parameters
IM = slice(9, 21)
# The commit whose estimator.py is the path without the feature (the C core's commit; estimator.py before
# the numpy twin).
BEFORE = "9f72e58"


def declared(sc: Scenario, **changes: float) -> Scenario:
    return sc.replace(**{k: SIGMA for k in KEYS}, **changes)


@pytest.fixture(scope="module")
def paper() -> Scenario:
    return load_scenario(default_scenario_path()).replace(t_end=T_END, noise_std=1.0e-7)


@pytest.fixture(scope="module")
def true_values(paper: Scenario) -> np.ndarray:
    return np.array([getattr(paper, n) * TRUE_FACTOR[n] for n in NAMES])


@pytest.fixture(scope="module")
def record(paper: Scenario, true_values: np.ndarray) -> Tuple[Truth, np.ndarray]:
    """The truth of the off-nominal mechanism and the force as read (white noise SIGMA_U)."""
    tr = binding.truth(paper.replace(**dict(zip(NAMES, true_values.tolist()))))
    u = tr.u + SIGMA_U * np.random.default_rng(20261128).standard_normal(len(tr.u))
    return tr, u


def run_twin(sc: Scenario, u: np.ndarray, y: np.ndarray, cfg: EstimatorConfig = None) -> Dict[str, np.ndarray]:
    """The numpy twin over the record: physical x, P (values for the parameters) and the raw P (theta)."""
    ekf = AugmentedEKF(sc, cfg if cfg is not None else scenario_config(sc))
    n = len(y)
    out = {"x": np.empty((n, ekf.n)), "P": np.empty((n, ekf.n, ekf.n)), "P_theta": np.empty((n, ekf.n, ekf.n)),
           "flags": np.empty(n, dtype=np.int64)}
    for k in range(n):
        out["flags"][k] = ekf.step(float(u[k]), y[k])[0]
        out["x"][k], out["P"][k] = ekf.physical()
        out["P_theta"][k] = ekf.P
    out["setting"] = ekf.mech_setting
    return out


@pytest.fixture(scope="module")
def both(paper: Scenario, record: Tuple[Truth, np.ndarray]) -> Tuple[Dict[str, np.ndarray], Dict[str, np.ndarray]]:
    """(C, numpy) over the record with every parameter declared and input1_sigma."""
    tr, u = record
    sc = declared(paper, input1_sigma=SIGMA_U)
    est = binding.Estimator(sc)
    n = len(tr.y)
    c = {"x": np.empty((n, est.n)), "P": np.empty((n, est.n, est.n)), "flags": np.empty(n, dtype=np.int64)}
    for k in range(n):
        c["flags"][k] = est.step(float(u[k]), tr.y[k]).flags
        c["x"][k], c["P"][k] = est.x, est.P
    whole = binding.run(sc, u, tr.y)  # the loop in C: the same filter
    np.testing.assert_array_equal(whole.x, c["x"])
    return c, run_twin(sc, u, tr.y)


def rel_err(a: np.ndarray, b: np.ndarray) -> float:
    """max |a - b| relative to b's largest magnitude per column."""
    scale = np.maximum(np.max(np.abs(b), axis=0), 1e-300)
    return float(np.max(np.abs(a - b) / scale))


# ---- (a) C and numpy ------------------------------------------------------------------------------------------
def test_c_and_numpy_twin_agree_on_state_and_covariance(both):
    """Two independent implementations of the same equations in double: every difference is rounding (LU vs.
    numpy's solve, the C core's scaled state), ~1e-16 per step, which the filter's own contraction keeps from
    growing: measured 5e-13 (q, v), 2e-13 (theta) and 4e-12 (P, relative to sqrt(P_ii P_jj)) over the 10,000
    steps. 1e-6 leaves a margin of 1e5 and still fails on each modelling slip tried (the trapezoidal factor 2 of
    the input noise, the hs of F's q-rows, the start's d_ab of a link, the gate's hold of the parameters).

    The parameters are compared as theta = ln(value / setting); P in theta's units (C's P divided by the
    factor value * value its accessor applies)."""
    c, nm = both
    flags_differ = np.flatnonzero(c["flags"] != nm["flags"])
    assert flags_differ.size == 0, f"flags differ first at step {flags_differ[:1]}"
    assert c["flags"][0] & 256  # GAMMA_FROZEN: no contact in 10 s: the parameters move on the free motion
    assert rel_err(nm["x"][:, :NX], c["x"][:, :NX]) < 1e-6  # q, v
    np.testing.assert_array_equal(nm["x"][:, NX], c["x"][:, NX])  # gamma frozen in both
    theta_c = np.log(c["x"][:, IM] / nm["setting"])
    theta_n = np.log(nm["x"][:, IM] / nm["setting"])
    assert np.max(np.abs(theta_c - theta_n)) < 1e-6 * SIGMA
    assert np.max(np.abs(theta_n[-1])) > 0.3 * SIGMA  # the parameters did move
    f = np.ones(21)
    P_c = np.empty_like(c["P"])
    for k in range(len(P_c)):
        f[IM] = c["x"][k, IM]
        P_c[k] = c["P"][k] / np.outer(f, f)
    d = np.sqrt(np.einsum("kii->ki", nm["P_theta"]))
    assert np.max(np.abs(nm["P_theta"] - P_c) / (d[:, :, None] * d[:, None, :])) < 1e-6


def test_c_accessor_reports_the_current_parameter_value(both):
    """The C accessors report a mechanism parameter as setting * exp(theta_k^+), the state after the step's
    correction (they once reported the value the step's model was built with, one correction behind)."""
    c, nm = both
    assert rel_err(c["x"][:, IM], nm["x"][:, IM]) < 1e-6


# ---- (b) F's columns against the twin's own Newton step --------------------------------------------------------
def step_from(ekf: AugmentedEKF, x_prev: np.ndarray, u_prev: float, u: float) -> np.ndarray:
    """x_k^- of one step of the twin from x_prev (its model at x_prev's parameters): the Newton solve only."""
    e = copy.deepcopy(ekf)
    e.x = x_prev.copy()
    e.u_prev = u_prev
    e._set_mechanism(e.x)
    return e.predict(u)[0][:NX]


def fd_case(sc: Scenario, cfg: EstimatorConfig, x_prev: np.ndarray, u_prev: float, u: float) -> None:
    ekf = AugmentedEKF(sc, cfg)
    ekf.x = x_prev.copy()
    ekf.u_prev = u_prev
    ekf._set_mechanism(ekf.x)
    xp, F, _, ok = ekf.predict(u)
    assert ok
    # h: the truncation error (h^2 relative) and the Newton solve's resolution (256 eps of its rows' terms,
    # ~1e-12 relative in contact) divided by h both stay below 1e-7 of the column
    h = 1e-4
    FD = np.empty((NX, ekf.nm))
    for j, i in enumerate(ekf.im):  # d x_k / d ln(value_j): perturb the value, solve the step again
        xa, xb = x_prev.copy(), x_prev.copy()
        xa[i] += h
        xb[i] -= h
        FD[:, j] = (step_from(ekf, xa, u_prev, u) - step_from(ekf, xb, u_prev, u)) / (2 * h)
    np.testing.assert_array_equal(F[NX:, ekf.im], np.eye(ekf.n)[NX:, ekf.im])  # random-walk rows
    for rows in (slice(0, NX // 2), slice(NX // 2, NX)):  # q-rows, v-rows: each to 1e-6 of its largest entry,
        # and each column to 1e-4 of its own (the columns span 1e-9 .. 1 of the largest: m3's barely moves)
        diff = np.abs(F[rows, ekf.im] - FD[rows])
        tol = 1e-6 * np.max(np.abs(FD[rows])) + 1e-4 * np.max(np.abs(FD[rows]), axis=0)
        assert np.all(diff <= tol), (rows, dict(zip(NAMES, np.max(diff / tol, axis=0))))
    # the measured input: x_k moves by dx/du_{k-1} + dx/du_k for an error held over the step (both ends)
    du = 1e-3
    both_ends = (step_from(ekf, x_prev, u_prev + du, u + du) - step_from(ekf, x_prev, u_prev - du, u - du)) / (2 * du)
    G = ekf.input_columns(xp)[:, 0]
    assert np.max(np.abs(G - both_ends)) <= 1e-6 * np.max(np.abs(both_ends))
    assert np.any(G != 0)


@pytest.mark.parametrize("case", ["trapezoidal, free", "trapezoidal, in contact", "backward Euler, in contact"])
def test_f_columns_match_finite_differences_of_the_newton_step(paper, both, case):
    """F's theta columns (and the input's G) against central differences of the twin's own step solver
    (model.StepSolver on the mechanism rebuilt at value * exp(+-h)), at a state of the run (free) and at one
    pushed 20 um into the contact (one step: substeps have the one-step columns by design, docs)."""
    _, nm = both
    sc = declared(paper, input1_sigma=SIGMA_U)
    cfg = replace(scenario_config(sc), contact_substeps=1, contact_slr_p=0.0)
    k = 4000
    x_prev = nm["x"][k].copy()
    x_prev[IM] = np.log(x_prev[IM] / nm["setting"])  # the state holds theta
    if "contact" in case:
        x_prev[1] = x_prev[2] + sc.gap + 2e-5
        x_prev[5] = x_prev[6] + 1e-3  # closing
    if "Euler" in case:
        cfg = replace(cfg, discretisation=BACKWARD_EULER)
    fd_case(sc, cfg, x_prev, -0.5, -0.51)


# ---- (c) what the estimates do ----------------------------------------------------------------------------------
def check_estimates(x: np.ndarray, P: np.ndarray, true_values: np.ndarray, setting: np.ndarray,
                    min_pinned: int = 2) -> None:
    """Every final error within 3 sigma; the parameters the record pins down (final sigma below half the
    declared) end closer to the truth than they started, and at least min_pinned are pinned."""
    err0 = setting / true_values - 1.0
    err = x[-1, IM] / true_values - 1.0
    sd = np.sqrt(np.diag(P[-1])[IM]) / true_values
    z = err / sd
    assert np.all(np.abs(z) < 3.0), dict(zip(NAMES, np.round(z, 2)))
    pinned = sd < 0.5 * SIGMA
    assert pinned.sum() >= min_pinned, dict(zip(NAMES, np.round(sd, 4)))
    assert np.all(np.abs(err[pinned]) < 0.5 * np.abs(err0[pinned])), (np.array(NAMES)[pinned], err[pinned])


def test_exact_force_the_declared_errors_shrink_and_end_within_3_sigma(paper, record, true_values):
    """The force read exactly (no input1_sigma): k1 (the static compliance of the driven body) and c1 are pinned
    down within 10 s of free motion and approach the truth; every parameter ends within 3 sigma of it (the ones
    this record does not excite keep their declared sigma and error)."""
    tr, _ = record
    res = run_twin(declared(paper), tr.u, tr.y)
    check_estimates(res["x"], res["P"], true_values, res["setting"])


def test_measured_force_the_declared_errors_end_within_3_sigma(both, true_values):
    """The force read with noise and input1_sigma declared: every parameter ends within 3 sigma, and k1 (the
    driven body's static compliance) is pinned. The force's noise hides c1 over these 10 s."""
    _, nm = both
    check_estimates(nm["x"], nm["P"], true_values, nm["setting"], min_pinned=1)


def test_the_inputs_trend_removes_the_driven_mass_errors_in_variables_bias(paper, record, true_values):
    """With the mass columns of F at the measured force's samples (input_trend_window = 0) the driven body's mass
    ends far off, and confidently: the columns carry the force's noise, which the innovations carry too
    (errors in variables). At the trend (the default window) it ends within 3 sigma."""
    tr, u = record
    z = {}
    for window in (0, paper.input_trend_window):
        res = binding.run(declared(paper, input1_sigma=SIGMA_U, input_trend_window=window), u, tr.y)
        assert res.P_diag is not None
        z[window] = (res.x[-1, 9] - true_values[0]) / math.sqrt(res.P_diag[-1, 9])
    assert paper.input_trend_window > 0
    assert abs(z[0]) > 6.0, z  # measured 17 sigma (+59 %)
    assert abs(z[paper.input_trend_window]) < 3.0, z  # measured 0.1 sigma (+0.3 %)


# ---- (d) nothing declared: the previous path, bit for bit ----------------------------------------------------
def estimator_before():
    """estimator.py of commit BEFORE, imported inside the package (its relative imports resolve)."""
    if shutil.which("git") is None or not (REPO / ".git").exists():
        pytest.skip("no git checkout: the previous estimator.py is not at hand")
    proc = subprocess.run(["git", "-C", str(REPO), "show", f"{BEFORE}:sim/src/caekf_sim/estimator.py"],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"commit {BEFORE} not in this clone")
    path = Path(__file__).parent / "__estimator_before.py"
    spec = importlib.util.spec_from_loader("caekf_sim._estimator_before", loader=None)
    assert spec is not None
    mod = importlib.util.module_from_spec(spec)
    mod.__package__ = "caekf_sim"
    sys.modules[spec.name] = mod  # dataclasses look their module up
    try:
        exec(compile(proc.stdout, str(path), "exec"), mod.__dict__)
    finally:
        del sys.modules[spec.name]
    return mod


def test_nothing_declared_is_the_previous_path_bit_for_bit(paper):
    """No parameter and no input noise declared: the twin's results equal the previous estimator.py's bit for bit,
    over contact (the sine sped up: contact from 2.6 s), with the default estimator (substeps, statistical
    linearisation, gate, mismatch monitor) and with the paper's switched preset (backward Euler)."""
    before = estimator_before()
    sc = paper.replace(t_end=4.0, u_freq=0.25)
    tr = binding.truth(sc)
    assert np.any(tr.delta > 0)
    for cfg in (scenario_config(sc), scenario_config(sc, "switched")):
        now = run_estimator(sc, cfg, tr.t, tr.u, tr.y)
        known = {k: v for k, v in cfg.__dict__.items() if k in before.EstimatorConfig.__dataclass_fields__}
        then = before.run_estimator(sc, before.EstimatorConfig(**known), tr.t, tr.u, tr.y)
        assert now.x.shape == then.x.shape == (len(tr.t), 9)
        np.testing.assert_array_equal(now.x, then.x)
        np.testing.assert_array_equal(now.P, then.P)
        np.testing.assert_array_equal(now.flags, then.flags)
        assert np.any(now.flags & 8)  # CONTACT_ACTIVE


def test_declared_zero_sigma_is_nothing_declared(paper):
    """A sigma of 0 declares nothing: the same state size and results as the scenario without the keys."""
    sc = paper.replace(t_end=0.5)
    tr = binding.truth(sc)
    zero = sc.replace(**{k: 0.0 for k in KEYS}, input1_sigma=0.0)
    a = run_estimator(sc, scenario_config(sc), tr.t, tr.u, tr.y)
    b = run_estimator(zero, scenario_config(zero), tr.t, tr.u, tr.y)
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.P, b.P)
    assert math.isclose(a.gamma[-1], sc.gamma0)
