"""Family specs, campaign metrics, and the campaign locally and on a Dask LocalCluster."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from caekf_sim import flags as fl
from caekf_sim.campaign.estimate import Estimate
from caekf_sim.campaign.metrics import run_metrics
from caekf_sim.campaign.runner import TIMING_COLUMNS, run_family
from caekf_sim.campaign.spec import evaluate, load_family, load_spec
from caekf_sim.campaign.tools import c_tool

SPEC = Path(__file__).resolve().parents[1] / "families" / "issue14.toml"
needs_c = pytest.mark.skipif(c_tool("caekf-truth") is None or c_tool("caekf-replay") is None,
                             reason="C host tools not built")


def test_spec_is_reproducible_and_prefix_stable():
    a, b, c = load_spec(SPEC, runs=5), load_spec(SPEC, runs=5), load_spec(SPEC, runs=3)
    assert [r.scenario for r in a.runs] == [r.scenario for r in b.runs]
    assert [r.scenario for r in a.runs[:3]] == [r.scenario for r in c.runs]
    assert load_spec(SPEC, runs=3, seed=1).runs[0].scenario != c.runs[0].scenario


def test_family_ranges_and_tuning_rules():
    fam = load_spec(SPEC, runs=60)
    for r in fam.runs:
        s, v = r.scenario, r.values
        for m in (s.m1, s.m2, s.m3, s.m4):
            assert 0.5 <= m <= 2.0
        for k in (s.k1, s.k12, s.k34, s.k4):
            assert 1e3 <= k <= 2e4
        for c in (s.c1, s.c12, s.c34, s.c4):
            assert 1.0 <= c <= 10.0
        assert 0.5e-3 <= s.gap <= 2e-3 and 1e7 <= s.gamma <= 1e9
        assert 0.5 <= s.gamma0 / s.gamma <= 1.5
        assert s.noise_std in (0.0, 5e-9, 2e-8, 5e-8)
        assert 0.03 <= s.u_freq <= 0.2
        assert 1.15 <= s.u_amp / (s.k1 * s.gap) <= 1.8
        # the filter is tuned from its own initial gamma, never from the truth
        assert s.sigma_gamma0 == pytest.approx(s.gamma0 / 3, rel=1e-15)
        assert s.sigma_q_gamma == pytest.approx(s.gamma0 / 75, rel=1e-15)
        assert s.gamma_min == pytest.approx(s.gamma0 / 75, rel=1e-15)
        assert v["gamma0_ratio"] == pytest.approx(s.gamma0 / s.gamma, rel=1e-14)
    # log-uniform: about as many mechanisms below 1e8 as above
    below = sum(r.scenario.gamma < 1e8 for r in fam.runs)
    assert 15 <= below <= 45


def test_expressions_are_arithmetic_only():
    assert evaluate("2 * a + sqrt(b) - pi", {"a": 1.0, "b": 4.0}) == pytest.approx(4 - math.pi)
    for bad in ("__import__('os')", "a.b", "c", "[1]"):
        with pytest.raises(ValueError):
            evaluate(bad, {"a": 1.0})


def test_folder_family(tmp_path):
    from caekf_sim.cli import main

    assert main(["family", str(SPEC), "--runs", "3", "--out", str(tmp_path)]) == 0
    fam = load_family(tmp_path)
    spec = load_spec(SPEC, runs=3)
    assert [r.scenario for r in fam.runs] == [r.scenario for r in spec.runs]


def test_metrics_follow_their_definitions():
    n = 1000
    t = np.arange(1, n + 1) * 1e-3
    delta = np.full(n, -1e-4)
    delta[200:400] = 1e-6  # one contact episode, exit at k = 400
    g_true = 1e8
    gamma = np.full(n, 0.8 * g_true)
    gamma[200:] = np.linspace(0.8, 1.0, 800) * g_true
    p_gg = np.full(n, (0.01 * g_true) ** 2)
    nis = np.linspace(0.0, 4.0, n)
    flags = np.zeros(n, dtype=np.int64)
    flags[300] = 2048
    m = run_metrics(t, g_true, delta, Estimate(gamma, p_gg, nis, flags))
    err = gamma / g_true - 1
    assert m["final_err"] == err[-1]
    assert m["last_exit_err"] == err[400]
    first_in = np.flatnonzero(np.abs(err) <= 0.05)[0]
    assert m["t_converge_5pct"] == t[first_in]
    assert not m["diverged"]
    assert m["nees_final"] == pytest.approx(err[-1] ** 2 * g_true**2 / p_gg[-1])
    assert m["nis_mean"] == pytest.approx(nis.mean()) and m["nis_max"] == nis.max()
    assert m["nis_mean_free_before_contact"] == pytest.approx(nis[:200].mean())
    assert m["steps_gamma_gated"] == 1 and "gamma_gated" in m["flags_seen_names"]
    gamma[-1] = -1.0
    assert run_metrics(t, g_true, delta, Estimate(gamma, p_gg, nis, flags))["diverged"]
    gamma[-1] = np.nan
    assert run_metrics(t, g_true, delta, Estimate(gamma, p_gg, nis, flags))["diverged"]


def test_metrics_of_several_contacts_report_each_and_the_worst():
    """Two contacts: contact 1's columns as for one contact, contact 2's with _c2; contact 2 diverges, so
    the run has diverged (worst contact) while contact 1 has not; NEES and |error| worst of the two."""
    n = 500
    t = np.arange(1, n + 1) * 1e-3
    delta = np.full((n, 2), -1e-4)
    delta[100:200, 0] = 1e-6
    delta[300:400, 1] = 1e-6
    g_true = np.array([1e8, 4e8])
    gamma = np.column_stack([np.full(n, 1.01e8), np.full(n, 4e8)])
    gamma[300:, 1] = 9e8  # contact 2 ends 125 % off
    p_gg = np.column_stack([np.full(n, 1e12), np.full(n, 1e14)])
    nis, flags = np.ones(n), np.zeros(n, dtype=np.int64)
    m = run_metrics(t, g_true, delta, Estimate(gamma, p_gg, nis, flags))
    one = run_metrics(t, g_true[0], delta[:, 0], Estimate(gamma[:, 0], p_gg[:, 0], nis, flags))
    for k, v in one.items():  # contact 1 keeps the one-contact names and values
        if not k.endswith("_worst") and k not in ("worst_contact", "nis_mean_free_before_contact",
                                                  "silent_wrong"):
            assert m[k] == v or (isinstance(v, float) and math.isnan(v) and math.isnan(m[k])), k
    assert m["final_err"] == pytest.approx(0.01) and m["final_err_c2"] == pytest.approx(1.25)
    assert not m["diverged"] and m["diverged_c2"] and m["diverged_worst"]
    assert m["worst_contact"] == 2 and m["abs_final_err_worst"] == m["abs_final_err_c2"]
    assert m["nees_final"] == pytest.approx(1.0) and m["nees_final_c2"] == pytest.approx(25e16 / 1e14)
    assert m["nees_final_worst"] == m["nees_final_c2"]
    assert m["consistent_3sigma"] and not m["consistent_3sigma_c2"] and not m["consistent_3sigma_worst"]
    assert m["t_first_contact"] == t[100] and m["t_first_contact_c2"] == t[300]
    assert m["nis_mean_free_before_contact"] == 1.0 and one["worst_contact"] == 1
    # one contact: the worst columns are contact 1's
    assert one["abs_final_err_worst"] == one["abs_final_err"] and one["diverged_worst"] == one["diverged"]


def _small_family():
    fam = load_spec(SPEC, runs=4, seed=5, t_end=4.0)
    # forcing fast enough that 4 s include contact (the family's other values as drawn)
    from dataclasses import replace

    runs = tuple(replace(r, scenario=r.scenario.replace(u_freq=0.25)) for r in fam.runs)
    return replace(fam, runs=runs)


def _comparable(rows):
    return [{k: v for k, v in r.items() if k not in TIMING_COLUMNS} for r in rows]


def _assert_rows_equal(a, b):
    assert len(a) == len(b)
    for ra, rb in zip(_comparable(a), _comparable(b)):
        assert ra.keys() == rb.keys()
        for k in ra:
            va, vb = ra[k], rb[k]
            if isinstance(va, float) and math.isnan(va):
                assert isinstance(vb, float) and math.isnan(vb), k
            else:
                assert va == vb, (k, va, vb)


@needs_c
def test_local_pool_equals_serial_and_dask_localcluster():
    distributed = pytest.importorskip("distributed")
    fam = _small_family()
    exps = ["switched", "switched-highq-constrained"]
    serial = run_family(fam, exps, workers=1, progress=False)
    pool = run_family(fam, exps, workers=2, progress=False)
    assert any(r["truth_contact_onsets"] > 0 for r in serial)
    _assert_rows_equal(serial, pool)
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        on_dask = run_family(fam, exps, client=client, progress=False)
    _assert_rows_equal(serial, on_dask)


@needs_c
def test_campaign_command_writes_table_and_plots(tmp_path, capsys):
    import pyarrow.parquet as pq

    from caekf_sim.cli import main

    out = tmp_path / "c"
    assert main(["campaign", str(SPEC), "--runs", "2", "--t-end", "2", "--out", str(out), "--no-progress",
                 "--workers", "1", "--experiment", "switched", "--experiment", "canonical"]) == 0
    text = capsys.readouterr().out
    assert "within 1 %" in text and "noise_std" in text
    runs = pq.read_table(out / "runs.parquet")
    assert runs.num_rows == 4
    assert set(runs.column("experiment").to_pylist()) == {"switched", "canonical"}
    summary = pq.read_table(out / "summary.parquet")
    assert summary.column("n").to_pylist()[0] == 2
    for name in ("error_histogram.png", "error_vs_parameters.png", "consistency.png", "summary.txt"):
        assert (out / name).stat().st_size > 0


def test_campaign_reports_a_missing_spec_in_one_line(tmp_path, capsys):
    from caekf_sim.cli import main

    assert main(["campaign", str(tmp_path / "nope.toml"), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "nope.toml" in err


@needs_c
def test_in_process_backends_equal_the_c_programs():
    """The campaign's defaults (truth and estimator through the binding, in process) give the same truth
    as the caekf-truth program and the same estimates as caekf-replay, on a small family."""
    from caekf_sim.campaign.estimate import estimate
    from caekf_sim.campaign.runner import truth_arrays

    fam = load_spec(SPEC, runs=2)
    for r in fam.runs:
        sc = r.scenario.replace(t_end=2.0)
        a, b = truth_arrays(sc, "binding"), truth_arrays(sc, "c")
        assert np.array_equal(a.y, b.y) and np.array_equal(a.delta, b.delta)
        for e in ("switched", "default"):
            x, y = estimate(sc, e, a.t, a.u, a.y, backend="binding"), estimate(sc, e, a.t, a.u, a.y, backend="replay")
            assert np.array_equal(x.gamma, y.gamma) and np.array_equal(x.p_gg, y.p_gg)
            assert np.array_equal(x.flags, y.flags)
            np.testing.assert_allclose(x.nis, y.nis, rtol=1e-8)  # caekf-replay prints 9 digits


def test_numpy_backend_runs_the_default_as_the_binding():
    """estimate(..., "default", backend="numpy"): the scenario's own settings (the trapezoidal rule with
    its contact substeps, the gate) on the numpy reference, the same gammas and flags as the binding's (the
    paper's mechanism)."""
    from caekf_sim.campaign.estimate import estimate
    from caekf_sim.campaign.runner import truth_arrays
    from caekf_sim.experiments import scenario_config

    fam = load_spec(SPEC, runs=2)
    for r in fam.runs:
        sc = r.scenario.replace(t_end=8.0)  # the first contacts begin after ~5 s
        assert scenario_config(sc).contact_substeps > 1
        a = truth_arrays(sc, "binding")
        x, y = estimate(sc, "default", a.t, a.u, a.y), estimate(sc, "default", a.t, a.u, a.y, backend="numpy")
        assert np.count_nonzero(x.flags & fl.CONTACT_ACTIVE) > 100
        np.testing.assert_allclose(y.gamma, x.gamma, rtol=1e-8, atol=0)
        np.testing.assert_array_equal(y.flags, x.flags)
        assert np.isnan(y.nis).all()


