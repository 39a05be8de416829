"""Truth simulation, sampled every dt.

Default (`method="continuous"`): the continuous model (the equations eq. 19 discretises),
integrated by scipy's `solve_ivp` (DOP853 by default, rtol 1e-11) with the contact event
delta = q2 - q3 - gap = 0 located and the integration restarted there with the contact mode
switched (open: no force; closed: gamma * max(delta, 0)^1.5). The Hertz force is only C^1 at
delta = 0, so a step across the event would lose the method's order; restarting keeps it.
Samples come from the dense output. It is an independent implementation of what the C tool
`caekf-truth` does with its own DOP853 and event location; the two agree to ~1e-13 m
(`tests/test_truth_accuracy.py`, `caekf-sim truth-check`).

Legacy (`method="backward-euler"`), kept identical to `caekf-truth --method backward-euler`:
  * start at rest, q = v = 0 at t = 0, gamma = scenario.gamma;
  * substep j = 1 .. N*truth_substeps at time t_j = j*h, u_j = u(t_j);
  * each substep solves eq. (19) for v_j by Newton from v_{j-1} (model.StepSolver);
  * sample k = 1..N is the state after substep j = k*truth_substeps, t_k = k*dt.
Both: recorded with u(t_k) and y = [q1, q4] + noise (noise from numpy default_rng(seed),
an (N, 2) standard-normal draw times noise_std, row k = [noise_y1, noise_y4]).
CSV columns: t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta written with %.17g.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import math
from typing import Any, List, Tuple, Union

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
    events: int = 0  # continuous: contact events located (closing and opening)
    rhs_evals: int = 0  # continuous: right-hand side evaluations


CONTINUOUS = "continuous"
BACKWARD_EULER = "backward-euler"
TRUTH_METHODS = (CONTINUOUS, BACKWARD_EULER)
TRUTH_RTOL = 1e-11
TRUTH_ATOL_Q = 1e-15  # [m]
TRUTH_ATOL_V = 1e-13  # [m/s]


def simulate(sc: Scenario, return_stats: bool = False, method: str = CONTINUOUS,
             integrator: str = "DOP853", rtol: float = TRUTH_RTOL, atol_q: float = TRUTH_ATOL_Q,
             atol_v: float = TRUTH_ATOL_V):
    """Run the truth model; returns Truth (and TruthStats when return_stats).

    method: "continuous" (event-located solve_ivp with `integrator`, "DOP853" or "Radau", at
    rtol / atol_q [m] / atol_v [m/s]) or "backward-euler" (eq. 19 at dt/truth_substeps).
    """
    q: Any  # (N, 4) arrays in the continuous branch, plain float lists in the backward-Euler hot loop
    v: Any
    if method == CONTINUOUS:
        q, v, stats = continuous_states(sc, integrator=integrator, rtol=rtol, atol_q=atol_q, atol_v=atol_v)
        truth = _sampled(sc, q, v)
        return (truth, stats) if return_stats else truth
    if method != BACKWARD_EULER:
        raise ValueError(f"unknown truth method {method!r}; choose from {TRUTH_METHODS}")
    plant = Plant.from_scenario(sc)
    n = sc.n_steps
    sub = sc.truth_substeps
    h = sc.dt / sub
    solver = StepSolver(plant, h, max_iter=TRUTH_NEWTON_MAX_ITER)

    # u at every substep time t_j = j*h, evaluated in one vectorised call.
    u_sub = np.asarray(plant.force(np.arange(1, n * sub + 1, dtype=float) * h)).tolist()

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

    truth = _sampled(sc, out_q, out_v)
    if return_stats:
        return truth, TruthStats(iters_total, iters_max, contact)
    return truth


def _sampled(sc: Scenario, q: np.ndarray, v: np.ndarray) -> Truth:
    """Samples k = 1..N from the states: time grid, input, seeded noisy measurements, penetration."""
    plant = Plant.from_scenario(sc)
    n = sc.n_steps
    t = np.arange(1, n + 1, dtype=float) * sc.dt
    noise = np.random.default_rng(sc.seed).standard_normal((n, 2)) * sc.noise_std
    y = q[:, [0, 3]] + noise
    return Truth(t=t, u=np.asarray(plant.force(t)), y=y, q=q, v=v, delta=np.asarray(plant.penetration(q)))


def continuous_states(sc: Scenario, integrator: str = "DOP853", rtol: float = TRUTH_RTOL,
                      atol_q: float = TRUTH_ATOL_Q, atol_v: float = TRUTH_ATOL_V,
                      t_end: "float | None" = None) -> Tuple[np.ndarray, np.ndarray, TruthStats]:
    """(q, v) at t_k = k dt, k = 1..N (or up to t_end) of the continuous model from rest.

    One solve_ivp per contact mode segment, each ended by the terminal event delta = 0 crossed
    in the direction that leaves the mode; the next segment restarts at the located event.
    """
    from scipy.integrate import solve_ivp  # scipy only for this method

    plant = Plant.from_scenario(sc)
    minv = 1.0 / plant.m
    K, C = plant.K, plant.C
    w = 2.0 * np.pi * sc.u_freq
    n = sc.n_steps if t_end is None else int(round(t_end / sc.dt))
    ts = np.arange(1, n + 1, dtype=float) * sc.dt
    atol = np.r_[[atol_q] * 4, [atol_v] * 4]

    def rhs(closed: bool):
        def f(t: float, x: np.ndarray) -> np.ndarray:
            a = -(K @ x[:4]) - C @ x[4:]
            a[0] += sc.u_amp * math.sin(w * t + sc.u_phase)
            if closed:
                d = x[1] - x[2] - sc.gap
                if d > 0.0:
                    fc = sc.gamma * d * math.sqrt(d)
                    a[1] -= fc
                    a[2] += fc
            return np.concatenate([x[4:], a * minv])
        return f

    def event(t: float, x: np.ndarray) -> float:
        return x[1] - x[2] - sc.gap

    event.terminal = True  # type: ignore[attr-defined]
    out = np.empty((n, 8))
    t, y, closed, i, events, nfev = 0.0, np.zeros(8), False, 0, 0, 0
    # The restart state is taken just past the located event, on the far side (a few ulps later at
    # most), so the new mode's event cannot fire again at once. A touch with no far side within
    # `graze` seconds (tangential) keeps the mode and continues `graze` later.
    graze = 1e-9
    while i < n:
        event.direction = -1.0 if closed else 1.0  # type: ignore[attr-defined]
        sol = solve_ivp(rhs(closed), (t, ts[-1]), y, method=integrator, rtol=rtol, atol=atol,
                        events=event, dense_output=True)
        if sol.status < 0:
            raise RuntimeError(f"truth integration failed at t = {sol.t[-1]:.6f} s: {sol.message}")
        nfev += sol.nfev
        if sol.status != 1:
            out[i:] = sol.sol(ts[i:]).T
            break
        t_ev = float(sol.t_events[0][0])
        want = -1.0 if closed else 1.0  # sign of delta past the event
        t_new = t_ev + graze
        switch = False
        for dtk in np.r_[0.0, np.geomspace(4 * np.finfo(float).eps * max(1.0, abs(t_ev)), graze, 24)]:
            yy = sol.sol(t_ev + dtk)
            if want * (yy[1] - yy[2] - sc.gap) > 0.0:
                t_new, switch = t_ev + dtk, True
                break
        j = int(np.searchsorted(ts, t_new, side="right"))
        if j > i:
            out[i:j] = sol.sol(ts[i:j]).T
        i = j
        t, y = t_new, sol.sol(t_new)
        if switch:
            closed = not closed
        events += 1
    return out[:, :4], out[:, 4:], TruthStats(0, 0, 0, events=events, rhs_evals=nfev)


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
    eps: List[Tuple[float, float]] = []
    for s, e in zip(starts, ends):
        if eps and t[s] - eps[-1][1] <= merge_gap:
            eps[-1] = (eps[-1][0], float(t[e]))
        else:
            eps.append((float(t[s]), float(t[e])))
    return eps
