"""Augmented EKF for contact-parameter estimation, written from the paper (numpy reference).

Augmented state x* = [q1..q4, v1..v4, gamma] (eq. 2, 18), random-walk gamma (eq. 3).
One step k:
  prediction   Newton solve of eq. (19) with gamma_{k-1}  -> x_k^-
               F_k = -(dg/dx_k)^-1 dg/dx_{k-1}             (eq. 10, full 9x9 Jacobians)
               P_k^- = F P F^T + Q                          (eq. 12)
  correction   G = P H^T (H P H^T + R)^-1, x += G (y - H x), P = (I - G H) P   (eqs. 13-15)
  modes        canonical: Table 1 every step.
               switched (Sec. 3.2): contact active iff delta(x_k^-) > 0 (eq. 21); while
               inactive Q_gamma = 0 and gamma, P_gg are frozen (eqs. 22-27). Two variants for
               the cross-covariance P_xg while inactive:
                 "paper"      eqs. 23-27 read literally: P_xg frozen, only P_xx moves;
                 "consistent" P_xg <- F_xx P_xg, then P_xg <- (I - G_x H_x) P_xg, i.e. a
                              Schmidt ("consider") update that keeps P positive semidefinite.
  constraint   if gamma^+ < gamma_min, redo the correction from (x^-, P^-) with the perfect
               measurement gamma = gamma_min: H^c = [H; D], R^c = blkdiag(R, 0) (eqs. 28-30).
               S^c is solved after diagonal equilibration, with a pseudo-inverse fallback when
               singular (flag SINGULAR_INNOVATION); afterwards gamma = gamma_min and P's gamma
               row/column are set to their exact-arithmetic values (gamma_min, 0).
Flags use the C core's bit layout (flags.py).
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional, Tuple

import numpy as np

from . import flags as fl
from .model import B_CONTACT, Plant, StepSolver, contact_force
from .scenario import Scenario

NX = 8  # physical states q, v
NA = 9  # augmented: + gamma
IG = 8  # index of gamma

CANONICAL = "canonical"
SWITCHED = "switched"
VARIANT_PAPER = "paper"
VARIANT_CONSISTENT = "consistent"


@dataclass(frozen=True)
class EstimatorConfig:
    mode: str = SWITCHED  # CANONICAL | SWITCHED
    switch_variant: str = VARIANT_CONSISTENT  # VARIANT_CONSISTENT | VARIANT_PAPER (switched only)
    q_gamma_scale: float = 1.0  # Q_gamma = q_gamma_scale * sigma_q_gamma^2 (Sec. 4.2 uses 1000)
    constrained: bool = False  # gamma >= gamma_min via eqs. (28)-(30)
    joseph: bool = False  # Joseph-form covariance updates instead of eq. (15)
    newton_max_iter: int = 20

    def __post_init__(self) -> None:
        if self.mode not in (CANONICAL, SWITCHED):
            raise ValueError(f"unknown mode {self.mode!r}")
        if self.switch_variant not in (VARIANT_PAPER, VARIANT_CONSISTENT):
            raise ValueError(f"unknown switch variant {self.switch_variant!r}")


def measurement_matrix() -> np.ndarray:
    """H of eq. (11): y = [q1, q4]; linear, so constant."""
    H = np.zeros((2, NA))
    H[0, 0] = 1.0
    H[1, 3] = 1.0
    return H


def joseph(IKH: np.ndarray, P: np.ndarray, G: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(I - G H) P (I - G H)^T + G R G^T: the PSD-preserving form of eq. (15)."""
    return IKH @ P @ IKH.T + G @ R @ G.T


