"""Issue 27's model-mismatch families: a [mismatch] table makes the truth differ from the filter's model
(docs/family.md); the campaign's flagged_mismatch_end / silent_wrong metrics and the not_silent_wrong target."""
from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from caekf_sim import flags as fl
from caekf_sim.campaign import runner
from caekf_sim.campaign.estimate import Estimate, estimate
from caekf_sim.campaign.metrics import run_metrics
from caekf_sim.campaign.report import format_summary, format_targets, summary_rows
from caekf_sim.campaign.spec import MISMATCH_SETTINGS, load_spec
from caekf_sim.schema import SCHEMA

FAMILIES = Path(__file__).resolve().parents[1] / "families"
ISSUE14 = FAMILIES / "issue14.toml"
MISMATCH = FAMILIES / "mismatch.toml"


def _spec(tmp_path: Path, mismatch: str) -> Path:
    """issue14.toml with a [mismatch] table appended (its base resolved from the same folder)."""
    text = ISSUE14.read_text().replace('base = "../scenarios/paper.toml"',
                                       f'base = "{(FAMILIES.parent / "scenarios" / "paper.toml").as_posix()}"')
    p = tmp_path / "m.toml"
    p.write_text(text + "\n[mismatch]\n" + mismatch + "\n")
    return p


def _capture(monkeypatch):
    """Record what the campaign hands the truth and the estimator (the real functions still run)."""
    seen: dict = {"truth": [], "estimate": []}
    real_truth, real_estimate = runner.truth_arrays, runner.estimate

    def truth(sc, backend="binding"):
        tr = real_truth(sc, backend)
        seen["truth"].append((sc, tr))
        return tr

    def est(sc, e, t, u, y, backend="binding"):
        seen["estimate"].append((sc, np.array(u, float), np.array(y, float)))
        return real_estimate(sc, e, t, u, y, backend=backend)

    monkeypatch.setattr(runner, "truth_arrays", truth)
    monkeypatch.setattr(runner, "estimate", est)
    return seen


def test_mismatch_leaves_the_filters_family_as_issue14s_and_draws_lognormal_factors():
    """The shipped mismatch families are issue 14's mechanisms run for run (the [mismatch] draws come after
    the family's); the truth's masses, springs and dampers are the filter's times factors whose logarithms
    have the spec's sigma."""
    n = 40
    plain = load_spec(ISSUE14, runs=n)
    keys = [k for name in MISMATCH_SETTINGS for k in SCHEMA.by_name(name).keys[:4]]
    assert len(keys) == 12  # the 4-body chain: 4 masses, 4 springs, 4 dampers
    for spec, sigma in (("mismatch.toml", 0.03), ("mismatch-params1.toml", 0.01), ("mismatch-force.toml", None)):
        fam = load_spec(FAMILIES / spec, runs=n)
        assert fam.seed == plain.seed
        logs = []
        for a, b in zip(plain.runs, fam.runs):
            assert b.scenario == a.scenario  # the filter's model: issue 14's, unchanged
            assert {k: v for k, v in b.values.items() if k in a.values} == a.values
            truth = b.truth_scenario()
            if sigma is None:
                assert b.truth_factors == () and truth == b.scenario
                continue
            assert [k for k, _ in b.truth_factors] == keys
            for k, f in b.truth_factors:
                assert getattr(truth, k) == pytest.approx(getattr(b.scenario, k) * f, rel=1e-15)
                assert b.values[f"truth_factor_{k}"] == f
                logs.append(math.log(f))
            # every other key is the filter's
            same = {k: v for k, v in truth.values().items() if k not in keys}
            assert same == {k: v for k, v in b.scenario.values().items() if k not in keys}
        if sigma is not None:
            logs_a = np.array(logs)
            assert abs(logs_a.mean()) < 4 * sigma / math.sqrt(len(logs_a))
            assert logs_a.std() == pytest.approx(sigma, rel=0.1)


def test_truth_runs_the_perturbed_model_and_the_filter_the_nominal_one(tmp_path, monkeypatch):
    fam = load_spec(_spec(tmp_path, "params_lognormal_sigma = 0.03"), runs=2, t_end=1.0)
    seen = _capture(monkeypatch)
    for r in fam.runs:
        seen["truth"].clear()
        seen["estimate"].clear()
        runner.run_task(runner.Task(r, ("default",)))
        (truth_sc, tr), = seen["truth"]
        (est_sc, u, y), = seen["estimate"]
        assert truth_sc == r.truth_scenario() != r.scenario
        for k, f in r.truth_factors:
            assert getattr(truth_sc, k) / getattr(est_sc, k) == pytest.approx(f, rel=1e-14)
        assert est_sc == r.scenario
        np.testing.assert_array_equal(y, tr.y)
        np.testing.assert_array_equal(u, tr.u)  # no input noise asked: the true force, exactly
        # the measurements are the perturbed truth's, not the filter model's
        assert not np.allclose(y, _plain_truth(r.scenario).y, rtol=0, atol=1e-9)


