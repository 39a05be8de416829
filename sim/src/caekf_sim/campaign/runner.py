"""Run a family: for each mechanism the truth, each requested estimator configuration and the
metrics; locally on a process pool or on a Dask distributed cluster. Rows come back sorted by
(run, experiment), so the table does not depend on where or in which order runs executed."""
from __future__ import annotations

import math
import os
import subprocess
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, Iterable, List, Optional, Sequence, Tuple

import numpy as np

from ..scenario import Scenario
from ..truth import simulate
from .estimate import estimate
from .metrics import contact_suffix, run_metrics, truth_stats
from .spec import Family, Run, scenario_text
from .tools import require_tool

TRUTH_BACKENDS = ("binding", "c", "numpy", "c-backward-euler")
TIMING_COLUMNS = ("truth_s", "estimate_s")  # wall times: excluded when comparing campaigns


@dataclass(frozen=True)
class Task:
    run: Run
    experiments: Tuple[str, ...]
    truth: str = "binding"
    estimator: str = "binding"
    observability: bool = False  # also the observability tool's verdict on the estimated law parameters and,
    # where the scenario declares uncertain parameters, the admission by gamma's bound (admission_verdict)


@dataclass(frozen=True)
class TruthArrays:
    t: np.ndarray
    u: np.ndarray  # (N,) for one input, else (N, inputs) [N]
    y: np.ndarray  # (N, sensors)
    delta: np.ndarray  # (N,) for one contact, else (N, contacts) [m]
    failed: bool
    q: np.ndarray  # (N, bodies) true positions [m]
    v: np.ndarray  # (N, bodies) true velocities [m/s]

    @property
    def deltas(self) -> np.ndarray:
        """delta as (N, contacts)."""
        return self.delta.reshape(len(self.t), -1)


def _failed_truth(sc: Scenario) -> TruthArrays:
    """A run whose integration failed: NaN arrays of the mechanism's shapes."""
    n = sc.n_steps
    nan = lambda *shape: np.full((n,) + shape, np.nan)  # noqa: E731
    one = lambda k: nan() if k == 1 else nan(k)  # noqa: E731
    return TruthArrays(nan(), one(sc.inputs), nan(sc.sensors), one(sc.contacts), True, nan(sc.bodies),
                       nan(sc.bodies))


def truth_arrays(sc: Scenario, backend: str = "binding") -> TruthArrays:
    """Measurements and penetrations of a scenario, any mechanism: caekf-truth's C generator in process
    (binding, default), the caekf-truth program ("c", "c-backward-euler") or the numpy truth."""
    if backend == "binding":
        from ..binding import truth as c_truth

        try:
            tr = c_truth(sc)
        except ValueError:  # the integration failed: report the run as failed
            return _failed_truth(sc)
        return TruthArrays(tr.t, tr.u, tr.y, tr.delta, False, tr.q, tr.v)
    if backend == "numpy":
        tr = simulate(sc)
        return TruthArrays(tr.t, tr.u, tr.y, tr.delta, False, tr.q, tr.v)
    if backend not in TRUTH_BACKENDS:
        raise ValueError(f"unknown truth backend {backend!r}; choose from {TRUTH_BACKENDS}")
    tool = require_tool("caekf-truth")
    method = "backward-euler" if backend == "c-backward-euler" else "dop853"
    ni, ns, nq, nc = sc.inputs, sc.sensors, sc.bodies, sc.contacts
    width = 1 + ni + ns + 2 * nq + nc  # t, u.., y.., q.., v.., delta..: the CSV's columns
    with tempfile.TemporaryDirectory(prefix="caekf-truth-") as tmp:
        scen, binf = Path(tmp) / "scenario.toml", Path(tmp) / "truth.bin"
        scen.write_text(scenario_text(sc), encoding="utf-8")
        proc = subprocess.run([str(tool), "--scenario", str(scen), "--no-csv", "--bin", str(binf), "--quiet",
                               "--method", method], capture_output=True, check=False)
        if proc.returncode not in (0, 5):
            raise RuntimeError(f"caekf-truth exit {proc.returncode}: {proc.stderr.decode(errors='replace').strip()}")
        rec = np.fromfile(binf, dtype="<f8").reshape(-1, width)
    n = sc.n_steps
    failed = proc.returncode == 5 or len(rec) < n
    if len(rec) < n:  # the integration stopped: pad so the run is still reported (as failed)
        rec = np.vstack([rec, np.full((n - len(rec), width), np.nan)])
    cols = np.cumsum([1, ni, ns, nq, nq, nc])
    u, y, q, v, delta = (rec[:, a:b] for a, b in zip(cols[:-1], cols[1:]))
    return TruthArrays(rec[:, 0], u[:, 0] if ni == 1 else u, y, delta[:, 0] if nc == 1 else delta, failed, q, v)