class AugmentedEKF:
    """State (x, P) plus the constant matrices; `step` advances one sample."""

    def __init__(self, sc: Scenario, cfg: EstimatorConfig) -> None:
        self.sc = sc
        self.cfg = cfg
        self.plant = Plant.from_scenario(sc)
        self.solver = StepSolver(self.plant, sc.dt, max_iter=cfg.newton_max_iter)
        self.dt = sc.dt
        self.H = measurement_matrix()
        self.Hx = self.H[:, :NX]
        self.R = np.eye(2) * sc.sigma_r**2
        self.q_gamma = cfg.q_gamma_scale * sc.sigma_q_gamma**2
        self.Q = np.diag([sc.sigma_qx_q**2] * 4 + [sc.sigma_qx_v**2] * 4 + [self.q_gamma])
        self.Qx = self.Q[:NX, :NX]
        self.x = np.zeros(NA)
        self.x[IG] = sc.gamma0
        self.P = np.diag([sc.sigma_q0**2] * 4 + [sc.sigma_v0**2] * 4 + [sc.sigma_gamma0**2])
        # dg/dx_{k-1} of eq. (19): constant.
        m_dt = self.plant.m / self.dt
        self.Jprev = -np.diag(np.r_[np.full(4, 1.0 / self.dt), m_dt, 1.0])
        # dg/dx_k without the contact terms; contact adds k_c b b^T and df_c/dgamma b.
        Jk = np.zeros((NA, NA))
        Jk[:4, :4] = np.eye(4) / self.dt
        Jk[:4, 4:8] = -np.eye(4)
        Jk[4:8, :4] = self.plant.K
        Jk[4:8, 4:8] = np.diag(m_dt) + self.plant.C
        Jk[IG, IG] = 1.0
        self.Jk0 = Jk
        self.F0 = self._transition(Jk)  # F while out of contact: constant, computed once
        # Constrained-correction pieces (eq. 29-30): D selects gamma.
        D = np.zeros((1, NA))
        D[0, IG] = 1.0
        self.Hc = np.vstack([self.H, D])
        self.Rc = np.zeros((3, 3))
        self.Rc[:2, :2] = self.R
        self.I = np.eye(NA)

    # ---- prediction -------------------------------------------------------------------
    def _transition(self, Jk: np.ndarray) -> np.ndarray:
        """Eq. (10): F = -(dg/dx_k)^-1 dg/dx_{k-1}."""
        return -np.linalg.solve(Jk, self.Jprev)

    def transition_matrix(self, q: np.ndarray, gamma: float) -> np.ndarray:
        """F_k at the predicted state (eq. 10 with the full 9x9 Jacobians of eq. 19)."""
        delta = q[1] - q[2] - self.plant.gap
        _, kc, dfc_dg = contact_force(delta, gamma)
        if kc == 0.0 and dfc_dg == 0.0:
            return self.F0
        Jk = self.Jk0.copy()
        Jk[4:8, :4] += kc * np.outer(B_CONTACT, B_CONTACT)
        Jk[4:8, IG] = dfc_dg * B_CONTACT
        return self._transition(Jk)

    def predict(self, u: float) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """Newton solve of eq. (19): returns (x_k^-, F_k, iterations, converged)."""
        x = self.x
        q, v, iters, ok = self.solver.solve(x[:4], x[4:8], u, x[IG])
        xp = np.empty(NA)
        xp[:4] = q
        xp[4:8] = v
        xp[IG] = x[IG]  # random walk: gamma_k^- = gamma_{k-1}^+ (eq. 19, third row)
        return xp, self.transition_matrix(q, x[IG]), iters, ok

    # ---- correction -------------------------------------------------------------------
    def _gain(self, P: np.ndarray, H: np.ndarray, R: np.ndarray) -> np.ndarray:
        """Eq. (13): G = P H^T S^-1, solved rather than inverted."""
        PHt = P @ H.T
        S = H @ PHt + R
        return np.linalg.solve(S, PHt.T).T

    def _full_correction(
        self, xp: np.ndarray, P: np.ndarray, y: np.ndarray
    ) -> Tuple[np.ndarray, np.ndarray]:
        """Eqs. (13)-(15) on the whole augmented state."""
        G = self._gain(P, self.H, self.R)
        x = xp + G @ (y - self.H @ xp)
        IKH = self.I - G @ self.H
        P = joseph(IKH, P, G, self.R) if self.cfg.joseph else IKH @ P
        return x, P

    def _constrained_correction(
        self, xp: np.ndarray, P: np.ndarray, y: np.ndarray
    ) -> Tuple[np.ndarray, np.ndarray, bool]:
        """Eqs. (28)-(30): perfect measurement gamma = gamma_min appended to y.

        S^c = H^c P H^c^T + R^c has a zero noise entry, so it is singular when P_gg (or its
        posterior value) is 0 and badly scaled always (metres^2 next to gamma^2). We
        equilibrate it with its diagonal before solving, and fall back to the pseudo-inverse
        (least-squares gain) if it is still singular. Returns (x, P, used_pinv).
        """
        Hc, Rc = self.Hc, self.Rc
        PHt = P @ Hc.T
        S = Hc @ PHt + Rc
        d = np.sqrt(np.abs(np.diag(S)))
        d[d == 0.0] = 1.0
        Sn = S / np.outer(d, d)
        used_pinv = False
        try:
            if np.linalg.cond(Sn) > 1e14:
                raise np.linalg.LinAlgError("ill-conditioned")
            G = (np.linalg.solve(Sn, (PHt / d).T) / d[:, None]).T
        except np.linalg.LinAlgError:
            G = (PHt / d) @ np.linalg.pinv(Sn, rcond=1e-14) / d
            used_pinv = True
        yc = np.r_[y, self.sc.gamma_min]
        x = xp + G @ (yc - Hc @ xp)
        IKH = self.I - G @ Hc
        P = joseph(IKH, P, G, Rc) if self.cfg.joseph else IKH @ P
        if not used_pinv:
            # A perfect measurement leaves gamma = gamma_min and zero gamma row/column in exact
            # arithmetic; restore that, else round-off (P_gg ~ -1e-15 P_gg^-) makes P indefinite.
            x[IG] = self.sc.gamma_min
            P[IG, :] = 0.0
            P[:, IG] = 0.0
        return x, P, used_pinv

    def _switched_off_correction(
        self, xp: np.ndarray, P: np.ndarray, y: np.ndarray
    ) -> Tuple[np.ndarray, np.ndarray]:
        """Contact inactive: correct x only (gamma frozen, eqs. 25-27); P_gg untouched."""
        Pxx = P[:NX, :NX]
        PHt = Pxx @ self.Hx.T
        S = self.Hx @ PHt + self.R
        Gx = np.linalg.solve(S, PHt.T).T  # G_x of eq. (26)
        x = xp.copy()
        x[:NX] += Gx @ (y - self.H @ xp)
        IKH = np.eye(NX) - Gx @ self.Hx
        Pn = P.copy()
        Pn[:NX, :NX] = joseph(IKH, Pxx, Gx, self.R) if self.cfg.joseph else IKH @ Pxx  # eq. (27)
        if self.cfg.switch_variant == VARIANT_CONSISTENT:
            Pxg = IKH @ P[:NX, IG]  # Schmidt update of the cross-covariance
            Pn[:NX, IG] = Pxg
            Pn[IG, :NX] = Pxg
        return x, Pn

    # ---- one step -----------------------------------------------------------------------
    def step(self, u: float, y: np.ndarray) -> Tuple[int, int]:
        """Advance one sample with input u_k and measurement y_k; returns (flags, Newton iters)."""
        cfg = self.cfg
        status = 0
        xp, F, iters, ok = self.predict(u)
        if not ok:
            status |= fl.NEWTON_NOT_CONVERGED
        active = self.plant.penetration(xp[:4]) > 0.0  # eq. (21), on the predicted state
        if active:
            status |= fl.CONTACT_ACTIVE
        P = self.P
        full = cfg.mode == CANONICAL or active
        if full:
            Pm = F @ P @ F.T + self.Q  # eq. (12)
        else:
            Fxx = F[:NX, :NX]  # F_xg = 0 out of contact (df_c/dgamma = 0), eq. (23)
            Pm = P.copy()
            Pm[:NX, :NX] = Fxx @ P[:NX, :NX] @ Fxx.T + self.Qx  # eq. (24)
            if cfg.switch_variant == VARIANT_CONSISTENT:
                Pxg = Fxx @ P[:NX, IG]
                Pm[:NX, IG] = Pxg
                Pm[IG, :NX] = Pxg
            # Q_gamma = 0 (eq. 21): P_gg and gamma stay as they are.
        if full:
            x, Pp = self._full_correction(xp, Pm, y)
            if cfg.constrained and x[IG] < self.sc.gamma_min:  # eq. (28): c = D x - d < 0
                x, Pp, used_pinv = self._constrained_correction(xp, Pm, y)
                status |= fl.CONSTRAINT_APPLIED
                if used_pinv:
                    status |= fl.SINGULAR_INNOVATION
        else:
            x, Pp = self._switched_off_correction(xp, Pm, y)
            status |= fl.GAMMA_FROZEN
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(Pp))):
            status |= fl.NON_FINITE
        self.x, self.P = x, Pp
        return status, iters


