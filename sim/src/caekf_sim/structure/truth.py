"""Truth of a linear structure with Hertz contacts, independent of the C code:

    M q'' + C q' + K q + W f = B_u u(t),   delta = W^T q - gap,   f = gamma delta^n (delta > 0), else 0,

by the implicit trapezoidal rule (Newmark's average acceleration) at h = dt / substeps:

    q1 = q0 + h/2 (v0 + v1),   M (v1 - v0) = h/2 (r0 + r1),   r = B_u u - C v - K q - W f,

i.e. q1 = q0 + h v0 + h^2/4 (a0 + a1), v1 = v0 + h/2 (a0 + a1) with the equation of motion at both ends.
Given the contact forces the step is linear, x1 = A x0 + B (u0 + u1) + F (f0 + f1) for x = (q, v); the maps
come once from one factorisation of S = M + h/2 C + h^2/4 K (step_maps). The contact-free prediction d of
delta1 then moves by -G (f0 + f1), G = h^2/4 W^T S^-1 W, and each substep solves that small equation exactly.

Two rules for the contact's term f0 + f1 (`rule`):
  * "endpoint": the trapezoidal rule as it stands, f1 = f(delta1): delta1 + G f(delta1) = d - G f0, solved by
    Newton from above (convex increasing left side: monotone convergence, never crossing the root).
  * "secant" (default): 2 (Phi(delta1) - Phi(delta0)) / (delta1 - delta0), Phi the contact's potential
    gamma delta_+^(n+1) / (n+1) (a discrete gradient, as in energy-momentum contact schemes): its work over
    the step is exactly Phi's change, so with C = 0 and no input the energy is conserved to rounding at any
    step. Also second order; the two rules converge to the same solution. Solved by brentq on its bracket.
The plain endpoint rule is unstable for a contact that lasts few substeps: on the default beam with
C = 0, gamma = 1e9 and 10 substeps its energy grows 11 % in 2 s, with 1 or 2 substeps it grows without
bound; the secant rule keeps it within 1e-8. Several contacts: scipy's root on the same equations.
Samples report f = f(delta) at the sample and the acceleration of the equation of motion with it.

The rule does not damp what it does not resolve: a mode with omega h >> 1 (a fine mesh's top modes) that an
impact or a load step excites keeps ringing at the substep's Nyquist frequency, even where Rayleigh's beta
makes it overdamped. With an even `substeps` the samples see it as a slowly decaying offset. On the default
beam (beam.BeamSpec, 10 substeps) modes 10 and up carry about 0.4 % of the tip accelerometer's rms.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple, Union

import numpy as np
import scipy.linalg
import scipy.optimize
from numpy.typing import NDArray

from .files import Structure

Matrix = NDArray[np.float64]
Force = Union[Callable[[Matrix], Matrix], Matrix]
KINDS = ("position", "velocity", "acceleration")
RULES = ("secant", "endpoint")
CHUNK = 4096  # substeps whose input terms are formed at once (memory: CHUNK x (2 dofs + contacts) doubles)
NEWTON_MAX_ITER = 100


@dataclass(frozen=True, eq=False)
class BeamTruth:
    """Samples k = 0..N at t_k = k dt (k = 0: the initial state): u (N+1, inputs), q, v, a (N+1, dofs), f and
    delta (N+1, contacts), y (N+1, sensors) the noiseless readings of H's rows by `kinds`."""

    t: Matrix
    u: Matrix
    q: Matrix
    v: Matrix
    a: Matrix
    f: Matrix
    delta: Matrix
    y: Matrix
    kinds: Tuple[str, ...]


@dataclass(frozen=True, eq=False)
class StepMaps:
    """x1 = A x0 + B (u0 + u1) + F (f0 + f1) for x = (q, v), and G = -W^T F[q rows] (delta1's response to f1)."""

    A: Matrix
    B: Matrix
    F: Matrix
    G: Matrix


