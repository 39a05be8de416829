"""The four-body lumped model of paper Sec. 3.1 and its backward-Euler step (eq. 19).

Conventions (shared with the C core): x = [q1..q4, v1..v4]; the input force u acts on body 1
(B_u = e1); penetration delta = q2 - q3 - gap; Hertz force f_c = gamma * delta^1.5 for
delta > 0 (eq. 16-17), acting -f_c on body 2 and +f_c on body 3.

Backward Euler, eq. (19) plus the damping term C v_k that the paper omits:
    (q_k - q_{k-1})/h - v_k = 0
    M (v_k - v_{k-1})/h + C v_k + K q_k - B_u u_k + b f_c(q_k, gamma) = 0,   b = [0, 1, -1, 0]
Substituting q_k = q_{k-1} + h v_k leaves 4 equations in v_k, solved by Newton from
v_{k-1} with Jacobian J = M/h + C + h (K + k_c b b^T), k_c = 1.5 gamma delta^0.5.
Convergence (the same test as the C core, caekf_model_newton): after at least one update,
max_i |r_i| <= rtol * max_i mag_i, where mag_i is the sum of the magnitudes of row i's terms
(a norm-wise backward error: a lightly loaded row cannot be resolved better than the rounding
the coupled solve spreads from the heavily loaded ones); rtol = 256 eps.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Tuple

import numpy as np

from .scenario import Scenario

# Contact direction b: the contact force enters the residual as +b f_c (-f_c on body 2, +f_c on 3).
B_CONTACT = np.array([0.0, 1.0, -1.0, 0.0])
# Input direction B_u = e1.
B_INPUT = np.array([1.0, 0.0, 0.0, 0.0])

NEWTON_RTOL = 256 * np.finfo(float).eps
NEWTON_MAX_ITER = 20


def chain_matrix(a1: float, a12: float, a34: float, a4: float) -> np.ndarray:
    """K or C of the chain ground-1-2 | 3-4-ground (2-3 only via contact)."""
    return np.array(
        [
            [a1 + a12, -a12, 0.0, 0.0],
            [-a12, a12, 0.0, 0.0],
            [0.0, 0.0, a34, -a34],
            [0.0, 0.0, -a34, a34 + a4],
        ]
    )


@dataclass(frozen=True)
class Plant:
    """Constant matrices of the model; gamma is passed separately (it is estimated)."""

    m: np.ndarray  # diagonal of M
    K: np.ndarray
    C: np.ndarray
    gap: float
    u_amp: float
    u_freq: float
    u_phase: float

    @staticmethod
    def from_scenario(sc: Scenario) -> "Plant":
        return Plant(
            m=np.array([sc.m1, sc.m2, sc.m3, sc.m4]),
            K=chain_matrix(sc.k1, sc.k12, sc.k34, sc.k4),
            C=chain_matrix(sc.c1, sc.c12, sc.c34, sc.c4),
            gap=sc.gap,
            u_amp=sc.u_amp,
            u_freq=sc.u_freq,
            u_phase=sc.u_phase,
        )

    @property
    def M(self) -> np.ndarray:
        return np.diag(self.m)

    def force(self, t: "np.ndarray | float") -> "np.ndarray | float":
        """Input u(t) = u_amp sin(2 pi u_freq t + u_phase); vectorised over t."""
        return self.u_amp * np.sin(2.0 * np.pi * self.u_freq * np.asarray(t) + self.u_phase)

    def penetration(self, q: np.ndarray) -> "np.ndarray | float":
        """delta = q2 - q3 - gap; works on a state row or an (n, >=4) array."""
        q = np.asarray(q)
        return q[..., 1] - q[..., 2] - self.gap


def contact_force(delta: float, gamma: float) -> Tuple[float, float, float]:
    """Hertz law eq. (16)-(17): returns (f_c, df_c/ddelta, df_c/dgamma); all zero if delta <= 0."""
    if delta <= 0.0:
        return 0.0, 0.0, 0.0
    s = math.sqrt(delta)
    d15 = delta * s
    return gamma * d15, 1.5 * gamma * s, d15


@dataclass
class StepSolver:
    """Backward-Euler step of eq. (19) for a fixed step h, with the linear part factorised once.

    `solve` reproduces Newton-from-v_{k-1}: when neither the initial guess nor the linear
    solution is in contact, one Newton iteration lands on the linear solution exactly, so
    we take it straight from the precomputed inverse (1 iteration); otherwise we iterate.
    """

    plant: Plant
    h: float
    rtol: float = NEWTON_RTOL
    max_iter: int = NEWTON_MAX_ITER
    # derived
    J0: np.ndarray = field(init=False)  # M/h + C + hK: Newton Jacobian without contact
    J0_inv: np.ndarray = field(init=False)
    m_h: np.ndarray = field(init=False)
    abs_C: np.ndarray = field(init=False)
    abs_K: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        p, h = self.plant, self.h
        self.m_h = p.m / h
        self.J0 = np.diag(self.m_h) + p.C + h * p.K
        self.J0_inv = np.linalg.inv(self.J0)
        self.abs_C = np.abs(p.C)
        self.abs_K = np.abs(p.K)

    def residual(
        self, v: np.ndarray, q_prev: np.ndarray, v_prev: np.ndarray, u: float, gamma: float
    ) -> Tuple[np.ndarray, np.ndarray, float]:
        """Momentum rows of eq. (19) in v_k, each row's sum of term magnitudes, and delta."""
        p = self.plant
        q = q_prev + self.h * v
        delta = q[1] - q[2] - p.gap
        fc, _, _ = contact_force(delta, gamma)
        inertia = self.m_h * (v - v_prev)
        r = inertia + p.C @ v + p.K @ q + fc * B_CONTACT
        r[0] -= u
        mag = np.abs(inertia) + self.abs_C @ np.abs(v) + self.abs_K @ np.abs(q) + abs(fc) * np.abs(B_CONTACT)
        mag[0] += abs(u)
        return r, mag, delta

    def jacobian(self, q: np.ndarray, gamma: float) -> np.ndarray:
        """dr/dv_k = M/h + C + h (K + k_c b b^T)."""
        delta = q[1] - q[2] - self.plant.gap
        _, kc, _ = contact_force(delta, gamma)
        if kc == 0.0:
            return self.J0
        J = self.J0.copy()
        hk = self.h * kc
        J[1, 1] += hk
        J[1, 2] -= hk
        J[2, 1] -= hk
        J[2, 2] += hk
        return J

    def linear_velocity(self, q_prev: np.ndarray, v_prev: np.ndarray, u: float) -> np.ndarray:
        """Exact root of the contact-free residual: J0 v = M/h v_prev - K q_prev + B_u u."""
        rhs = self.m_h * v_prev - self.plant.K @ q_prev
        rhs[0] += u
        return self.J0_inv @ rhs

    def solve(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: float, gamma: float
    ) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """One step: returns (q_k, v_k, Newton iterations, converged)."""
        h, gap = self.h, self.plant.gap
        guess_delta = (q_prev[1] + h * v_prev[1]) - (q_prev[2] + h * v_prev[2]) - gap
        if guess_delta <= 0.0:
            v = self.linear_velocity(q_prev, v_prev, u)
            q = q_prev + h * v
            if q[1] - q[2] - gap <= 0.0:
                return q, v, 1, True
        return self.newton(q_prev, v_prev, u, gamma)

    def newton(
        self, q_prev: np.ndarray, v_prev: np.ndarray, u: float, gamma: float
    ) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """Plain Newton on the residual of eq. (19) from v_{k-1}; bounded iterations.

        Returns the last iterate and the number of linear solves done when it gives up.
        """
        v = v_prev.copy()
        for it in range(self.max_iter + 1):
            r, mag, _ = self.residual(v, q_prev, v_prev, u, gamma)
            # At least one update (it solves the linear part exactly); NaN never converges.
            if it > 0 and np.max(np.abs(r)) <= self.rtol * np.max(mag):
                return q_prev + self.h * v, v, it, True
            if it == self.max_iter:
                break
            J = self.jacobian(q_prev + self.h * v, gamma)
            try:
                v = v - np.linalg.solve(J, r)
            except np.linalg.LinAlgError:
                break
        return q_prev + self.h * v, v, it, False
