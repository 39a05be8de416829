"""The paper's experiments over CAN, one after the other on one running estimator."""
from __future__ import annotations

import time
from pathlib import Path
from typing import Callable, List, Optional, Sequence, Union

from .bench import Bench, StepInputs
from .codec import EXPERIMENTS
from .results import HilRun

PathLike = Union[str, Path]


def load_truth(sc, truth_csv: Optional[PathLike] = None, log: Callable[[str], None] = print):
    """The truth CSV when given (e.g. from caekf-truth), else the numpy truth model."""
    from ..truth import read_truth_csv, simulate

    if truth_csv is not None:
        return read_truth_csv(truth_csv)
    log("hil: no --truth given: simulating the truth with numpy (caekf-truth is much faster)")
    return simulate(sc)


def rows_for(sc, n_total: int, duration: Optional[float]) -> int:
    if duration is None:
        return n_total
    return max(1, min(n_total, int(round(duration / sc.dt))))


def run_experiment(bench: Bench, sc, inputs: StepInputs, experiment: str, rows: int, mode: str = "lockstep",
                   window: int = 1, timeout: float = 1.0, progress: Optional[bool] = None,
                   params=None) -> HilRun:
    """Configure the scenario with the preset `experiment`, snapshot the counters, run rows [0, rows),
    snapshot again, decode."""
    from .transport import SocketcanTransport

    ack = bench.configure(experiment, bench.params_from_scenario(sc, experiment) if params is None else params)
    before = bench.status()
    if mode == "lockstep":
        rec = bench.run_lockstep(inputs, 0, rows, window=window, timeout=timeout, progress=progress,
                                 desc=experiment)
    elif mode == "realtime" and isinstance(bench.transport, SocketcanTransport):
        rec = bench.run_paced(inputs, sc.dt, 0, rows)  # absolute deadlines, kernel timestamps
    elif mode == "realtime":
        rec = bench.run_realtime(inputs, sc.dt, 0, rows, progress=progress, desc=experiment)
    else:
        raise ValueError(f"unknown mode {mode!r}")
    time.sleep(0.01)
    after = bench.status()
    dec = bench.decode_run(rec, inputs)
    return HilRun(experiment, inputs, rec, dec, before, after, ack)


def run_experiments(bench: Bench, sc, truth, experiments: Sequence[str] = EXPERIMENTS, duration=None,
                    mode: str = "lockstep", window: int = 1, timeout: float = 1.0,
                    progress: Optional[bool] = None, log: Callable[[str], None] = print) -> List[HilRun]:
    t0 = time.perf_counter()
    bench.match_scenario(sc)  # the mechanism's frames (diagnostics), or the paper's I/O checked
    inputs = bench.prepare(truth.t, truth.u, truth.y)
    log(f"hil: {len(inputs)} steps encoded and sealed-ready in {time.perf_counter() - t0:.2f} s "
        f"(numpy, checked against cantools); transport {bench.transport.name}")
    rows = rows_for(sc, len(inputs), duration)
    runs = []
    for name in experiments:
        run = run_experiment(bench, sc, inputs, name, rows, mode, window, timeout, progress)
        res = run.result
        g = res.gamma
        log(f"hil: {name}: {int(run.decoded.complete.sum())}/{rows} steps in {run.record.elapsed:.1f} s "
            f"({run.steps_per_second:.0f} steps/s), timeouts {run.record.timeouts}, final gamma "
            + (f"{g[-1]:.6g} ({100 * (g[-1] / sc.gamma - 1):+.3f} %)" if len(g) else "-"))
        runs.append(run)
    return runs
