"""The numpy reference estimator on a structure given as matrices (docs/structure.md): Mechanism.from_structure
reads the matrices with the scenario's counts and kinds (a non-diagonal M through its modal basis, as the binding),
the paper's chain written as matrices estimates in numpy as the chain does, and the numpy estimator agrees with the
shipped C estimator (binding.Estimator) on the beam example and on a dense random 5-dof structure with position,
velocity and acceleration sensors, through contact; `caekf-sim estimate --engine numpy` runs the beam."""
from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict

import numpy as np
import pytest
import scipy.linalg

from caekf_sim import flags as fl
from caekf_sim.binding import Estimator, RunResult
from caekf_sim.estimator import AugmentedEKF, EstimateResult, run_estimator
from caekf_sim.experiments import scenario_config
from caekf_sim.measurements import columns_of, read_measurements_csv
from caekf_sim.mechanism import ACCELERATION, POSITION, VELOCITY, Mechanism, MechanismError
from caekf_sim.scenario import Scenario, load_scenario, scenario_from_values
from caekf_sim.structure.files import Structure
from caekf_sim.structure.truth import simulate

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
BEAM = SCENARIOS / "beam.toml"
RECORDING = SCENARIOS / "beam-recording.csv"
BEAM_SAMPLES = 2000  # 0.2 s at 10 kHz: the filter's transient and the first 7 impacts (79 samples in contact)


def agreement(c: RunResult, r: EstimateResult) -> Dict[str, float]:
    """The numpy estimate against the C's: each state's largest difference over its column's largest value, P's
    diagonal likewise, and gamma's largest relative difference."""
    scale = np.abs(c.x).max(axis=0)
    assert c.P_diag is not None and r.P is not None
    pd = np.diagonal(r.P, axis1=1, axis2=2)
    gi = c.gamma_index
    return {"x": float(np.max(np.abs(c.x - r.x) / scale)),
            "P": float(np.max(np.abs(c.P_diag - pd) / np.abs(c.P_diag).max(axis=0))),
            "gamma": float(np.max(np.abs(r.x[:, gi] / c.x[:, gi] - 1.0)))}


# ---- the mechanism ----------------------------------------------------------------------------------------------
def test_from_scenario_reads_the_beam_structure() -> None:
    sc = load_scenario(BEAM)
    st = sc.structure
    mech = Mechanism.from_scenario(sc)
    assert mech.is_structure and mech.modal_basis is None
    assert (mech.nq, mech.n_inputs, mech.n_sensors, mech.n_contacts) == (st.dofs, 1, 3, 1)
    np.testing.assert_array_equal(mech.m, np.diag(st.M))
    for mine, theirs in ((mech.K, st.K), (mech.C, st.C), (mech.B_u, st.Bu), (mech.B_load, st.Bu), (mech.B_c, st.W.T)):
        np.testing.assert_array_equal(mine, theirs)
    assert mech.sensor_kind.tolist() == [ACCELERATION, ACCELERATION, POSITION]
    np.testing.assert_array_equal(mech.H_acc[:2], st.H[:2])  # the accelerometers read rows of q''
    np.testing.assert_array_equal(mech.H[2, : st.dofs], st.H[2])  # the strain gauge a row of q
    assert not mech.H[:2].any() and not mech.H_acc[2].any() and not mech.H[2, st.dofs:].any()
    assert mech.sensor_names() == ("y1", "y2", "y3") and mech.input_names() == ("u",)
    q = np.random.default_rng(1).normal(size=(4, st.dofs))
    np.testing.assert_allclose(mech.penetrations(q)[:, 0], q @ st.W[:, 0] - sc.contact1_gap, rtol=1e-14)
    with pytest.raises(ValueError, match="contact_laws"):
        _ = mech.contacts  # a line's ends: a structure has none


def test_a_non_diagonal_mass_goes_to_its_modal_basis_as_in_the_binding() -> None:
    st, sc = dense_structure(3), dense_scenario(3, DENSE_GAP, np.ones(3))
    mech = Mechanism.from_structure(st, sc)
    modal, phi = st.modal()
    assert mech.structure is not None and mech.structure.diagonal_mass()
    np.testing.assert_array_equal(mech.modal_basis, phi)
    np.testing.assert_array_equal(mech.m, np.ones(st.dofs))
    np.testing.assert_array_equal(mech.K, modal.K)
    np.testing.assert_array_equal(mech.B_c, modal.W.T)
    assert mech.sensor_kind.tolist() == [POSITION, VELOCITY, ACCELERATION]
    np.testing.assert_array_equal(mech.H[1, st.dofs:], modal.H[1])  # the velocity sensor's row of q'


