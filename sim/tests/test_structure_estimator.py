"""A structure given as matrices through the binding, the scenario and the tools (docs/structure.md): the paper's
chain written as matrices estimates as the chain, the shipped beam example is regenerated bit for bit and
converges through `caekf-sim estimate`, and a beam family runs."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from caekf_sim.binding import Estimator, truth
from caekf_sim.measurements import columns_of
from caekf_sim.scenario import ScenarioError, load_scenario, scenario_from_text
from caekf_sim.structure.beam import BeamSpec, assemble
from caekf_sim.structure.example import EXAMPLE_MODES, filter_model, write_example
from caekf_sim.structure.family import BeamFamily, format_targets, run_family, summary
from caekf_sim.structure.files import Structure
from caekf_sim.truth import simulate

SCENARIOS = Path(__file__).resolve().parents[1] / "scenarios"
PAPER = SCENARIOS / "paper.toml"


def chain_structure(est: Estimator) -> Structure:
    """The paper's chain as matrices: its masses, the K and C its links give, the contact's e2 - e3, the input on
    body 1, the sensors on bodies 1 and 4 (built here from the scenario's links, independently of the C)."""
    sc = load_scenario(PAPER)
    k = {(1, 0): sc.k1, (1, 2): sc.k12, (3, 4): sc.k34, (4, 0): sc.k4}
    c = {(1, 0): sc.c1, (1, 2): sc.c12, (3, 4): sc.c34, (4, 0): sc.c4}
    K, C = np.zeros((4, 4)), np.zeros((4, 4))
    for (a, b), v in k.items():
        for mat, val in ((K, v), (C, c[(a, b)])):
            e = np.zeros(4)
            e[a - 1] = 1.0
            if b:
                e[b - 1] = -1.0
            mat += val * np.outer(e, e)
    W = np.zeros((4, 1))
    W[1, 0], W[2, 0] = 1.0, -1.0
    Bu = np.zeros((4, 1))
    Bu[0, 0] = 1.0
    H = np.zeros((2, 4))
    H[0, 0] = H[1, 3] = 1.0
    return Structure(M=np.diag([sc.m1, sc.m2, sc.m3, sc.m4]), K=K, C=C, Bu=Bu, W=W, H=H)


def test_the_chain_as_matrices_estimates_as_the_chain_through_the_binding() -> None:
    sc = load_scenario(PAPER)
    line = Estimator(sc)
    st = chain_structure(line)
    mats = Estimator(sc, structure=st)
    assert mats.bodies == 4 and mats.n == line.n
    tr = truth(sc.replace(t_end=25.0))  # the paper's first contacts
    a, b = line.run(tr.u, tr.y, t=tr.t), mats.run(tr.u, tr.y, t=tr.t)
    assert np.any(a.flags & 8)  # contact_active
    assert np.array_equal(a.flags, b.flags)
    np.testing.assert_allclose(b.x[:, :8], a.x[:, :8], rtol=0, atol=1e-12)
    np.testing.assert_allclose(b.gamma, a.gamma, rtol=1e-9)


def test_a_structure_with_the_wrong_shapes_is_refused_in_one_line() -> None:
    sc = load_scenario(PAPER)
    st = chain_structure(Estimator(sc))
    bad = Structure(M=st.M, K=st.K, C=st.C, Bu=st.Bu, W=st.W, H=st.H[:1])  # one sensor row for two sensors
    with pytest.raises(ValueError, match="H must hold 8 items"):
        Estimator(sc, structure=bad)


def test_a_scenario_names_its_structure_folder(tmp_path: Path) -> None:
    sc = load_scenario(SCENARIOS / "beam.toml")
    assert sc.structure.dofs == EXAMPLE_MODES + 2 and sc.structure.diagonal_mass()
    assert columns_of(sc) == (("u",), ("y1", "y2", "y3"))
    assert sc.replace(dt=2e-4).structure is sc.structure  # replace() keeps the structure it names
    with pytest.raises(ScenarioError, match="expected a quoted folder name"):
        scenario_from_text("structure = beam-structure\n", str(tmp_path / "x.toml"))
    sc2 = scenario_from_text((SCENARIOS / "beam.toml").read_text() + "t_end = 1.0\nnoise_std = 0\nseed = 1\n"
                             "truth_substeps = 10\ninput1_amp = 1\ninput1_freq = 1\ninput1_phase = 0\n",
                             str(SCENARIOS / "beam.toml"))
    with pytest.raises(ValueError, match="has its own truth"):
        simulate(sc2)


def test_the_shipped_beam_example_is_regenerated_bit_for_bit(tmp_path: Path) -> None:
    run = write_example(tmp_path)
    for name in ("beam.toml", "beam-recording.csv"):
        assert (tmp_path / name).read_bytes() == (SCENARIOS / name).read_bytes(), name
    for f in sorted((SCENARIOS / "beam-structure").iterdir()):
        assert (tmp_path / "beam-structure" / f.name).read_bytes() == f.read_bytes(), f.name
    m = run.metrics
    assert abs(m["final_err"]) < 0.01 and m["consistent_3sigma"] and not m["diverged"]


def test_the_beam_example_converges_through_caekf_sim_estimate(tmp_path: Path) -> None:
    from caekf_sim.cli import main

    out = tmp_path / "est.csv"
    assert main(["estimate", "--scenario", str(SCENARIOS / "beam.toml"), "--measurements",
                 str(SCENARIOS / "beam-recording.csv"), "--out", str(out)]) == 0
    data = np.genfromtxt(out, delimiter=",", names=True)
    gamma, p_gg = data["gamma"][-1], data["p_gg"][-1]
    assert abs(gamma / 1e8 - 1) < 0.01
    assert abs(gamma - 1e8) <= 3 * math.sqrt(p_gg)


def test_the_filter_model_keeps_the_stop_s_static_compliance() -> None:
    full, _ = assemble(BeamSpec())
    red = filter_model(full, 4)
    exact = full.W[:, 0] @ np.linalg.solve(full.K, full.W[:, 0])
    reduced = red.W[:, 0] @ np.linalg.solve(red.K, red.W[:, 0])
    assert reduced == pytest.approx(exact, rel=1e-9)
    assert red.dofs == 6 and np.allclose(red.M, np.eye(6), atol=1e-9)


def test_a_small_beam_family_runs_and_prints_its_targets() -> None:
    draws = {"length": {"dist": "fixed", "value": 0.4}, "width": {"dist": "fixed", "value": 0.025},
             "thickness": {"dist": "fixed", "value": 0.005}, "gap": {"dist": "fixed", "value": 0.5e-3},
             "gamma": {"dist": "loguniform", "low": 5e7, "high": 2e8},
             "modes": {"dist": "integers", "low": 6, "high": 7},
             "closing": {"dist": "fixed", "value": 1.2}, "freq_ratio": {"dist": "fixed", "value": 0.69},
             "noise_fraction": {"dist": "fixed", "value": 0.003}, "gamma0_ratio": {"dist": "fixed", "value": 0.8}}
    fam = BeamFamily(name="t", runs=2, seed=5, dt=1e-4, t_end=0.6, truth_substeps=10, draws=draws)
    rows = run_family(fam, workers=1, progress=False)
    assert [r["run"] for r in rows] == [0, 1]
    s = summary(rows)
    assert s["runs"] == 2 and s["diverged"] == 0 and s["admitted"] == 2
    assert all(abs(r["final_err"]) < 0.05 for r in rows)
    assert "admitted within 2 %" in format_targets(s)
