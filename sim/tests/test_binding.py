"""The C binding (caekf_sim.Estimator / run) against caekf-replay, bit for bit, in double and in float.

The C tools are looked up in $CAEKF_BUILD_DIR/host (the double build, as in tools/run-tests.sh) and
build/host-double/host; the float build in $CAEKF_BUILD_DIR_FLOAT/host, the host-float sibling of
$CAEKF_BUILD_DIR, and build/host-float/host. Without them these comparisons are skipped, except where
$CAEKF_BUILD_DIR is set (CI), where a missing tool fails.
"""
from __future__ import annotations

import os
import pickle
import subprocess
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context
from pathlib import Path
from typing import Dict, Optional

import numpy as np
import pytest

import caekf_sim
from caekf_sim import flags as fl
from caekf_sim.binding import check_build
from caekf_sim.scenario import ScenarioError, default_scenario_path, load_scenario

REPO = Path(__file__).resolve().parents[2]
EXPERIMENTS = ("canonical", "switched", "switched-highq", "switched-highq-constrained")
REPLAY_COLUMNS = "t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters,nis".split(",")


def host_dirs(precision: str):
    env = os.environ.get("CAEKF_BUILD_DIR")
    dirs = []
    if precision == "double":
        if env:
            dirs.append(Path(env) / "host")
    else:
        if os.environ.get("CAEKF_BUILD_DIR_FLOAT"):
            dirs.append(Path(os.environ["CAEKF_BUILD_DIR_FLOAT"]) / "host")
        if env:
            dirs.append(Path(env).parent / "host-float" / "host")
    dirs.append(REPO / "build" / f"host-{precision}" / "host")
    return dirs


def tool(name: str, precision: str) -> Path:
    for d in host_dirs(precision):
        if (d / name).is_file() and os.access(d / name, os.X_OK):
            return d / name
    if os.environ.get("CAEKF_BUILD_DIR"):  # CI names the build: a missing tool is a failure
        pytest.fail(f"{name} ({precision}) not found in {[str(d) for d in host_dirs(precision)]}")
    pytest.skip(f"{name} ({precision}) not built")


def read_csv(path: Path) -> Dict[str, np.ndarray]:
    """Columns of a CSV, parsed with Python's float (correctly rounded, so %.17g values come back exactly)."""
    lines = Path(path).read_text().splitlines()
    header = lines[0].split(",")
    cells = np.array([ln.split(",") for ln in lines[1:] if ln], dtype=str)
    cells[cells == ""] = "nan"
    return {h: cells[:, i].astype(np.float64) for i, h in enumerate(header)}


def replay(precision: str, csv: Path, out: Path, *args: str, scenario: Optional[Path] = None) -> Dict[str, np.ndarray]:
    subprocess.run([str(tool("caekf-replay", precision)), "--scenario", str(scenario or default_scenario_path()),
                    "--in", str(csv), "--out", str(out), *args], check=True, timeout=300)
    return read_csv(out)


def assert_same_as_replay(rep: Dict[str, np.ndarray], res: caekf_sim.RunResult) -> None:
    """Every column of caekf-replay's output equals the binding's, bit for bit (nis as replay prints it)."""
    def same(a, b, what):
        a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
        assert a.shape == b.shape, what
        bad = ~((a == b) | (np.isnan(a) & np.isnan(b)))
        assert not bad.any(), f"{what}: {int(bad.sum())} rows differ, first at row {int(np.argmax(bad))}"

    same(rep["t"], res.t, "t")
    for i, name in enumerate(REPLAY_COLUMNS[1:10]):
        same(rep[name], res.x[:, i], name)
    same(rep["p_norm"], res.p_norm, "p_norm")
    same(rep["p_gg"], res.p_gg, "p_gg")
    same(rep["flags"], res.flags, "flags")
    same(rep["newton_iters"], res.newton_iters, "newton_iters")
    # caekf-replay prints nis with %.9g
    same(rep["nis"], np.char.mod("%.9g", res.nis).astype(np.float64), "nis")