@pytest.mark.parametrize("change, key", [
    ({"sensors": 2}, "sensors = 2: the structure has 3"),
    ({"contacts": 0}, "contacts = 0: the structure has 1"),
    ({"sensor2_kind": 3, "sensor2_ref": 0}, "sensor2_kind = relative: a structure's sensor reads position"),
    ({"input1_kind": 1, "springs": 1, "spring1_a": 1, "spring1_b": 0, "spring1_k": 1.0, "input1_link": 1},
     "input1_kind"),
    ({"m1_sigma": 0.1}, "m1_sigma = 0.1: a structure's masses and links are not estimated"),
])
def test_what_the_core_refuses_for_a_structure_is_refused_by_key(change: Dict[str, Any], key: str) -> None:
    sc = load_scenario(BEAM)
    with pytest.raises(MechanismError, match=key):
        Mechanism.from_structure(sc.structure, sc.replace(**change))


# ---- the chain as matrices ----------------------------------------------------------------------------------
def test_the_chain_as_matrices_estimates_in_numpy_as_the_chain() -> None:
    """The paper's chain written as a structure (its masses, its links' K and C, w = e2 - e3, B_u = e1, rows e1 and
    e4) through the structure's paths (rows of H, contacts along w) estimates as the line's paths do."""
    sc = load_scenario(SCENARIOS / "paper.toml")
    line = Mechanism.from_scenario(sc)
    st = Structure(M=line.M, K=line.K, C=line.C, Bu=line.B_u, W=line.B_c.T, H=line.H[:, : line.nq])
    mats = Mechanism.from_structure(st, sc)
    from caekf_sim.binding import truth

    tr = truth(sc.replace(t_end=16.0))  # the first contacts from 12.8 s
    cfg = scenario_config(sc)
    a = run_estimator(sc, cfg, tr.t, tr.u, tr.y, keep_P=False, mech=line)
    b = run_estimator(sc, cfg, tr.t, tr.u, tr.y, keep_P=False, mech=mats)
    assert np.count_nonzero(a.flags & fl.CONTACT_ACTIVE) > 100
    np.testing.assert_array_equal(a.flags, b.flags)
    np.testing.assert_allclose(b.x[:, :8], a.x[:, :8], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.gamma, a.gamma, rtol=1e-10)


# ---- against the C estimator: the beam ------------------------------------------------------------------------
@pytest.fixture(scope="module")
def beam() -> Any:
    sc = load_scenario(BEAM)
    meas = read_measurements_csv(RECORDING, sc.dt, columns_of(sc))
    n = BEAM_SAMPLES
    return sc, meas.t[:n], meas.u[:n], meas.y[:n]


def test_numpy_agrees_with_the_c_estimator_on_the_beam_example(beam: Any) -> None:
    """The shipped beam (8 dofs, two accelerometers and a strain gauge, the stop along w) with the estimator's
    default configuration, as `caekf-sim estimate --engine numpy` runs it (trapezoidal, substeps, statistically
    linearised contact, gate, monitor): gamma within 1e-9, the states and P's diagonal within 2e-9 of their
    columns' size (measured 1e-11, 9e-10 and 9e-10: the largest in the first 20 samples, where the prior's
    collapse onto the sensors amplifies rounding as much), the same flags and Newton iterations."""
    sc, t, u, y = beam
    c = Estimator(sc).run(u, y, t=t)
    r = run_estimator(sc, scenario_config(sc), t, u, y)
    assert np.count_nonzero(c.flags & fl.CONTACT_ACTIVE) > 50
    np.testing.assert_array_equal(r.flags, c.flags.astype(np.int64))
    np.testing.assert_array_equal(r.newton_iters, c.newton_iters)
    err = agreement(c, r)
    assert err["gamma"] < 1e-9 and err["x"] < 2e-9 and err["P"] < 2e-9, err


def test_caekf_sim_estimate_runs_the_beam_with_the_numpy_engine(beam: Any, tmp_path: Path) -> None:
    """The CLI's numpy engine on a structure's recording (its first row at t = 0 corrected without a time update,
    as the C engine does) writes what the C engine writes, to the same agreement."""
    from caekf_sim.cli import main

    sc, t, u, y = beam
    rec = tmp_path / "beam.csv"
    np.savetxt(rec, np.column_stack([t, u, y]), delimiter=",", header="t,u,y1,y2,y3", comments="", fmt="%.17g")
    out = {}
    for engine in ("numpy", "c"):
        out[engine] = tmp_path / f"{engine}.csv"
        assert main(["estimate", "--engine", engine, "--scenario", str(BEAM), "--measurements", str(rec),
                     "--out", str(out[engine])]) == 0
    a, b = (np.genfromtxt(out[e], delimiter=",", names=True) for e in ("numpy", "c"))
    assert a.dtype.names == b.dtype.names and len(a) == BEAM_SAMPLES
    np.testing.assert_array_equal(a["flags"], b["flags"])
    np.testing.assert_allclose(a["gamma"], b["gamma"], rtol=1e-9)
    for name in a.dtype.names[1:17]:  # q1..q8, v1..v8
        assert np.max(np.abs(a[name] - b[name])) < 2e-9 * np.max(np.abs(b[name])), name


