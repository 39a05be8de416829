"""The FMUs (fmu/, docs/fmu.md) through FMPy, a real FMI master: validation of both FMUs in both FMI versions,
the estimator FMU against caekf-replay bit for bit, lost samples, instances side by side, and the plant FMU
plus the estimator FMU reproducing the switched experiment.

The FMUs are looked up in $CAEKF_BUILD_DIR/fmu (CI: the host-double preset builds them) and
build/host-double/fmu; without them these tests skip, except where $CAEKF_BUILD_DIR is set, where a missing
FMU fails.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Dict

import numpy as np
import pytest

fmpy = pytest.importorskip("fmpy")
from fmpy.fmi1 import FMICallException  # noqa: E402
from fmpy.validation import validate_fmu  # noqa: E402

from caekf_sim import fmu, schema  # noqa: E402
from caekf_sim.experiments import run_experiment  # noqa: E402
from caekf_sim.scenario import default_scenario_path  # noqa: E402

from test_binding import replay  # noqa: E402

EXPERIMENTS = (None, "canonical", "switched", "switched-highq", "switched-highq-constrained")
VERSIONS = (3, 2)


def fmu_file(role: str, version: int) -> Path:
    p = fmu.find_fmu(role, version)
    if p is None:
        if os.environ.get("CAEKF_BUILD_DIR"):
            pytest.fail(f"caekf_{role}_fmi{version}.fmu not built in {[str(d) for d in fmu.fmu_dirs()]}")
        pytest.skip(f"caekf_{role}_fmi{version}.fmu not built")
    return p


def assert_same(rep: Dict[str, np.ndarray], out: Dict[str, np.ndarray], prefix: str = "") -> None:
    """caekf-replay's columns equal the FMU's outputs bit for bit (nis as replay prints it, %.9g)."""
    pairs = [(f"{c}{i}", f"{c}{i}") for c in "qv" for i in range(1, 5)]
    pairs += [("gamma", "gamma1"), ("p_gg", "var_gamma1"), ("p_norm", "p_norm"), ("flags", "flags"),
              ("newton_iters", "newton_iters")]
    for a, b in pairs:
        x, y = rep[a], out[prefix + b]
        assert x.shape == y.shape, a
        bad = ~((x == y) | (np.isnan(x) & np.isnan(y)))
        assert not bad.any(), f"{a}: {int(bad.sum())} rows differ, first at row {int(np.argmax(bad))}"
    nis = np.char.mod("%.9g", out[prefix + "nis"]).astype(np.float64)
    assert np.array_equal(rep["nis"], nis), "nis"


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("role", ["estimator", "plant"])
def test_fmu_validates(role, version):
    """modelDescription.xml against the standard's XSD (FMPy's copy), names, units, the model structure."""
    assert validate_fmu(str(fmu_file(role, version))) == []


@pytest.mark.parametrize("version", VERSIONS)
def test_parameters_are_the_schema(version):
    """Every wire setting is a parameter of the estimator FMU with its unit, and every start value is the
    scenario's value or else the schema's default; the plant carries the truth-only keys."""
    md = fmpy.read_model_description(str(fmu_file("estimator", version)))
    params = {v.name: v for v in md.modelVariables if v.causality == "parameter"}
    given = schema.codegen.read_scenario_values(schema.SCHEMA, default_scenario_path(), wire_only=False)
    given = {schema.canonical(k): v for k, v in given.items()}
    wire = [(k, s, i) for k, s, i in schema.SCHEMA.keys() if s.on_wire]
    assert sorted(params) == sorted(k for k, _, _ in wire)
    for k, s, i in wire:
        v = params[k]
        if s.type == "real":
            assert (v.unit or "") == s.unit, k
        want = given.get(k, 0.0 if s.element_required(i) else s.default_value(index=i))
        start = {"true": 1.0, "false": 0.0}.get(str(v.start), None)
        assert (float(v.start) if start is None else start) == want, k
    plant = fmpy.read_model_description(str(fmu_file("plant", version)))
    names = {v.name for v in plant.modelVariables if v.causality == "parameter"}
    assert {"contact1_gamma", "input1_amp", "seed", "noise_std", "m1", "contact1_gap"} <= names


@pytest.mark.parametrize("version", VERSIONS)
@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_estimator_fmu_equals_replay_bit_for_bit(experiment, version, truth_csv, truth_cols, tmp_path):
    args = ("--experiment", experiment) if experiment else ()
    rep = replay("double", truth_csv, tmp_path / "replay.csv", *args)
    y = np.column_stack([truth_cols["y1"], truth_cols["y4"]])
    out = fmu.replay(fmu_file("estimator", version), truth_cols["t"], truth_cols["u"], y, preset=experiment)
    assert_same(rep, out)


@pytest.mark.parametrize("version", VERSIONS)
def test_lost_samples_bridge_like_replay(version, truth_cols, tmp_path):
    """y{j}_valid = false is caekf_predict: the same as caekf-replay --missing-y-predict on empty fields."""
    n = 14000
    t, u, y1, y4 = (truth_cols[c][:n] for c in ("t", "u", "y1", "y4"))
    lost = np.zeros(n, dtype=bool)
    lost[12700:12900] = True  # 0.2 s around the first contact
    lost[::37] = True
    csv = tmp_path / "lossy.csv"
    with csv.open("w") as f:
        f.write("t,u,y1,y4\n")
        for k in range(n):
            ys = ",," if lost[k] else f",{float(y1[k])!r},{float(y4[k])!r}"
            f.write(f"{float(t[k])!r},{float(u[k])!r}{ys}\n")
    rep = replay("double", csv, tmp_path / "replay.csv", "--missing-y-predict", "--experiment", "switched")
    out = fmu.replay(fmu_file("estimator", version), t, u, np.column_stack([y1, y4]), has_y=~lost, preset="switched")
    assert_same(rep, out)
    assert np.all(out["flags"][lost].astype(int) & 1024)  # no_measurement


def test_instances_side_by_side(truth_cols):
    """Two instances in one process, stepped alternately with different presets, equal each run alone."""
    path = fmu_file("estimator", 3)
    n = 13500
    a = fmu.Slave(path, "a", fmu.preset_parameters("switched"))
    b = fmu.Slave(path, "b", fmu.preset_parameters("canonical"), unzip_dir=a.unzip_dir)
    try:
        ga, gb = [], []
        a.set({"y1_valid": False, "y2_valid": False})
        b.set({"y1_valid": False, "y2_valid": False})
        a.do_step()
        b.do_step()
        a.set({"y1_valid": True, "y2_valid": True})
        b.set({"y1_valid": True, "y2_valid": True})
        for k in range(n):
            row = {"u1": truth_cols["u"][k], "y1": truth_cols["y1"][k], "y2": truth_cols["y4"][k]}
            a.set(row)
            b.set(row)
            a.do_step()
            b.do_step()
            ga.append(a.get(["gamma1"])[0])
            gb.append(b.get(["gamma1"])[0])
    finally:
        b.close()
        a.close()
    y = np.column_stack([truth_cols["y1"][:n], truth_cols["y4"][:n]])
    alone_a = fmu.replay(path, truth_cols["t"][:n], truth_cols["u"][:n], y, preset="switched")
    alone_b = fmu.replay(path, truth_cols["t"][:n], truth_cols["u"][:n], y, preset="canonical")
    assert np.array_equal(np.array(ga), alone_a["gamma1"])
    assert np.array_equal(np.array(gb), alone_b["gamma1"])
    assert not np.array_equal(alone_a["gamma1"], alone_b["gamma1"])


@pytest.mark.parametrize("version", VERSIONS)
def test_plant_fmu_equals_caekf_truth(version, truth_cols):
    """The plant FMU's samples are caekf-truth's, bit for bit (the same DOP853 stepper), to t = 14 s."""
    from fmpy import simulate_fmu

    n = 14000
    res = simulate_fmu(str(fmu_file("plant", version)), stop_time=n * 1e-3, output_interval=1e-3,
                       output=["u1", "y1", "y2", "q2", "q3", "delta1"])
    for a, b in (("u", "u1"), ("y1", "y1"), ("y4", "y2"), ("q2", "q2"), ("q3", "q3"), ("delta", "delta1")):
        assert np.array_equal(res[b][1:], truth_cols[a][:n]), a


def test_parameter_errors_are_fmi_errors():
    path = fmu_file("estimator", 3)
    with pytest.raises(FMICallException):
        fmu.Slave(path, "bad", {"m2": -1.0})  # exitInitializationMode: "m2 = -1: must be finite and > 0"
    s = fmu.Slave(path, "ok")
    try:
        with pytest.raises(FMICallException):
            s.set({"m2": 2.0})  # a fixed parameter after initialisation
        with pytest.raises(FMICallException):
            s.fmu.doStep(currentCommunicationPoint=0.0, communicationStepSize=2 * s.dt)  # one step is dt
    finally:
        s.fmu.freeInstance()


@pytest.fixture(scope="module")
def cosim() -> Dict[str, np.ndarray]:
    """The switched experiment as published (Table 1: no innovation gate), plant FMU + estimator FMU, 60 s."""
    from caekf_sim.scenario import load_scenario

    sc = load_scenario(default_scenario_path())
    return fmu.cosimulate(fmu_file("plant", 3), fmu_file("estimator", 3), sc.t_end, preset="switched",
                          parameters={"gamma_gate_nis": 0.0})


def test_cosimulation_equals_the_c_experiment(cosim, truth_csv, tmp_path):
    """Plant FMU + estimator FMU in one FMPy co-simulation = caekf-truth | caekf-replay --experiment switched
    (tools/experiments.sh's pipeline), bit for bit over the whole 60 s."""
    rep = replay("double", truth_csv, tmp_path / "replay.csv", "--experiment", "switched", "--gate", "0")
    assert np.array_equal(cosim["t"], rep["t"])
    assert_same(rep, cosim, prefix="est_")


def test_cosimulation_reproduces_the_switched_experiment(cosim, sc, truth):
    """The same against the Python experiment (caekf_sim.experiments.run_experiment: the numpy reference
    filter on the Python truth). The two truths integrate the same continuous model at rtol 1e-13 (their
    samples part by ~1e-13 m on a ~1 mm motion) and the two filters are the same equations rounded in another
    order. Away from contact that leaves the states within 1e-12 m (test_c_tools' bound for the C filter
    against the numpy one on identical measurements). At each contact onset the correction maps the
    innovation into gamma through a penetration of ~1e-6 m, so a 1e-13 m difference moves gamma by ~1e-7 of
    itself for a few samples (3.8e-7 measured): the trajectory is bounded at 2e-6 of the true gamma. The
    experiment's result, the final gamma error (about -0.23 %), must agree within 1e-8 (measured 3e-11), and
    the switching (contact_active, gamma_frozen, constraint, Newton) on every step."""
    ref = run_experiment(sc, truth, "switched", keep_P=False)
    g_true = sc.contact1_gamma
    g_fmu, g_ref = cosim["est_gamma1"], ref.gamma
    assert g_fmu.shape == g_ref.shape
    assert np.max(np.abs(g_fmu - g_ref)) <= 2e-6 * g_true
    assert abs(g_fmu[-1] / g_true - g_ref[-1] / g_true) <= 1e-8
    q = np.column_stack([cosim[f"est_q{i}"] for i in range(1, 5)])
    assert np.max(np.abs(q - ref.x[:, :4])) < 1e-12
    shared = 0b100001101  # newton_not_converged, constraint_applied, contact_active, gamma_frozen
    assert np.all(((cosim["est_flags"].astype(np.int64) ^ ref.flags) & shared) == 0)