def test_build_is_current():
    """The installed modules were built from this checkout's C sources (else: rerun tools/bootstrap.sh)."""
    check_build(REPO)
    assert caekf_sim.binding._module("double").SCALAR == "double"
    assert caekf_sim.binding._module("float").SCALAR == "float"


@pytest.mark.parametrize("precision", ["double", "float"])
@pytest.mark.parametrize("experiment", EXPERIMENTS)
def test_run_equals_replay_bit_for_bit(experiment, precision, truth_csv, truth_cols, tmp_path):
    rep = replay(precision, truth_csv, tmp_path / "replay.csv", "--experiment", experiment)
    sc = load_scenario(default_scenario_path())
    y = np.column_stack([truth_cols["y1"], truth_cols["y4"]])
    res = caekf_sim.run(sc, truth_cols["u"], y, t=truth_cols["t"], experiment=experiment, precision=precision,
                        p_norm=True)
    assert res.precision == precision
    assert_same_as_replay(rep, res)


@pytest.mark.parametrize("precision", ["double", "float"])
def test_missing_measurements_bridged_like_replay(precision, truth_cols, tmp_path):
    """Rows without y (a 0.2 s gap in contact, and scattered single rows) go through caekf_predict,
    as `caekf-replay --missing-y-predict` does."""
    n = len(truth_cols["t"])
    missing = np.zeros(n, dtype=bool)
    contact = np.flatnonzero(truth_cols["delta"] > 0)
    missing[contact[0] + 50: contact[0] + 250] = True
    missing[np.random.default_rng(1).choice(n, 300, replace=False)] = True
    y = np.column_stack([truth_cols["y1"], truth_cols["y4"]])
    y[missing] = np.nan
    csv = tmp_path / "gaps.csv"
    with open(csv, "w") as f:
        f.write("t,u,y1,y4\n")
        for k in range(n):
            yy = ",," if missing[k] else f",{y[k, 0]:.17g},{y[k, 1]:.17g}"
            f.write(f"{truth_cols['t'][k]:.17g},{truth_cols['u'][k]:.17g}{yy}\n")
    rep = replay(precision, csv, tmp_path / "replay.csv", "--missing-y-predict")
    res = caekf_sim.run(default_scenario_path(), truth_cols["u"], y, t=truth_cols["t"], precision=precision,
                        p_norm=True)
    assert np.array_equal(~res.has_y, missing)
    assert np.array_equal((res.flags & fl.NO_MEASUREMENT) != 0, missing)
    assert_same_as_replay(rep, res)


def test_bad_scenario_refused_with_the_c_message(tmp_path):
    """A scenario file is read by the schema's rules: the binding's message is caekf-replay's."""
    text = default_scenario_path().read_text()
    bad = tmp_path / "bad.toml"
    bad.write_text(text.replace("sigma_r = 1.0e-7", "sigma_r = -1.0e-7"))
    assert "sigma_r = -1.0e-7" in bad.read_text()
    p = subprocess.run([str(tool("caekf-replay", "double")), "--scenario", str(bad), "--in", "/dev/null"],
                       capture_output=True, text=True)
    assert p.returncode == 3
    c_message = p.stderr.strip().removeprefix("caekf-replay: ")
    for precision in ("double", "float"):
        with pytest.raises(ScenarioError) as exc:
            caekf_sim.Estimator(bad, precision=precision)
        assert str(exc.value) == c_message


@pytest.mark.parametrize("field,value,text", [
    ("psd_check_period", 0, "psd_check_period = 0: must be an integer in [1, 1000]"),
    ("mode", 7, "mode = 7: must be one of 0 (canonical), 1 (switched)"),
    ("dt", 0.0, "dt = 0: must be finite and > 0"),
    ("m3", -1.0, "m[2] = -1: must be finite and > 0"),
    ("newton_max_iter", 99, "newton_max_iter = 99: must be an integer in [1, 20]"),
    ("gamma0", 0.0, "gamma0[0] = 0: must be within gamma_min .. gamma_max while constraint_enabled")])
