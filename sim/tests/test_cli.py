"""End-to-end through the console entry point on a shortened scenario."""
import re
from pathlib import Path

import numpy as np

from caekf_sim import flags as fl
from caekf_sim.cli import COMMAND_MODULES, build_parser, main
from caekf_sim.results import read_result_csv
from caekf_sim.scenario import default_scenario_path
from caekf_sim.truth import read_truth_csv
from recording_support import (REPO, project_version, text_without, truth_keys_in_use, write_recording,
                               write_scenario_without_truth)


def test_all_documented_subcommands_exist():
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    assert {"truth", "estimate", "experiments", "plot", "observability", "filterpy-check",
            "truth-diff"} <= set(sub.choices)
    assert len(COMMAND_MODULES) >= 2


def test_truth_estimate_and_diff(tmp_path: Path, capsys):
    t = tmp_path / "truth.csv"
    assert main(["truth", "--t-end", "1.0", "--out", str(t)]) == 0
    assert len(read_truth_csv(t)) == 1000
    e = tmp_path / "est.csv"
    assert main(["estimate", "--measurements", str(t), "--experiment", "switched", "--out", str(e)]) == 0
    r = read_result_csv(e)
    assert len(r.t) == 1000 and np.all(np.isfinite(r.x))
    assert main(["truth-diff", str(t), str(t)]) == 0
    other = tmp_path / "other.csv"
    lines = t.read_text().splitlines()
    cols = lines[5].split(",")
    cols[4] = repr(float(cols[4]) + 1e-9)  # q1 off by 1 nm
    lines[5] = ",".join(cols)
    other.write_text("\n".join(lines) + "\n")
    assert main(["truth-diff", str(t), str(other)]) == 1


def test_experiments_with_plots(tmp_path: Path, capsys):
    out = tmp_path / "exp"
    assert main(["experiments", "--t-end", "14.0", "--outdir", str(out), "--plots"]) == 0
    text = capsys.readouterr().out
    for name in ("canonical", "switched", "switched-highq", "switched-highq-constrained"):
        assert (out / f"{name}.csv").exists() and name in text
    pngs = sorted(p.name for p in out.glob("*.png"))
    assert pngs == ["fig3_p_norm.png", "fig4_gamma.png", "fig5_q2.png",
                    "fig6a_gamma_constrained.png", "fig6b_gamma_constrained.png"]
    assert all((out / p).stat().st_size > 10_000 for p in pngs)
    figs = tmp_path / "figs"
    assert main(["plot", "--results-dir", str(out), "--truth", str(out / "truth.csv"),
                 "--outdir", str(figs)]) == 0
    assert len(list(figs.glob("*.png"))) == 5


def test_observability_command_confirms_both_claims(capsys):
    assert main(["observability"]) == 0
    out = capsys.readouterr().out
    assert "claim 1 (contact active: observable, even with one position sensor): confirmed" in out
    assert "claim 2 (contact inactive: unobservable, gamma's mode at lambda = 0): confirmed" in out


def test_estimate_discretisation_in_both_engines(tmp_path: Path):
    """--discretisation reaches the C settings and the numpy config alike: the engines agree with the
    trapezoidal rule, which moves the states off the switched preset's backward Euler."""
    t = tmp_path / "truth.csv"
    assert main(["truth", "--t-end", "0.5", "--out", str(t)]) == 0
    runs = {}
    for engine in ("c", "numpy"):
        for disc in ("trapezoidal", None):
            e = tmp_path / f"{engine}-{disc}.csv"
            extra = ["--discretisation", disc] if disc else []
            assert main(["estimate", "--measurements", str(t), "--engine", engine, "--experiment", "switched",
                         "--out", str(e)] + extra) == 0
            runs[engine, disc] = read_result_csv(e).x
    np.testing.assert_allclose(runs["c", "trapezoidal"], runs["numpy", "trapezoidal"], rtol=1e-8, atol=1e-15)
    np.testing.assert_allclose(runs["c", None], runs["numpy", None], rtol=1e-8, atol=1e-15)
    assert np.max(np.abs(runs["c", "trapezoidal"][:, :8] - runs["c", None][:, :8])) > 1e-9


