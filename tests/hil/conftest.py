"""HIL suite fixtures: caekf-host on vcan0 (started once per session), one bench on the bus, the truth,
and the four experiments over the full scenario in strict lockstep (run once, used by several tests).

Run it with tools/hil-tests.sh (one user-mode Linux boot when this kernel has no vcan). Without the
interface or the binaries every test FAILS with the reason: this suite never skips for a missing
environment.

Environment:
  CAEKF_HIL_IFACE        CAN interface (default vcan0)
  CAEKF_BUILD_DIR        build tree with caekf-host, caekf-replay, caekf-truth (default build/host-double)
  CAEKF_HIL_TRUTH        truth CSV made beforehand (default: caekf-truth is run here)
  CAEKF_HIL_OUT          where logs and CSVs of the run are kept (default: pytest's tmp dir)
  CAEKF_HIL_WINDOW       lockstep window of the full runs (default 32 steps in flight; 1 = strict lockstep)
  CAEKF_HIL_PROFILE      protocol profile of caekf-host and the bench: diagnostics (default), production or fd
"""
from __future__ import annotations

import contextlib
import os
import subprocess
from pathlib import Path
from typing import Dict

import pytest

from hilcfg import (EXPERIMENTS, HOST_BIN, HOST_STEP_TIMEOUT_MS, IFACE, PROFILE, REPLAY_BIN, REPORT, SCENARIO,
                    TRUTH_BIN, report)


def pytest_terminal_summary(terminalreporter):
    if REPORT:
        terminalreporter.section("HIL measurements")
        for line in REPORT:
            terminalreporter.write_line(line)


@pytest.fixture(scope="session")
def out_dir(tmp_path_factory) -> Path:
    d = os.environ.get("CAEKF_HIL_OUT")
    if d:
        p = Path(d)
        p.mkdir(parents=True, exist_ok=True)
        return p
    return tmp_path_factory.mktemp("hil")


@pytest.fixture(scope="session")
def iface() -> str:
    if not os.path.exists(f"/sys/class/net/{IFACE}"):
        pytest.fail(f"HIL: CAN interface '{IFACE}' does not exist. This suite needs SocketCAN: run it with "
                    "tools/hil-tests.sh (it boots user-mode Linux with vcan0 when this kernel has no CAN), or create "
                    "it: sudo modprobe vcan && sudo ip link add dev vcan0 type vcan && sudo ip link set vcan0 up",
                    pytrace=False)
    return IFACE


@pytest.fixture(scope="session")
def binaries() -> Dict[str, Path]:
    missing = [str(p) for p in (HOST_BIN, REPLAY_BIN, TRUTH_BIN) if not p.exists()]
    if missing:
        pytest.fail(f"HIL: not built: {', '.join(missing)}. Build first: cmake --preset host-double && "
                    "cmake --build --preset host-double", pytrace=False)
    return {"host": HOST_BIN, "replay": REPLAY_BIN, "truth": TRUTH_BIN}


@pytest.fixture(scope="session")
def sc():
    from caekf_sim.scenario import load_scenario

    return load_scenario(SCENARIO)


@pytest.fixture(scope="session")
def truth(binaries, out_dir):
    from caekf_sim.truth import read_truth_csv

    path = os.environ.get("CAEKF_HIL_TRUTH")
    if not path:
        path = out_dir / "truth.csv"
        subprocess.run([str(binaries["truth"]), "--scenario", str(SCENARIO), "--out", str(path), "--quiet"],
                       check=True, stdout=subprocess.DEVNULL)
    return read_truth_csv(path)


@contextlib.contextmanager
def host_process(iface: str, binaries, log_path: Path, *extra: str, profile: str = PROFILE):
    """caekf-host on the interface while the block runs (profile, extra options; caekf_sim.bench.hostproc); its
    log is printed at the end. Fails the test with the log if it exits at start-up."""
    from caekf_sim.bench.hostproc import HostError, running_host

    # --step-timeout-ms: the bench sends a step's frames in one burst, so a partial step can only come from the
    # machine stalling between them; a guest on a busy host stalls for tens of ms at times, and the app's 20 ms
    # default (a real-time setting) then drops the step, shifting the estimator against the truth for the rest
    # of the run. A second keeps the comparison with caekf-replay about the estimator.
    try:
        with running_host(binaries["host"], iface, log_path, profile,
                          extra=("--step-timeout-ms", HOST_STEP_TIMEOUT_MS, *extra), settle=0.2) as proc:
            yield proc
    except HostError as e:
        pytest.fail(f"HIL: {e}", pytrace=False)
    finally:
        if log_path.exists():
            print(log_path.read_text())


@pytest.fixture(scope="session")
def estimator(iface, binaries, out_dir):
    """caekf-host on the interface for the whole session; its counters are printed at the end."""
    with host_process(iface, binaries, out_dir / "caekf-host.log") as proc:
        yield proc


@pytest.fixture(scope="session")
def bench(estimator, iface):
    from caekf_sim.bench import Bench

    b = Bench.open("socketcan", iface, profile=PROFILE)
    b.wait_for_estimator(timeout=10.0)
    yield b
    b.close()


@pytest.fixture(scope="session")
def inputs(bench, truth):
    return bench.prepare(truth.t, truth.u, truth.y)


@pytest.fixture(scope="session")
def seen_inputs_csv(inputs, out_dir) -> Path:
    """t,u,y1,y4 as the estimator decodes them from the frames, for caekf-replay."""
    from caekf_sim.bench.results import write_seen_inputs

    return write_seen_inputs(out_dir / "inputs-seen.csv", inputs)


@pytest.fixture(scope="session")
def replay(binaries, seen_inputs_csv, out_dir):
    """caekf-replay of each experiment on the exact inputs the estimator saw (full scenario)."""
    from caekf_sim.bench.results import run_c_replay

    cache = {}

    def get(experiment: str):
        if experiment not in cache:
            cache[experiment] = run_c_replay(binaries["replay"], SCENARIO, seen_inputs_csv, experiment,
                                             out_dir / f"replay-{experiment}.csv")
        return cache[experiment]

    return get


@pytest.fixture(scope="session")
def full_runs(bench, sc, inputs, out_dir):
    """The four experiments back to back over the full 60 s, lockstep (window CAEKF_HIL_WINDOW), one caekf-host."""
    from caekf_sim.bench.results import format_summary, save_runs
    from caekf_sim.bench.runner import run_experiment

    window = int(os.environ.get("CAEKF_HIL_WINDOW", "32"))
    runs = {}
    for name in EXPERIMENTS:
        runs[name] = run_experiment(bench, sc, inputs, name, len(inputs), "lockstep", window=window, timeout=2.0)
        r = runs[name]
        report(f"[{PROFILE}] lockstep (window {window}) {name}: {r.record.n} steps in {r.record.elapsed:.1f} s = "
               f"{r.steps_per_second:.0f} steps/s, timeouts {r.record.timeouts}")
    # decoded runs only (CSVs are slow to write in the TCG VM): `caekf-sim hil report --outdir <out>/full
    # --truth <out>/truth.csv` turns them into the CSVs, summary.txt and figures afterwards
    (out_dir / "full").mkdir(exist_ok=True)
    save_runs(list(runs.values()), out_dir / "full" / "runs.npz", f"HIL suite, lockstep window {window}")
    report(format_summary(list(runs.values()), sc.gamma))
    return runs