def step_maps(s: Structure, h: float) -> StepMaps:
    """The trapezoidal step with the accelerations eliminated (q1 = q0 + h/2 (v0 + v1) and the momentum
    balance averaged over both ends):

        S v1 = (2 M - S) v0 - h K q0 + h/2 B_u (u0 + u1) - h/2 W (f0 + f1),   S = M + h/2 C + h^2/4 K.

    Every map is bounded for any omega h (S^-1 (2 M - S) -> -I for stiff modes), so no large terms cancel:
    forming the maps through a0 = M^-1 (...) instead loses (omega_max h)^2 digits, which the static
    equilibrium of the map amplifies by 1 / (omega_1 h)^2 (an error of 1e-6 in a contact's penetration)."""
    n = s.dofs
    newton = scipy.linalg.lu_factor(s.M + 0.5 * h * s.C + 0.25 * h * h * s.K)
    v_of = scipy.linalg.lu_solve(newton, np.hstack([2.0 * s.M, -h * s.K, 0.5 * h * s.Bu, -0.5 * h * s.W]))
    v_v, v_q, v_u, v_f = np.split(v_of, np.cumsum([n, n, s.inputs]), axis=1)
    v_v -= np.eye(n)
    A = np.block([[np.eye(n) + 0.5 * h * v_q, 0.5 * h * (np.eye(n) + v_v)], [v_q, v_v]])
    B, F = np.vstack([0.5 * h * v_u, v_u]), np.vstack([0.5 * h * v_f, v_f])
    return StepMaps(A=A, B=B, F=F, G=-(s.W.T @ F[:n]))


def input_samples(force: Force, inputs: int, dt: float, steps: int, substeps: int) -> Matrix:
    """u at every substep time j h, j = 0..steps*substeps: a callable of t, or samples at k dt interpolated."""
    t = np.arange(steps * substeps + 1, dtype=np.float64) * (dt / substeps)
    if callable(force):
        u = np.asarray(force(t), dtype=np.float64).reshape(len(t), -1)
    else:
        samples = np.asarray(force, dtype=np.float64)
        if len(samples) != steps + 1:
            raise ValueError(f"force: {len(samples)} samples, need {steps + 1} (t = 0, dt, ..., t_end)")
        samples = samples.reshape(steps + 1, -1)
        ts = np.arange(steps + 1) * dt
        u = np.column_stack([np.interp(t, ts, col) for col in samples.T]) if samples.shape[1] else \
            np.zeros((len(t), 0))
    if u.shape[1] != inputs:
        raise ValueError(f"force gives {u.shape[1]} inputs, the structure has {inputs}")
    return u


def penetration(d: float, c: float, n: float) -> float:
    """The root of delta + c delta^n = d for d > 0, c > 0, n >= 1: Newton from min(d, (d / c)^(1/n)), both
    upper bounds of the root, descends monotonically on the convex increasing left side."""
    x = min(d, (d / c) ** (1.0 / n))
    for _ in range(NEWTON_MAX_ITER):
        step = (x + c * x**n - d) / (1.0 + n * c * x ** (n - 1.0))
        x -= step
        if step <= 1e-15 * x:
            return x
    raise RuntimeError(f"contact Newton did not converge (d = {d!r}, c = {c!r})")


def penetrations(d: Matrix, G: Matrix, gamma: Matrix, n: float) -> Matrix:
    """delta with delta + G (gamma delta_+^n) = d for several contacts (a strictly convex potential's gradient
    times G: one root); all open if every predicted d <= 0."""
    if np.all(d <= 0.0):
        return d

    def residual(x: Matrix) -> Tuple[Matrix, Matrix]:
        xp = np.maximum(x, 0.0)
        return x + G @ (gamma * xp**n) - d, np.eye(len(x)) + G * (gamma * n * xp ** (n - 1.0))

    return _root(lambda x: residual(x)[0], residual, np.maximum(d, 0.0), d)