# ---- against the C estimator: a dense random structure --------------------------------------------------------
DENSE_GAP = 0.4  # of the contact-free response's largest w^T q
DENSE_GAMMA = 2e7
DENSE_DT = 1e-3


def dense_structure(seed: int, diagonal_mass: bool = False) -> Structure:
    """5 dofs, every matrix dense (M too, which takes the modal basis; or M diagonal with unequal masses, which
    the filters take as it is: M^-1 in the accelerometers, the input noise and the second-order noise), one contact
    along a random w, one input, three sensors (position, velocity, acceleration) on random rows; 7-33 Hz."""
    rng = np.random.default_rng(seed)
    n = 5
    a, b = rng.normal(size=(n, n)), rng.normal(size=(n, n))
    M = a @ a.T / n + np.eye(n)
    if diagonal_mass:
        M = np.diag(np.diag(M) * np.array([0.3, 1.0, 2.5, 0.6, 1.7]))
    K = (b @ b.T + n * np.eye(n)) * 2e3
    return Structure(M=M, K=K, C=0.5 * M + 2e-4 * K, Bu=rng.normal(size=(n, 1)), W=rng.normal(size=(n, 1)),
                     H=rng.normal(size=(3, n)))


def dense_scenario(seed: int, gap: float, sigmas: np.ndarray, **extra: Any) -> Scenario:
    """The filter's scenario: the line's keys at placeholders, the sensors' kinds and noise, gamma0 0.7 of the
    truth with a 70 % prior std, the schema's estimator settings unless `extra` changes them."""
    values: Dict[str, Any] = {
        "bodies": 1, "m1": 1.0, "springs": 0, "inputs": 1, "input1_body": 1, "contacts": 1, "contact1_a": 1,
        "contact1_b": 0, "contact1_gap": gap, "contact1_n": 1.5, "dt": DENSE_DT, "sensors": 3,
        "gamma0": 0.7 * DENSE_GAMMA, "sigma_gamma0": 0.7 * DENSE_GAMMA, "sigma_q_gamma": 1e-3 * DENSE_GAMMA,
        "sigma_q0": 1e-3, "sigma_v0": 1e-2, "sigma_qx_q": 1e-9, "sigma_qx_v": 1e-5,
        "sigma_r": float(min(sigmas)), "sigma_rv": float(min(sigmas))}
    for i, (kind, s) in enumerate(zip((POSITION, VELOCITY, ACCELERATION), sigmas), start=1):
        values.update({f"sensor{i}_kind": kind, f"sensor{i}_body": 1, f"sensor{i}_sigma": float(s)})
    values.update(extra)
    return scenario_from_values(values, f"dense{seed}")


@dataclass(frozen=True)
class DenseRun:
    structure: Structure
    gap: float
    sigmas: np.ndarray
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray


@functools.lru_cache(maxsize=None)
def dense_run(diagonal_mass: bool) -> DenseRun:
    """3 s of the structure's truth (caekf_sim.structure.truth, 10 substeps) driven at 0.8 of its first frequency,
    the gap at 0.4 of the free response (contact on 3-5 % of the samples), 1 % noise on each sensor."""
    seed = 3
    st = dense_structure(seed, diagonal_mass)
    f1 = float(np.sqrt(scipy.linalg.eigh(st.K, st.M, eigvals_only=True)[0])) / (2 * np.pi)

    def force(t: np.ndarray) -> np.ndarray:
        return 20.0 * np.sin(2 * np.pi * 0.8 * f1 * t)[:, None]

    kinds = ("position", "velocity", "acceleration")
    free = simulate(st, 1.0, 1.0, 1.5, force, DENSE_DT, 3.0, 10, kinds=kinds)
    gap = DENSE_GAP * float(np.max(free.q @ st.W[:, 0]))
    tr = simulate(st, gap, DENSE_GAMMA, 1.5, force, DENSE_DT, 3.0, 10, kinds=kinds)
    rng = np.random.default_rng(seed)
    sigmas = 0.01 * np.sqrt(np.mean(tr.y**2, axis=0))
    return DenseRun(st, gap, sigmas, tr.t, tr.u, tr.y + rng.normal(size=tr.y.shape) * sigmas)