def _plain_truth(sc):
    from caekf_sim.binding import truth

    return truth(sc)


def test_filter_reads_the_truths_force_plus_white_noise_of_the_given_std(tmp_path, monkeypatch):
    rel = 0.01
    fam = load_spec(_spec(tmp_path, f"input_noise_rel = {rel}"), runs=3, t_end=4.0)
    real_truth = runner.truth_arrays
    marker = 0.125  # a truth whose force differs from the nominal scenario's: the filter must read this one

    def shifted_truth(sc, backend="binding"):
        tr = real_truth(sc, backend)
        return replace(tr, u=tr.u + marker)

    monkeypatch.setattr(runner, "truth_arrays", shifted_truth)
    seen = _capture(monkeypatch)
    seeds = set()
    for r in fam.runs:
        assert r.truth_factors == () and r.truth_scenario() == r.scenario
        seeds.add(r.input_noise_seed)
        seen["truth"].clear()
        seen["estimate"].clear()
        runner.run_task(runner.Task(r, ("default",)))
        (_, tr), = seen["truth"]
        (_, u, _), = seen["estimate"]
        noise = u - tr.u
        std = rel * abs(r.scenario.u_amp)
        assert r.input_noise_std == (pytest.approx(std, rel=1e-15),)
        assert abs(noise.mean()) < 5 * std / math.sqrt(len(noise))
        assert noise.std() == pytest.approx(std, rel=0.05)
        lag1 = np.corrcoef(noise[:-1], noise[1:])[0, 1]
        assert abs(lag1) < 5 / math.sqrt(len(noise))  # white
        # the sine's samples come from the truth run (shifted here), not regenerated from the scenario
        assert np.median(u - _plain_truth(r.scenario).u) == pytest.approx(marker, abs=std / 10)
    assert len(seeds) == len(fam.runs)  # each run its own noise


def test_without_mismatch_the_campaign_gives_the_same_numbers(tmp_path):
    """issue14.toml's runs through the campaign equal the pipeline without the feature (truth of the
    scenario, the estimator on its true force and measurements, the metrics), and a [mismatch] table with
    nothing in it changes nothing."""
    fam = load_spec(ISSUE14, runs=2, t_end=6.0)
    fam = replace(fam, runs=tuple(replace(r, scenario=r.scenario.replace(u_freq=0.25)) for r in fam.runs))
    empty = load_spec(_spec(tmp_path, ""), runs=2, t_end=6.0)
    assert [r.scenario for r in empty.runs] == [r.scenario for r in load_spec(ISSUE14, runs=2, t_end=6.0).runs]
    assert [r.values for r in empty.runs] == [r.values for r in load_spec(ISSUE14, runs=2, t_end=6.0).runs]
    rows = runner.run_family(fam, ["default"], workers=1, progress=False)
    for r, row in zip(fam.runs, rows):
        assert not r.mismatched
        tr = _plain_truth(r.scenario)
        est = estimate(r.scenario, "default", tr.t, tr.u, tr.y)
        want = run_metrics(tr.t, r.scenario.gamma, tr.delta, est)
        for k, v in want.items():
            assert row[k] == v or (isinstance(v, float) and math.isnan(v) and math.isnan(row[k])), k
        assert row["truth_contact_onsets"] > 0
        assert "truth_factor_m1" not in row and "input_noise_seed" not in row


def _est(flags_last: int, gamma_final: float, n: int = 5) -> Estimate:
    flags = np.zeros(n, dtype=np.int64)
    flags[-1] = flags_last
    g = np.full(n, 1e8)
    g[-1] = gamma_final
    return Estimate(gamma=g, p_gg=np.full(n, 1e12), nis=np.ones(n), flags=flags)


