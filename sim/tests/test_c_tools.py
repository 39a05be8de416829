"""Cross-check against the C tools (caekf-truth, caekf-replay) when a build is present.

Looks in $CAEKF_BUILD_DIR/host, then build/<preset>/host for the double-precision presets.
Skipped when no build exists (the Python package must also work on its own).
"""
import os
import re
import subprocess
from pathlib import Path

import numpy as np
import pytest

from caekf_sim.results import read_result_csv
from caekf_sim.scenario import default_scenario_path
from caekf_sim.truth import read_truth_csv, write_truth_csv
from recording_support import (project_version, text_without, truth_keys_in_use, write_recording,
                               write_scenario_without_truth)

REPO = Path(__file__).resolve().parents[2]


def find_tool(name: str):
    dirs = []
    if os.environ.get("CAEKF_BUILD_DIR"):
        dirs.append(Path(os.environ["CAEKF_BUILD_DIR"]) / "host")
    dirs += [REPO / "build" / p / "host" for p in ("dev", "release", "dev-asan")]
    for d in dirs:
        if (d / name).is_file() and os.access(d / name, os.X_OK):
            return d / name
    return None


@pytest.fixture(scope="module")
def c_truth_csv(tmp_path_factory):
    tool = find_tool("caekf-truth")
    if tool is None:
        if os.environ.get("CAEKF_BUILD_DIR"):  # CI names the build: missing tools are a failure
            pytest.fail("caekf-truth not found under $CAEKF_BUILD_DIR/host")
        pytest.skip("caekf-truth not built")
    out = tmp_path_factory.mktemp("c") / "truth.csv"
    subprocess.run([str(tool), "--scenario", str(default_scenario_path()), "--out", str(out), "--quiet"],
                   check=True, timeout=120)
    return out


def test_c_truth_matches_numpy_truth(c_truth_csv, truth):
    c = read_truth_csv(c_truth_csv)
    assert len(c) == len(truth)
    np.testing.assert_allclose(c.t, truth.t, rtol=1e-15)
    # two implementations of the continuous model, each within 1e-10 m of the reference (docs/truth.md)
    assert np.max(np.abs(c.q - truth.q)) < 2e-10  # metres
    assert np.max(np.abs(c.y - truth.y)) < 2e-10


@pytest.mark.parametrize("name", ["canonical", "switched", "switched-highq-constrained"])
def test_c_replay_matches_numpy_estimator(name, truth, results, sc, tmp_path):
    """Same equations, same Newton test: agreement far below any physical effect. The innovation
    gate is off in the C run (the numpy reference has none; on the continuous truth it can fire).

    (switched-highq is left out: after its Newton failures the trajectory is chaotic.)
    """
    tool = find_tool("caekf-replay")
    if tool is None:
        if os.environ.get("CAEKF_BUILD_DIR"):  # CI names the build: missing tools are a failure
            pytest.fail("caekf-replay not found under $CAEKF_BUILD_DIR/host")
        pytest.skip("caekf-replay not built")
    out = tmp_path / f"{name}.csv"
    measurements = tmp_path / "truth.csv"  # the numpy estimator's own input, bit for bit
    write_truth_csv(truth, measurements)
    subprocess.run([str(tool), "--scenario", str(default_scenario_path()), "--in", str(measurements),
                    "--out", str(out), "--experiment", name, "--gate", "0"],  # the numpy filter has no gate
                   check=True, timeout=120)
    c, py = read_result_csv(out), results[name]
    assert np.max(np.abs(c.gamma - py.gamma)) < 1e-8 * sc.gamma
    assert np.max(np.abs(c.x[:, :4] - py.x[:, :4])) < 1e-12
    both = ~(c.flags ^ py.flags) & 0xFFFF  # bits on which the two agree
    shared = 0b100001101  # newton_not_converged, constraint_applied, contact_active, gamma_frozen
    assert np.all((both & shared) == shared)


