"""The implicit step of any lumped mechanism on a line or linear structure given as matrices (mechanism.py):
backward Euler (eq. 19) or the trapezoidal rule (the setting `discretisation`).

Conventions (shared with the C core): x = [q_1..q_nq, v_1..v_nq]; inputs enter through B_u (one
column per input), contact c through b_c (a line's e_a - e_b, ground omitted; a structure's w_c), delta_c =
b_c^T q - gap_c, with the law of `mechanism.contact_law`. The code reads the vectors only (their nonzero
entries: Mechanism.contact_dirs, input_dirs), so a line and a structure take the same paths; on a line each sum
has the same terms in the same order as the ends' formulas had. The paper's mechanism (mechanism defaults) is 4
bodies, B_u = e1, one Hertz contact with b = [0, 1, -1, 0].

Backward Euler, eq. (19) plus the damping term C v_k that the paper omits:
    (q_k - q_{k-1})/h - v_k = 0
    M (v_k - v_{k-1})/h + C v_k + K q_k - B_u u_k + sum_c b_c f_c(q_k, v_k, gamma_c) = 0
Substituting q_k = q_{k-1} + h v_k leaves nq equations in v_k, solved by Newton from v_{k-1} with
Jacobian A = M/h + C + h K + sum_c (h df_c/ddelta + df_c/dddelta) b_c b_c^T.
Convergence (the same test as the C core, caekf_model_newton): after at least one update,
max_i |r_i| <= rtol * max_i mag_i, where mag_i is the sum of the magnitudes of row i's terms
(a norm-wise backward error: a lightly loaded row cannot be resolved better than the rounding
the coupled solve spreads from the heavily loaded ones); rtol = 256 eps.

Trapezoidal rule, with the generalised force G(q, v, u) = C v + K q - B_u u + sum_c b_c f_c(q, v, gamma_c):
    (q_k - q_{k-1})/h - (v_{k-1} + v_k)/2 = 0
    M (v_k - v_{k-1})/h + G(q_k, v_k, u_k)/2 + G(q_{k-1}, v_{k-1}, u_{k-1})/2 = 0
The momentum rows are solved multiplied by 2, i.e. with the half step s = h/2:
    r(v_k) = M (v_k - v_{k-1})/s + G(q_k, v_k, u_k) + G_0,   q_k = q_{k-1} + s (v_{k-1} + v_k),
G_0 = G(q_{k-1}, v_{k-1}, u_{k-1}) a constant of the step, and the same Newton matrix as above with s for
h: A = M/s + C + s K + sum_c (s df_c/ddelta + df_c/dddelta) b_c b_c^T. The sizes of G_0's terms join
each row's magnitude in the convergence test (its rounding is part of the residual's).

A base displacement u [m] (input{i}_kind, docs/mechanism.md) of a link of stiffness k and damper c enters as
a force on its body: k u_k + c (u_k - u_{k-1}) / hs at the step's end and k u_{k-1} at its start (trapezoidal:
both ends' sum is k (u_k + u_{k-1}) + 2 c (u_k - u_{k-1}) / h, twice the mean of k u + c du/dt for u linear
over the step), as the C core's base_forces.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, List, Tuple

import numpy as np

from .mechanism import Direction, Mechanism, along, contact_law

# The paper's contact direction b (-f_c on body 2, +f_c on body 3) and input direction B_u = e1.
B_CONTACT = np.array([0.0, 1.0, -1.0, 0.0])
B_INPUT = np.array([1.0, 0.0, 0.0, 0.0])

NEWTON_RTOL = 256 * np.finfo(float).eps
NEWTON_MAX_ITER = 20

# The setting `discretisation` (schema enum, in its order).
BACKWARD_EULER = "backward_euler"
TRAPEZOIDAL = "trapezoidal"
DISCRETISATIONS = (BACKWARD_EULER, TRAPEZOIDAL)

# The model is the mechanism: `Plant` is the name the callers written for the paper's chain use.
Plant = Mechanism

# Statistically linearised contacts (the setting contact_slr_p, docs/discretisation.md): 20-node
# Gauss-Hermite rule for E[g(t)], t ~ N(d, s^2) = sum_k w_k g(d + sqrt(2) s x_k) with sum w_k = 1.
_GH_X, _GH_W = np.polynomial.hermite.hermgauss(20)
_GH_W = _GH_W / math.sqrt(math.pi)


def slr_moments(d: float, s: float, n: float) -> Tuple[float, float]:
    """(E[max(0, t)^n], E[n max(0, t)^(n-1)]) for t ~ N(d, s^2): the elastic law's expected force and slope
    over gamma, each node's taken from `contact_law` at gamma = 1 (its written-out n = 1.5 and n = 1)."""
    e = e1 = 0.0
    for x, w in zip(_GH_X.tolist(), _GH_W.tolist()):
        f, fd, _, _ = contact_law(d + math.sqrt(2.0) * s * x, 0.0, 1.0, n, 0.0)
        e += w * f
        e1 += w * fd
    return e, e1