def secant_force(x: float, x0: float, gamma: float, n: float) -> float:
    """(Phi(x) - Phi(x0)) / (x - x0), Phi(delta) = gamma delta_+^(n+1) / (n+1): the force whose work over a step
    is exactly the potential's change. Within 1e-5 relative of each other the midpoint's force stands in for
    it (their difference is O(step^2), the quotient's rounding O(eps / step))."""
    if abs(x - x0) <= 1e-5 * (abs(x) + abs(x0)):
        return gamma * max(0.5 * (x + x0), 0.0) ** n
    phi = gamma / (n + 1.0) * (max(x, 0.0) ** (n + 1.0) - max(x0, 0.0) ** (n + 1.0))
    return phi / (x - x0)


def secant_penetration(d: float, x0: float, c: float, gamma: float, n: float) -> float:
    """The root of x + c secant_force(x, x0) / gamma = d (c = 2 G gamma): increasing in x (a convex potential's
    secant), bracketed by [d - c max(f(d), f(x0)) / gamma, d] since the secant lies between its end forces."""
    def psi(x: float) -> float:
        return x + c / gamma * secant_force(x, x0, gamma, n) - d

    lo = d - c * max(max(d, 0.0) ** n, max(x0, 0.0) ** n)
    if psi(lo) >= 0.0:  # rounding at a tiny force
        return lo
    if psi(d) <= 0.0:
        return d
    return float(scipy.optimize.brentq(psi, lo, d, xtol=1e-16 * max(abs(lo), abs(d)), rtol=8.9e-16))


def secant_penetrations(d: Matrix, x0: Matrix, G: Matrix, gamma: Matrix, n: float) -> Matrix:
    """Several contacts: x + 2 G secant_force(x, x0) = d (monotone, one root); open if all stay open."""
    if np.all(d <= 0.0) and np.all(x0 <= 0.0):
        return d

    def residual(x: Matrix) -> Matrix:
        fbar = np.array([secant_force(float(a), float(b), float(g), n) for a, b, g in zip(x, x0, gamma)])
        return x + 2.0 * G @ fbar - d

    return _root(residual, None, np.maximum(d, 0.0), d)


def _root(fun: Callable[[Matrix], Matrix], jac: Optional[Callable[[Matrix], Tuple[Matrix, Matrix]]],
          start: Matrix, d: Matrix) -> Matrix:
    if jac is not None:
        sol = scipy.optimize.root(jac, start, jac=True, method="hybr", options={"xtol": 1e-12})
    else:
        sol = scipy.optimize.root(fun, start, method="hybr", options={"xtol": 1e-12})
    # judged by the residual: hybr's own flag reports xtol too small when it has already hit rounding
    if not np.max(np.abs(fun(sol.x))) <= 1e-12 * np.max(np.abs(d)):
        raise RuntimeError(f"contact solve failed: {sol.message}")
    return np.asarray(sol.x, dtype=np.float64)


def simulate(structure: Structure, gap: Union[float, Sequence[float]], gamma: Union[float, Sequence[float]],
             n: float, force: Force, dt: float, t_end: float, substeps: int, x0: Optional[Matrix] = None,
             kinds: Optional[Sequence[str]] = None, rule: str = "secant") -> BeamTruth:
    """Integrate the whole structure with its contacts (module docstring) and sample every dt up to t_end.

    gap, gamma: one value or one per contact; force: u(t) for an array t -> (len(t), inputs), or samples at
    k dt (N+1 rows) linearly interpolated; x0: (q0, v0) stacked (default rest); kinds: each sensor's kind,
    "position" (default), "velocity" or "acceleration"; rule: the contact force over a step, "secant"
    (energy-consistent, default) or "endpoint" (the plain trapezoidal rule, (f0 + f1) / 2)."""
    nq, m = structure.dofs, structure.contacts
    gaps, gammas = (np.broadcast_to(np.asarray(x, dtype=np.float64), (m,)).copy() for x in (gap, gamma))
    kinds_t = tuple(kinds) if kinds is not None else ("position",) * structure.sensors
    _check_args(structure, n, dt, substeps, gammas, kinds_t, rule)
    steps = int(round(t_end / dt))
    u = input_samples(force, structure.inputs, dt, steps, substeps)
    z = np.zeros(2 * nq) if x0 is None else np.array(x0, dtype=np.float64).reshape(2 * nq)
    maps = step_maps(structure, dt / substeps)
    law = ContactLaw(gaps, gammas, n)
    step = (_secant_step if rule == "secant" else _endpoint_step)(maps, law, nq)
    states, forces = _march(structure, maps, u, z, law, step, substeps)
    return _samples(structure, u[::substeps], states, forces, gaps, dt, kinds_t)


