"""Issue 14 part 3 prototype: does a more accurate discretisation inside the filter pay off?

Not part of the package (nothing ships from here): the numpy AEKF of caekf_sim.estimator with its
prediction replaced by
  - "be":         backward Euler at dt (eq. 19), the shipped model (the baseline);
  - "be-sub M":   backward Euler at dt/M, M substeps per sample, F the product of substep maps;
  - "trap M":     the trapezoidal rule (implicit, 2nd order, no numerical damping of the linear
                  modes) at dt/M; input linear between samples; F by the implicit function theorem.
Every substep is Newton-solved on v (q = q0 + h/2 (v0 + v)) with the contact force at both ends.
Run over a family with the continuous truth (caekf-truth) and print the family table:

    python sim/prototypes/discretisation.py sim/families/issue14.toml --runs 60 --seed 99 \
        --model be --model "trap 1" --model "trap 4"
"""
from __future__ import annotations

import argparse
import os
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from typing import Dict, List, Tuple

import numpy as np

from caekf_sim import flags as fl
from caekf_sim.campaign.estimate import Estimate
from caekf_sim.campaign.metrics import run_metrics
from caekf_sim.campaign.report import format_summary, summary_rows
from caekf_sim.campaign.runner import truth_arrays
from caekf_sim.campaign.spec import load_spec
from caekf_sim.estimator import IG, NA, AugmentedEKF, EstimatorConfig
from caekf_sim.model import B_CONTACT, NEWTON_RTOL
from caekf_sim.scenario import Scenario

B = B_CONTACT
BB = np.outer(B, B)


def _fc(delta: float, gamma: float) -> Tuple[float, float, float]:
    if delta <= 0.0:
        return 0.0, 0.0, 0.0
    s = np.sqrt(delta)
    return gamma * delta * s, 1.5 * gamma * s, delta * s


class SubstepEKF(AugmentedEKF):
    """AugmentedEKF whose prediction integrates with `scheme` ("be" or "trap") in `m` substeps."""

    def __init__(self, sc: Scenario, cfg: EstimatorConfig, scheme: str = "trap", m: int = 1) -> None:
        super().__init__(sc, cfg)
        self.scheme, self.m, self.h = scheme, m, sc.dt / m
        self.u_prev = 0.0  # u(0): the family and the paper start at rest with phase pi
        p = self.plant
        self.M, self.K, self.C = np.diag(p.m), p.K, p.C
        self.th = 0.5 if scheme == "trap" else 1.0  # weight of the new end (theta method)
        self.nis = float("nan")
        th, h = self.th, self.h
        # contact-free substep: linear, J0 v = M/h v0 - (1-th) C v0 - K q0 - th (1-th) h K v0 + u
        self.J0 = self.M / h + th * self.C + th * th * h * self.K
        self.J0inv = np.linalg.inv(self.J0)
        x0 = np.zeros(NA)
        x0[:4] = -1.0  # any open-contact state: F does not depend on it without contact
        x0[1], x0[2] = -1.0, 1.0
        self.F0 = self._sub_full(x0, 0.0, 0.0, linear_only=True)[1]

    def _sub(self, x: np.ndarray, ua: float, ub: float) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """Contact-free fast path (linear solve, constant F), else the Newton substep."""
        h, th, gap = self.h, self.th, self.plant.gap
        q0, v0 = x[:4], x[4:8]
        if q0[1] - q0[2] - gap <= 0.0:
            u = th * ub + (1 - th) * ua
            # r(v) = M (v - v0)/h + C (th v + (1-th) v0) + K (q0 + h th (th v + (1-th) v0)) - u = 0, exactly:
            rhs = self.M @ v0 / h - (1 - th) * (self.C @ v0) - self.K @ q0 - th * h * (1 - th) * (self.K @ v0)
            rhs[0] += u
            v = self.J0inv @ rhs
            q = q0 + h * (th * v + (1 - th) * v0)
            if q[1] - q[2] - gap <= 0.0:
                xn = x.copy()
                xn[:4], xn[4:8] = q, v
                return xn, self.F0, 1, True
        return self._sub_full(x, ua, ub)

    def _sub_full(self, x: np.ndarray, ua: float, ub: float, linear_only: bool = False):
        """One theta-method substep: returns x_new, F (9x9), iterations, converged."""
        h, th, gap = self.h, self.th, self.plant.gap
        M, K, C = self.M, self.K, self.C
        q0, v0, g = x[:4], x[4:8], x[IG]
        f0, k0, d0 = _fc(q0[1] - q0[2] - gap, g)
        u = th * ub + (1 - th) * ua
        v = v0.copy()
        ok, it = False, 0
        for it in range(1, 31):
            q = q0 + h * (th * v + (1 - th) * v0)
            f1, k1, _ = _fc(q[1] - q[2] - gap, g)
            r = M @ (v - v0) / h + C @ (th * v + (1 - th) * v0) + K @ (th * q + (1 - th) * q0) \
                + B * (th * f1 + (1 - th) * f0)
            r[0] -= u
            mag = np.abs(M @ (v - v0) / h) + np.abs(C) @ np.abs(v) + np.abs(K) @ np.abs(q) + abs(f1) + abs(f0)
            mag[0] += abs(u)
            if it > 1 and np.max(np.abs(r)) <= NEWTON_RTOL * np.max(mag):
                ok = True
                break
            J = M / h + th * C + th * th * h * (K + k1 * BB)
            v = v - np.linalg.solve(J, r)
        q = q0 + h * (th * v + (1 - th) * v0)
        f1, k1, d1 = _fc(q[1] - q[2] - gap, g)
        J = M / h + th * C + th * th * h * (K + k1 * BB)
        Kt1, Kt0 = K + k1 * BB, K + k0 * BB
        dr_dq0 = th * Kt1 + (1 - th) * Kt0
        dr_dv0 = -M / h + (1 - th) * C + th * (1 - th) * h * Kt1
        dr_dg = B * (th * d1 + (1 - th) * d0)
        Jinv = np.linalg.inv(J)
        dv_dq0, dv_dv0, dv_dg = -Jinv @ dr_dq0, -Jinv @ dr_dv0, -Jinv @ dr_dg
        F = np.eye(NA)
        F[:4, :4] = np.eye(4) + h * th * dv_dq0
        F[:4, 4:8] = h * ((1 - th) * np.eye(4) + th * dv_dv0)
        F[:4, IG] = h * th * dv_dg
        F[4:8, :4], F[4:8, 4:8], F[4:8, IG] = dv_dq0, dv_dv0, dv_dg
        xn = x.copy()
        xn[:4], xn[4:8] = q, v
        return xn, F, it, ok

    def predict(self, u: float):
        x, Phi, its, ok_all = self.x.copy(), np.eye(NA), 0, True
        for j in range(self.m):
            ua = self.u_prev + (u - self.u_prev) * j / self.m
            ub = self.u_prev + (u - self.u_prev) * (j + 1) / self.m
            x, F, it, ok = self._sub(x, ua, ub)
            Phi = F @ Phi
            its += it
            ok_all &= ok
        self.u_prev = u
        return x, Phi, its, ok_all