def test_estimate_contact_substeps_in_both_engines(tmp_path: Path):
    """--contact-substeps reaches the C settings and the numpy config alike: with the trapezoidal rule and
    4 substeps the engines agree through contact (the paper's chain driven at 0.5 Hz touches at 0.3 s),
    and the substeps move gamma and cost iterations against the preset's 1. The canonical preset: no
    innovation gate in either engine."""
    text = Path(default_scenario_path()).read_text()
    text = re.sub(r"(?m)^u_freq = .*$", "u_freq = 0.5", re.sub(r"(?m)^u_phase = .*$", "u_phase = 0.0", text))
    sc = tmp_path / "fast.toml"
    sc.write_text(text)
    t = tmp_path / "truth.csv"
    assert main(["truth", "--scenario", str(sc), "--t-end", "0.6", "--out", str(t)]) == 0
    runs = {}
    for engine, substeps in (("c", "4"), ("numpy", "4"), ("c", "1")):
        e = tmp_path / f"{engine}-{substeps}.csv"
        assert main(["estimate", "--scenario", str(sc), "--measurements", str(t), "--engine", engine,
                     "--experiment", "canonical", "--discretisation", "trapezoidal", "--contact-substeps", substeps,
                     "--out", str(e)]) == 0
        runs[engine, substeps] = read_result_csv(e)
    c4, np4, c1 = runs["c", "4"], runs["numpy", "4"], runs["c", "1"]
    assert np.count_nonzero(c4.flags & fl.CONTACT_ACTIVE) > 100
    np.testing.assert_allclose(np4.x[:, 8], c4.x[:, 8], rtol=1e-8, atol=0)
    np.testing.assert_array_equal(np4.flags, c4.flags)
    assert np.count_nonzero(np4.newton_iters != c4.newton_iters) <= len(c4.t) // 100
    assert np.max(np.abs(c4.x[:, 8] / c1.x[:, 8] - 1)) > 1e-2
    assert c4.newton_iters.sum() > 1.5 * c1.newton_iters.sum()


def test_estimate_runs_any_mechanism_as_caekf_replay_does(tmp_path: Path):
    """`caekf-sim estimate` reads the scenario's own measurement columns (the valve: t,u,y1,yv1, a velocity
    sensor) and without --experiment runs the recommended estimator, as caekf-replay does: the same
    numbers, column by column; the numpy engine follows to 1e-8 in gamma."""
    from test_binding import read_csv, tool

    import subprocess

    scenario = Path(__file__).resolve().parents[2] / "sim" / "scenarios" / "valve.toml"
    t = tmp_path / "truth.csv"
    assert main(["truth", "--scenario", str(scenario), "--t-end", "4", "--out", str(t)]) == 0
    est, ref = tmp_path / "est.csv", tmp_path / "replay.csv"
    assert main(["estimate", "--scenario", str(scenario), "--measurements", str(t), "--out", str(est)]) == 0
    subprocess.run([str(tool("caekf-replay", "double")), "--scenario", str(scenario), "--in", str(t), "--out",
                    str(ref)], check=True)
    mine, theirs = read_csv(est), read_csv(ref)
    assert list(mine) == [c for c in theirs if c in mine] and {"q2", "v2", "gamma", "p_gg", "flags"} <= set(mine)
    for column, values in mine.items():
        np.testing.assert_array_equal(values, theirs[column], err_msg=column)
    assert np.count_nonzero(mine["flags"].astype(int) & fl.CONTACT_ACTIVE) > 100
    ours = tmp_path / "numpy.csv"
    assert main(["estimate", "--scenario", str(scenario), "--measurements", str(t), "--engine", "numpy",
                 "--out", str(ours)]) == 0
    np.testing.assert_allclose(read_csv(ours)["gamma"], mine["gamma"], rtol=1e-8, atol=0)