def _check_args(s: Structure, n: float, dt: float, substeps: int, gammas: Matrix, kinds: Tuple[str, ...],
                rule: str) -> None:
    if n < 1.0:
        raise ValueError(f"exponent n = {n}: must be >= 1 (the contact solve needs a convex law)")
    if not (dt > 0.0 and substeps >= 1):
        raise ValueError(f"dt = {dt}, substeps = {substeps}: must be positive")
    if np.any(gammas <= 0.0):
        raise ValueError("gamma must be positive")
    if len(kinds) != s.sensors or any(k not in KINDS for k in kinds):
        raise ValueError(f"kinds {kinds}: one of {KINDS} per sensor ({s.sensors})")
    if rule not in RULES:
        raise ValueError(f"rule {rule!r}: one of {RULES}")


@dataclass(frozen=True, eq=False)
class ContactLaw:
    """Each contact's gap and gamma, and the exponent n of f = gamma delta_+^n."""

    gaps: Matrix
    gammas: Matrix
    n: float

    def force(self, delta: Matrix) -> Matrix:
        return np.asarray(self.gammas * np.maximum(delta, 0.0) ** self.n, dtype=np.float64)


# One substep's contact: (pred, delta0, f0) -> (x1, delta1, f1), pred the contact-free x1 (no contact force
# at either end) with its w^T q1 rows appended.
Step = Callable[[Matrix, Matrix, Matrix], Tuple[Matrix, Matrix, Matrix]]


