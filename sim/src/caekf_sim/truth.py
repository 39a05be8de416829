"""Truth simulation of any mechanism (mechanism.py), sampled every dt.

Default (`method="continuous"`): the continuous model (the equations eq. 19 discretises),
    q' = v,  M v' = B_u u(t) - C v - K q - sum_c b_c f_c(q, v, gamma_c),
integrated by scipy's `solve_ivp` (DOP853 by default, rtol 1e-11) with every contact's event
delta_c = 0 located and the integration restarted there with that contact's mode switched (open:
no force; closed: its law). A power law is only C^1 (n = 1.5) or C^0 (n = 1) at delta = 0, so a
step across the event would lose the method's order; restarting keeps it. Samples come from the
dense output. It is an independent implementation of what the C tool `caekf-truth` does with its
own DOP853 and event location; the two agree to ~1e-13 m on the paper (`tests/test_truth_accuracy.py`,
`caekf-sim truth-check`).

Legacy (`method="backward-euler"`), kept identical to `caekf-truth --method backward-euler`:
  * start at rest, q = v = 0 at t = 0, gamma_c = contact{c}_gamma;
  * substep j = 1 .. N*truth_substeps at time t_j = j*h, u_j = u(t_j);
  * each substep solves eq. (19) for v_j by Newton from v_{j-1} (model.StepSolver);
  * sample k = 1..N is the state after substep j = k*truth_substeps, t_k = k*dt.
Inputs: the sines of the scenario (input{i}_amp/freq/phase), or `inputs=` samples (t_j, u_j) read
from a CSV (`read_input_csv`), linearly interpolated, end values held outside their time range.
Both: recorded with u(t_k) and y = the sensors' q or v + noise (noise from numpy
default_rng(seed), an (N, ns) standard-normal draw, column i times noise_std for a position
sensor, noise_std_v for a velocity sensor).
CSV columns (the paper): t,u,y1,y4,q1,q2,q3,q4,v1,v2,v3,v4,delta written with %.17g; in general
t, u or u1..u<ni>, the sensor names (y<body>, yv<body>), q1..q<nq>, v1..v<nq>, delta or delta1..delta<nc>.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, List, Optional, Tuple, Union

import numpy as np

from .mechanism import BASE_DISPLACEMENT, VELOCITY, InputSeries, Mechanism, contact_law, contact_values, scenario_value
from .model import StepSolver
from .scenario import Scenario, require_truth

TRUTH_COLUMNS = ("t", "u", "y1", "y4", "q1", "q2", "q3", "q4", "v1", "v2", "v3", "v4", "delta")
TRUTH_NEWTON_MAX_ITER = 50

PathLike = Union[str, Path]
InputFn = Callable[[Any], np.ndarray]  # t (...,) -> u (..., ni)


@dataclass(frozen=True)
class Truth:
    """Samples k = 1..N. Arrays have length N: q, v (N, nq), y (N, ns); u (N,) for one input else
    (N, ni); delta (N,) for one contact else (N, nc) (the CSV's columns)."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray  # (N, ns): the sensors' readings (the paper: q1, q4)
    q: np.ndarray
    v: np.ndarray
    delta: np.ndarray
    y_names: Tuple[str, ...] = ("y1", "y4")

    def __len__(self) -> int:
        return len(self.t)

    @property
    def inputs(self) -> np.ndarray:
        """u as (N, ni)."""
        return self.u.reshape(len(self.t), -1)

    @property
    def deltas(self) -> np.ndarray:
        """delta as (N, nc)."""
        return self.delta.reshape(len(self.t), -1)

    def columns(self) -> Tuple[str, ...]:
        ni, nq, nc = self.inputs.shape[1], self.q.shape[1], self.deltas.shape[1]
        return ("t", *(["u"] if self.u.ndim == 1 else [f"u{i}" for i in range(1, ni + 1)]), *self.y_names,
                *[f"q{i}" for i in range(1, nq + 1)], *[f"v{i}" for i in range(1, nq + 1)],
                *(["delta"] if self.delta.ndim == 1 else [f"delta{i}" for i in range(1, nc + 1)]))

    def as_array(self) -> np.ndarray:
        return np.column_stack([self.t, self.u, self.y, self.q, self.v, self.delta])


@dataclass(frozen=True)
class TruthStats:
    newton_iters_total: int
    newton_iters_max: int
    contact_substeps: int
    events: int = 0  # continuous: contact events located (closing and opening, all contacts)
    rhs_evals: int = 0  # continuous: right-hand side evaluations


CONTINUOUS = "continuous"
BACKWARD_EULER = "backward-euler"
TRUTH_METHODS = (CONTINUOUS, BACKWARD_EULER)
TRUTH_RTOL = 1e-11
TRUTH_ATOL_Q = 1e-15  # [m]
TRUTH_ATOL_V = 1e-13  # [m/s]


def input_function(mech: Mechanism, inputs: Any = None) -> InputFn:
    """u(t) -> (..., ni): the mechanism's sines, or an InputSeries / (t, u) pair of samples."""
    if inputs is None:
        return mech.inputs
    series = inputs if isinstance(inputs, InputSeries) else InputSeries(*inputs)
    if series.u.shape[1] != mech.n_inputs:
        raise ValueError(f"input series has {series.u.shape[1]} columns, the scenario {mech.n_inputs} inputs")
    return series


def rate_function(mech: Mechanism, inputs: Any = None) -> InputFn:
    """du/dt (..., ni) of input_function(mech, inputs): the sines' derivatives, or a series' central differences
    (InputSeries.rate). A base displacement's force takes it (c du/dt)."""
    if inputs is None or inputs == mech.inputs:
        return mech.input_rates
    rate = getattr(inputs, "rate", None)
    if rate is None:
        rate = InputSeries(*inputs).rate if isinstance(inputs, tuple) else None
    if rate is None:
        raise ValueError("a base displacement needs its rate: give the inputs as samples or an InputSeries")
    return rate


def simulate(sc: Scenario, return_stats: bool = False, method: str = CONTINUOUS,
             integrator: str = "DOP853", rtol: float = TRUTH_RTOL, atol_q: float = TRUTH_ATOL_Q,
             atol_v: float = TRUTH_ATOL_V, inputs: Any = None, mech: Optional[Mechanism] = None):
    """Run the truth model; returns Truth (and TruthStats when return_stats).

    method: "continuous" (event-located solve_ivp with `integrator`, "DOP853" or "Radau", at
    rtol / atol_q [m] / atol_v [m/s]) or "backward-euler" (eq. 19 at dt/truth_substeps).
    inputs: None (the scenario's sines) or samples (t (M,), u (M, ni)) / an InputSeries.
    """
    q: Any  # (N, nq) arrays in the continuous branch, plain float lists in the backward-Euler hot loop
    v: Any
    require_truth(sc)  # gamma, the inputs' sines, t_end, noise, seed: a recording's scenario has none
    if getattr(sc, "structure", None) is not None:
        raise ValueError(f"{sc.source}: a structure given as matrices has its own truth (caekf_sim.structure: "
                         "the full model it was reduced from), not a line's")
    mech = mech if mech is not None else Mechanism.from_scenario(sc)
    ufn = input_function(mech, inputs)
    dufn = rate_function(mech, ufn) if mech.has_base_inputs else None
    if method == CONTINUOUS:
        q, v, stats = continuous_states(sc, integrator=integrator, rtol=rtol, atol_q=atol_q, atol_v=atol_v,
                                        inputs=ufn, mech=mech)
        truth = _sampled(sc, mech, ufn, q, v, dufn)
        return (truth, stats) if return_stats else truth
    if method != BACKWARD_EULER:
        raise ValueError(f"unknown truth method {method!r}; choose from {TRUTH_METHODS}")
    n = sc.n_steps
    sub = sc.truth_substeps
    h = sc.dt / sub
    sampled_mech = mech
    solver = StepSolver(mech, h, max_iter=TRUTH_NEWTON_MAX_ITER)
    nq = mech.nq
    gamma = contact_values(sc, "gamma", mech.n_contacts)

    # u at every substep time t_j = j*h, evaluated in one vectorised call.
    u_sub = np.asarray(ufn(np.arange(1, n * sub + 1, dtype=float) * h)).tolist()
    if mech.has_base_inputs:
        # A base displacement enters backward Euler as the force k u_j + c (u_j - u_{j-1}) / h on its body (the
        # C truth's caekf_model_newton with u_{j-1}, u_j): these forces, and B_u's columns e_body for them.
        ua = np.asarray(ufn(np.arange(0, n * sub + 1, dtype=float) * h)).reshape(n * sub + 1, -1)
        base = mech.input_kind == BASE_DISPLACEMENT
        gain = np.where(base, mech.B_u.sum(axis=0), 1.0)
        rate = mech.B_du.sum(axis=0)
        f = np.where(base, gain * ua[1:] + rate * (ua[1:] - ua[:-1]) / h, ua[1:])
        u_sub = f.tolist()
        mech = dataclasses.replace(mech, input_kind=np.zeros_like(mech.input_kind),
                                   input_link=np.full_like(mech.input_link, -1))
        solver = StepSolver(mech, h, max_iter=TRUTH_NEWTON_MAX_ITER)

    # Contact-free substeps are an affine map of (q, v): v' = J0^-1 (M/h v - K q + B_u u).
    # Keep the hot loop in plain floats over the precomputed rows: much faster than numpy
    # calls on short vectors, and still the same arithmetic up to round-off.
    # Row i of the map: v'_i = sum_j a[i][j] q_j + sum_j a[i][nq+j] v_j + sum_j a[i][2nq+j] u_j.
    Jinv = solver.J0_inv
    a = np.hstack([-(Jinv @ mech.K), Jinv * solver.m_h[None, :], Jinv @ mech.B_u]).tolist()
    pen = solver.penetrations

    q = [0.0] * nq
    v = [0.0] * nq
    out_q = np.empty((n, nq))
    out_v = np.empty((n, nq))
    iters_total = 0
    iters_max = 0
    contact = 0
    j = 0
    for k in range(n):
        for _ in range(sub):
            uj = u_sub[j]
            j += 1
            # Newton's initial guess out of contact -> try the one-iteration linear answer.
            if all(d <= 0.0 for d in pen([qi + h * vi for qi, vi in zip(q, v)])):
                z = q + v + uj
                nv = [_dot(r, z) for r in a]
                nq_ = [qi + h * vi for qi, vi in zip(q, nv)]
                if all(d <= 0.0 for d in pen(nq_)):
                    q, v = nq_, nv
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

    truth = _sampled(sc, sampled_mech, ufn, out_q, out_v, dufn)
    if return_stats:
        return truth, TruthStats(iters_total, iters_max, contact)
    return truth


def _dot(r: List[float], z: List[float]) -> float:
    """Left-to-right sum of products (not sum(), which compensates since Python 3.12)."""
    acc = r[0] * z[0]
    for ri, zi in zip(r[1:], z[1:]):
        acc += ri * zi
    return acc


def _truth_force(d: float, dd: float, g: float, n: float, lam: float) -> float:
    """The contact force of the continuous truth: the law of mechanism.contact_law, with the paper's
    Hertz case written as the truth always wrote it, (gamma delta) sqrt(delta)."""
    if n == 1.5 and lam == 0.0:
        return g * d * math.sqrt(d)
    return contact_law(d, dd, g, n, lam)[0]


def _sampled(sc: Scenario, mech: Mechanism, ufn: InputFn, q: np.ndarray, v: np.ndarray,
             dufn: Optional[InputFn] = None) -> Truth:
    """Samples k = 1..N from the states: time grid, input, seeded noisy measurements, penetration. dufn: the
    inputs' rates (a base displacement's; None: none)."""
    n = sc.n_steps
    t = np.arange(1, n + 1, dtype=float) * sc.dt
    std = np.array([float(scenario_value(sc, f"sensor{i}_noise")) or
                    float(scenario_value(sc, "noise_std_v" if k == VELOCITY else "noise_std"))
                    for i, k in enumerate(mech.sensor_kind.tolist(), start=1)])
    bias = np.array([float(scenario_value(sc, f"sensor{i}_bias")) for i in range(1, mech.n_sensors + 1)])
    noise = np.random.default_rng(sc.seed).standard_normal((n, mech.n_sensors))
    noise = noise * (std[0] if np.all(std == std[0]) else std)
    u = np.asarray(ufn(t))
    du = np.asarray(dufn(t)).reshape(n, -1) if dufn is not None else None
    a = (mech.accelerations(q, v, u.reshape(n, -1), contact_values(sc, "gamma", mech.n_contacts), du)
         if mech.has_acceleration else None)
    ends = mech.base_ends(u.reshape(n, -1), du) if du is not None else None
    y = mech.measure(q, v, a, ends) + noise
    if np.any(bias != 0.0):
        y = y + bias
    delta = mech.penetrations(q)
    return Truth(t=t, u=u[:, 0] if mech.n_inputs == 1 else u, y=y, q=q, v=v,
                 delta=delta[:, 0] if mech.n_contacts == 1 else delta, y_names=mech.sensor_names())


def continuous_states(sc: Scenario, integrator: str = "DOP853", rtol: float = TRUTH_RTOL,
                      atol_q: float = TRUTH_ATOL_Q, atol_v: float = TRUTH_ATOL_V,
                      t_end: "float | None" = None, inputs: Optional[InputFn] = None,
                      mech: Optional[Mechanism] = None) -> Tuple[np.ndarray, np.ndarray, TruthStats]:
    """(q, v) at t_k = k dt, k = 1..N (or up to t_end) of the continuous model from rest.

    One solve_ivp per contact-mode segment (a mode: which contacts are closed), each ended by the
    first terminal event delta_c = 0 crossed in the direction that leaves contact c's mode; the next
    segment restarts at the located event with that contact's mode switched (`integrate_modes`).
    """
    require_truth(sc)
    mech = mech if mech is not None else Mechanism.from_scenario(sc)
    nq, nc = mech.nq, mech.n_contacts
    minv = 1.0 / mech.m
    K, C = mech.K, mech.C
    contacts = mech.contacts
    gammas = contact_values(sc, "gamma", nc).tolist()
    rows = mech.input_body.tolist()
    n = sc.n_steps if t_end is None else int(round(t_end / sc.dt))
    ts = np.arange(1, n + 1, dtype=float) * sc.dt
    atol = np.r_[[atol_q] * nq, [atol_v] * nq]
    sines = [(2.0 * np.pi * f, a, p) for a, f, p in
             zip(mech.input_amp.tolist(), mech.input_freq.tolist(), mech.input_phase.tolist())]
    if inputs is None:  # the sines, scalar math in the right-hand side (the hot path)
        def u_at(t: float) -> List[float]:
            return [a * math.sin(w * t + p) for w, a, p in sines]
    else:
        def u_at(t: float) -> List[float]:
            return np.asarray(inputs(t)).tolist()
    # A base displacement u: k u + c du/dt on its body (K and C hold -k q, -c v), du/dt the sines' derivative or
    # the series' central differences (rate_function).
    base = [(int(i), float(mech.B_u[rows[i], i]), float(mech.B_du[rows[i], i]))
            for i in np.flatnonzero(mech.input_kind == BASE_DISPLACEMENT).tolist()]
    if base and (inputs is None or inputs == mech.inputs):
        def du_at(t: float) -> List[float]:
            return [a * w * math.cos(w * t + p) for w, a, p in sines]
    elif base:
        rate = rate_function(mech, inputs)

        def du_at(t: float) -> List[float]:
            return np.asarray(rate(t)).tolist()

    def rhs(closed: Tuple[bool, ...]):
        def f(t: float, x: np.ndarray) -> np.ndarray:
            a = -(K @ x[:nq]) - C @ x[nq:]
            uu = u_at(t)
            if base:  # the input's force: k u + c du/dt in place of u
                du = du_at(t)
                uu = list(uu)
                for i, k, c in base:
                    uu[i] = k * uu[i] + c * du[i]
            for row, uj in zip(rows, uu):
                a[row] += uj
            for (ia, ib, gap, ne, lam), g, on in zip(contacts, gammas, closed):
                if on:
                    d = (x[ia] if ia >= 0 else 0.0) - (x[ib] if ib >= 0 else 0.0) - gap
                    if d > 0.0:
                        dd = (x[nq + ia] if ia >= 0 else 0.0) - (x[nq + ib] if ib >= 0 else 0.0)
                        fc = _truth_force(d, dd, g, ne, lam)
                        if ia >= 0:
                            a[ia] -= fc
                        if ib >= 0:
                            a[ib] += fc
            return np.concatenate([x[nq:], a * minv])
        return f

    out, events, nfev = integrate_modes(rhs, np.zeros(2 * nq), mech, ts, integrator, rtol, atol)
    return out[:, :nq], out[:, nq:], TruthStats(0, 0, 0, events=events, rhs_evals=nfev)


def integrate_modes(rhs: Callable[[Tuple[bool, ...]], Callable[[float, np.ndarray], np.ndarray]], y0: np.ndarray,
                    mech: Mechanism, ts: np.ndarray, integrator: str, rtol: float, atol: Any
                    ) -> Tuple[np.ndarray, int, int]:
    """(states at ts (len(ts), len(y0)), events located, rhs evaluations) of x' = rhs(closed)(t, x) from
    y0 at t = 0, the state's first 2 nq entries being [q; v]: one solve_ivp per contact-mode segment,
    each ended by the first terminal event delta_c = 0 crossed in the direction that leaves contact c's
    mode; the next segment restarts at the located event with that contact's mode switched. Entries
    beyond [q; v] (e.g. sensitivities) ride along.
    """
    from scipy.integrate import solve_ivp  # scipy only for this method

    nc = mech.n_contacts
    contacts = mech.contacts
    n = len(ts)

    def penetration(c: int) -> Callable[[np.ndarray], float]:
        ia, ib, gap = contacts[c][:3]
        return lambda x: (x[ia] if ia >= 0 else 0.0) - (x[ib] if ib >= 0 else 0.0) - gap

    pens = [penetration(c) for c in range(nc)]

    def event_of(c: int):
        def event(t: float, x: np.ndarray) -> float:
            return pens[c](x)
        event.terminal = True  # type: ignore[attr-defined]
        return event

    events_fn = [event_of(c) for c in range(nc)]
    out = np.empty((n, len(y0)))
    t, y, i, events, nfev = 0.0, np.asarray(y0, dtype=float), 0, 0, 0
    closed = [False] * nc
    # The restart state is taken just past the located event, on the far side (a few ulps later at
    # most), so the new mode's event cannot fire again at once. A touch with no far side within
    # `graze` seconds (tangential) keeps the mode and continues `graze` later.
    graze = 1e-9
    while i < n:
        for c, ev in enumerate(events_fn):
            ev.direction = -1.0 if closed[c] else 1.0  # type: ignore[attr-defined]
        sol = solve_ivp(rhs(tuple(closed)), (t, ts[-1]), y, method=integrator, rtol=rtol, atol=atol,
                        events=events_fn if nc != 1 else events_fn[0], dense_output=True)
        if sol.status < 0:
            raise RuntimeError(f"truth integration failed at t = {sol.t[-1]:.6f} s: {sol.message}")
        nfev += sol.nfev
        if sol.status != 1:
            out[i:] = sol.sol(ts[i:]).T
            break
        fired = [(float(te[0]), c) for c, te in enumerate(sol.t_events) if len(te)]
        t_ev, c = min(fired)
        want = -1.0 if closed[c] else 1.0  # sign of delta_c past the event
        t_new = t_ev + graze
        switch = False
        for dtk in np.r_[0.0, np.geomspace(4 * np.finfo(float).eps * max(1.0, abs(t_ev)), graze, 24)]:
            if want * pens[c](sol.sol(t_ev + dtk)) > 0.0:
                t_new, switch = t_ev + dtk, True
                break
        j = int(np.searchsorted(ts, t_new, side="right"))
        if j > i:
            out[i:j] = sol.sol(ts[i:j]).T
        i = j
        t, y = t_new, sol.sol(t_new)
        if switch:
            closed[c] = not closed[c]
        events += 1
    return out, events, nfev


def write_truth_csv(truth: Truth, path: PathLike) -> None:
    np.savetxt(path, truth.as_array(), fmt="%.17g", delimiter=",", header=",".join(truth.columns()),
               comments="")


def read_truth_csv(path: PathLike) -> Truth:
    """Read a truth CSV (ours or the C tool's); columns are matched by header name (TRUTH_COLUMNS for
    the paper; u/u<i>, y<body>/yv<body>, q<i>, v<i>, delta/delta<c> in general)."""
    with open(path, encoding="utf-8") as f:
        header = [c.strip() for c in f.readline().split(",")]

    def numbered(prefix: str) -> List[str]:
        return sorted((c for c in header if c.startswith(prefix) and c[len(prefix):].isdigit()),
                      key=lambda c: int(c[len(prefix):]))

    qn, vn = numbered("q"), numbered("v")
    un = ["u"] if "u" in header else numbered("u")
    dn = ["delta"] if "delta" in header else numbered("delta")
    yn = [c for c in header if (c.startswith("yv") and c[2:].isdigit()) or (c.startswith("y") and c[1:].isdigit())]
    missing = [c for c in TRUTH_COLUMNS if c not in header] if not qn or not yn or "t" not in header else []
    if missing or len(vn) != len(qn):
        raise ValueError(f"{path}: missing columns {missing or ['v1']}")
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {name: data[:, header.index(name)] for name in header}

    def stack(names: List[str], squeeze: bool) -> np.ndarray:
        if not names:
            return np.zeros((len(data), 0))
        return col[names[0]] if squeeze else np.column_stack([col[c] for c in names])

    return Truth(
        t=col["t"],
        u=stack(un, un == ["u"]),
        y=np.column_stack([col[c] for c in yn]),
        q=np.column_stack([col[c] for c in qn]),
        v=np.column_stack([col[c] for c in vn]),
        delta=stack(dn, dn == ["delta"]),
        y_names=tuple(yn),
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
