#!/usr/bin/env python3
"""Campaign benchmark: the same family locally (process pool) and on a 2-worker Dask LocalCluster.

Prints wall times, their ratio and whether the two tables are equal row for row (wall-time columns
excepted). Usage: .venv/bin/python tools/campaign-bench.py [SPEC] [--runs N] [--t-end S]
"""
from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

from caekf_sim.campaign.runner import TIMING_COLUMNS, run_family
from caekf_sim.campaign.spec import load_spec

ROOT = Path(__file__).resolve().parents[1]


def same(a, b) -> bool:
    if len(a) != len(b):
        return False
    for ra, rb in zip(a, b):
        for k in ra:
            if k in TIMING_COLUMNS:
                continue
            va, vb = ra[k], rb.get(k)
            if isinstance(va, float) and math.isnan(va):
                if not (isinstance(vb, float) and math.isnan(vb)):
                    return False
            elif va != vb:
                return False
    return True


def main() -> int:
    ap = argparse.ArgumentParser()
    ap.add_argument("spec", nargs="?", default=str(ROOT / "sim" / "families" / "issue14.toml"))
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--t-end", type=float, default=None)
    ap.add_argument("--experiment", action="append", default=None)
    a = ap.parse_args()
    exps = a.experiment or ["switched"]
    fam = load_spec(a.spec, runs=a.runs, t_end=a.t_end)
    t0 = time.perf_counter()
    local = run_family(fam, exps, progress=False)
    t_local = time.perf_counter() - t0
    import distributed

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=None) as cluster, distributed.Client(cluster) as client:
        t0 = time.perf_counter()
        dask_rows = run_family(fam, exps, client=client, progress=False)
        t_dask = time.perf_counter() - t0
    truth_cpu = sum(r["truth_s"] for r in local) / len(exps)
    est_cpu = sum(r["estimate_s"] for r in local)
    t_end = fam.runs[0].scenario.t_end
    print(f"{'where':<28} {'runs':>5} {'t_end s':>7} {'wall s':>8} {'truth cpu s':>11} {'estimator cpu s':>15}")
    print(f"{'local pool (all cores)':<28} {len(fam.runs):>5} {t_end:>7g} {t_local:>8.1f} {truth_cpu:>11.1f} "
          f"{est_cpu:>15.1f}")
    print(f"{'Dask LocalCluster, 2 workers':<28} {len(fam.runs):>5} {t_end:>7g} {t_dask:>8.1f} {'':>11} {'':>15}")
    print(f"ratio dask/local {t_dask / t_local:.2f}; tables equal row for row: {same(local, dask_rows)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
