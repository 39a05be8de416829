"""caekf-sim identify: maximum-likelihood values of scenario keys from recordings, through the C filter.

Records: the paper's mechanism forced faster than the paper (the contact closes within 2 s) with 1e-7 m
noise, 6 s at 1 kHz, from the C truth (binding.truth). The filter's process noise on velocities is set to
1e-5 (a predictor that re-synchronises after the contact's events; docs/identify.md)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from caekf_sim.binding import truth
from caekf_sim.cli import main
from caekf_sim.identify import IdentifyError, identify, unknowns
from caekf_sim.measurements import Measurements
from caekf_sim.scenario import default_scenario_path, load_scenario
from caekf_sim.settings_adapter import scenario_toml

NOISE = 1e-7


def _scenario(freq: float):
    return load_scenario(default_scenario_path()).replace(
        u_freq=freq, u_phase=0.0, t_end=6.0, noise_std=NOISE, sigma_r=NOISE, seed=3, sigma_qx_v=1e-5)


def _record(sc, name="rec"):
    tr = truth(sc)
    assert (tr.delta > 0).sum() > 500  # the contact closes
    return Measurements(name, tr.t, tr.u, tr.y)


def _check_recovered(est, start, narrower_than_start=True):
    """The estimate's own interval covers the truth and the estimate is within that interval's half-width
    of the truth; the interval is narrower than the start's error (the data says more than the start knew)."""
    lo, hi = est.interval
    half = (hi - lo) / 2
    assert lo <= est.truth <= hi, est
    assert abs(est.value - est.truth) <= half
    if narrower_than_start:
        assert half < abs(start - est.truth), est


def test_identify_recovers_gamma_and_its_interval_covers_the_truth():
    sc = _scenario(0.1)
    res = identify(sc, [_record(sc)], ["contact1_gamma"], starts=2, workers=1,
                   truth={"contact1_gamma": sc.gamma})
    e = res.estimate("contact1_gamma")
    assert e.start == sc.gamma0 == 0.75 * sc.gamma
    _check_recovered(e, e.start)
    assert (e.interval[1] - e.interval[0]) / 2 < 0.05 * e.value
    assert e.pinned and res.not_pinned == []
    assert res.nll_after < res.nll_before
    # the scenario for the online filter: the estimate as gamma0, the interval as its P0
    assert res.scenario.gamma0 == e.value and res.scenario.sigma_gamma0 == pytest.approx(e.sigma)
    assert e.sigma == pytest.approx(max(e.value - e.interval[0], e.interval[1] - e.value) / 1.959963984540054)
    assert res.scenario.gamma == sc.gamma  # the truth key is left alone


def test_identify_recovers_gamma_and_n_together():
    sc = _scenario(0.25)
    res = identify(sc, [_record(sc)], ["contact1_gamma", "contact1_n"], starts=1, workers=1,
                   truth={"contact1_gamma": sc.gamma, "contact1_n": sc.contact1_n})
    g, n = res.estimate("contact1_gamma"), res.estimate("contact1_n")
    # 6 s of one depth range pin gamma delta^n, not gamma and n apart: gamma's interval is wide (half-width
    # 35 % of the estimate with 3 contact substeps, 50 % with the default 5, where n ends 1.481 and gamma 80 %
    # of the truth, as their correlation says)
    _check_recovered(g, g.start, narrower_than_start=False)
    assert (g.interval[1] - g.interval[0]) / 2 < 0.6 * g.value
    lo, hi = n.interval
    assert lo <= n.truth <= hi and abs(n.value - n.truth) <= (hi - lo) / 2
    assert (hi - lo) / 2 < 0.05 * n.value
    # gamma and n are strongly correlated (an error dn moves gamma by dn |ln delta|)
    assert res.correlation[0, 1] > 0.9
    # n is not estimated online by this scenario: the written scenario holds it as n0 and as the model's n
    assert res.scenario.contact1_n0 == n.value == res.scenario.contact1_n
    assert res.scenario.contact1_sigma_n0 == pytest.approx(n.sigma)