def test_settings_validation_names_the_element(field, value, text):
    """Settings the C validation refuses: its message, naming the element, its value and the rule."""
    sc = load_scenario(default_scenario_path())
    extra = {"constraint_enabled": 1} if field == "gamma0" else {}
    with pytest.raises(caekf_sim.SettingsError) as exc:
        caekf_sim.Estimator(sc, **{field: value}, **extra)
    assert str(exc.value) == "settings refused: " + text


def test_unknown_enum_name_is_a_one_line_error():
    sc = load_scenario(default_scenario_path())
    with pytest.raises(ValueError, match=r"^mode = 'sideways': must be one of"):
        caekf_sim.Estimator(sc, mode="sideways")


@pytest.mark.parametrize("precision", ["double", "float"])
def test_step_and_predict_equal_run(precision, truth_cols):
    """Estimator.step / predict one call at a time give run()'s results, bit for bit."""
    n = 14000  # into the first contact (about 12.8 s)
    u, y = truth_cols["u"][:n], np.column_stack([truth_cols["y1"], truth_cols["y4"]])[:n].copy()
    y[13000:13040] = np.nan
    res = caekf_sim.run(default_scenario_path(), u, y, precision=precision)
    est = caekf_sim.Estimator(default_scenario_path(), precision=precision)
    xs, nis, flags, iters, delta, pd = [], [], [], [], [], []
    for k in range(n):
        r = est.predict(u[k]) if np.isnan(y[k, 0]) else est.step(u[k], y[k])
        xs.append(est.x)
        pd.append(np.diag(est.P))
        nis.append(r.nis)
        flags.append(r.flags)
        iters.append(r.newton_iters)
        delta.append(r.delta)
        assert r.status == 0
    assert np.array_equal(np.array(xs), res.x)
    assert np.array_equal(np.array(pd), res.P_diag)
    assert np.array_equal(np.array(nis), res.nis)
    assert np.array_equal(np.array(flags), res.flags)
    assert np.array_equal(np.array(iters), res.newton_iters)
    assert np.array_equal(np.array(delta), res.delta)
    assert (res.flags & fl.CONTACT_ACTIVE).any()
    assert est.step_count == n
    assert est.gamma == res.gamma[-1]


def test_non_finite_input_is_reported_not_raised():
    est = caekf_sim.Estimator(default_scenario_path())
    x0 = est.x
    r = est.step(float("nan"), [0.0, 0.0])
    assert r.status == -4 and r.flags & fl.INPUT_REJECTED
    assert np.array_equal(est.x, x0)
    assert caekf_sim.binding._module("double").status_str(r.status)


def test_float_is_float():
    """The two modules are two builds: float rounds differently, and its defaults follow its epsilon."""
    sc = load_scenario(default_scenario_path())
    d, f = caekf_sim.settings_for(sc), caekf_sim.settings_for(sc, precision="float")
    assert f.newton_rtol > 1e6 * d.newton_rtol
    u = np.zeros(100)
    y = np.full((100, 2), 1e-5)
    assert not np.array_equal(caekf_sim.run(d, u, y).x, caekf_sim.run(f, u, y).x)
    with pytest.raises(ValueError, match="built for double"):
        caekf_sim.Estimator(d, precision="float")


def test_run_in_process_pool(truth_cols):
    """run() and its inputs and results pickle: the same results from spawned worker processes."""
    sc = load_scenario(default_scenario_path())
    n = 5000
    u, y = truth_cols["u"][:n], np.column_stack([truth_cols["y1"], truth_cols["y4"]])[:n]
    jobs = [(caekf_sim.settings_for(sc, e, p), u, y) for e, p in (("canonical", "double"), ("switched", "float"))]
    with ProcessPoolExecutor(max_workers=2, mp_context=get_context("spawn")) as pool:
        remote = [f.result() for f in [pool.submit(caekf_sim.run, *job) for job in jobs]]
    for job, r in zip(jobs, remote):
        local = caekf_sim.run(*job)
        assert r.settings == local.settings
        assert np.array_equal(r.x, local.x) and np.array_equal(r.flags, local.flags)