def make_ekf(sc: Scenario, cfg: EstimatorConfig, model: str) -> AugmentedEKF:
    parts = model.split()
    if parts == ["be"]:
        return AugmentedEKF(sc, cfg)
    scheme = {"be-sub": "be", "trap": "trap"}[parts[0]]
    return SubstepEKF(sc, cfg, scheme=scheme, m=int(parts[1]) if len(parts) > 1 else 1)


def run_one(args) -> List[Dict]:
    run, models, t_end = args
    sc = run.scenario
    tr = truth_arrays(sc, "c")
    rows = []
    for model in models:
        ekf = make_ekf(sc, EstimatorConfig(), model)
        n = len(tr.t)
        g, pgg, nis, flg = np.empty(n), np.empty(n), np.full(n, np.nan), np.zeros(n, np.int64)
        H, R = ekf.H, ekf.R
        t0 = time.perf_counter()
        with np.errstate(all="ignore"):
            for k in range(n):
                try:
                    flg[k], _ = ekf.step(float(tr.u[k]), tr.y[k])
                    g[k], pgg[k] = ekf.x[IG], ekf.P[IG, IG]
                except (np.linalg.LinAlgError, ValueError):  # a diverged filter: NaN from here on
                    g[k] = np.nan
                if not np.isfinite(g[k]):
                    g[k:], pgg[k:] = np.nan, np.nan
                    break
        row = {"run": run.run, "experiment": model, **{k: float(v) for k, v in run.values.items()}}
        row.update(run_metrics(tr.t, sc.gamma, tr.delta, Estimate(g, pgg, nis, flg)))
        row["wall_s"] = time.perf_counter() - t0
        rows.append(row)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("spec")
    ap.add_argument("--runs", type=int, default=60)
    ap.add_argument("--seed", type=int, default=None)
    ap.add_argument("--t-end", type=float, default=None)
    ap.add_argument("--model", action="append", default=None)
    ap.add_argument("--workers", type=int, default=os.cpu_count())
    a = ap.parse_args(argv)
    models = a.model or ["be", "trap 1"]
    fam = load_spec(a.spec, runs=a.runs, seed=a.seed, t_end=a.t_end)
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=a.workers) as pool:
        rows = [r for rs in pool.map(run_one, [(r, models, a.t_end) for r in fam.runs]) for r in rs]
    print(f"family {fam.name}, {len(fam.runs)} runs, seed {fam.seed}, numpy switched filter (no gate), "
          f"continuous truth; {time.perf_counter() - t0:.0f} s")
    print(format_summary(summary_rows(rows, fam, models)))
    import pyarrow.parquet as pq
    from caekf_sim.campaign.runner import rows_table

    os.makedirs("out/prototype", exist_ok=True)
    pq.write_table(rows_table(rows), f"out/prototype/discretisation-{fam.seed}-{len(fam.runs)}.parquet")
    return 0


if __name__ == "__main__":
    sys.exit(main())