def test_plot_and_experiments_figures_of_a_two_contact_mechanism(tmp_path: Path):
    """The shuttle (6 bodies, 2 contacts, a velocity sensor): a run's figure with its truth (contact bands
    while any contact is closed, body 2's error) and the experiments' Figs 3-6."""
    scenario = Path(__file__).resolve().parents[2] / "sim" / "scenarios" / "shuttle.toml"
    t, est, fig = tmp_path / "truth.csv", tmp_path / "est.csv", tmp_path / "run.png"
    assert main(["truth", "--scenario", str(scenario), "--t-end", "7", "--out", str(t)]) == 0  # both contacts close
    assert main(["estimate", "--scenario", str(scenario), "--measurements", str(t), "--out", str(est)]) == 0
    assert main(["plot", str(est), "--scenario", str(scenario), "--truth", str(t), "--out", str(fig)]) == 0
    assert fig.stat().st_size > 10_000
    # each contact's gamma in a panel of its own, with its own reference and its own contact bands
    from caekf_sim.mechanism import contact_values
    from caekf_sim.plots import run_figure
    from caekf_sim.scenario import load_scenario

    sc, res, truth = load_scenario(scenario), read_result_csv(est), read_truth_csv(t)
    refs = contact_values(sc, "gamma", 2)
    axes = run_figure({"est": res}, truth, refs, contact_values(sc, "n", 2)).axes
    assert len(axes) == 2 + 2  # two gammas, the norm of P, body 2's error
    for c in range(2):
        lines = axes[c].get_lines()
        np.testing.assert_array_equal(lines[0].get_ydata(), res.gammas[:, c])
        assert lines[-1].get_ydata()[0] == refs[c] and f"gamma_{c + 1}" in axes[c].get_ylabel()
        bands = [p for p in axes[c].patches]
        assert any(p.get_label() == f"contact {c + 1} (truth)" for p in bands)
    out = tmp_path / "experiments"
    assert main(["experiments", "--scenario", str(scenario), "--t-end", "2", "--outdir", str(out), "--plots",
                 "--no-progress"]) == 0
    assert {p.name for p in out.glob("fig*.png")} >= {"fig3_p_norm.png", "fig4_gamma.png", "fig5_q2.png"}