def contact_force(delta: float, gamma: float) -> Tuple[float, float, float]:
    """The paper's Hertz law eq. (16)-(17): (f_c, df_c/ddelta, df_c/dgamma); all zero if delta <= 0."""
    f, fd, _, fg = contact_law(delta, 0.0, gamma, 1.5, 0.0)
    return f, fd, fg


def as_inputs(u: Any) -> Tuple[float, ...]:
    """u_k as a tuple of floats: a number is the single input, a sequence one value per input."""
    if isinstance(u, (float, int, np.floating, np.integer)):
        return (float(u),)
    return tuple(float(x) for x in np.asarray(u, dtype=float).ravel())


def as_gammas(gamma: Any) -> Tuple[float, ...]:
    """gamma as a tuple of floats, one per contact (a number for a single contact)."""
    return as_inputs(gamma)


@dataclass
class StepSolver:
    """One implicit step for a fixed step h (backward Euler, eq. 19, or the trapezoidal rule: `scheme`),
    with the linear part factorised once.

    `solve` reproduces Newton-from-v_{k-1}: when neither the initial guess nor the linear
    solution has a contact closed, one Newton iteration lands on the linear solution exactly, so
    we take it straight from the precomputed inverse (1 iteration); otherwise we iterate.
    u: a number (one input) or one value per input; gamma: a number (one contact) or one per contact.
    The trapezoidal rule also needs the inputs at the step's start, u_prev (solve's argument; None:
    u held over the step).
    """

    plant: Mechanism
    h: float
    rtol: float = NEWTON_RTOL
    max_iter: int = NEWTON_MAX_ITER
    scheme: str = BACKWARD_EULER
    # derived
    hs: float = field(init=False)  # the implicit stage's step: h (backward Euler) or h/2 (trapezoidal)
    trapezoidal: bool = field(init=False)
    J0: np.ndarray = field(init=False)  # M/hs + C + hs K: Newton Jacobian without contact
    J0_inv: np.ndarray = field(init=False)
    m_h: np.ndarray = field(init=False)
    abs_C: np.ndarray = field(init=False)
    abs_K: np.ndarray = field(init=False)
    laws: Tuple[Tuple[Direction, float, float, float], ...] = field(init=False)  # (b_c, gap, n, lambda) per contact
    # A line's (a, b, gap, n, lambda) per contact, for code written against the ends (the previous estimator that
    # test_mechanism_uncertainty runs on this model); the step reads `laws` only. A structure's: none.
    contacts: Tuple[Tuple[int, int, float, float, float], ...] = field(init=False)
    contact_vecs: Tuple[Tuple[np.ndarray, np.ndarray], ...] = field(init=False)  # b_c's (indices, values)
    input_dirs: Tuple[Direction, ...] = field(init=False)  # where each input's force acts (Mechanism.B_load)
    # Statistically linearised contacts: per contact the penetration's std s (> 0: the Newton matrix takes the
    # elastic law's tangent expected over N(delta, s^2), a quasi-Newton step; 0 or absent: the law's own).
    slr: Tuple[float, ...] = field(init=False, default=())

    def __post_init__(self) -> None:
        if self.scheme not in DISCRETISATIONS:
            raise ValueError(f"unknown discretisation {self.scheme!r}; choose from {', '.join(DISCRETISATIONS)}")
        self.trapezoidal = self.scheme == TRAPEZOIDAL
        self.hs = self.h / 2 if self.trapezoidal else self.h
        p, h = self.plant, self.hs
        self.m_h = p.m / h
        self.J0 = np.diag(self.m_h) + p.C + h * p.K
        self.J0_inv = np.linalg.inv(self.J0)
        self.abs_C = np.abs(p.C)
        self.abs_K = np.abs(p.K)
        self.laws = p.contact_laws
        self.contacts = () if p.is_structure else p.contacts
        self.contact_vecs = tuple((np.array(i, dtype=np.int64), np.array(w)) for i, w in p.contact_dirs)
        self.input_dirs = p.input_dirs  # a base displacement's: its link's body
        # base displacements: (input, k, c) of each (its force k u + c du/dt; forces_at)
        self.base = tuple((int(i), float(p.B_u[p.input_body[i], i]), float(p.B_du[p.input_body[i], i]))
                          for i in np.flatnonzero(p.input_kind != 0).tolist())

    def forces_at(self, u: Any, u_prev: Any) -> Tuple[Any, Any]:
        """The inputs as the forces the momentum rows take at the step's end and start (u, u_prev unchanged
        when every input is a force): a base displacement's k u + c (u - u_prev) / hs and k u_prev (u_prev
        None: u, held over the step)."""
        if not self.base:
            return u, u_prev
        end, start = list(as_inputs(u)), list(as_inputs(u if u_prev is None else u_prev))
        for i, k, c in self.base:
            end[i], start[i] = k * end[i] + c * (end[i] - start[i]) / self.hs, k * start[i]
        return tuple(end), tuple(start)

    def slr_tangents(self, c: int, delta: float, gamma: float, n: float) -> "Tuple[float, float] | None":
        """Contact c's statistically linearised (df/ddelta, df/dgamma), or None when it has no std."""
        s = self.slr[c] if c < len(self.slr) else 0.0
        if not s > 0.0:
            return None
        e, e1 = slr_moments(delta, s, n)
        return gamma * e1, e

    def any_on(self, q: np.ndarray, gamma: Any) -> bool:
        """Whether a contact changes the Newton matrix at positions q: closed (delta > 0), or linearised
        statistically with a nonzero expected tangent."""
        for c, ((d, gap, n, _), g) in enumerate(zip(self.laws, as_gammas(gamma))):
            delta = along(d, q) - gap
            if delta > 0.0:
                return True
            slr = self.slr_tangents(c, delta, g, n)
            if slr is not None and slr[0] != 0.0:
                return True
        return False

    def penetrations(self, q: "np.ndarray | List[float]") -> List[float]:
        """delta of each contact at positions q (plain floats)."""
        return [along(d, q) - gap for d, gap, _, _ in self.laws]

    def positions(self, q_prev: np.ndarray, v_prev: np.ndarray, v: np.ndarray) -> np.ndarray:
        """q_k of the step for the velocities v_k."""
        if self.trapezoidal:
            return q_prev + self.hs * (v_prev + v)
        return q_prev + self.h * v

    def force(self, q: np.ndarray, v: np.ndarray, u: Any, gamma: Any) -> Tuple[np.ndarray, np.ndarray]:
        """G(q, v, u) = C v + K q - B_u u + sum_c b_c f_c and each row's sum of term magnitudes."""
        p = self.plant
        Cv, Kq = p.C * v[None, :], p.K * q[None, :]
        G = Cv.sum(axis=1) + Kq.sum(axis=1)
        mag = np.abs(Cv).sum(axis=1) + np.abs(Kq).sum(axis=1)
        for (d, gap, n, lam), g in zip(self.laws, as_gammas(gamma)):
            fc = contact_law(along(d, q) - gap, along(d, v), g, n, lam)[0]
            _add_load(G, mag, d, fc)
        for d, uj in zip(self.input_dirs, as_inputs(u)):
            _add_load(G, mag, d, -uj)
        return G, mag

    def residual(
        self, v: np.ndarray, q_prev: np.ndarray, v_prev: np.ndarray, u: Any, gamma: Any,
        start: "Tuple[np.ndarray, np.ndarray] | None" = None,
    ) -> Tuple[np.ndarray, np.ndarray, List[float]]:
        """Momentum rows of the step in v_k, each row's sum of term magnitudes, and the deltas.
        Trapezoidal: `start` = (G_0, its magnitudes), from `force` at the step's start."""
        if self.trapezoidal:
            q = self.positions(q_prev, v_prev, v)
            inertia = self.m_h * (v - v_prev)
            G, mag = self.force(q, v, u, gamma)
            g0, mag0 = start if start is not None else (np.zeros_like(v), np.zeros_like(v))
            return inertia + G + g0, np.abs(inertia) + mag + mag0, self.penetrations(q)
        p = self.plant
        q = q_prev + self.h * v
        inertia = self.m_h * (v - v_prev)
        r = inertia + p.C @ v + p.K @ q
        mag = np.abs(inertia) + self.abs_C @ np.abs(v) + self.abs_K @ np.abs(q)
        deltas = []
        for (d, gap, n, lam), g in zip(self.laws, as_gammas(gamma)):
            delta = along(d, q) - gap
            deltas.append(delta)
            fc = contact_law(delta, along(d, v), g, n, lam)[0]
            _add_load(r, mag, d, fc)
        for d, uj in zip(self.input_dirs, as_inputs(u)):
            _add_load(r, mag, d, -uj)
        return r, mag, deltas

    def jacobian(self, q: np.ndarray, gamma: Any, v: "np.ndarray | None" = None) -> np.ndarray:
        """dr/dv_k = M/hs + C + hs K + sum_c (hs df_c/ddelta + df_c/dddelta) b_c b_c^T (v: for Hunt-Crossley)."""
        J = self.J0
        for c, ((d, gap, n, lam), g) in enumerate(zip(self.laws, as_gammas(gamma))):
            delta = along(d, q) - gap
            dd = 0.0 if v is None else along(d, v)
            slr = self.slr_tangents(c, delta, g, n)
            if slr is not None:
                kc, kd = slr[0], 0.0
            else:
                _, kc, kd, _ = contact_law(delta, dd, g, n, lam)
            if kc == 0.0 and kd == 0.0:
                continue
            if J is self.J0:
                J = self.J0.copy()
            # hk b b^T over b's nonzero entries, (hk b_i) b_j as the C core's add_structure_block (a line's: +-hk)
            idx, w = self.contact_vecs[c]
            J[np.ix_(idx, idx)] += np.outer((self.hs * kc + kd) * w, w)
        return J

    def linear_velocity(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: Any,
        start: "Tuple[np.ndarray, np.ndarray] | None" = None,
    ) -> np.ndarray:
        """Exact root of the contact-free residual: J0 v = M/h v_prev - K q_prev + B_u u (backward Euler);
        trapezoidal: J0 v = M/s v_prev - K (q_prev + s v_prev) + B_u u - G_0."""
        if self.trapezoidal:
            rhs = self.m_h * v_prev - self.plant.K @ (q_prev + self.hs * v_prev)
            if start is not None:
                rhs = rhs - start[0]
        else:
            rhs = self.m_h * v_prev - self.plant.K @ q_prev
        for (idx, w), uj in zip(self.input_dirs, as_inputs(u)):
            for i, wi in zip(idx, w):
                rhs[i] += wi * uj
        return self.J0_inv @ rhs

    def step_start(self, q_prev: np.ndarray, v_prev: np.ndarray, u_prev: Any, gamma: Any
                   ) -> "Tuple[np.ndarray, np.ndarray] | None":
        """The trapezoidal rule's constant G_0 = G(q_{k-1}, v_{k-1}, u_{k-1}) and its magnitudes; None for
        backward Euler."""
        return self.force(q_prev, v_prev, u_prev, gamma) if self.trapezoidal else None

    def solve(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: Any, gamma: Any, u_prev: Any = None,
        J_first: "np.ndarray | None" = None,
    ) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """One step: returns (q_k, v_k, Newton iterations, converged). u_prev: the trapezoidal rule's inputs
        at the step's start (None: u). J_first: the Jacobian the first Newton update takes (a substep's
        start's; None: the initial guess's, plain Newton)."""
        u, u_prev = self.forces_at(u, u_prev)
        start = self.step_start(q_prev, v_prev, u if u_prev is None else u_prev, gamma)
        first_linear = (J_first is self.J0 if J_first is not None
                        else not self.any_on(self.positions(q_prev, v_prev, v_prev), gamma))
        if first_linear:
            v = self.linear_velocity(q_prev, v_prev, u, start)
            q = self.positions(q_prev, v_prev, v)
            if all(d <= 0.0 for d in self.penetrations(q)):
                return q, v, 1, True
        return self._newton(q_prev, v_prev, u, gamma, start, J_first)

    def newton(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: Any, gamma: Any, u_prev: Any = None,
        start: "Tuple[np.ndarray, np.ndarray] | None" = None, J_first: "np.ndarray | None" = None,
    ) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """Newton on the step's residual from v_{k-1}; bounded iterations. u_prev as for `solve` (start: its
        G_0, when already computed); the first update takes J_first when given, every other the Jacobian
        at its iterate.

        Returns the last iterate and the number of linear solves done when it gives up.
        """
        u, u_prev = self.forces_at(u, u_prev)
        if start is None:
            start = self.step_start(q_prev, v_prev, u if u_prev is None else u_prev, gamma)
        return self._newton(q_prev, v_prev, u, gamma, start, J_first)

    def _newton(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: Any, gamma: Any,
        start: "Tuple[np.ndarray, np.ndarray] | None", J_first: "np.ndarray | None",
    ) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """`newton` with the inputs as forces (forces_at) and the trapezoidal rule's G_0 given."""
        v = v_prev.copy()
        for it in range(self.max_iter + 1):
            r, mag, _ = self.residual(v, q_prev, v_prev, u, gamma, start)
            # At least one update (it solves the linear part exactly); NaN never converges.
            if it > 0 and np.max(np.abs(r)) <= self.rtol * np.max(mag):
                return self.positions(q_prev, v_prev, v), v, it, True
            if it == self.max_iter:
                break
            if it == 0 and J_first is not None:
                J = J_first
            else:
                J = self.jacobian(self.positions(q_prev, v_prev, v), gamma, v)
            try:
                v = v - np.linalg.solve(J, r)
            except np.linalg.LinAlgError:
                break
        return self.positions(q_prev, v_prev, v), v, it, False


def _add_load(r: np.ndarray, mag: np.ndarray, d: Direction, f: float) -> None:
    """r += b f and mag += |b f| over the direction's nonzero entries (a line's +-f on its bodies)."""
    for i, w in zip(*d):
        t = w * f
        r[i] += t
        mag[i] += abs(t)