def test_flagged_and_silent_wrong_follow_their_definitions():
    bit = fl.mask("model_mismatch")
    t, delta = np.arange(5) * 1e-3, np.array([0, 1e-6, 1e-6, 0, 0], float)
    cases = {  # (last step flagged, final gamma) -> (flagged_mismatch_end, silent_wrong)
        (True, 1.5e8): (True, False),   # wrong by 50 sigma but flagged
        (False, 1.5e8): (False, True),  # wrong and silent: the defect
        (False, 1.0e8): (False, False),  # within 3 sigma
        (True, 1.0e8): (True, False),
    }
    rows = []
    for (flag, g), (want_flag, want_silent) in cases.items():
        m = run_metrics(t, 1e8, delta, _est(bit if flag else 0, g))
        assert (m["flagged_mismatch_end"], m["silent_wrong"]) == (want_flag, want_silent)
        rows.append({**m, "experiment": "default"})
    # a flag earlier in the run does not count: only the last step's
    early = _est(0, 1.5e8)
    early.flags[2] = bit
    assert run_metrics(t, 1e8, delta, early)["flagged_mismatch_end"] is False
    from caekf_sim.campaign.spec import Family

    fam = Family(name="f", runs=(), targets=(("not_silent_wrong", 0.75),))
    summary = summary_rows(rows, fam, ["default"])
    assert (summary[0]["flagged_mismatch_end"], summary[0]["silent_wrong"]) == (2, 1)
    assert "not_silent_wrong 75.0 % >= 75 %: met" in format_targets(fam, summary, [])
    assert "NOT met" in format_targets(replace(fam, targets=(("not_silent_wrong", 0.8),)), summary, [])


def test_without_the_flag_in_the_schema_flagged_is_unavailable(monkeypatch):
    """While the schema has no model_mismatch flag, flagged_mismatch_end is None and the table says n/a
    (no crash); silent_wrong then counts every run outside 3 sigma."""
    monkeypatch.setattr(fl, "_MASK", {k: v for k, v in fl._MASK.items() if k != "model_mismatch"})
    t, delta = np.arange(5) * 1e-3, np.array([0, 1e-6, 1e-6, 0, 0], float)
    all_bits = sum(f.mask for f in SCHEMA.flags)
    m = run_metrics(t, 1e8, delta, _est(all_bits, 1.5e8))
    assert m["flagged_mismatch_end"] is None and m["silent_wrong"] is True
    from caekf_sim.campaign.spec import Family

    summary = summary_rows([{**m, "experiment": "default"}], Family(name="f", runs=()), ["default"])
    assert summary[0]["flagged_mismatch_end"] is None and summary[0]["silent_wrong"] == 1
    assert "| n/a " in format_summary(summary)


def test_mismatch_table_is_checked_in_one_line(tmp_path, capsys):
    from caekf_sim.cli import main

    for body, expect in (("params_lognormal_sigma = -0.1", "number >= 0"), ("force_noise = 0.01", "unknown key"),
                         ('input_noise_rel = "1 %"', "number >= 0")):
        spec = tmp_path / "t.toml"
        spec.write_text(f'[family]\nname = "t"\n[mismatch]\n{body}\n')
        assert main(["campaign", str(spec), "--runs", "1", "--out", str(tmp_path / "o")]) == 2
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and expect in err


