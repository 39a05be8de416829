"""Which contact-law parameters a run can observe, and how well: sensitivities, rank test, Cramer-Rao bound.

For a scenario (mechanism, sensors, excitation) the truth's measurement trajectory y_k = H x(t_k) depends
on the chosen law parameters theta (any of gamma, n, lambda, gap of any contact) and, unless it is
declared known, on the initial state x0. Their sensitivities S_k = dy_k/d[x0; theta] come from the
variational equations of the continuous model (docs/mechanism.md), integrated with the truth's own
event-located mode segments (truth.integrate_modes):

    x' = f(t, x, theta),   d/dt (dx/dp) = A(t) dx/dp + df/dp,   A = df/dx,   dx/dx0 (0) = I, dx/dtheta (0) = 0.

A contact's force is continuous at delta = 0, so the sensitivities do not jump at its events. Then

  * rank test: the Fisher information J = sum_k S_k^T R^-1 S_k (R from sigma_r / sigma_rv), its columns
    equilibrated (unit diagonal, a zero column stays zero), is rank deficient along its null space;
    parameter i is observable iff e_i has no component in that null space (RANK_RTOL, NULL_TOL) and its
    bound is below MAX_REL_CRB times its scale (a sensitivity that is only the decayed rest of a
    transient is not information);
  * Cramer-Rao bound of an observable parameter: sqrt([J^+]_ii) (x0 as a nuisance); the posterior bound
    adds the prior P0^-1 (contact{i}_sigma_gamma0, sigma_q0, sigma_v0, optional priors for n, lambda, gap);
  * both cumulatively along the run (J over the samples up to t), so a user sees when the bound falls
    below 1 % of the value.

Declared mechanism parameters (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0; `mechanism_params`) are
unknowns too, each column dy/d ln(value), the declared sigma its prior; a declared force noise
(input{i}_sigma > 0) is process noise: the information is whitened by the Kalman filter of its response
through the model linearised along the truth (`information_input_noise`; docs/observability.md).

Columns are scaled for the integrator (the parameter's value, 1 SI unit for a zero value; sigma_q0 and
sigma_v0 for the initial state); the results are in SI units.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .mechanism import (ACCELERATION, LINK_FORCE, Mechanism, MechanismError, bias_layout, contact_law, contact_values,
                        scenario_value)
from .mechanism import sensor_sigmas as mechanism_sensor_sigmas
from .scenario import require_truth
from .schema import setting_of
from .truth import TRUTH_ATOL_Q, TRUTH_ATOL_V, input_function, integrate_modes

PARAMS = ("gamma", "n", "lambda", "gap")  # the law's parameters: the schema's contact{i}_<name> keys
SENS_RTOL = 1e-9  # the sensitivity integration's rtol (atol: the truth's, on the scaled columns)
RANK_RTOL = 1e-6  # singular value of the equilibrated, whitened S below RANK_RTOL * the largest: null
NULL_TOL = 1e-3  # a parameter with a larger component in the null space is not observable
MAX_REL_CRB = 1e6  # nor is one whose bound exceeds a million times its scale: its sensitivity is numerical dust
REL_TARGET = 0.01  # the relative bound the report times ("when does the CRB fall below 1 %")


class IdentifiabilityError(ValueError):
    """A request the analysis cannot serve; one line."""


@dataclass(frozen=True)
class Param:
    """One unknown: a contact's law parameter, an entry of the initial state (contact = 0), or a declared
    mechanism parameter (contact = 0, `mech` its kind)."""

    contact: int  # 1-based contact number; 0 for the initial state and the mechanism's parameters
    name: str  # gamma | n | lambda | gap, q0_<body> / v0_<body>, or the value's key m<i> / spring<i>_k / spring<i>_c
    value: float
    scale: float  # the column scale of the integration (SI units of the parameter)
    mech: str = ""  # a mechanism parameter's kind: "m" (a mass), "k" (a link's stiffness), "c" (its damper),
    # or "b" (a sensor's offset)
    element: int = -1  # its body, link or sensor, 0-based
    prior: float = math.inf  # its prior std in SI (the declared sigma times the value; inf: none)

    @property
    def key(self) -> str:
        """The scenario key (contact1_gamma, q0_2, ...)."""
        return f"contact{self.contact}_{self.name}" if self.contact else self.name

    @property
    def label(self) -> str:
        return self.key


def law_params(sc: Any, params: Sequence[str], contacts: Sequence[int]) -> List[Param]:
    """The chosen law parameters of the chosen contacts (1-based), values from the scenario."""
    mech = Mechanism.from_scenario(sc)
    for what, items in (("parameter", params), ("contact", contacts)):
        dup = [x for i, x in enumerate(items) if x in items[:i]]
        if dup:
            raise IdentifiabilityError(f"{what} {dup[0]!r} chosen twice")
    out = []
    for c in contacts:
        if not 1 <= c <= mech.n_contacts:
            raise IdentifiabilityError(f"contact {c}: the scenario has contacts 1..{mech.n_contacts}")
        for name in params:
            if name not in PARAMS:
                raise IdentifiabilityError(f"parameter {name!r}: choose from {', '.join(PARAMS)}")
            key = f"contact{c}_{name}"
            setting_of(key)  # the schema's key (KeyError would be a bug here)
            value = float(scenario_value(sc, key))
            out.append(Param(c, name, value, abs(value) if value != 0.0 else 1.0))
    return out


def mechanism_params(sc: Any) -> List[Param]:
    """The scenario's declared mechanism parameters (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0),
    in the filter's state order (binding.mech_layout: masses, stiffnesses, dampers): the unknown is the
    value, its column scale the value itself, so a column is dy/d ln(value) and the relative bound that of
    ln(value); the declared sigma times the value is its prior std. Then the sensors' declared offsets
    (sensor{i}_bias_sigma > 0), each scaled and its prior std its declared sigma (docs/sensors.md)."""
    from .binding import mech_layout

    out = []
    for key in mech_layout(sc):
        value = float(scenario_value(sc, key))
        sigma = float(scenario_value(sc, f"{key}_sigma"))
        if key.startswith("m"):
            kind, elem = "m", int(key[1:]) - 1
        else:  # spring<i>_<k|c>
            head, kind = key.rsplit("_", 1)
            elem = int(head[len("spring"):]) - 1
        out.append(Param(0, key, value, value, mech=kind, element=elem, prior=sigma * value))
    for i, sigma in bias_layout(sc):  # the sensors' offsets (sensor{i}_bias_sigma > 0): unknown from 0
        out.append(Param(0, f"sensor{i + 1}_bias", 0.0, sigma, mech="b", element=i, prior=sigma))
    return out


def input_sigmas(sc: Any, mech: Mechanism) -> np.ndarray:
    """Each input's declared white-noise std input{i}_sigma [N] (0: read exactly)."""
    return np.array([float(scenario_value(sc, f"input{i + 1}_sigma")) for i in range(mech.n_inputs)])