@pytest.mark.parametrize("name, fires", [("switched", True), ("switched-highq-constrained", False)])
def test_c_replay_with_its_gate_matches_numpy_with_the_scenarios_settings(name, fires, truth, sc, tmp_path):
    """caekf-replay as it runs by default (innovation gate 25 on) against the numpy reference configured
    from the same scenario and preset (experiments.scenario_config): the gate holds gamma on the same
    steps in both."""
    from caekf_sim.estimator import run_estimator
    from caekf_sim.experiments import scenario_config

    tool = find_tool("caekf-replay")
    if tool is None:
        if os.environ.get("CAEKF_BUILD_DIR"):
            pytest.fail("caekf-replay not found under $CAEKF_BUILD_DIR/host")
        pytest.skip("caekf-replay not built")
    out, measurements = tmp_path / f"{name}.csv", tmp_path / "truth.csv"
    write_truth_csv(truth, measurements)
    subprocess.run([str(tool), "--scenario", str(default_scenario_path()), "--in", str(measurements),
                    "--out", str(out), "--experiment", name], check=True, timeout=120)
    cfg = scenario_config(sc, name)
    assert cfg.gate_nis == 25.0
    py = run_estimator(sc, cfg, truth.t, truth.u, truth.y, keep_P=False)
    c = read_result_csv(out)
    gated = 0x800
    assert np.any(py.flags & gated) == fires  # switched: NIS 27 at the onsets (README)
    np.testing.assert_array_equal(c.flags & gated, py.flags & gated)
    assert np.max(np.abs(c.gamma - py.gamma)) < 1e-8 * sc.gamma


# ---- a recording's scenario (no truth-only key) through every C tool; --version of every tool ----------------


def _build_host() -> Path:
    """The build's host/ folder (the one find_tool takes caekf-replay from)."""
    tool = find_tool("caekf-replay")
    if tool is None:
        if os.environ.get("CAEKF_BUILD_DIR"):
            pytest.fail("caekf-replay not found under $CAEKF_BUILD_DIR/host")
        pytest.skip("the C tools are not built")
    return tool.parent


def _host_tool(name: str) -> Path:
    """A host executable by name anywhere under the build's host/ (caekf-host is in host/caekf_host/)."""
    found = [p for p in _build_host().rglob(name) if p.is_file() and os.access(p, os.X_OK)]
    if not found:
        pytest.fail(f"{name} not built under {_build_host()}")
    return found[0]


def _run(args, **kw):
    return subprocess.run([str(a) for a in args], capture_output=True, text=True, timeout=120, **kw)


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    d = tmp_path_factory.mktemp("recording")
    return write_scenario_without_truth(d / "mechanism.toml"), write_recording(d / "rec.csv")


def test_every_host_executable_answers_version_with_the_cmake_project_version():
    """Every executable built from host/ (caekf-replay, caekf-truth, caekf-bench, caekf-reference, caekf-host,
    and any added later) prints "<name> <project version> (<scalar>)" and exits 0."""
    host = _build_host()
    tools = sorted(p for p in host.rglob("*") if p.is_file() and os.access(p, os.X_OK)
                   and "CMakeFiles" not in p.parts and p.suffix == "")
    names = {p.name for p in tools}
    assert {"caekf-replay", "caekf-truth", "caekf-bench", "caekf-reference"} <= names, names
    for p in tools:
        r = _run([p, "--version"])
        assert r.returncode == 0, (p.name, r.stderr)
        assert re.fullmatch(rf"{re.escape(p.name)} {re.escape(project_version())} \((double|float)\)\n", r.stdout), \
            (p.name, r.stdout)