def test_observability_names_why_the_papers_claims_need_its_mechanism(capsys):
    """Without --params the command tests the paper's two claims on its chain: another mechanism gets one
    line naming the first difference and the option that does apply (exit 2), not an array error."""
    scenario = Path(__file__).resolve().parents[2] / "sim" / "scenarios" / "shuttle.toml"
    assert main(["observability", "--scenario", str(scenario)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "bodies = 6 (the paper's chain has 4)" in err[0] and "--params" in err[0]
    # FilterPy's check is the paper's canonical AEKF: the same one line, not an array error
    assert main(["filterpy-check", "--scenario", str(scenario)]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "filterpy-check" in err[0] and "bodies = 6 (the paper's chain has 4)" in err[0]


# ---- a recording's scenario (no truth-only key) through every caekf-sim tool; --version -----------------------


def test_tools_take_a_scenario_without_truth_keys(tmp_path: Path, capsys):
    """estimate (both engines), tune, plot and observability run on a recording with the scenario a user writes
    for a real mechanism: no truth-only key. The estimate equals the one with the full reference scenario."""
    scenario = write_scenario_without_truth(tmp_path / "mechanism.toml")
    rec = write_recording(tmp_path / "rec.csv")
    for engine in ("c", "numpy"):
        est, full = tmp_path / f"est-{engine}.csv", tmp_path / f"full-{engine}.csv"
        assert main(["estimate", "--scenario", str(scenario), "--measurements", str(rec), "--engine", engine,
                     "--out", str(est)]) == 0, capsys.readouterr().err
        assert main(["estimate", "--measurements", str(rec), "--engine", engine, "--out", str(full)]) == 0
        assert est.read_text() == full.read_text() and len(read_result_csv(est).t) == 300
    tuned = tmp_path / "tuned.toml"
    assert main(["tune", "--scenario", str(scenario), "--runs", str(rec), "--burn-in", "0.05", "--max-evals", "3",
                 "--out", str(tuned)]) == 0, capsys.readouterr().err
    assert tuned.exists() and "nan" not in tuned.read_text().split("\n# ")[-1].lower()
    fig = tmp_path / "fig.png"
    assert main(["plot", "--scenario", str(scenario), str(tmp_path / "est-c.csv"), "--out", str(fig)]) == 0, \
        capsys.readouterr().err
    assert fig.stat().st_size > 10_000
    capsys.readouterr()
    assert main(["observability", "--scenario", str(scenario)]) == 0, capsys.readouterr().err
    out = capsys.readouterr().out
    assert "claim 1 (contact active: observable, even with one position sensor): confirmed" in out
    assert "claim 2 (contact inactive: unobservable, gamma's mode at lambda = 0): confirmed" in out


def test_truth_commands_refuse_a_scenario_without_a_truth_key_naming_file_and_key(tmp_path: Path, capsys):
    """truth, experiments and observability --crb simulate a truth: a missing truth-only key is a one-line error
    (exit 3) naming the file and the key, and nothing is written."""
    for key in truth_keys_in_use():
        scenario = tmp_path / f"no-{key}.toml"
        scenario.write_text(text_without([key]))
        for argv in (["truth", "--out", str(tmp_path / "t.csv")], ["experiments", "--outdir", str(tmp_path / "x")],
                     ["observability", "--crb"]):
            capsys.readouterr()
            assert main([argv[0], "--scenario", str(scenario), *argv[1:]]) == 3, (key, argv)
            assert capsys.readouterr().err == (f"caekf-sim: {scenario}: missing key '{key}' (it has no default; "
                                               "simulating a truth needs it)\n"), (key, argv)
        assert not (tmp_path / "t.csv").exists() and not (tmp_path / "x").exists()


def test_version_is_the_cmake_project_version(capsys):
    """caekf-sim --version prints the project's one version (CMake's project version: sim/pyproject.toml reads
    it from there instead of keeping a copy)."""
    try:
        main(["--version"])
    except SystemExit as exc:
        assert exc.code == 0
    assert capsys.readouterr().out == f"caekf-sim {project_version()}\n"
    text = (REPO / "sim" / "pyproject.toml").read_text()
    assert re.search(r"^version\s*=", text, re.MULTILINE) is None and 'dynamic = ["version"]' in text
    assert '__version__ = "' not in (REPO / "sim" / "src" / "caekf_sim" / "__init__.py").read_text()


def test_estimate_says_in_words_when_the_model_does_not_fit(tmp_path: Path, capsys):
    """issue 27 point 4: a run that ends flagged MODEL_MISMATCH is said in words by `estimate`; a fitting one
    is not. The record is the reference truth; the mismatched scenario's spring 1 (body 1 to the ground,
    which sets the quasi-static positions) is 10 % stiffer than the truth's."""
    t = tmp_path / "truth.csv"
    assert main(["truth", "--t-end", "3.0", "--out", str(t)]) == 0
    capsys.readouterr()
    e = tmp_path / "est.csv"
    assert main(["estimate", "--measurements", str(t), "--out", str(e)]) == 0
    assert "model mismatch" not in capsys.readouterr().out
    k1 = next(ln for ln in REPO.joinpath("sim/scenarios/paper.toml").read_text().splitlines() if ln.startswith("k1 "))
    wrong = tmp_path / "wrong.toml"
    wrong.write_text(REPO.joinpath("sim/scenarios/paper.toml").read_text().replace(k1, "k1 = 2.2e3", 1))
    assert main(["estimate", "--scenario", str(wrong), "--measurements", str(t), "--out", str(e)]) == 0
    out = capsys.readouterr().out
    assert re.search(r"model mismatch: the innovations have not fitted the model since t = [0-9.]+ s", out), out
    assert read_result_csv(e).flags[-1] & fl.MODEL_MISMATCH