def test_estimator_pickles_mid_run(truth_cols):
    u, y = truth_cols["u"][:2000], np.column_stack([truth_cols["y1"], truth_cols["y4"]])[:2000]
    a = caekf_sim.Estimator(default_scenario_path(), precision="float")
    a.run(u[:1000], y[:1000])
    b = pickle.loads(pickle.dumps(a))
    ra, rb = a.run(u[1000:], y[1000:]), b.run(u[1000:], y[1000:])
    assert np.array_equal(ra.x, rb.x) and b.step_count == 2000


@pytest.mark.parametrize("experiment", ["canonical", "switched"])
def test_log_det_s_is_the_innovation_covariance(experiment, truth_cols):
    """run(log_det_s=True) derives log det S_k from the posterior P; check it against S = H P- H' + R
    from the prior P- that caekf_predict gives on a copy of the estimator just before step k."""
    n = 13500  # past the first contact (about 12.8 s)
    u, y = truth_cols["u"][:n], np.column_stack([truth_cols["y1"], truth_cols["y4"]])[:n]
    sc = load_scenario(default_scenario_path())
    res = caekf_sim.run(sc, u, y, experiment=experiment, log_det_s=True)
    est = caekf_sim.Estimator(sc, experiment=experiment)
    checked = 0
    for k in range(n):
        if k in (0, 1, 500, 12790, 12800, 12900, 13400) or k % 1000 == 999:
            prior = pickle.loads(pickle.dumps(est))
            prior.predict(u[k])
            P = prior.P
            S = P[np.ix_([0, 3], [0, 3])] + sc.sigma_r ** 2 * np.eye(2)
            assert np.isfinite(res.log_det_s[k]), k
            assert res.log_det_s[k] == pytest.approx(np.log(np.linalg.det(S)), rel=1e-9, abs=1e-9), k
            checked += 1
        est.step(u[k], y[k])
    assert checked >= 15
    assert np.array_equal(est.x, res.x[-1])
    assert (res.flags[12790:13400] & fl.CONTACT_ACTIVE).any()


def test_c_names_reachable():
    from caekf_sim.binding import experiment_names, flag_name, status_str

    assert experiment_names() == EXPERIMENTS
    assert [flag_name(b) for b in range(12)] == [fl.NAMES[1 << b] for b in range(12)]
    assert status_str(0) == "ok" and status_str(-4) != status_str(-5)


def test_truth_equals_caekf_truth(tmp_path):
    """binding.truth runs caekf-truth's generator: the same samples, noise included, bit for bit."""
    from caekf_sim.binding import truth
    from caekf_sim.settings_adapter import scenario_toml

    sc = load_scenario(default_scenario_path()).replace(t_end=13.5, noise_std=1e-7, seed=7)
    path = tmp_path / "s.toml"
    path.write_text(scenario_toml(sc))
    out = tmp_path / "truth.csv"
    subprocess.run([str(tool("caekf-truth", "double")), "--scenario", str(path), "--out", str(out), "--quiet"],
                   check=True, timeout=300)
    c = read_csv(out)
    tr = truth(sc)
    assert len(tr) == len(c["t"]) == 13500
    for name, mine in (("t", tr.t), ("u", tr.u), ("y1", tr.y[:, 0]), ("y4", tr.y[:, 1]), ("delta", tr.delta)):
        assert np.array_equal(mine, c[name]), name
    for i in range(4):
        assert np.array_equal(tr.q[:, i], c[f"q{i + 1}"]) and np.array_equal(tr.v[:, i], c[f"v{i + 1}"])
    assert (tr.delta > 0).any() and not np.array_equal(tr.y[:, 0], tr.q[:, 0])