@dataclass
class EstimateResult:
    """Per-step estimator output for samples k = 1..N."""

    t: np.ndarray
    x: np.ndarray  # (N, 9)
    p_norm: np.ndarray  # 2-norm of P^+, physical units
    p_gg: np.ndarray
    flags: np.ndarray  # int
    newton_iters: np.ndarray  # int
    P: Optional[np.ndarray] = None  # (N, 9, 9) when kept
    wall_time: float = float("nan")

    @property
    def gamma(self) -> np.ndarray:
        return self.x[:, IG]

    @property
    def steps_per_second(self) -> float:
        return len(self.t) / self.wall_time


def spectral_norms(P: np.ndarray, chunk: int = 8192) -> np.ndarray:
    """2-norms of a stack of matrices (largest singular value), NaN where not finite."""
    out = np.full(len(P), np.nan)
    for s in range(0, len(P), chunk):
        blk = P[s : s + chunk]
        good = np.all(np.isfinite(blk), axis=(1, 2))
        if good.any():
            out[s : s + chunk][good] = np.linalg.svd(blk[good], compute_uv=False)[:, 0]
    return out


def run_estimator(
    sc: Scenario,
    cfg: EstimatorConfig,
    t: np.ndarray,
    u: np.ndarray,
    y: np.ndarray,
    keep_P: bool = True,
    progress: bool = False,
) -> EstimateResult:
    """Run the filter over measurements y (N, 2) with inputs u (N,) sampled at t_k = k dt."""
    ekf = AugmentedEKF(sc, cfg)
    n = len(t)
    xs = np.empty((n, NA))
    Ps = np.empty((n, NA, NA))
    fls = np.zeros(n, dtype=np.int64)
    its = np.zeros(n, dtype=np.int64)
    rng = range(n)
    if progress:
        try:
            from tqdm import tqdm

            rng = tqdm(rng, unit="step", mininterval=1.0)
        except ImportError:  # tqdm is optional
            pass
    u_list = np.asarray(u, dtype=float).tolist()
    t0 = time.perf_counter()
    with np.errstate(all="ignore"):  # a diverging filter is an outcome we record, not a crash
        for k in rng:
            fls[k], its[k] = ekf.step(u_list[k], y[k])
            xs[k] = ekf.x
            Ps[k] = ekf.P
    wall = time.perf_counter() - t0
    return EstimateResult(
        t=np.asarray(t, dtype=float),
        x=xs,
        p_norm=spectral_norms(Ps),
        p_gg=Ps[:, IG, IG].copy(),
        flags=fls,
        newton_iters=its,
        P=Ps if keep_P else None,
        wall_time=wall,
    )