def initial_state_params(sc: Any, mech: Mechanism) -> List[Param]:
    """q0_1..q0_nq, v0_1..v0_nq at the truth's start (rest), scaled by the estimator's sigma_q0, sigma_v0."""
    sq, sv = float(scenario_value(sc, "sigma_q0")), float(scenario_value(sc, "sigma_v0"))
    return ([Param(0, f"q0_{i}", 0.0, sq) for i in range(1, mech.nq + 1)]
            + [Param(0, f"v0_{i}", 0.0, sv) for i in range(1, mech.nq + 1)])


def sensor_sigmas(sc: Any, mech: Mechanism) -> np.ndarray:
    """R's standard deviation per sensor (mechanism.sensor_sigmas), refusals in this module's words."""
    try:
        return mechanism_sensor_sigmas(sc, mech)
    except MechanismError as e:
        raise IdentifiabilityError(str(e)) from None


@dataclass(frozen=True)
class Sensitivity:
    """Samples k = 1..N: t (N,), the noise-free y (N, ns), delta (N, nc) and dy/dp (N, ns, m) per
    *scaled* unknown p = theta / scale (multiply column j by 1/params[j].scale for SI units)."""

    t: np.ndarray
    y: np.ndarray
    delta: np.ndarray
    dy: np.ndarray
    params: Tuple[Param, ...]
    events: int
    x: Optional[np.ndarray] = None  # (N, 2 nq): the truth's [q; v] at the samples (the linearisation's point)