def _spring_off(tmp_path: Path) -> tuple:
    """The paper's mechanism whose true spring 1 (body 1 - ground) is 5 % stiffer than the filter's setting,
    the filter told so by spring1_k_sigma = 0.1 and, for a second parameter, m3_sigma = 0.03 (m3 exact):
    the filter's scenario file, the truth's CSV (caekf-truth's C generator) and the truth's scenario."""
    from caekf_sim.truth import write_truth_csv

    sc = load_scenario(default_scenario_path())
    true_sc = sc.replace(spring1_k=1.05 * sc.spring1_k)
    scen, csv = tmp_path / "declared.toml", tmp_path / "truth.csv"
    # the reference file plus the two lines a user adds (every other key as the file gives it: a default
    # relative to the build's epsilon stays each build's own)
    scen.write_text(default_scenario_path().read_text() + "spring1_k_sigma = 0.1\nm3_sigma = 0.03\n")
    write_truth_csv(caekf_sim.binding.truth(true_sc), csv)
    return scen, csv, true_sc


@pytest.mark.parametrize("precision", ["double", "float"])
def test_mechanism_parameters_columns_equal_replay_and_converge(precision, tmp_path):
    """Declared mechanism parameters (spring1_k_sigma, m3_sigma) are named by their scenario keys in both
    outputs: caekf-replay's columns m3, spring1_k after the gammas and p_m3, p_spring1_k after p_gg, and
    RunResult.mech / p_mech, equal bit for bit; on a record whose true spring 1 is 5 % off, the estimate of
    spring1_k ends at the truth within 0.5 % and 3 sigma, m3 at its (exact) value, and gamma within 1 %."""
    scen, csv, true_sc = _spring_off(tmp_path)
    rep = replay(precision, csv, tmp_path / "replay.csv", scenario=scen)
    header = (tmp_path / "replay.csv").read_text().split("\n", 1)[0].split(",")
    assert header == ("t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,m3,spring1_k,p_norm,p_gg,p_m3,p_spring1_k,flags,"
                      "newton_iters,nis").split(",")
    cols = read_csv(csv)
    res = caekf_sim.run(load_scenario(scen), cols["u"], np.column_stack([cols["y1"], cols["y4"]]), t=cols["t"],
                        precision=precision, p_norm=True)
    assert list(res.mech) == ["m3", "spring1_k"] and list(res.p_mech) == ["p_m3", "p_spring1_k"]
    assert_same_as_replay(rep, res)
    for name, series in {**res.mech, **res.p_mech}.items():
        bad = series != rep[name]
        assert not bad.any(), f"{name}: {int(bad.sum())} rows differ from caekf-replay's"
    # the values are the parameters in SI, their variances P's, starting at the settings and sigma^2 value^2
    assert res.mech["spring1_k"][0] == pytest.approx(2000.0, rel=1e-3)
    assert res.p_mech["p_spring1_k"][0] == pytest.approx((0.1 * 2000.0) ** 2, rel=1e-3)
    k, var_k = res.mech["spring1_k"][-1], res.p_mech["p_spring1_k"][-1]
    assert abs(k / true_sc.spring1_k - 1) < 0.005 and (k - true_sc.spring1_k) ** 2 <= 9 * var_k
    assert abs(res.mech["m3"][-1] / true_sc.m3 - 1) < 0.01
    assert abs(res.gamma[-1] / true_sc.gamma - 1) < 0.01
    # the same record without the declaration: the filter's own spring is wrong and so is gamma
    undeclared = caekf_sim.run(load_scenario(default_scenario_path()), cols["u"],
                               np.column_stack([cols["y1"], cols["y4"]]), t=cols["t"], precision=precision)
    assert undeclared.mech == {} and undeclared.n == res.n - 2
    assert abs(undeclared.gamma[-1] / true_sc.gamma - 1) > 0.02