def observability_verdict(sc: Scenario, layout: Sequence[Tuple[int, str]]) -> Dict[str, Any]:
    """What the observability tool (identifiability.py) says of the estimated law parameters and the gammas
    of their contacts on this run's truth: `observable_all` (the rank test passes for every one),
    `crb_meets_targets` (3 times the Cramer-Rao bound at the end is within metrics.JOINT_TOL for every one:
    an efficient, consistent estimator can meet the targets) and each parameter's relative (the gap:
    absolute) bound."""
    from .. import identifiability as idf
    from .metrics import JOINT_TOL

    contacts = sorted({c + 1 for c, _ in layout})
    names = ["gamma"] + [p for p in ("n", "lambda", "gap") if any(name == p for _, name in layout)]
    params = idf.law_params(sc, names, contacts)
    try:
        an = idf.analyse_run(sc, params)
    except (ValueError, RuntimeError) as exc:  # the sensitivities' integration failed: the tool cannot say
        return {"observable_all": False, "crb_meets_targets": False, "observability_error": str(exc)}
    out: Dict[str, Any] = {"observable_all": bool(np.all(an.observable))}
    meets = True
    for p, crb in zip(params, an.crb[-1]):
        bound = float(crb) if p.name == "gap" else float(crb) / abs(p.value)
        out[f"crb_contact{p.contact}_{p.name}"] = bound
        meets = meets and 3.0 * bound <= JOINT_TOL[p.name]
    out["crb_meets_targets"] = bool(meets and out["observable_all"])
    return out


# Admission by the Cramer-Rao bound (issue 27's targets): a run is admitted when ADMIT_SIGMAS bounds of gamma,
# with every declared parameter unknown, fit within ADMIT_TOL (relative): an efficient, consistent estimator
# then ends within ADMIT_TOL.
ADMIT_TOL = 0.02
ADMIT_SIGMAS = 3.0


def declares_uncertainty(sc: Scenario) -> bool:
    """The filter's scenario declares a mechanism parameter (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma
    > 0) or an input's noise (input{i}_sigma > 0)."""
    from ..binding import mech_layout
    from ..mechanism import scenario_value

    return bool(mech_layout(sc)) or any(float(scenario_value(sc, f"input{i + 1}_sigma")) > 0.0
                                        for i in range(int(sc.inputs)))


def admission_verdict(sc: Scenario, layout: Sequence[Tuple[int, str]]) -> Dict[str, Any]:
    """The Cramer-Rao bound of every contact's gamma on this run's truth `sc` (which carries the filter's
    declarations) with every declared mechanism parameter unknown, the estimated law parameters too, the
    initial state a nuisance and the declared input noise as process noise (identifiability.analyse_run).
    The posterior bound: the filter is given each declared sigma (and its P0) as prior information, which the
    Fisher bound alone ignores. `crb_gamma_declared` (the worst contact's relative posterior bound),
    `crb_gamma_declared_fisher` (the same without the prior; inf when not observable), `crb_<key>` (each
    declared parameter's relative posterior bound) and `crb_admitted` (ADMIT_SIGMAS bounds within ADMIT_TOL)."""
    from .. import identifiability as idf

    nc = int(sc.contacts)
    contacts = list(range(1, nc + 1))
    names = ["gamma"] + [p for p in ("n", "lambda", "gap") if any(name == p for _, name in layout)]
    params = idf.law_params(sc, names, contacts) + idf.mechanism_params(sc)
    try:
        an = idf.analyse_run(sc, params)
    except (ValueError, RuntimeError) as exc:  # the sensitivities' integration failed: the tool cannot say
        return {"crb_gamma_declared": float("inf"), "crb_admitted": False, "admission_error": str(exc)}
    gammas = [i for i, p in enumerate(an.params) if p.name == "gamma" and p.contact]
    post = [float(an.crb_post[-1, i]) / abs(an.params[i].value) for i in gammas]
    fisher = [float(an.crb[-1, i]) / abs(an.params[i].value) for i in gammas]
    worst = max(post) if post else float("inf")
    out: Dict[str, Any] = {"crb_gamma_declared": worst, "crb_gamma_declared_fisher": max(fisher, default=math.inf),
                           "crb_admitted": bool(ADMIT_SIGMAS * worst <= ADMIT_TOL)}
    for i, p in enumerate(an.params):
        if p.mech:  # relative to the value; an offset's (value 0) in its own unit
            out[f"crb_{p.key}"] = float(an.crb_post[-1, i]) / (abs(p.value) if p.mech != "b" else 1.0)
    return out