def test_mismatch_campaign_prints_its_table_and_target(tmp_path, capsys):
    from caekf_sim.cli import main

    assert main(["campaign", str(MISMATCH), "--runs", "2", "--t-end", "2", "--out", str(tmp_path), "--no-progress",
                 "--workers", "1", "--experiment", "default", "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "[mismatch]: params_lognormal_sigma = 0.03, input_noise_rel = 0.01" in text
    assert "silent wrong" in text
    line = next(t for t in text.splitlines() if t.startswith("default: "))
    assert "not_silent_wrong" in line


# ---- issue 27's declared family: admission by gamma's Cramer-Rao bound with every declared parameter unknown ----

def declared_spec(path: Path) -> Path:
    """mismatch.toml (its filters and truths, run for run) with the uncertainty declared to the filter (every mass,
    spring and damper 3 %, the force's noise 1 % of its amplitude) and issue 27's admitted targets."""
    base = f'base = "{FAMILIES.parent}/scenarios/paper.toml"'
    text = MISMATCH.read_text().replace('base = "../scenarios/paper.toml"', base)
    set_end = 'gamma_min = "gamma0 / 75"          # 1e6\n'  # the last line of [set]
    assert text.count(set_end) == 1
    text = text.replace(set_end, set_end + '"m{i}_sigma" = "0.03"\n"spring{i}_k_sigma" = "0.03"\n'
                        '"spring{i}_c_sigma" = "0.03"\ninput1_sigma = "0.01 * u_amp"\n')
    text = text.replace("not_silent_wrong = 0.95", "within_2pct_admitted = 0.90\ndiverged_admitted = 0\n"
                        "consistent_3sigma = 0.95")
    path.write_text(text)
    return path


def test_a_declared_family_keeps_mismatchs_runs_and_takes_the_admitted_targets(tmp_path):
    plain, dec = load_spec(MISMATCH, runs=3), load_spec(declared_spec(tmp_path / "d.toml"), runs=3)
    for a, b in zip(plain.runs, dec.runs):
        assert b.truth_factors == a.truth_factors and b.input_noise_std == a.input_noise_std
        assert b.scenario.replace(**{k: 0.0 for k in declared_keys(b.scenario)}) == a.scenario
        assert runner.declares_uncertainty(b.scenario) and not runner.declares_uncertainty(a.scenario)
    assert dict(dec.targets) == {"within_2pct_admitted": 0.9, "diverged_admitted": 0.0, "consistent_3sigma": 0.95}


def declared_keys(sc):
    from caekf_sim.binding import mech_layout

    return [f"{k}_sigma" for k in mech_layout(sc)] + ["input1_sigma"]


def test_admitted_targets_count_over_the_admitted_runs_and_print_the_share():
    from caekf_sim.campaign.spec import Family

    fam = Family(name="d", runs=(), targets=(("within_2pct_admitted", 0.9), ("diverged_admitted", 0.0)))
    row = {"experiment": "a", "group": "all", "n": 20, "admitted": 10, "within_2pct_admitted": 9,
           "diverged_admitted": 0}
    text = format_targets(fam, [row], [])
    assert "within_2pct_admitted 90.0 % of 10 admitted (50.0 % of 20) >= 90 %: met" in text
    assert "diverged_admitted 0 of 10 admitted (50.0 % of 20) <= 0: met" in text and text.endswith("every target met")
    assert "NOT met" in format_targets(fam, [{**row, "within_2pct_admitted": 8}], [])
    assert "NOT met" in format_targets(fam, [{**row, "diverged_admitted": 1}], [])
    unmeasured = {k: v for k, v in row.items() if not k.endswith("admitted")}
    assert "within_2pct_admitted: not measured (--observability)" in format_targets(fam, [unmeasured], [])


def test_declared_campaign_admits_runs_by_gammas_bound_with_every_declared_parameter(tmp_path, capsys):
    """Two short runs of the declared family with --observability: each run's posterior bound of gamma with its
    12 declared mechanism parameters unknown and the force noise as process noise (the bound of each declared
    parameter too), never below the bound with them known; admitted = 3 bounds within 2 %; the table and the
    targets say how many the bound admits. Without --observability nothing of it appears."""
    import pyarrow.parquet as pq

    from caekf_sim import identifiability as idf
    from caekf_sim.cli import main

    out, spec = tmp_path / "camp", declared_spec(tmp_path / "declared.toml")
    assert main(["campaign", str(spec), "--runs", "2", "--t-end", "14", "--out", str(out), "--no-progress",
                 "--workers", "1", "--experiment", "default", "--no-plots", "--observability"]) == 0
    text = capsys.readouterr().out
    assert "admitted by the Cramer-Rao bound of gamma with every declared parameter unknown" in text
    line = next(t for t in text.splitlines() if t.startswith("default: "))
    assert "within_2pct_admitted" in line and "admitted (" in line and "not measured" not in line
    rows = pq.read_table(out / "runs.parquet").to_pylist()
    fam = load_spec(spec, runs=2, t_end=14.0)
    for r, run in zip(rows, fam.runs):
        keys = [k for k in declared_keys(run.scenario) if k != "input1_sigma"]
        assert len(keys) == 12 and all(f"crb_{k[:-len('_sigma')]}" in r for k in keys)
        assert r["crb_admitted"] == (runner.ADMIT_SIGMAS * r["crb_gamma_declared"] <= runner.ADMIT_TOL)
        known = run.truth_scenario().replace(**{k: 0.0 for k in declared_keys(run.scenario)})
        alone = idf.analyse_run(known, idf.law_params(known, ["gamma"], [1]))
        assert r["crb_gamma_declared"] >= alone.crb_post[-1, 0] / known.contact1_gamma * (1 - 1e-9)
    summary = pq.read_table(out / "summary.parquet").to_pylist()
    assert summary[0]["admitted"] == sum(r["crb_admitted"] for r in rows)
    assert summary[0]["within_2pct_admitted"] == sum(r["crb_admitted"] and r["abs_final_err_worst"] <= 0.02
                                                     for r in rows)
    assert main(["campaign", str(spec), "--runs", "1", "--t-end", "2", "--out", str(tmp_path / "plain"),
                 "--no-progress", "--workers", "1", "--experiment", "default", "--no-plots"]) == 0
    text = capsys.readouterr().out
    assert "admitted by" not in text and "within_2pct_admitted: not measured (--observability)" in text
    assert "admitted" not in pq.read_table(tmp_path / "plain" / "summary.parquet").column_names