# --- families of structures (sim/families/structures.toml) -----------------------------------------

STRUCTURES = SPEC.with_name("structures.toml")


def test_structures_family_validates_against_the_schema(tmp_path):
    """Every drawn mechanism is a valid scenario (the schema's ranges, the mechanism's rules, the C
    estimator's validation), within the spec's ranges, and its forcing is 1.15-1.8x the amplitude that
    closes its contacts quasi-statically."""
    import caekf_sim
    from caekf_sim.campaign.structure import closing_amplitude
    from caekf_sim.cli import main
    from caekf_sim.mechanism import Mechanism, contact_values
    from caekf_sim.scenario import load_scenario

    fam = load_spec(STRUCTURES, runs=40)
    assert main(["family", str(STRUCTURES), "--runs", "40", "--out", str(tmp_path)]) == 0
    seen = set()
    for r in fam.runs:
        s = r.scenario
        assert load_scenario(tmp_path / f"run-{r.run:04d}.toml") == s
        mech = Mechanism.from_scenario(s)
        caekf_sim.Estimator(s)  # caekf_settings_validate accepts it
        assert 2 <= s.bodies <= 8 and 1 <= s.contacts <= 2 and s.inputs == 1 and s.sensors == 2
        seen.add((s.bodies, s.contacts))
        assert np.all((0.5 <= mech.m) & (mech.m <= 2.0))
        assert np.all((1e3 <= mech.spring_k) & (mech.spring_k <= 2e4))
        assert np.all((1.0 <= mech.spring_c) & (mech.spring_c <= 10.0))
        assert np.all((0.5e-3 <= mech.contact_gap) & (mech.contact_gap <= 2e-3))
        assert np.linalg.matrix_rank(mech.K) == s.bodies  # every piece of the chain is held by the ground
        gamma, gamma0 = contact_values(s, "gamma", s.contacts), contact_values(s, "gamma0", s.contacts)
        assert np.all((1e7 <= gamma) & (gamma <= 1e9)) and np.all((0.5 <= gamma0 / gamma) & (gamma0 / gamma <= 1.5))
        np.testing.assert_allclose(contact_values(s, "sigma_gamma0", s.contacts), gamma0 / 3, rtol=1e-15)
        np.testing.assert_allclose(contact_values(s, "sigma_q_gamma", s.contacts), gamma0 / 75, rtol=1e-15)
        assert 0.03 <= s.input1_freq <= 0.2 and s.noise_std in (0.0, 5e-9, 2e-8, 5e-8)
        a, _ = closing_amplitude(s.values())
        assert 1.15 <= s.input1_amp / a <= 1.8 and s.input1_amp / a == pytest.approx(r.values["closing"], rel=1e-12)
    assert len({b for b, _ in seen}) >= 5 and {c for _, c in seen} == {1, 2}