def filter_inputs(run: Run, tr: TruthArrays) -> np.ndarray:
    """The inputs the filter reads: the truth run's forces, plus the run's input noise under [mismatch]."""
    noise = run.input_noise(len(tr.t))
    return tr.u if noise is None else tr.u + noise


def run_task(task: Task) -> List[Dict[str, Any]]:
    """All rows of one mechanism: one per experiment. The truth simulates the run's truth scenario (the
    filter's own unless the family's [mismatch] perturbs it); every estimator runs the filter's scenario on
    the truth's measurements and the inputs it reads (filter_inputs)."""
    sc = task.run.scenario
    t0 = time.perf_counter()
    truth_sc = task.run.truth_scenario()
    tr = truth_arrays(truth_sc, task.truth)
    u_read = filter_inputs(task.run, tr)
    truth_s = time.perf_counter() - t0
    from ..mechanism import contact_values, law_layout, scenario_value

    nc = int(sc.contacts)
    g_true = contact_values(truth_sc, "gamma", nc)
    g0 = contact_values(sc, "gamma0", nc)
    base: Dict[str, Any] = {"run": task.run.run, "source": task.run.source}
    base.update({k: float(v) for k, v in task.run.values.items()})
    for c in range(nc):
        base[f"gamma_true{contact_suffix(c)}"] = float(g_true[c])
        base[f"gamma0{contact_suffix(c)}"] = float(g0[c])
    base.update({"bodies": int(sc.bodies), "contacts": nc, "sensors": int(sc.sensors),
                 "truth_failed": bool(tr.failed)})
    base.update(truth_stats(tr.delta, nc))
    layout = law_layout(sc, nc)
    law_true = {f"contact{c + 1}_{name}": float(scenario_value(truth_sc, f"contact{c + 1}_{name}"))
                for c, name in layout}
    if task.observability and layout:
        base.update(observability_verdict(truth_sc, layout))
    if task.observability and declares_uncertainty(sc):  # issue 27: admitted by gamma's bound, all declared unknown
        base.update(admission_verdict(truth_sc, layout))
    rows = []
    for e in task.experiments:
        t1 = time.perf_counter()
        est = estimate(sc, e, tr.t, u_read, tr.y, backend=task.estimator)
        row = dict(base)
        row["experiment"] = e
        row.update(run_metrics(tr.t, g_true, tr.delta, est, law_true))
        row["truth_s"] = truth_s
        row["estimate_s"] = time.perf_counter() - t1
        rows.append(row)
    return rows


def _progress(total: int, enabled: bool):
    if not enabled:
        return None
    try:
        from tqdm import tqdm
    except ImportError:  # pragma: no cover
        return None
    return tqdm(total=total, unit="run", mininterval=0.5)


def run_family(family: Family, experiments: Sequence[str], truth: str = "binding", estimator: str = "binding",
               workers: Optional[int] = None, scheduler: Optional[str] = None, client: Any = None,
               progress: bool = True, observability: bool = False) -> List[Dict[str, Any]]:
    """Rows of every (run, experiment), sorted. Local process pool by default (workers: all cores);
    scheduler "tcp://HOST:PORT" or a dask.distributed Client runs the same tasks on Dask."""
    tasks = [Task(r, tuple(experiments), truth, estimator, observability) for r in family.runs]
    bar = _progress(len(tasks), progress)
    rows: List[Dict[str, Any]] = []
    if client is not None or scheduler is not None:
        from distributed import Client, as_completed as dask_completed

        own = client is None
        cl = Client(scheduler) if own else client
        try:
            futures = cl.map(run_task, tasks, pure=False)
            for fut in dask_completed(futures):
                rows.extend(fut.result())
                if bar is not None:
                    bar.update(1)
        finally:
            if own:
                cl.close()
    elif workers == 1:
        for task in tasks:
            rows.extend(run_task(task))
            if bar is not None:
                bar.update(1)
    else:
        with ProcessPoolExecutor(max_workers=workers or os.cpu_count() or 1) as pool:
            for fut in as_completed([pool.submit(run_task, task) for task in tasks]):
                rows.extend(fut.result())
                if bar is not None:
                    bar.update(1)
    if bar is not None:
        bar.close()
    order = {e: i for i, e in enumerate(experiments)}
    rows.sort(key=lambda r: (r["run"], order[r["experiment"]]))
    return rows


def rows_table(rows: Iterable[Dict[str, Any]]):
    """A pyarrow Table of the rows (columns in first-seen order)."""
    import pyarrow as pa

    rows = list(rows)
    cols: Dict[str, List[Any]] = {}
    for r in rows:
        for k in r:
            cols.setdefault(k, [])
    for r in rows:
        for k in cols:
            cols[k].append(r.get(k))
    return pa.table(cols)