# The filter's configurations (scenario keys over dense_scenario's, some in units of the gap).
CONFIGS: Dict[str, Callable[[float], Dict[str, Any]]] = {
    "default": lambda gap: {},  # the schema's estimator: trapezoidal, substeps, statistically linearised contact
    # the whole law estimated: ln gamma, n, lambda and the gap along w; the second-order noise along M^-1 w
    "joint": lambda gap: {"gamma_log": 1, "contact1_estimate_n": 1, "contact1_n0": 1.55, "contact1_sigma_n0": 0.1,
                          "contact1_n_max": 3.0, "contact1_estimate_gap": 1, "contact1_gap0": 1.01 * gap,
                          "contact1_sigma_gap0": 0.02 * gap, "contact1_estimate_lambda": 1, "contact1_lambda0": 1.0,
                          "contact1_sigma_lambda0": 1.0},
    # a measured input's noise in the accelerometer's R through h^T M^-1 b, an offset state, a damped contact
    "measured": lambda gap: {"input1_sigma": 0.2, "sensor1_bias_sigma": 1e-5, "contact1_lambda": 0.5},
    "canonical": lambda gap: {"mode": 0},  # every step's gamma live
}


@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_numpy_agrees_with_the_c_estimator_on_a_dense_structure(name: str) -> None:
    """Through contact, gamma, the states and P's diagonal within 1e-9 of the C's (measured at most 4e-10), the
    same flags. M dense: both filters take the same modal basis."""
    run = dense_run(False)
    sc = dense_scenario(3, run.gap, run.sigmas, **CONFIGS[name](run.gap))
    c = Estimator(sc, structure=run.structure).run(run.u, run.y, t=run.t)
    r = run_estimator(sc, scenario_config(sc), run.t, run.u[:, 0], run.y,
                      mech=Mechanism.from_structure(run.structure, sc))
    assert np.count_nonzero(c.flags & fl.CONTACT_ACTIVE) > 50
    np.testing.assert_array_equal(r.flags, c.flags.astype(np.int64))
    assert np.count_nonzero(r.newton_iters != c.newton_iters) <= 3  # a test right at the tolerance may go either way
    err = agreement(c, r)
    assert err["gamma"] < 1e-9 and err["x"] < 1e-9 and err["P"] < 1e-9, err


@pytest.mark.parametrize("diagonal_mass", [False, True], ids=["dense_mass", "diagonal_mass"])
@pytest.mark.parametrize("name", sorted(CONFIGS))
def test_each_numpy_step_from_the_c_estimate_is_the_c_step(name: str, diagonal_mass: bool) -> None:
    """Every step of the run made by both from the C's estimate (x, P and the monitor's mean): the states within
    1e-11 of their columns' size and P's diagonal within 1e-8 (measured 1e-12 and 4e-10), the same flags. A run
    whose filter amplifies rounding (on the diagonal masses the canonical run's gamma moves 1e-6 when P is perturbed
    by 1e-15 a step, and so far apart end the two filters) still agrees here, step by step."""
    run = dense_run(diagonal_mass)
    sc = dense_scenario(3, run.gap, run.sigmas, **CONFIGS[name](run.gap))
    est = Estimator(sc, structure=run.structure)
    ekf = AugmentedEKF(sc, scenario_config(sc), Mechanism.from_structure(run.structure, sc))
    xc, xn, pc, pn = (np.empty((len(run.t), ekf.n)) for _ in range(4))
    contact = 0
    for k in range(len(run.t)):
        ekf.x, ekf.P = estimator_state(ekf, est.x, est.P)
        ekf.nis_mean, ekf.q_scale = est.mismatch()
        if k == 0:  # the recording's first row, at t = 0: a correction alone (Estimator.run's convention)
            est.run(run.u[:1], run.y[:1], t=run.t[:1])
            theirs = est.last_flags
        else:
            theirs = est.step(float(run.u[k, 0]), run.y[k]).flags
        mine, _ = ekf.step(float(run.u[k, 0]), run.y[k], predict=k > 0)
        assert mine == theirs, (k, fl.describe(mine), fl.describe(theirs))
        contact += bool(mine & fl.CONTACT_ACTIVE)
        x, P = ekf.physical()
        xc[k], xn[k], pc[k], pn[k] = est.x, x, np.diag(est.P), np.diag(P)
    assert contact > 50
    x_err = np.max(np.abs(xc - xn) / np.abs(xc).max(axis=0))
    p_err = np.max(np.abs(pc - pn) / np.abs(pc))
    assert x_err < 1e-11 and p_err < 1e-8, (x_err, p_err)


def estimator_state(ekf: AugmentedEKF, x: np.ndarray, P: np.ndarray) -> Any:
    """The C's estimate (binding: gamma itself) as the numpy filter's states (ln gamma with gamma_log)."""
    z, f = x.copy(), np.ones(len(x))
    if ekf.cfg.gamma_log:
        z[ekf.ig] = np.log(x[ekf.ig])
        f[ekf.ig] = x[ekf.ig]
    return z, P / np.outer(f, f)
