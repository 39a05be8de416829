"""The example mechanisms over CAN (diagnostics profile): sim/scenarios/shuttle.toml (6 bodies, 2 inputs, 4 sensors
with a velocity sensor, 2 contacts) and valve.toml (2 bodies, a position and a velocity sensor, a contact to ground).

The session's caekf-host and bench (the paper's profile) are switched to the mechanism for the test
(`Bench.use_mechanism`: its inputs and sensors on BENCH_U, BENCH_U2, BENCH_Y1, BENCH_Y4, BENCH_S*_POS,
BENCH_S*_VEL; every body's EST_Q/EST_V, EST_GAMMA, EST_P_GG and contact 2's EST_GAMMA2, EST_P_GG2 back), configured
with the scenario over the schema's defaults (the recommended estimator; after the paper's canonical preset, so
nothing of an earlier configuration may carry over), and driven with the first seconds of
caekf-truth in lockstep. Checked: every step answered and complete, a clean bus, and every state (2 bodies +
contacts), P norm, P_gamma,gamma of every contact equal to caekf-replay's on the inputs the estimator decoded within
each signal's wire resolution, flags and Newton iterations identical. The window reaches a contact, so gamma is
compared while it is estimated. Diagnostics profile only (production and fd carry the paper's frames).
"""
import subprocess

import numpy as np
import pytest

from hilcfg import PROFILE, REPO, report

SECONDS = {"valve": 3.0, "shuttle": 4.0}  # short: the CI HIL stage stays near 3 minutes
CONTACT_ACTIVE = 1 << 3

pytestmark = pytest.mark.skipif(PROFILE != "diagnostics", reason="mechanisms travel in the diagnostics profile")


@pytest.fixture(scope="module")
def mechanism_bench(bench):
    """The session's bench, switched to a mechanism by the test and back to the paper afterwards."""
    saved = (bench.profile, bench.names)
    yield bench
    bench.profile, bench.names = saved


@pytest.mark.parametrize("name", sorted(SECONDS))
def test_mechanism_over_can_equals_replay(mechanism_bench, binaries, out_dir, name):
    from caekf_sim.bench.results import compare_with_replay, run_c_replay, write_seen_inputs
    from caekf_sim.bench.runner import rows_for, run_experiment
    from caekf_sim.mechanism import Mechanism
    from caekf_sim.scenario import load_scenario
    from caekf_sim.truth import read_truth_csv

    bench = mechanism_bench
    scenario = REPO / "sim" / "scenarios" / f"{name}.toml"
    sc = load_scenario(scenario)
    mech = Mechanism.from_scenario(sc)
    truth_csv = out_dir / f"truth-{name}.csv"
    subprocess.run([str(binaries["truth"]), "--scenario", str(scenario), "--out", str(truth_csv), "--quiet"],
                   check=True, stdout=subprocess.DEVNULL)
    truth = read_truth_csv(truth_csv)
    prof = bench.use_mechanism(sc)
    rows = rows_for(sc, len(truth.t), SECONDS[name])
    inputs = bench.prepare(truth.t[:rows], truth.u[:rows], truth.y[:rows])
    # first the paper's canonical run (mode, discretisation, sensor kinds other than the defaults' and the
    # mechanism's): the mechanism's configuration must leave nothing of it (the bus stages from the running settings)
    bench.configure("canonical", bench.params_from_scenario(load_scenario(REPO / "sim" / "scenarios" / "paper.toml"),
                                                            "canonical"))
    run = run_experiment(bench, sc, inputs, "defaults", rows, "lockstep", window=32, timeout=2.0,
                         params=bench.params_from_scenario(sc))
    seen = write_seen_inputs(out_dir / f"inputs-seen-{name}.csv", inputs)
    ref = run_c_replay(binaries["replay"], scenario, seen, None, out_dir / f"replay-{name}.csv")

    # every state of the mechanism and every contact's gamma and P_gamma,gamma came over CAN
    states = [f"q{i}" for i in range(1, mech.nq + 1)] + [f"v{i}" for i in range(1, mech.nq + 1)]
    states += ["gamma", "gamma2"][:mech.n_contacts]
    assert len(states) == 2 * mech.nq + mech.n_contacts
    want = set(states) | {"p_norm", "p_gg"} | ({"p_gg2"} if mech.n_contacts > 1 else set())
    assert want <= set(prof.results), sorted(want - set(prof.results))

    dec = run.decoded
    agr = compare_with_replay(dec, ref, bench.codec, prof)
    report(f"[mechanism {name}] {rows} steps ({mech.nq} bodies, {mech.n_inputs} inputs, {mech.n_sensors} sensors, "
           f"{mech.n_contacts} contacts) in {run.record.elapsed:.1f} s: CAN vs caekf-replay: {agr.text()}")
    assert agr.ok, agr.text()
    assert set(agr.carried) == want and all(agr.carried[c] == rows for c in want), agr.carried
    assert run.record.timeouts == 0
    assert dec.complete.all(), f"{int((~dec.complete).sum())} steps incomplete"
    assert (dec.bad_crc, dec.bad_dlc, dec.counter_duplicates, dec.counter_jumps) == (0, 0, 0, 0)
    h = run.health
    assert h["STEPS_DONE"] == rows
    for counter in ("RX_BAD_CRC", "RX_BAD_DLC", "RX_COUNTER_JUMP", "RX_DUPLICATE", "RX_LOST", "RX_BAD_VALUE",
                    "RX_LATE", "RX_REPEATED", "STEPS_TIMED_OUT", "STEPS_SUPERSEDED", "STEPS_SKIPPED", "TX_ERRORS",
                    "TX_SATURATED"):
        assert h[counter] == 0, (counter, h[counter])

    # the window reaches a contact: gamma is compared while it is being estimated
    assert np.any(dec.columns["flags"].astype(np.int64) & CONTACT_ACTIVE), "no contact in the window"