def sensitivities(sc: Any, params: Sequence[Param], initial_state: bool = True, inputs: Any = None,
                  rtol: float = SENS_RTOL, t_end: Optional[float] = None) -> Sensitivity:
    """Integrate the truth and its variational equations for the unknowns [x0 (if initial_state); params]."""
    require_truth(sc)
    mech = Mechanism.from_scenario(sc)
    if mech.has_base_inputs:  # the right-hand side below takes every input as a force
        raise IdentifiabilityError("a base_displacement input (input{i}_kind): the sensitivities take every input "
                                   "as a force (docs/mechanism.md, Base excitation)")
    nq, nc = mech.nq, mech.n_contacts
    unknowns = (initial_state_params(sc, mech) if initial_state else []) + list(params)
    m = len(unknowns)
    n2 = 2 * nq
    minv = 1.0 / mech.m
    K, C, B_c = mech.K, mech.C, mech.B_c
    rows = mech.input_body.tolist()
    gammas = contact_values(sc, "gamma", nc).tolist()
    contacts = mech.contacts
    ufn = input_function(mech, inputs)
    # per contact: (column, name, scale) of its chosen parameters
    cols: List[List[Tuple[int, str, float]]] = [[] for _ in range(nc)]
    for j, p in enumerate(unknowns):
        if p.contact:
            cols[p.contact - 1].append((j, p.name, p.scale))
    # the mechanism's: a mass (column, body), a link (column, e = e_a - e_b, scale, on q or on v)
    mass_cols = [(j, p.element) for j, p in enumerate(unknowns) if p.mech == "m"]
    link_cols = []
    for j, p in enumerate(unknowns):
        if p.mech in ("k", "c"):
            e = np.zeros(nq)
            for end, sign in ((int(mech.spring_a[p.element]), 1.0), (int(mech.spring_b[p.element]), -1.0)):
                if end >= 0:
                    e[end] += sign
            link_cols.append((j, e, p.scale, p.mech == "c"))

    def rhs(closed: Tuple[bool, ...]):
        def f(t: float, z: np.ndarray) -> np.ndarray:
            q, v = z[:nq], z[nq:n2]
            S = z[n2:].reshape(n2, m)
            Sq, Sv = S[:nq], S[nq:]
            a = -(K @ q) - C @ v
            for row, uj in zip(rows, np.asarray(ufn(t)).tolist()):
                a[row] += uj
            dSv = -(K @ Sq) - C @ Sv
            for c, ((ia, ib, gap, ne, lam), g, on) in enumerate(zip(contacts, gammas, closed)):
                if not on:
                    continue
                d = (q[ia] if ia >= 0 else 0.0) - (q[ib] if ib >= 0 else 0.0) - gap
                if d <= 0.0:
                    continue
                dd = (v[ia] if ia >= 0 else 0.0) - (v[ib] if ib >= 0 else 0.0)
                fc, fd, fdd, fg = contact_law(d, dd, g, ne, lam)
                if fg == 0.0:  # clamped: no force, no sensitivity
                    continue
                b = B_c[c]
                a -= b * fc
                drow = fd * (b @ Sq) + fdd * (b @ Sv)
                for j, name, scale in cols[c]:
                    if name == "gamma":
                        dp = fg
                    elif name == "n":
                        dp = fc * math.log(d)
                    elif name == "lambda":
                        dp = g * fg / (1.0 + lam * dd) * dd
                    else:  # gap: delta = ... - gap
                        dp = -fd
                    drow[j] += dp * scale
                dSv -= np.outer(b, drow)
            # the mechanism's parameters, scaled by their values: d(F_i / m_i)/d ln m_i = -F_i / m_i, and a
            # link's force -value e (e^T q) (stiffness) or -value e (e^T v) (damper) on its two ends
            for j, i in mass_cols:
                dSv[i, j] -= a[i]
            for j, e, scale, on_v in link_cols:
                dSv[:, j] -= scale * float(e @ (v if on_v else q)) * e
            return np.concatenate([v, a * minv, Sv.ravel(), (dSv * minv[:, None]).ravel()])
        return f

    n = sc.n_steps if t_end is None else int(round(t_end / sc.dt))
    ts = np.arange(1, n + 1, dtype=float) * sc.dt
    S0 = np.zeros((n2, m))
    if initial_state:
        S0[:, :n2] = np.eye(n2) * np.array([p.scale for p in unknowns[:n2]])[None, :]
    atol_x = np.r_[[TRUTH_ATOL_Q] * nq, [TRUTH_ATOL_V] * nq]
    atol = np.r_[atol_x, np.repeat(atol_x, m)]
    z0 = np.r_[np.zeros(n2), S0.ravel()]
    out, events, _ = integrate_modes(rhs, z0, mech, ts, "DOP853", rtol, atol)
    q, v = out[:, :nq], out[:, nq:n2]
    S = out[:, n2:].reshape(n, n2, m)
    dy = np.einsum("sx,kxm->ksm", mech.H, S)  # the sensors linear in [q; v] (docs/sensors.md)
    a = None
    if mech.has_acceleration:  # an accelerometer reads the model's acceleration: the right-hand side's
        every = rhs(tuple([True] * nc))  # the law itself is 0 where a contact is open
        fz = np.array([every(float(t), z) for t, z in zip(ts.tolist(), out)])
        a = fz[:, nq:n2]
        dA = fz[:, n2:].reshape(n, n2, m)[:, nq:]
    for i, (b, kind, link) in enumerate(zip(mech.sensor_body.tolist(), mech.sensor_kind.tolist(),
                                            mech.sensor_link.tolist())):
        if kind == ACCELERATION:
            dy[:, i, :] = dA[:, b, :]
        elif kind == LINK_FORCE:  # the link's own stiffness or damper: d/d ln(value) = its term
            for j, e, scale, on_v in link_cols:
                if unknowns[j].element == link:
                    dy[:, i, j] += scale * ((v if on_v else q) @ e)
    for j, p in enumerate(unknowns):
        if p.mech == "b":  # an offset: y + b
            dy[:, p.element, j] = p.scale
    offsets = np.array([float(scenario_value(sc, f"sensor{i}_bias")) for i in range(1, mech.n_sensors + 1)])
    return Sensitivity(t=ts, y=mech.measure(q, v, a) + offsets, delta=mech.penetrations(q), dy=dy,
                       params=tuple(unknowns), events=events, x=np.hstack([q, v]))


