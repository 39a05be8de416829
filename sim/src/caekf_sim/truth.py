"""Truth simulation: backward Euler (eq. 19) at h = dt/truth_substeps, sampled every dt.

Algorithm (kept identical to the C tool `caekf-truth` so the two agree to ~1e-12 m):
  * start at rest, q = v = 0 at t = 0, gamma = scenario.gamma;
  * substep j = 1 .. N*truth_substeps at time t_j = j*h, u_j = u(t_j);
  * each substep solves eq. (19) for v_j by Newton from v_{j-1} (model.StepSolver);
  * sample k = 1..N is the state after substep j = k*truth_substeps, t_k = k*dt,
    recorded with u(t_k) and y = [q1, q4] + noise (noise from numpy default_rng(seed),
    an (N, 2) standard-normal draw times noise_std, row k = [noise_y1, noise_y4]).
CSV columns: t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta written with %.17g.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Union

import numpy as np

from .model import Plant, StepSolver
from .scenario import Scenario

TRUTH_COLUMNS = ("t", "u", "y1", "y4", "q1", "q2", "q3", "q4", "v1", "v2", "v3", "v4", "delta")
TRUTH_NEWTON_MAX_ITER = 50

PathLike = Union[str, Path]


@dataclass(frozen=True)
class Truth:
    """Samples k = 1..N. Arrays have length N (q, v: shape (N, 4))."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray  # (N, 2): measured q1, q4
    q: np.ndarray
    v: np.ndarray
    delta: np.ndarray

    def __len__(self) -> int:
        return len(self.t)

    def as_array(self) -> np.ndarray:
        return np.column_stack([self.t, self.u, self.y, self.q, self.v, self.delta])


@dataclass(frozen=True)
class TruthStats:
    newton_iters_total: int
    newton_iters_max: int
    contact_substeps: int


def simulate(sc: Scenario, return_stats: bool = False):
    """Run the truth model; returns Truth (and TruthStats when return_stats)."""
    plant = Plant.from_scenario(sc)
    n = sc.n_steps
    sub = sc.truth_substeps
    h = sc.dt / sub
    solver = StepSolver(plant, h, max_iter=TRUTH_NEWTON_MAX_ITER)

    # u at every substep time t_j = j*h, evaluated in one vectorised call.
    u_sub = plant.force(np.arange(1, n * sub + 1, dtype=float) * h).tolist()

    # Contact-free substeps are an affine map of (q, v): v' = J0^-1 (M/h v - K q + e1 u).
    # Keep the hot loop in plain floats over the precomputed rows: much faster than numpy
    # calls on 4-vectors, and still the same arithmetic up to round-off.
    gap = plant.gap
    Jinv = solver.J0_inv
    # Row i of the map: v'_i = sum_j a[i][j] q_j + sum_j a[i][4+j] v_j + a[i][8] u.
    a = np.hstack([-(Jinv @ plant.K), Jinv * solver.m_h[None, :], Jinv[:, :1]]).tolist()

    q = [0.0, 0.0, 0.0, 0.0]
    v = [0.0, 0.0, 0.0, 0.0]
    out_q = np.empty((n, 4))
    out_v = np.empty((n, 4))
    iters_total = 0
    iters_max = 0
    contact = 0
    gamma = sc.gamma
    j = 0
    for k in range(n):
        for _ in range(sub):
            uj = u_sub[j]
            j += 1
            q0, q1, q2, q3 = q
            v0, v1, v2, v3 = v
            # Newton's initial guess out of contact -> try the one-iteration linear answer.
            if (q1 + h * v1) - (q2 + h * v2) - gap <= 0.0:
                nv = [
                    r[0] * q0 + r[1] * q1 + r[2] * q2 + r[3] * q3
                    + r[4] * v0 + r[5] * v1 + r[6] * v2 + r[7] * v3 + r[8] * uj
                    for r in a
                ]
                nq = [q0 + h * nv[0], q1 + h * nv[1], q2 + h * nv[2], q3 + h * nv[3]]
                if nq[1] - nq[2] - gap <= 0.0:
                    q, v = nq, nv
                    iters_total += 1
                    if iters_max < 1:
                        iters_max = 1
                    continue
            qa, va, it, ok = solver.newton(np.array(q), np.array(v), uj, gamma)
            if not ok:
                raise RuntimeError(f"truth Newton did not converge at t = {j * h:.6f} s")
            q, v = qa.tolist(), va.tolist()
            iters_total += it
            iters_max = max(iters_max, it)
            contact += 1
        out_q[k] = q
        out_v[k] = v

    t = np.arange(1, n + 1, dtype=float) * sc.dt
    noise = np.random.default_rng(sc.seed).standard_normal((n, 2)) * sc.noise_std
    y = out_q[:, [0, 3]] + noise
    truth = Truth(
        t=t, u=np.asarray(plant.force(t)), y=y, q=out_q, v=out_v, delta=plant.penetration(out_q)
    )
    if return_stats:
        return truth, TruthStats(iters_total, iters_max, contact)
    return truth


def write_truth_csv(truth: Truth, path: PathLike) -> None:
    np.savetxt(path, truth.as_array(), fmt="%.17g", delimiter=",", header=",".join(TRUTH_COLUMNS),
               comments="")


def read_truth_csv(path: PathLike) -> Truth:
    """Read a truth CSV (ours or the C tool's); columns are matched by header name."""
    with open(path, encoding="utf-8") as f:
        header = [c.strip() for c in f.readline().split(",")]
    missing = [c for c in TRUTH_COLUMNS if c not in header]
    if missing:
        raise ValueError(f"{path}: missing columns {missing}")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {name: data[:, header.index(name)] for name in TRUTH_COLUMNS}
    return Truth(
        t=col["t"],
        u=col["u"],
        y=np.column_stack([col["y1"], col["y4"]]),
        q=np.column_stack([col[f"q{i}"] for i in range(1, 5)]),
        v=np.column_stack([col[f"v{i}"] for i in range(1, 5)]),
        delta=col["delta"],
    )


def contact_episodes(t: np.ndarray, delta: np.ndarray, merge_gap: float = 0.0):
    """(start, end) times of runs with delta > 0; runs separated by <= merge_gap are merged."""
    active = delta > 0.0
    edges = np.diff(active.astype(np.int8), prepend=0, append=0)
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    eps = []
    for s, e in zip(starts, ends):
        if eps and t[s] - eps[-1][1] <= merge_gap:
            eps[-1] = (eps[-1][0], float(t[e]))
        else:
            eps.append((float(t[s]), float(t[e])))
    return eps