def test_structures_family_is_reproducible_and_prefix_stable():
    a, b, c = load_spec(STRUCTURES, runs=8), load_spec(STRUCTURES, runs=8), load_spec(STRUCTURES, runs=3)
    assert [r.scenario for r in a.runs] == [r.scenario for r in b.runs]
    assert [r.values for r in a.runs] == [r.values for r in b.runs]
    assert [r.scenario for r in a.runs[:3]] == [r.scenario for r in c.runs]
    assert load_spec(STRUCTURES, runs=3, seed=1).runs[0].scenario != c.runs[0].scenario


def test_every_drawn_contact_closes_in_the_truth():
    """On the family's first members (1 and 2 contacts), the truth's contact statistics: every contact
    closes, and no integration fails."""
    from caekf_sim.campaign.metrics import contact_suffix, truth_stats
    from caekf_sim.campaign.runner import truth_arrays

    fam = load_spec(STRUCTURES, runs=8)
    assert {r.scenario.contacts for r in fam.runs} == {1, 2}
    for r in fam.runs:
        tr = truth_arrays(r.scenario)
        stats = truth_stats(tr.delta, r.scenario.contacts)
        assert not tr.failed
        for c in range(r.scenario.contacts):
            assert stats[f"truth_contact_onsets{contact_suffix(c)}"] > 0, (r.run, c)
            assert stats[f"truth_max_delta{contact_suffix(c)}"] > 0, (r.run, c)