def test_identify_recovers_a_mechanism_parameter():
    sc = _scenario(0.1).replace(gamma0=1e8)  # the contact known; the spring to ground 3 % off
    rec = _record(sc.replace(spring1_k=1.03 * sc.spring1_k))
    res = identify(sc, [rec], ["k1"], starts=2, workers=1, truth={"spring1_k": 1.03 * sc.spring1_k})
    e = res.estimate("spring1_k")
    _check_recovered(e, sc.spring1_k)
    assert res.scenario.spring1_k == e.value
    assert res.nis_before > 2 * res.nis_after  # the wrong spring made the innovations inconsistent


def test_identify_command_writes_a_scenario_and_reports(tmp_path, capsys):
    sc = _scenario(0.1)
    rec = _record(sc)
    csv = tmp_path / "rec.csv"
    with open(csv, "w") as f:
        f.write("t,u,y1,y4\n")
        for k in range(len(rec)):
            f.write(f"{rec.t[k]:.17g},{rec.u[k]:.17g},{rec.y[k, 0]:.17g},{rec.y[k, 1]:.17g}\n")
    scen = tmp_path / "sc.toml"
    scen.write_text(scenario_toml(sc))
    out = tmp_path / "identified.toml"
    assert main(["identify", "--scenario", str(scen), "--runs", str(csv), "--params", "gamma", "--workers", "1",
                 "--starts", "2", "--truth-scenario", str(scen), "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "contact1_gamma" in text and "95 % interval" in text and "-log L" in text and "before" in text
    written = load_scenario(out)
    lo, hi = (float(x) for x in text.split("[", 1)[1].split("]", 1)[0].split(","))
    assert lo <= written.gamma0 <= hi and lo <= sc.gamma <= hi
    assert written.sigma_gamma0 > 0 and written.gamma0 != sc.gamma0


@pytest.mark.parametrize("params, bounds, key", [
    ("contact1_foo", [], "contact1_foo"),
    ("contact2_gamma", [], "contact2_gamma"),
    ("dt", [], "dt"),
    ("m5", [], "m5"),
    ("contact1_gamma,gamma", [], "gamma"),
    ("contact1_gamma", ["spring1_k=1:2"], "spring1_k"),
    ("contact1_gamma", ["contact1_gamma=2e8:1e8"], "contact1_gamma"),
    ("contact1_gamma", ["contact1_gamma=oops"], "contact1_gamma"),
])
def test_bad_arguments_are_one_line_errors_naming_the_key(tmp_path, capsys, params, bounds, key):
    csv = tmp_path / "rec.csv"
    csv.write_text("t,u,y1,y4\n0.001,0,0,0\n0.002,0,0,0\n")
    argv = ["identify", "--runs", str(csv), "--params", params, "--workers", "1"]
    if bounds:
        argv += ["--bounds", *bounds]
    assert main(argv) == 3
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and key in err and "Traceback" not in err


def test_unknowns_map_keys_to_the_filters_start_values():
    sc = _scenario(0.1).replace(contact1_estimate_n=1, contact1_n0=1.4, contact1_sigma_n0=0.1)
    us = {u.key: u for u in unknowns(sc, ["gamma", "contact1_n", "k12", "sigma_r"])}
    assert us["contact1_gamma"].start == sc.gamma0 and us["contact1_gamma"].out_key == "contact1_gamma0"
    assert us["contact1_n"].start == 1.4 and us["contact1_n"].out_key == "contact1_n0"  # n0: estimated online
    assert us["spring2_k"].start == sc.spring2_k and us["spring2_k"].out_key == "spring2_k"
    assert us["sigma_r"].kind == "noise" and all(u.log for u in us.values())
    with pytest.raises(IdentifyError, match="^contact1_lambda: start value 0"):
        unknowns(sc, ["contact1_lambda"])
    assert math.isclose(unknowns(sc, ["contact1_lambda"], {"contact1_lambda": (1.0, 100.0)})[0].lower, 1.0)
    assert np.isfinite(unknowns(sc, ["contact1_gap"])[0].upper)