def information(sens: Sensitivity, sigma: np.ndarray, stride: int = 1, t_from: float = 0.0
                ) -> Tuple[np.ndarray, np.ndarray]:
    """(t_c (nc,), J_c (nc, m, m)): the Fisher information of the scaled unknowns over the samples
    t_from <= t <= t_c, at checkpoints every `stride` samples (and the last sample)."""
    w = sens.dy / sigma[None, :, None]  # whitened: R^-1/2 S_k
    w = np.where((sens.t >= t_from)[:, None, None], w, 0.0)
    n, _, m = w.shape
    ends = np.r_[np.arange(stride, n, stride), n]
    per = np.empty((len(ends), m, m))
    start = 0
    for i, e in enumerate(ends.tolist()):
        blk = w[start:e]
        per[i] = np.einsum("ksi,ksj->ij", blk, blk)
        start = e
    return sens.t[ends - 1], np.cumsum(per, axis=0)


def noise_dynamics(sc: Any, sens: Sensitivity, rates: bool = False) -> Tuple[np.ndarray, ...]:
    """(F (N, 2 nq, 2 nq), G (N, 2 nq, inputs)): the continuous model linearised at the truth's state of each
    sample k (contacts' stiffness and damping included) over one sample dt, x_{k+1} = F_k x_k + G_k u_k with
    the force held over the sample (zero-order hold): expm of [[A, B], [0, 0]] dt. With `rates`, a third
    array (N, nq, 2 nq + inputs): the accelerations' rows of [A, B] at each sample (an accelerometer's H and
    feedthrough)."""
    from scipy.linalg import expm

    if sens.x is None:
        raise IdentifiabilityError("the sensitivities carry no states (integrate them with sensitivities())")
    mech = Mechanism.from_scenario(sc)
    nq, ni, nc = mech.nq, mech.n_inputs, mech.n_contacts
    n2, N = 2 * nq, len(sens.t)
    q, v = sens.x[:, :nq], sens.x[:, nq:]
    gammas = contact_values(sc, "gamma", nc).tolist()
    kc = np.zeros((N, nq, nq))  # the contacts' d force / d q and d force / d v, per sample
    cc = np.zeros((N, nq, nq))
    for c, ((ia, ib, gap, ne, lam), g) in enumerate(zip(mech.contacts, gammas)):
        b = mech.B_c[c]
        d, dd = q @ b - gap, v @ b
        for k in np.flatnonzero(d > 0.0).tolist():
            _, fd, fdd, _ = contact_law(float(d[k]), float(dd[k]), g, ne, lam)
            kc[k] += fd * np.outer(b, b)
            cc[k] += fdd * np.outer(b, b)
    closed = np.flatnonzero(np.any(kc != 0.0, axis=(1, 2)) | np.any(cc != 0.0, axis=(1, 2)))
    minv = 1.0 / mech.m

    def augmented(kk: np.ndarray, ck: np.ndarray) -> np.ndarray:
        M = np.zeros(kk.shape[:-2] + (n2 + ni, n2 + ni))
        M[..., :nq, nq:n2] = np.eye(nq)
        M[..., nq:n2, :nq] = -minv[:, None] * (mech.K + kk)
        M[..., nq:n2, nq:n2] = -minv[:, None] * (mech.C + ck)
        M[..., nq:n2, n2:] = minv[:, None] * mech.B_u
        return M * sc.dt

    E = np.empty((N, n2 + ni, n2 + ni))
    E[:] = expm(augmented(np.zeros((nq, nq)), np.zeros((nq, nq))))
    if closed.size:
        E[closed] = expm(augmented(kc[closed], cc[closed]))
    if rates:
        return E[:, :n2, :n2], E[:, :n2, n2:], augmented(kc, cc)[:, nq:n2, :] / sc.dt
    return E[:, :n2, :n2], E[:, :n2, n2:]