def test_small_structures_campaign_has_finite_metrics(tmp_path):
    import pyarrow.parquet as pq

    from caekf_sim.cli import main

    out = tmp_path / "s"
    assert main(["campaign", str(STRUCTURES), "--runs", "4", "--t-end", "10", "--out", str(out), "--no-progress",
                 "--workers", "1", "--experiment", "switched", "--experiment", "switched-highq-constrained"]) == 0
    rows = pq.read_table(out / "runs.parquet").to_pylist()
    assert len(rows) == 8
    for r in rows:
        assert not r["truth_failed"]
        names = ["abs_final_err_worst", "nees_final_worst", "nis_mean", "nis_max"]
        names += [f"{m}{'' if c == 1 else f'_c{c}'}" for c in range(1, r["contacts"] + 1)
                  for m in ("final_err", "nees_final", "min_gamma", "truth_max_delta")]
        for k in names:
            assert math.isfinite(r[k]), (r["run"], r["experiment"], k)
    assert "bodies = " in (out / "summary.txt").read_text()


def test_truth_check_runs_on_a_structure(capsys):
    from caekf_sim.cli import main

    assert main(["truth-check", "--spec", str(STRUCTURES), "--runs", "1", "--t-end", "1", "--no-paper"]) == 0
    assert "failures: caekf-truth 0/1" in capsys.readouterr().out