def test_replay_bench_reference_and_host_take_a_scenario_without_truth_keys(recording, tmp_path):
    """A recording's scenario has no truth-only key: caekf-replay estimates from it exactly what it estimates
    with the full reference scenario (the truth keys are never read), --summary has no gamma error to give."""
    scenario, rec = recording
    est, full = tmp_path / "est.csv", tmp_path / "full.csv"
    r = _run([_host_tool("caekf-replay"), "--scenario", scenario, "--in", rec, "--out", est, "--summary"])
    assert r.returncode == 0, r.stderr
    assert _run([_host_tool("caekf-replay"), "--scenario", default_scenario_path(), "--in", rec, "--out", full]
                ).returncode == 0
    assert est.read_text() == full.read_text() and len(est.read_text().splitlines()) == 301
    assert r.stderr.split()[4] == "-"  # the final gamma error: there is no true gamma
    r = _run([_host_tool("caekf-bench"), scenario, rec, "1"])
    assert r.returncode == 0 and "switched" in r.stdout, r.stderr
    r = _run([_host_tool("caekf-reference"), scenario, rec, tmp_path / "ref.h"])
    assert r.returncode == 0 and "reference_f64_final_gamma" in (tmp_path / "ref.h").read_text(), r.stderr
    # caekf-host reads the scenario and configures the estimator before it opens the bus
    r = _run([_host_tool("caekf-host"), "--scenario", scenario, "--iface", "caekfnosuch0"])
    assert "no network interface 'caekfnosuch0'" in r.stderr and "missing" not in r.stderr, r.stderr


@pytest.mark.parametrize("key", truth_keys_in_use())
def test_truth_refuses_a_scenario_without_a_truth_key_naming_file_and_key(key, tmp_path):
    """caekf-truth simulates a truth: each truth-only key it needs is refused when absent, in one line naming
    the file and the key, before any output exists."""
    scenario = tmp_path / "no-truth.toml"
    scenario.write_text(text_without([key]))
    out = tmp_path / "truth.csv"
    r = _run([_host_tool("caekf-truth"), "--scenario", scenario, "--out", out])
    assert r.returncode == 3
    assert r.stderr == f"caekf-truth: {scenario}: missing key '{key}' (it has no default; simulating a truth " \
                       "needs it)\n"
    assert not out.exists()


def test_estimate_csv_carries_the_mechanism_parameters_as_replay_does(tmp_path):
    """`caekf-sim estimate` writes caekf-replay's columns for declared mechanism parameters (m3, spring1_k
    after the gammas, p_m3, p_spring1_k after p_gg), the same text in every shared column, on a record whose
    true spring 1 is 5 % stiffer than the filter's setting (declared spring1_k_sigma = 0.1)."""
    from caekf_sim import binding
    from caekf_sim.campaign.spec import scenario_text
    from caekf_sim.cli import main
    from caekf_sim.scenario import load_scenario

    sc = load_scenario(default_scenario_path())
    true_sc = sc.replace(spring1_k=1.05 * sc.spring1_k)
    scen, meas = tmp_path / "declared.toml", tmp_path / "truth.csv"
    scen.write_text(scenario_text(sc.replace(spring1_k_sigma=0.1, m3_sigma=0.03)))
    write_truth_csv(binding.truth(true_sc), meas)
    rep, est = tmp_path / "replay.csv", tmp_path / "estimate.csv"
    r = _run([_host_tool("caekf-replay"), "--scenario", scen, "--in", meas, "--out", rep])
    assert r.returncode == 0, r.stderr
    assert main(["estimate", "--scenario", str(scen), "--measurements", str(meas), "--out", str(est),
                 "--no-progress"]) == 0
    rl, el = rep.read_text().splitlines(), est.read_text().splitlines()
    rh, eh = rl[0].split(","), el[0].split(",")
    assert eh == ("t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,m3,spring1_k,p_norm,p_gg,p_m3,p_spring1_k,flags,"
                  "newton_iters").split(",")
    assert len(rl) == len(el) == 60001
    rc = list(zip(*(ln.split(",") for ln in rl[1:])))
    ec = list(zip(*(ln.split(",") for ln in el[1:])))
    for name in eh:
        assert ec[eh.index(name)] == rc[rh.index(name)], name
    k = float(ec[eh.index("spring1_k")][-1])
    assert abs(k / true_sc.spring1_k - 1) < 0.005