def information_input_noise(sc: Any, sens: Sensitivity, sigma: np.ndarray, sigma_u: np.ndarray, stride: int = 1,
                            t_from: float = 0.0) -> Tuple[np.ndarray, np.ndarray]:
    """`information` when the inputs are read with white noise (input{i}_sigma > 0): the force the truth feels
    is the one read minus that noise, held over each sample, so the measurements carry, besides R, the noise's
    response e_{k+1} = F_k e_k + G_k w_k (w_k ~ N(0, diag(sigma_u^2)), e_0 = 0) through the model linearised
    along the truth (`noise_dynamics`). The Fisher information S^T Sigma^-1 S of that Gaussian output noise
    is summed from the innovations of the Kalman filter of that noise model run over the sensitivities (the
    whitening of Sigma = R + the noise response's covariance; exact for the linearised model). It is never
    larger than `information`'s: the bounds only grow."""
    mech = Mechanism.from_scenario(sc)
    acc = [(i, b) for i, (b, k) in enumerate(zip(mech.sensor_body.tolist(), mech.sensor_kind.tolist()))
           if k == ACCELERATION]
    F, G, *more = noise_dynamics(sc, sens, rates=bool(acc))
    H0 = mech.H
    R = np.diag(np.asarray(sigma, float) ** 2)
    Qw = np.diag(np.asarray(sigma_u, float) ** 2)
    n2 = F.shape[1]
    for i, b in acc:  # an accelerometer feels the input noise directly (its correlation with e_k+1 neglected)
        d = more[0][0, b, n2:]
        R[i, i] += float(d @ Qw @ d)
    n, _, m = sens.dy.shape
    X = np.zeros((n2, m))  # the noise state's prediction of each sensitivity column
    P = G[0] @ Qw @ G[0].T  # e_1 = G_0 w_0
    use = sens.t >= t_from
    ends = np.r_[np.arange(stride, n, stride), n]
    out = np.empty((len(ends), m, m))
    J = np.zeros((m, m))
    e = 0
    for k in range(n):
        H = H0
        if acc:  # an accelerometer's row: the linearised acceleration at this sample
            H = H0.copy()
            for i, b in acc:
                H[i] = more[0][k, b, :n2]
        if use[k]:
            PHt = P @ H.T
            S = H @ PHt + R
            nu = sens.dy[k] - H @ X
            Sinv_nu = np.linalg.solve(S, nu)
            J += nu.T @ Sinv_nu
            K = np.linalg.solve(S, PHt.T).T
            X = X + K @ nu
            P = P - K @ PHt.T
            P = 0.5 * (P + P.T)
        if k + 1 == ends[e]:
            out[e] = J
            e += 1
        if k + 1 < n:
            X = F[k] @ X
            P = F[k] @ P @ F[k].T + G[k] @ Qw @ G[k].T
    return sens.t[ends - 1], out