def test_structure_spec_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.toml"
    paper = SPEC.parent.parent / "scenarios" / "paper.toml"
    base = STRUCTURES.read_text().replace('base = "../scenarios/paper.toml"', f'base = "{paper}"')
    for old, new, what in (
        (', over = "contacts" }', " }", "not a scenario key pattern"),
        ("ground_contact = 0.3", "ground_contact = 1.3", "a probability in [0, 1]"),
        ("inputs = 1\n", "inputs = 1\nbogus = 2\n", "unknown key(s) bogus in [structure]"),
    ):
        bad.write_text(base.replace(old, new, 1))
        with pytest.raises(ValueError) as exc:
            load_spec(bad, runs=2)
        assert what in str(exc.value) and "\n" not in str(exc.value)


JOINT = Path(__file__).resolve().parents[1] / "families" / "joint.toml"


def test_joint_metrics_follow_the_targets():
    """The whole law's verdict: every estimated parameter within its target (gap in metres), else not."""
    from caekf_sim.campaign.metrics import JOINT_TOL, law_metrics

    n = 5
    truth = {"contact1_n": 1.5, "contact1_lambda": 200.0, "contact1_gap": 1e-3}

    def est(n_f, lam_f, gap_f):
        law = {"contact1_n": np.full(n, n_f), "contact1_lambda": np.full(n, lam_f), "contact1_gap": np.full(n, gap_f)}
        return Estimate(gamma=np.ones(n), p_gg=np.ones(n), nis=np.zeros(n), flags=np.zeros(n, dtype=np.int64),
                        law=law, law_var={k: np.full(n, 1e-30) for k in law})

    ok = law_metrics(est(1.5 * 1.019, 200 * 0.91, 1e-3 + 0.9e-7), truth, [0.019])
    assert ok["joint_ok"] and not ok["joint_diverged"]
    assert ok["contact1_gap_final_err"] == pytest.approx(0.9e-7) and ok["contact1_n_final_err"] == pytest.approx(0.019)
    for args, g in (((1.5 * 1.021, 200, 1e-3), 0.0), ((1.5, 200 * 1.11, 1e-3), 0.0), ((1.5, 200, 1e-3 + 1.1e-7), 0.0),
                    ((1.5, 200, 1e-3), JOINT_TOL["gamma"] * 1.01)):
        assert not law_metrics(est(*args), truth, [g])["joint_ok"]
    assert law_metrics(est(float("nan"), 200, 1e-3), truth, [0.0])["joint_diverged"]
    assert law_metrics(est(1.5, 200, 2.5e-3), truth, [0.0])["joint_diverged"]  # the gap off by more than itself