def _march(s: Structure, maps: StepMaps, u: Matrix, z: Matrix, law: ContactLaw, step: Step,
           substeps: int) -> Tuple[Matrix, Matrix]:
    """The substeps; returns the states x = (q, v) and contact forces at every substep-th one (and the first)."""
    nq, m = s.dofs, s.contacts
    wz = np.hstack([s.W.T, np.zeros((m, nq))])  # delta + gap = wz x
    # the maps with the contacts' rows appended, so one product gives the prediction and its w^T q
    A, B = (np.vstack([x, wz @ x]) for x in (maps.A, maps.B))
    delta = wz @ z - law.gaps
    f = law.force(delta)
    total = len(u) - 1
    states, forces = np.empty((total // substeps + 1, 2 * nq)), np.empty((total // substeps + 1, m))
    states[0], forces[0] = z, f
    for start in range(0, total, CHUNK):
        stop = min(start + CHUNK, total)
        drive = (u[start:stop] + u[start + 1:stop + 1]) @ B.T
        for j in range(stop - start):
            pred = A @ z
            pred += drive[j]
            z, delta, f = step(pred, delta, f)
            if (start + j + 1) % substeps == 0:
                k = (start + j + 1) // substeps
                states[k], forces[k] = z, f
    return states, forces


def _endpoint_step(maps: StepMaps, law: ContactLaw, nq: int) -> Step:
    """The trapezoidal rule as it stands: f0 known, f1 = f(delta1) with delta1 = d - G f1."""
    F = np.vstack([maps.F, -maps.G])  # x1's and delta1's response to f0 + f1
    if len(law.gaps) > 1:
        def several(pred: Matrix, delta0: Matrix, f0: Matrix) -> Tuple[Matrix, Matrix, Matrix]:
            y = pred + F @ f0
            delta = penetrations(y[2 * nq:] - law.gaps, maps.G, law.gammas, law.n)
            f = law.force(delta)
            return y[:2 * nq] + maps.F @ f, delta, f
        return several
    gap, gamma, n, c = float(law.gaps[0]), float(law.gammas[0]), law.n, float(maps.G[0, 0] * law.gammas[0])
    F1, zero = F[:, 0], np.zeros(1)

    def one(pred: Matrix, delta0: Matrix, f0: Matrix) -> Tuple[Matrix, Matrix, Matrix]:
        y = pred + F1 * f0[0] if f0[0] else pred
        d = float(y[2 * nq]) - gap
        if d <= 0.0:
            return y[:2 * nq], np.array([d]), zero
        x = penetration(d, c, n)
        f = gamma * x**n
        return y[:2 * nq] + F1[:2 * nq] * f, np.array([x]), np.array([f])
    return one


def _secant_step(maps: StepMaps, law: ContactLaw, nq: int) -> Step:
    """The energy-consistent step: f0 + f1 replaced by 2 secant_force(delta1, delta0)."""
    if len(law.gaps) > 1:
        def several(pred: Matrix, delta0: Matrix, f0: Matrix) -> Tuple[Matrix, Matrix, Matrix]:
            delta = secant_penetrations(pred[2 * nq:] - law.gaps, delta0, maps.G, law.gammas, law.n)
            fbar = np.array([secant_force(float(a), float(b), float(g), law.n)
                             for a, b, g in zip(delta, delta0, law.gammas)])
            return pred[:2 * nq] + 2.0 * maps.F @ fbar, delta, law.force(delta)
        return several
    gap, gamma, n, c = float(law.gaps[0]), float(law.gammas[0]), law.n, 2.0 * float(maps.G[0, 0] * law.gammas[0])
    F2, zero = 2.0 * maps.F[:, 0], np.zeros(1)

    def one(pred: Matrix, delta0: Matrix, f0: Matrix) -> Tuple[Matrix, Matrix, Matrix]:
        d, x0 = float(pred[2 * nq]) - gap, float(delta0[0])
        if d <= 0.0 and x0 <= 0.0:
            return pred[:2 * nq], np.array([d]), zero
        x = secant_penetration(d, x0, c, gamma, n)
        return pred[:2 * nq] + F2 * secant_force(x, x0, gamma, n), np.array([x]), np.array([gamma * max(x, 0.0) ** n])
    return one


def _samples(s: Structure, u: Matrix, states: Matrix, forces: Matrix, gaps: Matrix, dt: float,
             kinds: Tuple[str, ...]) -> BeamTruth:
    """The samples with the model's acceleration (from the equation of motion, contact included) and readings."""
    nq = s.dofs
    q, v = states[:, :nq], states[:, nq:]
    load = u @ s.Bu.T - v @ s.C - q @ s.K - forces @ s.W.T  # rows; C, K symmetric
    a = scipy.linalg.cho_solve(scipy.linalg.cho_factor(s.M), load.T).T
    by_kind = {"position": q, "velocity": v, "acceleration": a}
    y = np.column_stack([by_kind[k] @ s.H[i] for i, k in enumerate(kinds)]) if kinds else np.zeros((len(q), 0))
    t = np.arange(len(q), dtype=np.float64) * dt
    return BeamTruth(t=t, u=u, q=q, v=v, a=a, f=forces, delta=q @ s.W - gaps, y=y, kinds=kinds)


def energy(s: Structure, truth: BeamTruth, gamma: Union[float, Sequence[float]], n: float) -> Matrix:
    """Kinetic + elastic + contact potential (gamma delta_+^(n+1) / (n+1)) at every sample.

    In modal coordinates: q^T K q straight from K loses digits to K's conditioning (omega_max^2 / omega_1^2)."""
    modal, phi = s.modal()
    eta, deta = truth.q @ s.M @ phi, truth.v @ s.M @ phi  # phi^-1 = phi^T M
    kinetic = 0.5 * np.sum(deta**2, axis=1)
    elastic = 0.5 * np.sum(np.diag(modal.K) * eta**2, axis=1)
    contact = np.sum(np.asarray(gamma) * np.maximum(truth.delta, 0.0) ** (n + 1) / (n + 1), axis=1)
    return np.asarray(kinetic + elastic + contact, dtype=np.float64)
