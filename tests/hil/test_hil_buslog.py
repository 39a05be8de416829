"""Bus logs: a run recorded as a candump -L log (python-can's writer) and replayed into the estimator
gives the same estimate frames; through the library and through `caekf-sim hil replay-log`."""
import numpy as np

from hilcfg import IFACE, SCENARIO, report

ROWS = 2000


def test_recorded_log_replays_to_the_same_estimates(bench, sc, inputs, out_dir):
    from caekf_sim.bench.buslog import read_log
    from caekf_sim.bench.replay import replay_log, segment_results
    from caekf_sim.cli import main
    from caekf_sim.results import read_result_csv

    log_path = out_dir / "switched-2000.log"
    bench.journal = []
    try:
        bench.configure("switched", bench.params_from_scenario(sc, "switched"))
        rec = bench.run_lockstep(inputs, 0, ROWS)
        # one corrupted frame in the log: replayed as recorded, rejected again
        bad = bench.frame("BENCH_U", {"STEP": 0, "U": 0.0}, advance=False)
        bench.send(bad[:8] + bytes([bad[8] ^ 1]) + bad[9:])
        bench.status()
        n = bench.write_log(log_path)
    finally:
        bench.journal = None
    first = log_path.read_text().splitlines()[0]
    assert first.startswith("(") and f" {IFACE} " in first and "#" in first, first
    frames = read_log(log_path, bench.codec.from_estimator_ids)
    assert len(frames) == n >= ROWS * 15
    dec = bench.decode_run(rec, inputs)

    rep = replay_log(bench, log_path, timeout=2.0)
    report(f"log replay (library): {rep.text()}")
    assert rep.ok, rep.text()
    assert rep.matched >= ROWS * 12
    (name, res), = segment_results(bench, rep, sc.dt)
    assert name == "switched" and len(res.t) == ROWS
    np.testing.assert_array_equal(res.gamma, dec.columns["gamma"])
    np.testing.assert_allclose(res.t, inputs.t[:ROWS], rtol=0, atol=1e-12)

    outdir = out_dir / "replay-cli"
    rc = main(["hil", "replay-log", "--iface", IFACE, "--log", str(log_path), "--outdir", str(outdir),
               "--scenario", str(SCENARIO), "--no-progress"])
    assert rc == 0
    res2 = read_result_csv(outdir / "replay-0-switched.csv")
    np.testing.assert_array_equal(res2.gamma, dec.columns["gamma"])