def test_joint_campaign_prints_the_whole_law_table(tmp_path, capsys):
    """Two short runs of the joint family with the observability tool: the table and the columns."""
    import pyarrow.parquet as pq

    from caekf_sim.cli import main

    out = tmp_path / "camp"
    rc = main(["campaign", str(JOINT), "--runs", "2", "--t-end", "14", "--experiment", "default", "--workers",
               "1", "--observability", "--no-plots", "--no-progress", "--out", str(out)])
    assert rc == 0
    text = capsys.readouterr().out
    assert "the whole contact law" in text and "bound allows targets" in text
    rows = pq.read_table(out / "runs.parquet").to_pylist()
    assert len(rows) == 2
    for r in rows:
        assert {"joint_ok", "joint_diverged", "observable_all", "crb_meets_targets", "crb_contact1_n",
                "contact1_n_final_err", "contact1_lambda_final_err", "contact1_gap_final_err"} <= set(r)
        assert math.isfinite(r["contact1_gap_final_err"])
    joint = pq.read_table(out / "joint.parquet").to_pylist()
    assert joint[0]["group"] == "all" and joint[0]["n"] == 2


def test_targets_verdict_counts_each_bound():
    """[targets]: fractions of the group "all" (>=) and counts (<=), met exactly at the bound; a joint target
    without the joint table is not measured."""
    from caekf_sim.campaign.report import format_targets
    from caekf_sim.campaign.spec import Family

    fam = Family(name="f", runs=(), targets=(("within_1pct", 0.9), ("diverged", 0.0)))
    row = {"experiment": "a", "group": "all", "n": 10, "within_1pct": 9, "diverged": 0}
    assert format_targets(fam, [row], []).endswith("-> every target met")
    assert "within_1pct 90.0 % >= 90 %: met" in format_targets(fam, [row], [])
    for change in ({"within_1pct": 8}, {"diverged": 1}):
        text = format_targets(fam, [{**row, **change}], [])
        assert "NOT met" in text and text.endswith("-> targets NOT met")
    joint = Family(name="j", runs=(), targets=(("joint_ok", 0.8),))
    assert "joint_ok: not measured" in format_targets(joint, [row], [])
    jrow = {"experiment": "a", "group": "all", "crb_meets_targets": 5, "joint_ok": 4}
    assert "joint_ok 80.0 % >= 80 %: met" in format_targets(joint, [row], [jrow])
    assert format_targets(Family(name="none", runs=()), [row], []) == ""


def test_targets_table_is_checked_in_one_line(tmp_path, capsys):
    from caekf_sim.cli import main

    for body, expect in (("within_1pct = 1.5", "fraction in [0, 1]"), ("within_2pct = 0.5", "unknown key"),
                         ("diverged = -1", "count >= 0")):
        spec = tmp_path / "t.toml"
        spec.write_text(f'[family]\nname = "t"\n[targets]\n{body}\n')
        assert main(["campaign", str(spec), "--runs", "1", "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and expect in err


def test_issue14_family_prints_its_targets(tmp_path, capsys):
    from caekf_sim.cli import main

    assert main(["campaign", str(SPEC), "--runs", "2", "--t-end", "2", "--out", str(tmp_path), "--no-progress",
                 "--workers", "1", "--experiment", "default", "--no-plots"]) == 0
    text = capsys.readouterr().out
    line = next(t for t in text.splitlines() if t.startswith("default: "))
    for name in ("within_1pct", "within_5pct", "diverged", "consistent_3sigma"):
        assert name in line
    assert "targets (the spec's [targets]" in (tmp_path / "summary.txt").read_text()