@dataclass(frozen=True)
class RankResult:
    rank: int
    sv_rel: np.ndarray  # singular values of the equilibrated whitened S, / the largest, descending
    observable: np.ndarray  # (m,) bool
    null_directions: List[np.ndarray]  # unit vectors in the equilibrated coordinates
    dinv: np.ndarray  # (m,) the equilibration: 1 / sqrt(J_ii) of the scaled unknowns (0: no sensitivity)


def _equilibrated(J: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    d = np.sqrt(np.clip(np.diagonal(J, axis1=-2, axis2=-1), 0.0, None))
    dinv = np.divide(1.0, d, out=np.zeros_like(d), where=d > 0.0)
    return J * dinv[..., :, None] * dinv[..., None, :], dinv


def bounds(J: np.ndarray, rtol: float = RANK_RTOL, null_tol: float = NULL_TOL) -> Tuple[np.ndarray, np.ndarray]:
    """(crb (..., m), observable (..., m)) of information matrices J (..., m, m) of scaled unknowns:
    sqrt([J^+]_ii) for an observable unknown (e_i in J's numerical range and a bound below
    MAX_REL_CRB), inf otherwise. Vectorised over leading axes."""
    Jn, dinv = _equilibrated(J)
    w, V = np.linalg.eigh(Jn)
    keep = w > (rtol ** 2) * np.clip(w[..., -1:], 0.0, None)
    keep &= w[..., -1:] > 0.0
    V2 = V ** 2
    null_part = np.sqrt(np.sum(np.where(keep[..., None, :], 0.0, V2), axis=-1))
    observable = (null_part < null_tol) & (dinv > 0.0)
    inv_w = np.divide(1.0, w, out=np.zeros_like(w), where=keep)
    crb = np.sqrt(np.sum(V2 * inv_w[..., None, :], axis=-1)) * dinv
    observable &= crb < MAX_REL_CRB
    return np.where(observable, crb, np.inf), observable


def rank_test(J: np.ndarray, rtol: float = RANK_RTOL, null_tol: float = NULL_TOL) -> RankResult:
    """Numerical rank of the equilibrated information, its null space, and which unknowns it leaves alone."""
    Jn, dinv = _equilibrated(J)
    w, V = np.linalg.eigh(Jn)
    wmax = max(float(w[-1]), 0.0)
    sv = np.sqrt(np.clip(w, 0.0, None))[::-1]
    sv_rel = sv / sv[0] if wmax > 0.0 else np.zeros_like(sv)
    keep = w > (rtol ** 2) * wmax if wmax > 0.0 else np.zeros(len(w), dtype=bool)
    null = [V[:, j] for j in np.flatnonzero(~keep)]
    _, observable = bounds(J, rtol, null_tol)
    return RankResult(int(np.sum(keep)), sv_rel, observable, null, dinv)


@dataclass(frozen=True)
class Analysis:
    """Result of `analyse_run`: per chosen parameter (the `params`, x0 left out) the verdict and bounds."""

    params: Tuple[Param, ...]
    sens: Sensitivity
    t: np.ndarray  # checkpoints
    crb: np.ndarray  # (n_checkpoints, p) Fisher CRB, SI units (inf: not observable yet)
    crb_post: np.ndarray  # (n_checkpoints, p) posterior CRB
    prior: np.ndarray  # (p,) prior std (inf: none)
    rank: RankResult  # of the whole run's information, over all unknowns (x0 included)
    sel: np.ndarray  # indices of the params among the unknowns

    @property
    def observable(self) -> np.ndarray:
        return self.rank.observable[self.sel]

    def rel(self, which: str = "crb") -> np.ndarray:
        vals = np.array([abs(p.value) if p.value else (p.scale if p.mech == "b" else 0.0) for p in self.params])
        b = self.crb if which == "crb" else self.crb_post
        return np.divide(b, vals, out=np.full_like(b, np.inf), where=vals > 0)

    def time_below(self, target: float = REL_TARGET, which: str = "crb") -> np.ndarray:
        """Per parameter: first checkpoint time at which the relative bound is < target (nan: never)."""
        below = self.rel(which) < target
        first = np.argmax(below, axis=0)
        return np.where(below.any(axis=0), self.t[first], np.nan)

    def insensitive(self) -> List[str]:
        """The chosen parameters the run's measurements do not depend on at all (a zero column)."""
        return [p.label for p, d in zip(self.params, self.rank.dinv[self.sel]) if d == 0.0]

    def weak(self) -> List[str]:
        """Chosen parameters outside the null space whose bound still exceeds MAX_REL_CRB times their scale."""
        if self.rank.null_directions:
            null_part = np.linalg.norm(np.column_stack(self.rank.null_directions)[self.sel], axis=1)
        else:
            null_part = np.zeros(len(self.sel))
        return [p.label for p, d, ok, z in zip(self.params, self.rank.dinv[self.sel], self.observable, null_part)
                if d > 0.0 and not ok and z < NULL_TOL]

    def null_directions(self) -> List[Dict[str, float]]:
        """Invisible directions of the other chosen parameters, in relative changes (d theta_i / scale_i,
        largest component 1): moving the parameters (and the initial state) along one leaves y unchanged.
        A basis of the null space's projection onto the parameters, components > NULL_TOL."""
        if not self.rank.null_directions:
            return []
        dinv = self.rank.dinv[self.sel]
        live = dinv > 0.0
        N = np.column_stack(self.rank.null_directions)[self.sel][live]
        if N.size == 0:
            return []
        U, s, _ = np.linalg.svd(N, full_matrices=False)
        labels = [p.label for p, ok in zip(self.params, live) if ok]
        out = []
        for u in U[:, s > NULL_TOL].T:
            c = u * dinv[live]
            c = c / c[np.argmax(np.abs(c))]
            out.append({lab: float(x) for lab, x in zip(labels, c) if abs(x) > NULL_TOL})
        return out


def analyse_run(sc: Any, params: Sequence[Param], priors: Optional[Mapping[Tuple[int, str], float]] = None,
                initial_state: bool = True, inputs: Any = None, t_from: float = 0.0, checkpoints: int = 2000,
                t_end: Optional[float] = None, sens: Optional[Sensitivity] = None, input_noise: bool = True
                ) -> Analysis:
    """Sensitivities, rank test and (posterior) Cramer-Rao bounds of `params` along the scenario's run.

    params: law parameters (law_params) and, to have them unknown too, the declared mechanism parameters
    (mechanism_params). priors: {(contact, name): std} for the posterior bound; gamma's defaults to the
    scenario's contact{i}_sigma_gamma0, the initial state's to sigma_q0 / sigma_v0, a mechanism parameter's
    to its declared sigma times its value (key (0, "spring1_k")); others have none (0 information).
    input_noise: the inputs' declared white noise (input{i}_sigma > 0) enters the information as process
    noise (information_input_noise); False, or nothing declared: R alone."""
    mech = Mechanism.from_scenario(sc)
    sigma = sensor_sigmas(sc, mech)
    if not params:
        raise IdentifiabilityError("no parameters chosen")
    if sens is None:
        sens = sensitivities(sc, params, initial_state=initial_state, inputs=inputs, t_end=t_end)
    unknowns = sens.params
    n_x0 = len(unknowns) - len(params)
    scales = np.array([p.scale for p in unknowns])
    stride = max(1, len(sens.t) // max(1, checkpoints))
    sigma_u = input_sigmas(sc, mech)
    if input_noise and np.any(sigma_u > 0.0):
        t_c, J = information_input_noise(sc, sens, sigma, sigma_u, stride=stride, t_from=t_from)
    else:
        t_c, J = information(sens, sigma, stride=stride, t_from=t_from)
    # prior information in the scaled coordinates: (scale / std)^2
    given = dict(priors or {})
    std = []
    for p in unknowns:
        if p.mech:
            std.append(float(given.get((0, p.name), p.prior)))
        elif p.contact == 0:
            std.append(p.scale)  # x0's scales are sigma_q0 / sigma_v0
        elif (p.contact, p.name) in given:
            std.append(float(given[(p.contact, p.name)]))
        elif p.name == "gamma":
            std.append(float(scenario_value(sc, f"contact{p.contact}_sigma_gamma0")))
        else:
            std.append(math.inf)
    std_a = np.array(std)
    if np.any(~(std_a > 0.0)):
        raise IdentifiabilityError("a prior standard deviation must be > 0")
    p0inv = np.diag((scales / std_a) ** 2)
    crb, _ = bounds(J)
    crb_post, _ = bounds(J + p0inv)
    sel = np.arange(n_x0, len(unknowns))
    return Analysis(params=tuple(params), sens=sens, t=t_c, crb=crb[:, sel] * scales[sel],
                    crb_post=crb_post[:, sel] * scales[sel], prior=std_a[sel], rank=rank_test(J[-1]), sel=sel)


def format_table(an: Analysis, target: float = REL_TARGET) -> str:
    """The report: parameter, value, observable, CRB and posterior CRB at the end (absolute, relative),
    and when the relative bound first falls below `target`."""
    rel, relp = an.rel("crb")[-1], an.rel("crb_post")[-1]
    tb, tbp = an.time_below(target, "crb"), an.time_below(target, "crb_post")
    pct = f"{100 * target:g} %"
    head = (f"{'parameter':<18} {'value':>11} {'observable':>10} {'CRB':>10} {'CRB/value':>10} "
            f"{'t(<' + pct + ')':>9}   {'prior':>9} {'post. CRB':>10} {'/value':>9} {'t(<' + pct + ')':>9}")
    lines = [head]

    def num(x: float, fmt: str = ".3g") -> str:
        return "-" if not math.isfinite(x) else format(x, fmt)

    def t_(x: float) -> str:
        return "never" if not math.isfinite(x) else f"{x:.3f}"

    def pc(x: float) -> str:
        return "-" if not math.isfinite(x) else f"{100 * x:.3g} %"

    for i, p in enumerate(an.params):
        lines.append(f"{p.label:<18} {p.value:>11.4g} {'yes' if an.observable[i] else 'NO':>10} "
                     f"{num(an.crb[-1, i]):>10} {pc(rel[i]):>10} {t_(tb[i]):>9}   {num(an.prior[i]):>9} "
                     f"{num(an.crb_post[-1, i]):>10} {pc(relp[i]):>9} {t_(tbp[i]):>9}")
    r = an.rank
    n_x0 = len(r.sv_rel) - len(an.sel)
    lines.append(f"rank {r.rank} of {len(r.sv_rel)} unknowns ({len(an.sel)} parameters"
                 f"{f', {n_x0} initial-state entries' if n_x0 else ''}); "
                 f"smallest singular value / largest {r.sv_rel[-1]:.2e} (null below {RANK_RTOL:g})")
    if an.insensitive():
        lines.append("  no sensitivity at all (zero column): " + ", ".join(an.insensitive()))
    if an.weak():
        lines.append(f"  bound above {MAX_REL_CRB:g} x the scale (a decayed transient, no information): "
                     + ", ".join(an.weak()))
    for d in an.null_directions():
        lines.append("  invisible direction (relative changes): " + " ".join(f"{v:+.4g} {k}" for k, v in d.items()))
    return "\n".join(lines)


def write_csv(an: Analysis, path: Any) -> None:
    """t, then per parameter: crb_<key>, rel_<key>, post_<key>, post_rel_<key> (SI; inf where unobservable)."""
    rel, relp = an.rel("crb"), an.rel("crb_post")
    cols = [an.t]
    names = ["t"]
    for i, p in enumerate(an.params):
        cols += [an.crb[:, i], rel[:, i], an.crb_post[:, i], relp[:, i]]
        names += [f"crb_{p.key}", f"rel_{p.key}", f"post_{p.key}", f"post_rel_{p.key}"]
    np.savetxt(path, np.column_stack(cols), fmt="%.9g", delimiter=",", header=",".join(names), comments="")


def plot(an: Analysis, path: Any, target: float = REL_TARGET) -> None:
    """Relative CRB and posterior CRB of every parameter along the run (log scale), with the target line."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5))
    rel, relp = an.rel("crb"), an.rel("crb_post")
    for i, p in enumerate(an.params):
        line, = ax.semilogy(an.t, rel[:, i], label=f"{p.label} CRB")
        ax.semilogy(an.t, relp[:, i], "--", color=line.get_color(), label=f"{p.label} posterior")
    ax.axhline(target, color="k", lw=0.8, ls=":")
    ax.set_xlabel("t [s]")
    ax.set_ylabel("bound / |value|")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path)
    plt.close(fig)
