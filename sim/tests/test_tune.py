"""caekf-sim tune: maximum-likelihood noise from recorded runs makes the innovations consistent."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

from caekf_sim.binding import truth
from caekf_sim.cli import main
from caekf_sim.scenario import default_scenario_path, load_scenario
from caekf_sim.truth import simulate, write_truth_csv
from caekf_sim.measurements import Measurements, read_candump_runs, read_measurements_csv
from caekf_sim.tune import consistency, run_records, tune

NOISE = 1e-6  # measurement noise of the recorded runs [m]
REPO = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def recorded():
    """Two noisy 14 s runs (first contact near 12.8 s), different noise seeds: one to tune on, one held out."""
    sc = load_scenario(default_scenario_path()).replace(noise_std=NOISE, sigma_r=NOISE, t_end=14.0)
    runs = []
    for seed in (11, 12):
        tr = truth(sc.replace(seed=seed))  # caekf-truth's generator, through the binding
        runs.append(Measurements(f"seed{seed}", tr.t, tr.u, tr.y))
    return sc, runs


def test_tune_makes_a_mistuned_filter_consistent(recorded):
    sc, (train, held) = recorded
    mistuned = sc.replace(sigma_r=10 * NOISE)  # R 100x too large
    burn_in = 500
    before = consistency(run_records(mistuned, [held]), sc.gamma, burn_in)
    res = tune(mistuned, [train], holdout=[held], max_evals=150)
    after = consistency(run_records(res.scenario, [held]), sc.gamma, burn_in)
    # the report's held-out numbers are these
    assert res.holdout_before == before and res.holdout_after == after
    # NIS of a 2-dof chi-square: mean 2, 95 % of the steps in the 95 % band
    assert abs(np.log(after.nis_mean / 2)) < abs(np.log(before.nis_mean / 2))
    assert abs(after.in_band - 0.95) < abs(before.in_band - 0.95)
    assert after.nll < before.nll
    # and R comes back towards the noise the runs were recorded with
    assert abs(np.log10(res.noise_after["sigma_r"] / NOISE)) < abs(np.log10(10 * NOISE / NOISE))


def test_tune_command_writes_a_scenario_the_c_tools_read(recorded, tmp_path, capsys):
    sc, (train, held) = recorded
    csvs = []
    for rec in (train, held):
        path = tmp_path / f"{rec.name}.csv"
        with open(path, "w") as f:
            f.write("t,u,y1,y4,extra\n")
            for k in range(len(rec)):
                f.write(f"{rec.t[k]:.17g},{rec.u[k]:.17g},{rec.y[k, 0]:.17g},{rec.y[k, 1]:.17g},0\n")
        csvs.append(path)
    assert np.array_equal(read_measurements_csv(csvs[0], sc.dt).y, train.y)
    scen = tmp_path / "mistuned.toml"
    from caekf_sim.settings_adapter import scenario_toml

    scen.write_text(scenario_toml(sc.replace(sigma_r=10 * NOISE)))
    out = tmp_path / "tuned.toml"
    assert main(["tune", "--scenario", str(scen), "--runs", str(csvs[0]), "--holdout", str(csvs[1]),
                 "--params", "sigma_r", "--max-evals", "40", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "held-out, after" in text and f"wrote {out}" in text
    tuned = load_scenario(out)
    assert tuned.replace(sigma_r=sc.sigma_r) == sc  # only sigma_r changed
    assert tuned.sigma_r != 10 * NOISE
    replay = None
    for d in ([Path(os.environ["CAEKF_BUILD_DIR"]) / "host"] if os.environ.get("CAEKF_BUILD_DIR") else []) + \
            [REPO / "build" / "host-double" / "host"]:
        if (d / "caekf-replay").is_file():
            replay = d / "caekf-replay"
            break
    if replay is None:
        pytest.skip("caekf-replay not built: the C reader was not tried")
    p = subprocess.run([str(replay), "--scenario", str(out), "--in", str(csvs[1]), "--out", str(tmp_path / "r.csv")],
                       capture_output=True, text=True)
    assert p.returncode == 0, p.stderr


def test_tune_command_tunes_the_recommended_estimator_unless_told(recorded, tmp_path, monkeypatch, capsys):
    """Without --experiment, tune runs the estimator estimate and caekf-replay run without it (no preset:
    the recommended one with the scenario's settings); with it, that preset."""
    import caekf_sim.tune as tune_module

    sc, (train, _) = recorded
    path = tmp_path / "run.csv"
    with open(path, "w") as f:
        f.write("t,u,y1,y4\n")
        for k in range(len(train)):
            f.write(f"{train.t[k]:.17g},{train.u[k]:.17g},{train.y[k, 0]:.17g},{train.y[k, 1]:.17g}\n")
    scen = tmp_path / "s.toml"
    from caekf_sim.settings_adapter import scenario_toml

    scen.write_text(scenario_toml(sc))
    seen = []
    real = tune_module.settings_for

    def spy(sc_, experiment=None, *args, **kw):
        seen.append(experiment)
        return real(sc_, experiment, *args, **kw)

    monkeypatch.setattr(tune_module, "settings_for", spy)
    for extra, want in (([], None), (["--experiment", "switched"], "switched")):
        seen.clear()
        assert main(["tune", "--scenario", str(scen), "--runs", str(path), "--params", "sigma_r",
                     "--max-evals", "2"] + extra) == 0
        assert seen and set(seen) == {want}
    capsys.readouterr()


def test_tune_errors_are_one_line(tmp_path, capsys):
    assert main(["tune", "--runs", str(tmp_path / "none.csv")]) == 4  # I/O (the exit-code table)
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "none.csv" in err


def test_candump_log_of_the_production_profile_unwraps_its_8_bit_counter(tmp_path):
    """The production profile's BENCH_YP counts steps mod 2^8 beside BENCH_U's 2^16: over 600 steps every
    measurement comes back at its own step (a 16-bit unwrap of the 8-bit counter lost 344 of them)."""
    pytest.importorskip("can")
    from caekf_sim.bench.buslog import write_journal
    from caekf_sim.bench.codec import Codec, make_records

    codec = Codec()
    n = 600
    steps = np.arange(n)
    rng = np.random.default_rng(7)
    pu = codec.pack("BENCH_U", {"STEP": steps, "U": rng.normal(0, 2, n)}, counters=steps)
    pyp = codec.pack("BENCH_YP", {"STEP": steps, "Y1": rng.normal(0, 1e-4, n), "Y4": rng.normal(0, 1e-4, n)},
                     counters=steps)
    journal = []
    for k in range(n):
        for name, payload in (("BENCH_U", pu), ("BENCH_YP", pyp)):
            journal.append((k * 1e-3, 0, make_records(codec.messages[name].frame_id, payload[k][None]).tobytes()))
    log = tmp_path / "bus.log"
    write_journal(journal, log, "vcan0", 1000.0)
    (rec,) = read_candump_runs(log, 1e-3)
    ys = codec.unpack("BENCH_YP", pyp)
    np.testing.assert_array_equal(rec.y, np.column_stack([ys["Y1"], ys["Y4"]]))
    np.testing.assert_array_equal(rec.u, codec.unpack("BENCH_U", pu)["U"])


def test_candump_log_of_any_mechanism_gives_its_inputs_and_sensors(tmp_path):
    """The shuttle's frames (2 inputs, a velocity sensor among 4: mechanism_profile) come back as its u (n, 2)
    and y (n, 4): a lost input frame holds that input's last value, a lost sensor frame loses the step's
    measurement; caekf-sim estimate --candump then runs it as a CSV of the same values."""
    pytest.importorskip("can")
    from caekf_sim.bench.buslog import write_journal
    from caekf_sim.bench.codec import Codec, make_records
    from caekf_sim.bench.profiles import mechanism_profile
    from caekf_sim.mechanism import Mechanism

    shuttle = Path(__file__).resolve().parents[2] / "sim" / "scenarios" / "shuttle.toml"
    sc = load_scenario(shuttle)
    profile = mechanism_profile(Mechanism.from_scenario(sc))
    assert [m for m, _ in profile.inputs] == ["BENCH_U", "BENCH_U2", "BENCH_Y1", "BENCH_S2_VEL", "BENCH_S3_POS",
                                              "BENCH_S4_POS"]
    codec = Codec()
    rng = np.random.default_rng(5)
    n = 30
    steps = np.arange(n) + 100
    values = {key: rng.normal(0, 1e-4, n) for _, sigs in profile.inputs for _, key in sigs}
    payloads, expect = {}, {}
    for name, sigs in profile.inputs:
        ((sig, key),) = sigs
        payloads[name] = codec.pack(name, {"STEP": steps, sig: values[key]}, counters=np.arange(n))
        expect[key] = codec.unpack(name, payloads[name])[sig]
    journal = []
    for k in range(n):
        for name in payloads:
            if (name, k) in (("BENCH_U2", 11), ("BENCH_S3_POS", 17)):
                continue  # lost
            journal.append((k * 1e-3, 0, make_records(codec.messages[name].frame_id, payloads[name][k][None])
                            .tobytes()))
    log = tmp_path / "bus.log"
    write_journal(journal, log, "vcan0", 1000.0)
    (rec,) = read_candump_runs(log, 1e-3, sc)
    u_want = np.column_stack([expect["u"], expect["u2"]])
    u_want[11, 1] = u_want[10, 1]
    assert np.array_equal(rec.u, u_want)
    y_want = np.column_stack([expect[k] for k in ("y1", "y4", "y3s", "y4s")])
    y_want[17] = np.nan
    np.testing.assert_array_equal(rec.y, y_want)
    out = tmp_path / "est.csv"
    assert main(["estimate", "--scenario", str(shuttle), "--candump", str(log), "--out", str(out)]) == 0
    assert main(["tune", "--scenario", str(shuttle), "--candump", str(log), "--params", "sigma_r",
                 "--max-evals", "2"]) == 0


@pytest.mark.parametrize("content, code, words", [(None, 4, "no such file"), (b"\xff\xfe\x00", 3, "not a candump"),
                                                   (b"(0.1) vcan0 zz#\n", 3, "not a candump")])
def test_tune_refuses_a_bad_candump_log_in_one_line(tmp_path, capsys, content, code, words):
    """tune --candump reads a log as estimate --candump does: a missing file, bytes that are not text or
    lines that are not candump's are one line each naming the file (exit 4 and 3), not the decoder's
    bare message."""
    pytest.importorskip("can")
    log = tmp_path / "bus.log"
    if content is not None:
        log.write_bytes(content)
    assert main(["tune", "--candump", str(log), "--max-evals", "2"]) == code
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and str(log) in err and words in err.lower(), err


def test_candump_log_gives_the_runs_the_bench_sent(tmp_path):
    """Frames of two configurations, the step counter wrapping, a lost Y4 frame, a frame with a bad CRC."""
    pytest.importorskip("can")
    from caekf_sim.bench.buslog import write_journal
    from caekf_sim.bench.codec import Codec, make_records

    codec = Codec()
    rng = np.random.default_rng(3)
    n = 40
    u = rng.normal(0, 2, n)
    y = rng.normal(0, 1e-4, (n, 2))
    steps = (65520 + np.arange(n)) & 0xFFFF  # wraps after 16 steps
    cols = {"BENCH_U": {"STEP": steps, "U": u}, "BENCH_Y1": {"STEP": steps, "Y1": y[:, 0]},
            "BENCH_Y4": {"STEP": steps, "Y4": y[:, 1]}}
    payloads = {name: codec.pack(name, c, counters=np.arange(n)) for name, c in cols.items()}
    expect_u = codec.unpack("BENCH_U", payloads["BENCH_U"])["U"]
    expect_y = np.column_stack([codec.unpack("BENCH_Y1", payloads["BENCH_Y1"])["Y1"],
                                codec.unpack("BENCH_Y4", payloads["BENCH_Y4"])["Y4"]])
    reset = codec.pack("CTRL_RESET", {"N_PARAMS": np.array([0])})
    journal = []
    for k in range(n):
        if k == 25:
            journal.append((k * 1e-3, 0, make_records(codec.messages["CTRL_RESET"].frame_id, reset).tobytes()))
        for name in cols:
            data = payloads[name][k].copy()
            if name == "BENCH_Y4" and k == 7:
                continue  # lost
            if name == "BENCH_Y1" and k == 9:
                data[0] ^= 0xFF  # bad CRC: dropped
            journal.append((k * 1e-3 + 1e-5, 0, make_records(codec.messages[name].frame_id, data[None]).tobytes()))
    log = tmp_path / "bus.log"
    write_journal(journal, log, "vcan0", 1000.0)
    recs = read_candump_runs(log, 1e-3)
    assert [len(r) for r in recs] == [25, 15]
    u_all = np.concatenate([r.u for r in recs])
    y_all = np.concatenate([r.y for r in recs])
    assert np.array_equal(u_all, expect_u)
    lost = np.zeros(n, dtype=bool)
    lost[[7, 9]] = True
    assert np.array_equal(np.isnan(y_all).all(axis=1), lost)
    assert np.array_equal(y_all[~lost], expect_y[~lost])
    assert np.allclose(np.diff(recs[0].t), 1e-3) and recs[1].t[0] == pytest.approx(((65520 + 25) & 0xFFFF) * 1e-3)
    # a log runs through tune's evaluation like a CSV does
    sc = load_scenario(default_scenario_path())
    res = run_records(sc, recs)
    assert all(len(r) == len(rec) for r, rec in zip(res, recs))


def test_truth_csv_is_a_record(tmp_path):
    sc = load_scenario(default_scenario_path()).replace(t_end=0.05)
    tr = simulate(sc)
    write_truth_csv(tr, tmp_path / "t.csv")
    rec = read_measurements_csv(tmp_path / "t.csv", sc.dt)
    assert np.array_equal(rec.u, tr.u) and np.array_equal(rec.y, tr.y)


def test_bench_binding_prints_its_table(recorded, tmp_path, capsys):
    """The speed table runs end to end (no timing is asserted)."""
    sc, (train, _) = recorded
    from caekf_sim.truth import Truth

    tr = truth(sc.replace(t_end=0.3))
    write_truth_csv(Truth(tr.t, tr.u, tr.y, tr.q, tr.v, tr.delta), tmp_path / "t.csv")
    assert main(["bench-binding", "--truth", str(tmp_path / "t.csv"), "--repeats", "1", "--step-calls", "100",
                 "--py-steps", "20"]) == 0
    out = capsys.readouterr().out
    for row in ("caekf_sim.run", "Estimator.step, y = numpy row", "numpy AEKF", "FilterPy EKF"):
        assert row in out
    assert out.count("caekf_sim.run ") == 2  # double and float


def test_tune_searches_a_declared_input_noise_and_the_mechanisms_drift_only_when_declared():
    """issue 27: tune can fit input{i}_sigma (a measured force's noise) once it is declared (> 0, a log-scale
    search); sigma_q_mech, the declared mechanism parameters' drift, only when one is declared."""
    from caekf_sim.scenario import load_scenario, default_scenario_path
    from caekf_sim.settings_adapter import tunable_noise

    sc = load_scenario(default_scenario_path())
    assert "input1_sigma" not in tunable_noise(sc) and "sigma_q_mech" not in tunable_noise(sc)
    declared = sc.replace(input1_sigma=0.02, spring1_k_sigma=0.03)
    assert {"input1_sigma", "sigma_q_mech"} <= set(tunable_noise(declared))
