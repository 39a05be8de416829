"""Augmented EKF for contact-parameter estimation, written from the paper (numpy reference).

Augmented state x* = [q_1..q_nq, v_1..v_nq, gamma_1..gamma_nc] (eq. 2, 18) for any mechanism of
mechanism.py (the paper: [q1..q4, v1..v4, gamma]), bodies on a line or a structure given as matrices (its
degrees of freedom for the bodies; docs/structure.md), random-walk gammas (eq. 3). Contact c acts along b_c
(a line's e_a - e_b, a structure's w_c), sensor i reads the row h_i of [q; v] or of the model's acceleration
(a line's e_body). One step k:
  prediction   Newton solve of eq. (19) with gamma_{k-1}  -> x_k^-
               F_k = -(dg/dx_k)^-1 dg/dx_{k-1}             (eq. 10, full N x N Jacobians)
               (`discretisation` = "trapezoidal": the trapezoidal step of model.py instead of eq. 19;
               its start-of-step force G(x_{k-1}, u_{k-1}) puts K, C and the contact tangents at
               x_{k-1} into dg/dx_{k-1}. u_{k-1} is the previous step's input; the first step holds
               its own u_k over the interval unless `correct` gave the inputs at t0, as the C core.)
               (`contact_substeps` S > 1: when a contact is closed at x_{k-1}, or at the one-step
               x_k^- from an open x_{k-1}, the step is made from x_{k-1} in S steps of the same rule at
               dt/S, inputs linear from u_{k-1} to u_k, and F = F_S ... F_1, the product of their
               eq. (10) maps. A contact closed at x_{k-1} skips the one-step solve; a discarded one-step
               solve's iterations still count, its convergence does not.)
               (`contact_slr_p` p > 0: s_c = sqrt(b_c^T P_qq b_c) from P_{k-1}; an elastic contact of gamma
               alone takes the law's tangents expected over delta ~ N(delta, s_c^2) (20-node Gauss-Hermite)
               in F and in the Newton matrix (quasi-Newton), its force the law's own; a contact counts as on
               for the step map while delta > 0 or its expected tangent is nonzero; F is the contact-free
               one unless a contact is active, substepped, or (trapezoidal) on at x_{k-1}.)
               P_k^- = F P F^T + Q                          (eq. 12)
  correction   G = P H^T (H P H^T + R)^-1, x += G (y - H x), P = (I - G H) P   (eqs. 13-15)
  modes        canonical: Table 1 every step, every gamma live.
               switched (Sec. 3.2): gamma_c is live iff its own contact is closed at the
               prediction, delta_c(x_k^-) > 0 (eq. 21; contact_slr_p, an elastic law of gamma alone:
               while P(delta_c > 0) > p); a
               frozen gamma_c has Q = 0 and keeps its value and variance (eqs. 22-27), and the live
               block L (states + live gammas) is
               propagated and corrected alone. Two variants for the cross-covariance P_Lg of a
               frozen gamma:
                 "paper"      eqs. 23-27 read literally: P_Lg frozen, only P_LL moves;
                 "consistent" P_Lg <- F_LL P_Lg, then P_Lg <- (I - G_L H_L) P_Lg, i.e. a
                              Schmidt ("consider") update that keeps P positive semidefinite.
  gate         (optional, `gate_nis`) NIS = e^T S^-1 e above it: every live gamma is held for
               the correction of this step (Schmidt), as the C core does (flag GAMMA_GATED).
  constraint   contacts in order: if gamma_c^+ < gamma_min_c, redo the correction from
               (x^-, P^-) with the perfect measurements gamma = gamma_min of every violated contact
               so far appended: H^c = [H; D], R^c = blkdiag(R, 0) (eqs. 28-30; the same as
               sequential perfect measurements). S^c is solved after diagonal equilibration, with a
               pseudo-inverse fallback when singular (flag SINGULAR_INNOVATION); afterwards gamma_c =
               gamma_min_c and P's gamma_c row/column are set to their exact-arithmetic values.
  mechanism    (m{i}_sigma, spring{i}_k_sigma, spring{i}_c_sigma > 0; docs/mechanism.md) theta_j = ln(value_j /
               setting_j) are the last states, always live, random walk sigma_q_mech * sigma_j, no bounds; M, K,
               C are rebuilt at setting_j exp(theta_j) before each step and F's theta columns are eq. (10)'s
               -(dg/dx_k)^-1 dg/dtheta_j at x_k^- over the whole step (also when substepped). The gate holds
               them with the gammas. input{i}_sigma: P^- += G diag(sigma_u^2) G^T on the bodies' states, G =
               dx_k/du through the implicit step (trapezoidal: both ends' inputs). Read from the scenario, as
               the other noise settings.
Flags use the C core's bit layout (flags.py).
"""
from __future__ import annotations

import copy
import math
import time
from dataclasses import dataclass
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import flags as fl
from .mechanism import (ACCELERATION, BASE_DISPLACEMENT, LINK_FORCE, VELOCITY, Direction, Mechanism, along,
                        bias_layout, body_values, contact_law, contact_values, law_column_names, law_derivatives,
                        law_layout, mech_column_names, mech_layout, scenario_value, sensor_sigmas)
from .model import BACKWARD_EULER, DISCRETISATIONS, TRAPEZOIDAL, StepSolver, as_inputs
from .scenario import Scenario

# The paper's layout (4 bodies, one contact); a general mechanism has N = 2 nq + nc (AugmentedEKF.n).
NX = 8  # physical states q, v
NA = 9  # augmented: + gamma
IG = 8  # index of gamma

CANONICAL = "canonical"
SWITCHED = "switched"
VARIANT_PAPER = "paper"
VARIANT_CONSISTENT = "consistent"

Index = Union[slice, List[int]]


@dataclass(frozen=True)
class EstimatorConfig:
    mode: str = SWITCHED  # CANONICAL | SWITCHED
    switch_variant: str = VARIANT_CONSISTENT  # VARIANT_CONSISTENT | VARIANT_PAPER (switched only)
    q_gamma_scale: float = 1.0  # Q_gamma_c = q_gamma_scale * sigma_q_gamma_c^2 (Sec. 4.2 uses 1000)
    constrained: bool = False  # gamma_c >= gamma_min_c via eqs. (28)-(30)
    joseph: bool = False  # Joseph-form covariance updates instead of eq. (15)
    newton_max_iter: int = 20
    gate_nis: float = math.inf  # innovation gate on the gammas (the C setting gamma_gate_nis); inf: off
    # The step map (the setting `discretisation`): BACKWARD_EULER (eq. 19) | TRAPEZOIDAL. Backward Euler
    # here (the numpy reference's own default); experiments.scenario_config takes the scenario's.
    discretisation: str = BACKWARD_EULER
    # The setting `contact_substeps`: steps of dt / contact_substeps while a contact is closed at either end
    # of the step (1: never). 1 here (the numpy reference's own default); scenario_config takes the scenario's.
    contact_substeps: int = 1
    # The setting `gamma_log`: the gamma states hold ln gamma (P0 and Q relative to gamma0, bounds in ln).
    gamma_log: bool = False
    # The setting `law_second_order`: the Gaussian second-order term of a closed contact's force as process
    # noise on its bodies' velocities, for laws nonlinear in their states (ln gamma, n, lambda, gap).
    law_second_order: bool = True
    # The setting `contact_slr_p` (0: off): statistically linearised contacts. With s_c = sqrt(b_c^T P_qq b_c)
    # from P_{k-1}, an elastic contact of gamma alone (lambda = 0, none of n, lambda, gap estimated) takes
    # its law's tangents expected over delta ~ N(delta, s_c^2) in F and in the Newton matrix (its force stays
    # the law's), and is active (eq. 21) while P(delta > 0) > contact_slr_p; other laws keep eq. 21's sign.
    contact_slr_p: float = 0.0
    # The model-mismatch monitor (settings mismatch_window, mismatch_ratio, mismatch_adapt; docs/mismatch.md):
    # m <- m + (min(NIS / ny, 100) - m) / window after each correction (m = 1 at the start); the flag
    # MODEL_MISMATCH while m > ratio or the bodies' Q_x is still scaled; with adapt, that scale
    # rho <- clip(rho (1 + (m - 1) / window), 1, 1e12) once m has passed the ratio, until it is back at 1.
    # window 0 (the numpy reference's own default): no monitor.
    mismatch_window: int = 0
    mismatch_ratio: float = 3.0
    mismatch_adapt: bool = False
    # The setting `input_trend_window`: steps of the measured inputs' trend at which the mechanism parameters'
    # columns of F are taken (input{i}_sigma > 0; _add_mech_columns). 0 (the numpy reference's own default):
    # at the samples.
    input_trend_window: int = 0

    def __post_init__(self) -> None:
        if not self.contact_slr_p >= 0:
            raise ValueError(f"contact_slr_p = {self.contact_slr_p}: must be >= 0")
        if isinstance(self.contact_substeps, bool) or not isinstance(self.contact_substeps, int) \
                or self.contact_substeps < 1:
            raise ValueError(f"contact_substeps = {self.contact_substeps!r}: must be an integer >= 1")
        if self.discretisation not in DISCRETISATIONS:
            raise ValueError(f"unknown discretisation {self.discretisation!r}")
        if self.mode not in (CANONICAL, SWITCHED):
            raise ValueError(f"unknown mode {self.mode!r}")
        if self.switch_variant not in (VARIANT_PAPER, VARIANT_CONSISTENT):
            raise ValueError(f"unknown switch variant {self.switch_variant!r}")
        if not self.gate_nis > 0:
            raise ValueError(f"gate_nis = {self.gate_nis}: must be > 0 (inf: no gate)")


def measurement_matrix(mech: "Mechanism | None" = None, n_law: int = 0) -> np.ndarray:
    """H of eq. (11) on the augmented state: the sensed positions/velocities (paper: y = [q1, q4]); n_law
    estimated law parameters follow the gammas."""
    mech = mech if mech is not None else Mechanism.from_scenario({})
    return np.hstack([mech.H, np.zeros((mech.n_sensors, mech.n_contacts + n_law))])


def joseph(IKH: np.ndarray, P: np.ndarray, G: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(I - G H) P (I - G H)^T + G R G^T: the PSD-preserving form of eq. (15)."""
    return IKH @ P @ IKH.T + G @ R @ G.T


def _block(A: np.ndarray, rows: Index, cols: Index) -> np.ndarray:
    """A[rows, cols] for slices or index lists (a copy for lists)."""
    if isinstance(rows, slice) and isinstance(cols, slice):
        return A[rows, cols]
    return A[np.ix_(np.arange(A.shape[0])[rows], np.arange(A.shape[1])[cols])]


def _set_block(A: np.ndarray, rows: Index, cols: Index, value: np.ndarray) -> None:
    if isinstance(rows, slice) and isinstance(cols, slice):
        A[rows, cols] = value
    else:
        A[np.ix_(np.arange(A.shape[0])[rows], np.arange(A.shape[1])[cols])] = value


def _pin_to_bounds(x: np.ndarray, P: np.ndarray, violated: Sequence[Tuple[int, float]]) -> None:
    """A perfect measurement leaves the parameter on its bound and a zero row/column in exact arithmetic;
    restore that, else round-off (P_gg ~ -1e-15 P_gg^-) makes P indefinite."""
    for g, bound in violated:
        x[g] = bound
        P[g, :] = 0.0
        P[:, g] = 0.0


class AugmentedEKF:
    """State (x, P) plus the constant matrices; `step` advances one sample."""

    def __init__(self, sc: Scenario, cfg: EstimatorConfig, mech: Optional[Mechanism] = None) -> None:
        self.sc = sc
        self.cfg = cfg
        self.plant = mech if mech is not None else Mechanism.from_scenario(sc)
        p = self.plant
        nq, nc = p.nq, p.n_contacts
        self.nq, self.nc = nq, nc
        self.nx = 2 * nq
        # The estimated law parameters (docs/contact-law.md): states after the gammas, contact by contact.
        self.law = law_layout(sc, nc)
        # The estimated mechanism parameters (docs/mechanism.md): theta_j = ln(value_j / setting_j), the last nm
        # states; the model's M, K, C follow their estimates every step (_set_mechanism).
        self.base = p
        self.mech = mech_layout(sc)
        self.nm = nm = len(self.mech)
        # The sensors' estimated offsets (sensor{i}_bias_sigma > 0, docs/sensors.md): the last nb states.
        self.biases = bias_layout(sc)
        self.nb = nb = len(self.biases)
        self.n = n = 2 * nq + nc + len(self.law) + nm + nb
        self.im = list(range(n - nm - nb, n - nb))
        self.ib = list(range(n - nb, n))
        self.mech_setting = np.array([float(getattr(p, "m" if kind == "m" else f"spring_{kind}")[e])
                                      for kind, e, _ in self.mech])
        mech_sigma = np.array([sigma for _, _, sigma in self.mech])
        # the measured inputs' white noise [N] (input{i}_sigma): process noise through the implicit step
        self.input_sigma = np.array([float(scenario_value(sc, f"input{i}_sigma")) for i in range(1, p.n_inputs + 1)])
        self.ig = list(range(self.nx, self.nx + nc))  # indices of the gammas
        # state index of contact c's n, lambda, gap (absent: the mechanism's value)
        self.law_state: List[dict] = [{} for _ in range(nc)]
        for k, (c, name) in enumerate(self.law):
            self.law_state[c][name] = self.nx + nc + k
        # every parameter state of contact c: its gamma and its estimated law parameters
        self.pstates = [[self.ig[c]] + sorted(self.law_state[c].values()) for c in range(nc)]
        self.solver = StepSolver(p, sc.dt, max_iter=cfg.newton_max_iter, scheme=cfg.discretisation)
        # contact_slr_p: which contacts are statistically linearised (tangents and switch: an elastic law of
        # gamma alone), and their penetration std of the current step (0: none, or not linearised)
        self.slr_law = [lam == 0.0 and not self.law_state[c] for c, (_, _, _, lam) in enumerate(p.contact_laws)]
        self.slr_s: List[float] = [0.0] * nc
        # the last prediction: substepped, and a contact on at x_{k-1} (read when substeps or trapezoidal)
        self._substepped = False
        self._on_prev = False
        self.trapezoidal = cfg.discretisation == TRAPEZOIDAL
        self.u_prev: Any = None  # the inputs at the estimate's time (None until a step or `correct`)
        # the measured inputs' trend (_track_inputs): (inputs, 2) level and slope per step; None until a step
        self.input_trend: Optional[np.ndarray] = None
        self._step_u: Tuple[Any, Any] = (None, None)  # the step's inputs (u_{k-1}, u_k): a base input's ground end
        self.dt = sc.dt
        self.H = measurement_matrix(p, len(self.law) + nm + nb)
        self.Hx = self.H[:, : self.nx]
        # Sensors other than one state each (acceleration, relative, link force, an offset; any of a structure's,
        # as the C core's): rows of H from the state every step (`sensor_rows`), else the constant selection H.
        self.rows = nb > 0 or bool(np.any(p.sensor_kind > VELOCITY)) or p.is_structure
        self.sensor_sigma = sensor_sigmas(sc, p)
        r = self.sensor_sigma**2
        # a measured input's noise on the force it gives: 1 for a force; a base displacement's white noise e_k
        # through k u_k + c (u_k - u_{k-1}) / dt: the std of (k + c/dt) e_k - c/dt e_{k-1}
        c_dt = p.B_du.sum(axis=0) / sc.dt
        gain = np.where(p.input_kind == BASE_DISPLACEMENT, np.sqrt((p.B_u.sum(axis=0) + c_dt) ** 2 + c_dt**2), 1.0)
        for i, k in enumerate(p.sensor_kind.tolist()):
            if k == ACCELERATION:  # a measured force's noise e read through h^T M^-1 b: h_j (e b_j / m_j) summed
                r[i] += sum(along(p.accel_dirs[i], gain[j] * self.input_sigma[j] * p.B_load[:, j] / p.m) ** 2
                            for j in range(p.n_inputs))
        self.R = np.diag(r)
        self._h: Optional[np.ndarray] = None  # the step's h(x-) and H (sensor_rows), None: the selection
        self._Hk: np.ndarray = self.H
        self.gamma_min = contact_values(sc, "gamma_min", nc)
        g0 = contact_values(sc, "gamma0", nc)
        # ln gamma: P0, Q and the state relative to gamma0 (sigma / gamma0 is ln gamma's std to first order)
        rel = g0 if cfg.gamma_log else np.ones(nc)
        self.q_gamma = cfg.q_gamma_scale * (contact_values(sc, "sigma_q_gamma", nc) / rel) ** 2

        def law_value(key: str) -> np.ndarray:
            return np.array([float(scenario_value(sc, f"contact{c + 1}_{key.format(p=name)}"))
                             for c, name in self.law])

        bias_sigma = np.array([sigma for _, sigma in self.biases])
        q_mech = float(scenario_value(sc, "sigma_q_mech"))
        self.Q = np.diag(np.r_[[sc.sigma_qx_q**2] * nq, [sc.sigma_qx_v**2] * nq, self.q_gamma,
                               law_value("sigma_q_{p}") ** 2, (q_mech * mech_sigma) ** 2, (q_mech * bias_sigma) ** 2])
        self.Qx = self.Q[: self.nx, : self.nx]
        self.Qx_settings = np.diag(self.Qx).copy()
        self.nis_mean, self.q_scale = 1.0, 1.0  # the model-mismatch monitor
        # a structure starts at rest at q = 0 (q0_i and v0_i are a line's bodies'), as in the C core
        x0 = np.zeros(2 * nq) if p.is_structure else np.r_[body_values(sc, "q0_", nq), body_values(sc, "v0_", nq)]
        self.x = np.r_[x0,
                       np.log(g0) if cfg.gamma_log else g0, law_value("{p}0"), np.zeros(nm + nb)]
        self.P = np.diag(np.r_[[sc.sigma_q0**2] * nq, [sc.sigma_v0**2] * nq,
                               (contact_values(sc, "sigma_gamma0", nc) / rel) ** 2, law_value("sigma_{p}0") ** 2,
                               mech_sigma**2, bias_sigma**2])
        # Bounds (state, minimum, maximum or None), in state order: gamma's when constrained (eqs. 28-30),
        # an estimated law parameter's always. A maximum of 0 is none.
        self.bounds: List[Tuple[int, float, Optional[float]]] = []
        if cfg.constrained:
            gmax = contact_values(sc, "gamma_max", nc)
            for c in range(nc):
                lo, hi = float(self.gamma_min[c]), (float(gmax[c]) if gmax[c] > 0 else None)
                if cfg.gamma_log:  # ln 0 is no bound
                    lo = math.log(lo) if lo > 0 else -math.inf
                    hi = math.log(hi) if hi is not None else None
                self.bounds.append((self.ig[c], lo, hi))
        for k, (lo, hi) in enumerate(zip(law_value("{p}_min").tolist(), law_value("{p}_max").tolist())):
            self.bounds.append((self.nx + nc + k, lo, hi if hi > 0 else None))
        self.I = np.eye(n)
        # eq. (10)'s constant Jacobians and contact-free F at dt, and at dt / contact_substeps for the substeps
        self.Jk0, self.Jprev0, self.F0 = self._constant_jacobians(self.dt)
        self.sub_solver: Optional[StepSolver] = None
        self.sub_maps: Optional[Tuple[np.ndarray, np.ndarray, np.ndarray]] = None
        if cfg.contact_substeps > 1:
            h = self.dt / cfg.contact_substeps
            self.sub_solver = StepSolver(p, h, max_iter=cfg.newton_max_iter, scheme=cfg.discretisation)
            self.sub_maps = self._constant_jacobians(h)

    def _set_mechanism(self, x: np.ndarray) -> None:
        """The model at the mechanism parameters' estimates in x (value_j = setting_j exp(theta_j)): the
        mechanism, its step solvers (their statistical linearisation kept) and eq. (10)'s constant maps."""
        values = {kind: np.array(getattr(self.base, "m" if kind == "m" else f"spring_{kind}"), dtype=float)
                  for kind in ("m", "k", "c")}
        for (kind, e, _), setting, theta in zip(self.mech, self.mech_setting.tolist(), x[self.im].tolist()):
            values[kind][e] = setting * math.exp(theta)
        self.plant = p = self.base.with_values(values["m"], values["k"], values["c"])
        cfg, slr = self.cfg, self.solver.slr
        self.solver = StepSolver(p, self.dt, max_iter=cfg.newton_max_iter, scheme=cfg.discretisation)
        self.solver.slr = slr
        self.Jk0, self.Jprev0, self.F0 = self._constant_jacobians(self.dt)
        if self.sub_solver is not None:
            h = self.dt / cfg.contact_substeps
            self.sub_solver = StepSolver(p, h, max_iter=cfg.newton_max_iter, scheme=cfg.discretisation)
            self.sub_solver.slr = slr
            self.sub_maps = self._constant_jacobians(h)

    def mech_values(self, x: Optional[np.ndarray] = None) -> np.ndarray:
        """The estimated mechanism parameters' values, setting_j exp(theta_j), at x (default: the estimate)."""
        theta = (self.x if x is None else x)[self.im]
        return self.mech_setting * np.exp(theta)

    def _full_step_jacobian(self, xp: np.ndarray) -> np.ndarray:
        """dg/dx_k of the whole step (eq. 10's, step dt) at x_k^-: the contact tangents at x_k^- included.
        Its x-rows hold the Newton matrix M/hs + C + hs K + contacts (scaled by 1/2 for the trapezoidal rule's
        residual, whose momentum rows are the mean of both ends' forces)."""
        nq, nx = self.nq, self.nx
        w = 0.5 if self.trapezoidal else 1.0
        Jk = self._add_contacts(None, self.Jk0, w, xp[:nq], xp[nx:], xp[nq:nx])
        return self.Jk0 if Jk is None else Jk

    def mech_columns(self, x_prev: np.ndarray, xp: np.ndarray, u_prev: Any = None, u: Any = None) -> np.ndarray:
        """The mechanism parameters' columns of F's physical rows, dx_k / d theta_j (nx, nm), for the step
        x_{k-1} -> x_k^- (eq. 10 with theta_j a state: -(dg/dx_k)^-1 dg/dtheta_j). dg/dtheta_j = value_j
        dg/dvalue_j of the step's residual (the rows of _constant_jacobians): a mass m_a (v_k,a - v_{k-1},a)/dt
        on body a's momentum row; a link (a, b) of stiffness k: w k (d_ab(q_k) + d_ab(q_{k-1}) if trapezoidal)
        on row a, minus that on row b (d_ab = q_a - q_b, ground 0; w = 1/2 trapezoidal, 1 backward Euler); a
        damper the same with v. A ground end a base input moves is at u_k (u_{k-1} at x_{k-1}) and moves at
        (u_k - u_{k-1}) / dt (u_prev, u: the step's inputs; None: at rest). With substeps the same one-step
        formula over the whole step (the C core's)."""
        nq, nx = self.nq, self.nx
        values = self.mech_values(x_prev)
        p = self.base
        D = np.zeros((self.n, self.nm))
        w = 0.5 if self.trapezoidal else 1.0
        ground = {}  # link -> (its ground end at x_k, at x_{k-1}, its rate)
        if p.has_base_inputs and u is not None:
            uk = as_inputs(u)
            u0 = as_inputs(u if u_prev is None else u_prev)
            for i in np.flatnonzero(p.input_kind == BASE_DISPLACEMENT).tolist():
                ground[int(p.input_link[i])] = (uk[i], u0[i], (uk[i] - u0[i]) / self.dt)
        for j, ((kind, e, _), value) in enumerate(zip(self.mech, values.tolist())):
            if kind == "m":
                D[nq + e, j] = value * (xp[nq + e] - x_prev[nq + e]) / self.dt
                continue
            off = 0 if kind == "k" else nq
            a, b = int(p.spring_a[e]), int(p.spring_b[e])
            g1, g0, rate = ground.get(e, (0.0, 0.0, 0.0))
            if kind == "c":
                g1 = g0 = rate

            def diff(x: np.ndarray, g: float) -> float:
                return (x[off + a] if a >= 0 else g) - (x[off + b] if b >= 0 else g)

            d = diff(xp, g1) + (diff(x_prev, g0) if self.trapezoidal else 0.0)
            if a >= 0:
                D[nq + a, j] = w * value * d
            if b >= 0:
                D[nq + b, j] = -w * value * d
        return -np.linalg.solve(self._full_step_jacobian(xp), D)[:nx]

    def input_columns(self, xp: np.ndarray) -> np.ndarray:
        """dx_k / du (nx, inputs): how an error in the measured inputs moves the step's end (eq. 10's inverse
        Jacobian at x_k^- on dg/du). Backward Euler: u_k enters the momentum rows as -B_u; trapezoidal: u_{k-1}
        and u_k each as -B_u / 2, and a sensor's error held over the step enters at both ends (its white noise
        of the same low-frequency power), so the sum of both: twice the one-end gain. A base displacement's
        B_u column is k e_body: its damper's c (u_k - u_{k-1}) / dt does not see an error held over the step."""
        nq, nx = self.nq, self.nx
        Du = np.zeros((self.n, self.plant.n_inputs))
        Du[nq:nx] = -self.plant.B_u * (0.5 if self.trapezoidal else 1.0)
        if self.trapezoidal:
            Du[nq:nx] += -self.plant.B_u * 0.5  # u_{k-1}'s
        return -np.linalg.solve(self._full_step_jacobian(xp), Du)[:nx]

    def _add_mech_columns(self, F: np.ndarray, xp: np.ndarray) -> np.ndarray:
        """F with the mechanism parameters' columns (a copy; F itself when none is estimated). With measured
        inputs (input{i}_sigma > 0) and a trend (input_trend_window > 0) the columns are taken at the inputs'
        trend, not at the samples, and at the step's end that trend reaches to first order, x_k^- - G (u -
        trend) (G one end's dx_k/du; both ends' deviations with the trapezoidal rule): a column carrying the
        force's noise correlates with the innovation that noise makes and biases the parameters (errors in
        variables). An exact input keeps its samples. The C core's mech_columns."""
        if not self.nm:
            return F
        F = F.copy()
        u_prev, u = self._step_u
        noisy = self.input_sigma > 0
        if self.input_trend is None or self.cfg.input_trend_window == 0 or not noisy.any() or u is None:
            F[: self.nx, self.im] = self.mech_columns(self.x, xp, u_prev, u)
            return F
        uk = np.atleast_1d(np.asarray(u, dtype=float))
        u0 = np.atleast_1d(np.asarray(u if u_prev is None else u_prev, dtype=float))
        level, slope = self.input_trend[:, 0], self.input_trend[:, 1]
        t0 = np.where(noisy, level, u0)
        t1 = np.where(noisy, level + slope, uk)
        dev = (uk - t1) + ((u0 - t0) if self.trapezoidal else 0.0)
        G = self.input_columns(xp) / (2.0 if self.trapezoidal else 1.0)
        dv = G[self.nq : self.nx] @ dev
        xc = xp.copy()
        xc[: self.nq] -= self.solver.hs * dv
        xc[self.nq : self.nx] -= dv
        F[: self.nx, self.im] = self.mech_columns(self.x, xc, t0, t1)
        return F

    def _track_inputs(self, u: Any) -> None:
        """The measured inputs' trend after a step with inputs u: Holt's linear tracker, critically damped for
        window W (lambda = 1 - 1/W: level gain 1 - lambda^2, slope gain (1 - lambda) / (1 + lambda)); the C
        core's track_inputs."""
        uk = np.atleast_1d(np.asarray(u, dtype=float))
        if self.input_trend is None:
            self.input_trend = np.column_stack([uk, np.zeros_like(uk)])
            return
        lam = 1.0 - 1.0 / float(self.cfg.input_trend_window)
        a, b = 1.0 - lam * lam, (1.0 - lam) / (1.0 + lam)
        t = self.input_trend
        p = t[:, 0] + t[:, 1]
        level = p + a * (uk - p)
        t[:, 1] += b * (level - t[:, 0] - t[:, 1])
        t[:, 0] = level

    def _constant_jacobians(self, dt: float) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """dg/dx_k without the contact terms, dg/dx_{k-1} without them (backward Euler: constant) and the
        contact-free F of a step dt; contact c adds its law's derivatives along b_c b_c^T (_add_contacts)."""
        p, nq, n = self.plant, self.nq, self.n
        m_dt = p.m / dt
        Jprev = -np.diag(np.r_[np.full(nq, 1.0 / dt), m_dt, np.ones(n - self.nx)])
        Jk = np.zeros((n, n))
        Jk[:nq, :nq] = np.eye(nq) / dt
        Jk[:nq, nq : self.nx] = -np.eye(nq)
        Jk[nq : self.nx, :nq] = p.K
        Jk[nq : self.nx, nq : self.nx] = np.diag(m_dt) + p.C
        Jk[self.nx :, self.nx :] = np.eye(n - self.nx)
        if self.trapezoidal:
            # The trapezoidal residual (model.py, unscaled): both ends weigh 1/2 in the q rows' mean
            # velocity and in the momentum balance's G; the start's K and C enter dg/dx_{k-1}.
            Jk[:nq, nq : self.nx] = -0.5 * np.eye(nq)
            Jk[nq : self.nx, :nq] = 0.5 * p.K
            Jk[nq : self.nx, nq : self.nx] = np.diag(m_dt) + 0.5 * p.C
            Jprev[:nq, nq : self.nx] = -0.5 * np.eye(nq)
            Jprev[nq : self.nx, :nq] = 0.5 * p.K
            Jprev[nq : self.nx, nq : self.nx] += 0.5 * p.C
        return Jk, Jprev, self._transition(Jk, Jprev)

    # ---- prediction -------------------------------------------------------------------
    @staticmethod
    def _transition(Jk: np.ndarray, Jprev: np.ndarray) -> np.ndarray:
        """Eq. (10): F = -(dg/dx_k)^-1 dg/dx_{k-1}."""
        return -np.linalg.solve(Jk, Jprev)

    def laws(self, params: np.ndarray) -> Tuple[Tuple[Direction, float, float, float], ...]:
        """(b_c, gap, n, lambda) of every contact at the parameter states `params` = x[2 nq:]: the
        estimated ones from the state, the others the mechanism's."""
        if not self.law:
            return self.solver.laws
        out = []
        for c, (d, gap, n, lam) in enumerate(self.plant.contact_laws):
            st = self.law_state[c]
            pick = lambda name, v: float(params[st[name] - self.nx]) if name in st else v  # noqa: E731
            out.append((d, pick("gap", gap), pick("n", n), pick("lambda", lam)))
        return tuple(out)

    def gammas_of(self, params: np.ndarray) -> np.ndarray:
        """The contacts' gamma at the parameter states x[2 nq:] (exp of them with gamma_log)."""
        g = np.asarray(params[: self.nc], dtype=float)
        return np.exp(g) if self.cfg.gamma_log else g

    def physical(self) -> Tuple[np.ndarray, np.ndarray]:
        """(x, P) with gamma itself in place of ln gamma (gamma_log) and each estimated mechanism parameter's
        value setting exp(theta) in place of theta: P mapped to first order by d value = value d theta (d gamma
        = gamma d ln gamma); unchanged otherwise."""
        if not self.cfg.gamma_log and not self.nm:
            return self.x, self.P
        f = np.ones(self.n)
        x = self.x.copy()
        if self.cfg.gamma_log:
            g = self.gammas_of(self.x[self.nx :])
            f[self.ig] = g
            x[self.ig] = g
        if self.nm:
            values = self.mech_values()
            f[self.im] = values
            x[self.im] = values
        return x, self.P * np.outer(f, f)

    def _solver(self, solver: StepSolver, params: np.ndarray) -> StepSolver:
        """The step solver with the contact laws at the parameter states (itself without law states)."""
        if not self.law:
            return solver
        view = copy.copy(solver)
        view.laws = self.laws(params)
        return view

    def _add_contacts(self, J: Optional[np.ndarray], J0: np.ndarray, weight: float, q: np.ndarray,
                      params: np.ndarray, v: Optional[np.ndarray]) -> Optional[np.ndarray]:
        """J (a copy of J0 when None) plus `weight` times every closed contact's tangents at (q, v) and the
        parameter states `params` (gammas, then the estimated law parameters): dG/dq, dG/dv and the
        derivatives of b_c f_c with respect to gamma_c and contact c's estimated n, lambda and gap. Returns
        None when no contact contributes and J was None."""
        nq = self.nq
        gam = self.gammas_of(params)
        for c, (b_c, gap, n, lam) in enumerate(self.laws(params)):
            g = float(gam[c])
            delta = along(b_c, q) - gap
            dd = 0.0 if v is None else along(b_c, v)
            slr = self.solver.slr_tangents(c, delta, g, n)
            if slr is not None:  # statistically linearised: expected tangents, no law parameter states
                kc, kd, dfc_dg, dfc_dn, dfc_dl = slr[0], 0.0, slr[1], 0.0, 0.0
            else:
                _, kc, kd, dfc_dg, dfc_dn, dfc_dl = law_derivatives(delta, dd, g, n, lam)
            if kc == 0.0 and kd == 0.0 and dfc_dg == 0.0:
                continue
            if J is None:
                J = J0.copy()
            bb = self.plant.B_c[c]
            J[nq : self.nx, :nq] += weight * kc * np.outer(bb, bb)
            if kd != 0.0:
                J[nq : self.nx, nq : self.nx] += weight * kd * np.outer(bb, bb)
            # d/d ln gamma = gamma d/d gamma
            J[nq : self.nx, self.nx + c] = weight * dfc_dg * (g if self.cfg.gamma_log else 1.0) * bb
            st = self.law_state[c]
            for name, d in (("n", dfc_dn), ("lambda", dfc_dl), ("gap", -kc)):
                if name in st:
                    J[nq : self.nx, st[name]] = weight * d * bb
        return J

    def transition_matrix(self, q: np.ndarray, params: Any, v: Optional[np.ndarray] = None,
                          x_prev: Optional[np.ndarray] = None, substep: bool = False) -> np.ndarray:
        """F_k at the predicted state (eq. 10 with the full Jacobians of the step) with the parameter states
        `params` (x[2 nq:]: a number for the paper's single gamma); v for Hunt-Crossley.
        Trapezoidal: x_prev = x_{k-1} (the start-of-step tangents; None: no contact there).
        substep: the map of one substep (dt / contact_substeps) instead of the step's."""
        if substep:
            if self.sub_maps is None:
                raise ValueError("no substeps: contact_substeps is 1")
            Jk0, Jprev0, F0 = self.sub_maps
        else:
            Jk0, Jprev0, F0 = self.Jk0, self.Jprev0, self.F0
        params = np.atleast_1d(np.asarray(params, dtype=float))
        if not self.trapezoidal:
            Jk = self._add_contacts(None, Jk0, 1.0, q, params, v)
            return F0 if Jk is None else self._transition(Jk, Jprev0)
        Jk = self._add_contacts(None, Jk0, 0.5, q, params, v)
        Jprev = None
        if x_prev is not None:
            nq, nx = self.nq, self.nx
            Jprev = self._add_contacts(None, Jprev0, 0.5, x_prev[:nq], x_prev[nx:], x_prev[nq:nx])
        if Jk is None and Jprev is None:
            return F0
        return self._transition(Jk0 if Jk is None else Jk, Jprev0 if Jprev is None else Jprev)

    def predict(self, u: Any) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """Newton solve of the step: returns (x_k^-, F_k, iterations, converged). The trapezoidal rule
        starts from the inputs of the last step or `correct` (self.u_prev; none yet: u), and so do the
        substeps' inputs (`contact_substeps`), which the one-step solution calls for when it or x_{k-1}
        has a contact closed."""
        x, nq, nx = self.x, self.nq, self.nx
        gammas = x[nx:]  # and the law parameters: every parameter state carries over
        solver = self._solver(self.solver, gammas)
        u_prev = u if self.u_prev is None else self.u_prev
        self._step_u = (u_prev, u)
        # A contact "on" changes the step map: closed, or with a statistically linearised nonzero tangent.
        self._on_prev = (self.sub_solver is not None or self.trapezoidal) and solver.any_on(x[:nq],
                                                                                          self.gammas_of(gammas))
        self._substepped = True
        if self.sub_solver is not None and self._on_prev:
            xp, F, iters, ok = self.substep_predict(u_prev, u)  # closed at the start: no one-step solve needed
            return xp, self._add_mech_columns(F, xp), iters, ok
        q, v, iters, ok = solver.solve(x[:nq], x[nq:nx], u, self.gammas_of(gammas), u_prev)
        if self.sub_solver is not None and solver.any_on(q, self.gammas_of(gammas)):
            xp, F, sub_iters, ok = self.substep_predict(u_prev, u)
            return xp, self._add_mech_columns(F, xp), iters + sub_iters, ok
        self._substepped = False
        xp = np.empty(self.n)
        xp[:nq] = q
        xp[nq:nx] = v
        xp[nx:] = gammas  # random walk: gamma_k^- = gamma_{k-1}^+ (eq. 19, last rows)
        return xp, self._add_mech_columns(self.transition_matrix(q, gammas, v, x), xp), iters, ok

    def substep_predict(self, u0: Any, u: Any) -> Tuple[np.ndarray, np.ndarray, int, bool]:
        """x_{k-1} -> x_k^- in contact_substeps steps of dt / contact_substeps, the inputs linear from u0 (at
        x_{k-1}) to u (at x_k^-), each solved from the last one's end: (x_k^-, F_S ... F_1, the substeps'
        iterations, all converged)."""
        if self.sub_solver is None:
            raise ValueError("no substeps: contact_substeps is 1")
        steps, nq, nx = self.cfg.contact_substeps, self.nq, self.nx
        a = np.asarray(as_inputs(u0))
        b = np.asarray(as_inputs(u))
        xa = self.x.copy()
        gammas = xa[nx:]
        sub = self._solver(self.sub_solver, gammas)
        F = self.I
        iters, ok = 0, True
        ub = a
        for j in range(1, steps + 1):
            ua, ub = ub, (b if j == steps else a + (b - a) * j / steps)
            # the first Newton update of each substep takes the Jacobian at the substep's start (the C core
            # keeps it factorised from the previous substep's map)
            J_start = sub.jacobian(xa[:nq], self.gammas_of(gammas), xa[nq:nx])
            q, v, it, conv = sub.solve(xa[:nq], xa[nq:nx], ub, self.gammas_of(gammas), ua, J_start)
            iters += it
            ok = ok and conv
            F = self.transition_matrix(q, gammas, v, xa, substep=True) @ F
            xa = np.r_[q, v, gammas]
        return xa, F, iters, ok

    def _set_penetration_std(self) -> None:
        """contact_slr_p: the penetration std sqrt(b^T P_qq b) from P_{k-1} of each contact it linearises
        (0 for the others), into self.slr_s (the switch) and the step solvers (the tangents)."""
        P = self.P
        for c, (idx, w) in enumerate(self.plant.contact_dirs):
            # sum_i w_i^2 P_ii + 2 sum_{i<j} w_i w_j P_ij over b's nonzero entries in their order (a line's
            # P_aa + P_bb - 2 P_ab)
            var = along((idx, tuple(wi * wi for wi in w)), np.diagonal(P))
            var += 2.0 * sum(w[i] * w[j] * P[idx[i], idx[j]] for i in range(len(idx)) for j in range(i + 1, len(idx)))
            self.slr_s[c] = math.sqrt(var) if var > 0.0 and self.slr_law[c] else 0.0
        slr = tuple(self.slr_s)
        self.solver.slr = slr
        if self.sub_solver is not None:
            self.sub_solver.slr = slr

    def _second_order_noise(self, xp: np.ndarray, Pm: np.ndarray) -> np.ndarray:
        """Pm plus, for every closed contact, the variance of its force's second-order part in the parameter
        states' error, 1/2 tr(H P H P) (H: the force's Hessian in [gamma or ln gamma, n, lambda, gap] as
        estimated; P: their block of Pm), as noise on the velocities it acts on, dv = -hs/m df."""
        nq, nx = self.nq, self.nx
        params = xp[nx:]
        gam = self.gammas_of(params)
        hs = self.solver.hs
        out = Pm.copy()
        q, v = xp[:nq], xp[nq:nx]
        for c, ((dofs, wc), gap, n, lam) in enumerate(self.laws(params)):
            d = along((dofs, wc), q) - gap
            r = along((dofs, wc), v)
            f = law_derivatives(d, r, float(gam[c]), n, lam)[0]
            if not (d > 0.0 and f > 0.0):
                continue
            g = float(gam[c])
            L = math.log(d)
            fl_ = g * d**n * r  # df/dlambda
            kg = 1.0 if self.cfg.gamma_log else 1.0 / g  # df/dtheta = kg f
            st = self.law_state[c]
            names = ["gamma"] + [k for k in ("n", "lambda", "gap") if k in st]
            idx = [self.ig[c]] + [st[k] for k in names[1:]]
            second = {
                ("gamma", "gamma"): f if self.cfg.gamma_log else 0.0, ("gamma", "n"): kg * f * L,
                ("gamma", "lambda"): kg * fl_, ("gamma", "gap"): -kg * n * f / d,
                ("n", "n"): f * L * L, ("n", "lambda"): fl_ * L, ("n", "gap"): -(n * f * L + f) / d,
                ("lambda", "lambda"): 0.0, ("lambda", "gap"): -n * fl_ / d, ("gap", "gap"): n * (n - 1.0) * f / d**2,
            }
            H = np.array([[second.get((p1, p2), second.get((p2, p1), 0.0)) for p2 in names] for p1 in names])
            HP = H @ Pm[np.ix_(idx, idx)]
            var = 0.5 * float(np.trace(HP @ HP))
            w = np.zeros(nq)  # dv = -hs M^-1 b df
            for i, wi in zip(dofs, wc):
                w[i] = -hs * wi / self.plant.m[i]
            out[nq:nx, nq:nx] += var * np.outer(w, w)
        return out

    # ---- correction -------------------------------------------------------------------
    def sensor_rows(self, x: np.ndarray, u: Any, u_prev: Any = None) -> Tuple[np.ndarray, np.ndarray]:
        """(h(x), H = dh/dx) of every sensor at the augmented state x with the inputs u (docs/sensors.md): the
        mechanism's linear rows (position, velocity, relative, link force at the current values; a structure's
        h_i of q or v), the acceleration's h^T M^-1 (B_u u + B_du du - K q - C v - sum_c b_c f_c) with its
        derivatives, a mechanism parameter's column per ln(value), an offset's 1. u_prev: the inputs a step
        before (a base displacement's rate du = (u - u_prev) / dt; None: u, at rest), whose ground end a link
        force reads."""
        p, nq, nx = self.plant, self.nq, self.nx
        q, v = x[:nq], x[nq:nx]
        H = np.zeros((p.n_sensors, self.n))
        H[:, :nx] = p.H
        h = p.H @ x[:nx]
        mech_state = {(kind, e): j for (kind, e, _), j in zip(self.mech, self.im)}
        uu = np.atleast_1d(np.asarray(u, dtype=float)) if p.n_inputs else np.zeros(0)
        du = np.zeros_like(uu)
        if p.has_base_inputs and u_prev is not None:
            du = (uu - np.atleast_1d(np.asarray(u_prev, dtype=float))) / self.dt
        gq, gv = p.base_ends(uu, du)  # the links' ground ends (a base input's u, du/dt; else 0)

        def diff(z: np.ndarray, a: int, b: int, g: float) -> float:
            return (z[a] if a >= 0 else g) - (z[b] if b >= 0 else g)

        contacts: Optional[List[Tuple[float, float, float, float, float, float]]] = None
        for i, (k, link) in enumerate(zip(p.sensor_kind.tolist(), p.sensor_link.tolist())):
            if k == LINK_FORCE:
                ea, eb = int(p.spring_a[link]), int(p.spring_b[link])
                if p.has_base_inputs:  # the ground end at u: k (q_a - q_b) + c (v_a - v_b) with it
                    h[i] = p.spring_k[link] * diff(q, ea, eb, gq[link]) + p.spring_c[link] * diff(v, ea, eb, gv[link])
                for kind, z, value, g in (("k", q, p.spring_k[link], gq[link]), ("c", v, p.spring_c[link], gv[link])):
                    if (kind, link) in mech_state:
                        H[i, mech_state[(kind, link)]] = value * diff(z, ea, eb, g)
            elif k == ACCELERATION:
                if contacts is None:  # once for every accelerometer
                    contacts = self._contact_terms(x)
                h[i], H[i] = self._acceleration_row(x, p.accel_dirs[i], uu, mech_state, du, (gq, gv), contacts)
        for (i, _), j in zip(self.biases, self.ib):
            h[i] += x[j]
            H[i, j] = 1.0
        return h, H

    def _contact_terms(self, x: np.ndarray) -> List[Tuple[float, float, float, float, float, float]]:
        """(delta, rate, f, df/ddelta, df/drate, df/dgamma) of every contact at x, the tangents the step's
        (statistically linearised where the step's are)."""
        q, v = x[: self.nq], x[self.nq : self.nx]
        out = []
        for c, ((d, gap, ne, lam), g) in enumerate(zip(self.laws(x[self.nx :]), self.gammas_of(x[self.nx :]).tolist())):
            delta, rate = float(along(d, q) - gap), float(along(d, v))
            fc, fd, fdd, fg = contact_law(delta, rate, g, ne, lam)
            slr = self.solver.slr_tangents(c, delta, g, ne)  # the step's statistically linearised tangents
            if slr is not None:
                fd, fdd, fg = slr[0], 0.0, slr[1]
            out.append((delta, rate, fc, fd, fdd, fg))
        return out

    def _acceleration_row(self, x: np.ndarray, d: Direction, u: np.ndarray, mech_state: Dict[Tuple[str, int], int],
                          du: np.ndarray, ends: Tuple[np.ndarray, np.ndarray], contacts: Sequence[Tuple[float, ...]]
                          ) -> Tuple[float, np.ndarray]:
        """The acceleration h^T q'' along the sensor's row h (direction d: a line's e_body) at x and its row of H
        (sensor_rows): each degree of freedom's force over its own mass (a line's body: the momentum balance
        over m_b), summed with h's weights. du, ends: the inputs' rates and the links' ground ends (a base
        displacement's); contacts: _contact_terms at x."""
        value, row = 0.0, np.zeros(self.n)
        for b, hb in zip(*d):
            a, rb = self._dof_acceleration(x, b, u, mech_state, du, ends, contacts)
            value += hb * a
            row += hb * rb
        return value, row

    def _dof_acceleration(self, x: np.ndarray, b: int, u: np.ndarray, mech_state: Dict[Tuple[str, int], int],
                          du: np.ndarray, ends: Tuple[np.ndarray, np.ndarray], contacts: Sequence[Tuple[float, ...]]
                          ) -> Tuple[float, np.ndarray]:
        """Degree of freedom b's acceleration (B_u u + B_du du - K q - C v - sum_c b_c f_c)_b / m_b at x and its
        derivatives (_acceleration_row)."""
        p, nq, nx = self.plant, self.nq, self.nx
        q, v = x[:nq], x[nq:nx]
        row = np.zeros(self.n)
        inputs = float(p.B_u[b] @ u + p.B_du[b] @ du) if p.has_base_inputs else float(p.B_u[b] @ u)
        force = inputs - float(p.K[b] @ q) - float(p.C[b] @ v)
        row[:nq] -= p.K[b]
        row[nq:nx] -= p.C[b]
        for link in range(len(p.spring_k)):
            ea, eb = int(p.spring_a[link]), int(p.spring_b[link])
            side = 1.0 if ea == b else -1.0 if eb == b else 0.0
            for kind, z, value, g in (("k", q, p.spring_k[link], ends[0][link]),
                                      ("c", v, p.spring_c[link], ends[1][link])):
                if side != 0.0 and (kind, link) in mech_state:
                    dz = (z[ea] if ea >= 0 else g) - (z[eb] if eb >= 0 else g)
                    row[mech_state[(kind, link)]] -= side * value * dz
        gammas = self.gammas_of(x[nx:]).tolist()
        for c, (((cidx, cw), _, _, lam), g, (d, dd, fc, fd, fdd, fg)) in enumerate(
                zip(self.laws(x[nx:]), gammas, contacts)):
            side = -float(p.B_c[c, b])  # -f b_c: a line's -f on body a, +f on b
            if side == 0.0:
                continue
            force += side * fc
            for e, sign in zip(cidx, cw):
                row[e] += side * sign * fd
                row[nq + e] += side * sign * fdd
            row[self.ig[c]] += side * (g * fg if self.cfg.gamma_log else fg)
            st = self.law_state[c]
            if "n" in st and fc != 0.0:
                row[st["n"]] += side * fc * math.log(d)
            if "lambda" in st and fg != 0.0:
                row[st["lambda"]] += side * g * fg / (1.0 + lam * dd) * dd
            if "gap" in st:
                row[st["gap"]] -= side * fd
        mass = float(p.m[b])
        a = force / mass
        row /= mass
        if ("m", b) in mech_state:
            row[mech_state[("m", b)]] -= a
        return a, row

    def _index(self, live: Sequence[int]) -> Index:
        """The live block: the physical states plus the live contacts' parameter states (a slice when
        contiguous)."""
        idx = list(range(self.nx)) + sorted(g for c in live for g in self.pstates[c]) + self.im + self.ib
        return slice(0, len(idx)) if idx == list(range(len(idx))) else idx

    def _correct(
        self, xp: np.ndarray, P: np.ndarray, y: np.ndarray, L: Index, frozen: Sequence[int], schmidt: bool,
        violated: Sequence[Tuple[int, float]] = (), held: Sequence[int] = (),
    ) -> Tuple[np.ndarray, np.ndarray, bool]:
        """Eqs. (13)-(15) on the block L; the parameter states of the contacts `frozen` keep value and
        variance (eqs. 25-27), their cross-covariance with L Schmidt-updated when `schmidt`. `violated`
        (state, bound) pairs add the perfect measurements x_state = bound of eqs. (28)-(30); `held` states
        (outside L) are held as the frozen contacts' are. Returns (x, P, used_pinv)."""
        if self._h is not None:
            return self._correct_rows(xp, P, y, L, frozen, schmidt, violated, held)
        HL = self._Hk[:, L]
        R = self.R
        resid = y - (self._Hk @ xp if self._h is None else self._h)
        PLL = _block(P, L, L)
        used_pinv = False
        if violated:
            ns, nv = len(y), len(violated)
            lidx = list(range(self.n))[L] if isinstance(L, slice) else L
            D = np.zeros((nv, len(lidx)))
            for i, (g, _) in enumerate(violated):
                D[i, lidx.index(g)] = 1.0
            HL = np.vstack([HL, D])
            Rc = np.zeros((ns + nv, ns + nv))
            Rc[:ns, :ns] = R
            R = Rc
            resid = np.r_[resid, [bound - xp[g] for g, bound in violated]]
            # S^c has zero noise entries, so it is singular when a P_gg (or its posterior value)
            # is 0 and badly scaled always (metres^2 next to gamma^2): equilibrate with its
            # diagonal, fall back to the pseudo-inverse (least-squares gain) if still singular.
            PHt = PLL @ HL.T
            S = HL @ PHt + R
            d = np.sqrt(np.abs(np.diag(S)))
            d[d == 0.0] = 1.0
            Sn = S / np.outer(d, d)
            try:
                if np.linalg.cond(Sn) > 1e14:
                    raise np.linalg.LinAlgError("ill-conditioned")
                G = (np.linalg.solve(Sn, (PHt / d).T) / d[:, None]).T
            except np.linalg.LinAlgError:
                G = (PHt / d) @ np.linalg.pinv(Sn, rcond=1e-14) / d
                used_pinv = True
        else:
            PHt = PLL @ HL.T
            S = HL @ PHt + R
            G = np.linalg.solve(S, PHt.T).T  # eq. (13) (G_L of eq. 26), solved rather than inverted
        x = xp.copy()
        x[L] += G @ resid
        IKH = (self.I if isinstance(L, slice) and L.stop == self.n else np.eye(PLL.shape[0])) - G @ HL
        Pn = P.copy()
        _set_block(Pn, L, L, joseph(IKH, PLL, G, R) if self.cfg.joseph else IKH @ PLL)  # eq. (15) / (27)
        if schmidt:
            for g in [g for c in frozen for g in self.pstates[c]] + list(held):
                col = IKH @ P[L, g]  # Schmidt update of the cross-covariance
                Pn[L, g] = col
                Pn[g, L] = col
        if violated and not used_pinv:
            _pin_to_bounds(x, Pn, violated)
        return x, Pn, used_pinv

    def _correct_rows(
        self, xp: np.ndarray, P: np.ndarray, y: np.ndarray, L: Index, frozen: Sequence[int], schmidt: bool,
        violated: Sequence[Tuple[int, float]], held: Sequence[int],
    ) -> Tuple[np.ndarray, np.ndarray, bool]:
        """_correct for sensors whose rows of H reach states outside L (an accelerometer's gamma column): the
        Schmidt-Kalman ("consider") correction, S = H P H^T + R over every state, the gain on L only,
        P_LL - G (H P)_L (Joseph: symmetric), the held states' cross-covariance P_Lg - G (H P)_g."""
        lidx = list(range(self.n))[L] if isinstance(L, slice) else list(L)
        H, R, resid = self._Hk, self.R, y - self._h
        if violated:
            D = np.zeros((len(violated), self.n))
            for i, (g, _) in enumerate(violated):
                D[i, g] = 1.0
            H = np.vstack([H, D])
            R = np.pad(R, ((0, len(violated)), (0, len(violated))))
            resid = np.r_[resid, [bound - xp[g] for g, bound in violated]]
        HP = H @ P
        S = HP @ H.T + R
        S = 0.5 * (S + S.T)
        d = np.sqrt(np.abs(np.diag(S)))
        d[d == 0.0] = 1.0
        Sn = S / np.outer(d, d)
        used_pinv = False
        try:
            if violated and np.linalg.cond(Sn) > 1e14:
                raise np.linalg.LinAlgError("ill-conditioned")
            G = (np.linalg.solve(Sn, HP[:, lidx] / d[:, None]) / d[:, None]).T
        except np.linalg.LinAlgError:
            G = (HP[:, lidx] / d[:, None]).T @ np.linalg.pinv(Sn, rcond=1e-14) / d
            used_pinv = True
        x = xp.copy()
        x[lidx] += G @ resid
        GHP = G @ HP
        Pn = P.copy()
        block = GHP[:, lidx]
        new = P[np.ix_(lidx, lidx)] - (block + block.T - G @ S @ G.T if self.cfg.joseph else block)
        Pn[np.ix_(lidx, lidx)] = new
        if schmidt:
            for g in [g for c in frozen for g in self.pstates[c]] + list(held):
                col = P[lidx, g] - GHP[:, g]
                Pn[lidx, g] = col
                Pn[g, lidx] = col
        if violated and not used_pinv:
            _pin_to_bounds(x, Pn, violated)
        return x, Pn, used_pinv

    def _nis(self, xp: np.ndarray, P: np.ndarray, y: np.ndarray) -> float:
        """Normalised innovation squared e^T S^-1 e of the full correction."""
        e = y - (self._Hk @ xp if self._h is None else self._h)
        S = self._Hk @ P @ self._Hk.T + self.R
        return float(e @ np.linalg.solve(S, e))

    def _monitor(self, nis: float) -> int:
        """The model-mismatch monitor after a correction whose NIS is `nis` (EstimatorConfig): its flag."""
        cfg, w = self.cfg, float(self.cfg.mismatch_window)
        self.nis_mean += (min(nis / self.H.shape[0], 100.0) - self.nis_mean) / w
        if cfg.mismatch_adapt and (self.q_scale > 1.0 or self.nis_mean > cfg.mismatch_ratio):
            self.q_scale = min(max(self.q_scale * (1.0 + (self.nis_mean - 1.0) / w), 1.0), 1e12)
            self.Qx[np.diag_indices(self.nx)] = self.Qx_settings * self.q_scale  # a view of Q
        return fl.MODEL_MISMATCH if self.nis_mean > cfg.mismatch_ratio or self.q_scale > 1.0 else 0

    # ---- one step -----------------------------------------------------------------------
    def correct(self, u: Any, y: np.ndarray) -> int:
        """The measurements y at the estimate's own time, without a time update (a recording's sample at
        t0, where the initial estimate is given), as the C core's caekf_correct: the correction and
        constraint of `step` with P^- = P; u is remembered as the inputs at t0. Returns the flags."""
        return self.step(u, y, predict=False)[0]

    def step(self, u: Any, y: np.ndarray, predict: bool = True) -> Tuple[int, int]:
        """Advance one sample with input(s) u_k and measurement y_k; returns (flags, Newton iters).
        predict=False: `correct`."""
        cfg = self.cfg
        status = 0
        slr_p = cfg.contact_slr_p
        if self.nm:
            self._set_mechanism(self.x)  # the model at the mechanism parameters' estimates x_{k-1}
        if slr_p > 0:
            self._set_penetration_std()
        if predict:
            xp, F, iters, ok = self.predict(u)
        else:
            xp, F, iters, ok = self.x.copy(), self.I, 0, True
        if not ok:
            status |= fl.NEWTON_NOT_CONVERGED
        deltas = self._solver(self.solver, xp[self.nx :]).penetrations(xp[: self.nq])
        # eq. (21); statistically linearised: on while P(delta > 0) = erfc(-delta / (s sqrt 2)) / 2 > contact_slr_p
        closed = [0.5 * math.erfc(-d / (s * math.sqrt(2.0))) > slr_p if slr_p > 0 and s > 0 else d > 0.0
                  for d, s in zip(deltas, self.slr_s)]
        if predict and slr_p > 0 and not self._substepped and not any(closed) \
                and not (self.trapezoidal and self._on_prev):
            F = self._add_mech_columns(self.F0, xp)  # no contact active at either end: the contact-free F
        if any(closed):
            status |= fl.CONTACT_ACTIVE
        live = [c for c in range(self.nc) if cfg.mode == CANONICAL or closed[c]]
        frozen = [c for c in range(self.nc) if c not in live]
        if frozen:
            status |= fl.GAMMA_FROZEN
        L = self._index(live)
        P = self.P
        consistent = cfg.switch_variant == VARIANT_CONSISTENT
        if not predict:
            Pm = P.copy()  # no time update: P^- = P
        elif not frozen:
            Pm = F @ P @ F.T + self.Q  # eq. (12)
        elif not _block(F, L, [g for c in frozen for g in self.pstates[c]]).any():
            # F_Lg = 0 for a frozen gamma (its contact is open: df_c/dgamma = 0), eq. (23).
            FLL = _block(F, L, L)
            Pm = P.copy()
            _set_block(Pm, L, L, FLL @ _block(P, L, L) @ FLL.T + _block(self.Q, L, L))  # eq. (24)
            if consistent:
                for g in (g for c in frozen for g in self.pstates[c]):
                    col = FLL @ P[L, g]
                    Pm[L, g] = col
                    Pm[g, L] = col
        else:
            # The trapezoidal step's start or a substep: a contact closed at x_{k-1} (or within the step) and
            # open at x_k^- still moved the states through its gamma (F_Lg != 0) although its gamma is
            # frozen: the live rows of F in full.
            FL = _block(F, L, slice(0, self.n))
            Pm = P.copy()
            _set_block(Pm, L, L, FL @ P @ FL.T + _block(self.Q, L, L))
            if consistent:
                for g in (g for c in frozen for g in self.pstates[c]):
                    col = FL @ P[:, g]
                    Pm[L, g] = col
                    Pm[g, L] = col
            # Q_gamma = 0 (eq. 21): the frozen P_gg and gamma stay as they are.
        if predict and self.input_sigma.size and np.any(self.input_sigma > 0):
            # the measured inputs' noise through the implicit step: Q_u = G diag(sigma_u^2) G^T on the bodies
            G = self.input_columns(xp)
            Pm[: self.nx, : self.nx] += (G * self.input_sigma**2) @ G.T
        if predict and cfg.law_second_order and (self.law or cfg.gamma_log):
            Pm = self._second_order_noise(xp, Pm)
        if self.rows:  # the sensors' rows of H at x- (docs/sensors.md)
            self._h, self._Hk = self.sensor_rows(xp, u, self._step_u[0] if predict else u)
        if (live or self.nm or self.nb) and math.isfinite(cfg.gate_nis) and self._nis(xp, Pm, y) > cfg.gate_nis:
            # every live parameter (the mechanism's and the offsets too) held this step, as a consider state
            status |= fl.GAMMA_GATED
            x, Pp, _ = self._correct(xp, Pm, y, slice(0, self.nx), list(range(self.nc)), True,
                                     held=self.im + self.ib)
        else:
            x, Pp, _ = self._correct(xp, Pm, y, L, frozen, consistent)
            # Eqs. (28)-(30) over the active set: in state order, each live parameter outside a bound
            # joins the perfect measurements and the correction is redone, pass after pass.
            live_states = {g for c in live for g in self.pstates[c]}
            violated: List[Tuple[int, float]] = []
            for _ in range(len(self.bounds)):
                added = False
                for g, lo, hi in self.bounds:
                    if g not in live_states or any(g == v for v, _ in violated):
                        continue
                    bound = lo if x[g] < lo else hi if hi is not None and x[g] > hi else None
                    if bound is None:
                        continue
                    violated.append((g, bound))
                    added = True
                    x, Pp, used_pinv = self._correct(xp, Pm, y, L, frozen, consistent, violated)
                    status |= fl.CONSTRAINT_APPLIED
                    if used_pinv:
                        status |= fl.SINGULAR_INNOVATION
                if not added:
                    break
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(Pp))):
            status |= fl.NON_FINITE
        if cfg.mismatch_window > 0:
            status |= self._monitor(self._nis(xp, Pm, y))
        self.x, self.P = x, Pp
        self.u_prev = u
        if predict and self.nm and cfg.input_trend_window > 0 and bool((self.input_sigma > 0).any()):
            self._track_inputs(u)
        return status, iters


@dataclass
class EstimateResult:
    """Per-step estimator output for samples k = 1..N."""

    t: np.ndarray
    x: np.ndarray  # (N, 2 nq + nc); the paper: (N, 9)
    p_norm: np.ndarray  # 2-norm of P^+, physical units
    p_gg: np.ndarray  # P^+ of gamma_1 (the paper's gamma)
    flags: np.ndarray  # int
    newton_iters: np.ndarray  # int
    P: Optional[np.ndarray] = None  # (N, n, n) when kept
    wall_time: float = float("nan")
    n_contacts: int = 1
    p_ggs: Optional[np.ndarray] = None  # (N, nc): P^+ of every gamma_c
    n_law: int = 0  # estimated law parameters: the last n_law states
    law_names: Tuple[str, ...] = ()  # their CSV columns (mechanism.law_column_names)
    n_mech: int = 0  # estimated mechanism parameters: the last n_mech states (their values), after the law's
    mech_names: Tuple[str, ...] = ()  # their keys (mechanism.mech_column_names: m1, spring2_k, ...)

    @property
    def gammas(self) -> np.ndarray:
        """(N, nc): gamma_c of every contact, the nc states before the law parameters."""
        end = self.x.shape[1] - self.n_law - self.n_mech
        return self.x[:, end - self.n_contacts : end]

    @property
    def gamma(self) -> np.ndarray:
        """gamma of contact 1 (the paper's gamma)."""
        return self.gammas[:, 0]

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
    mech: Optional[Mechanism] = None,
) -> EstimateResult:
    """Run the filter over measurements y (N, ns) with inputs u (N,) or (N, ni) sampled at t_k = k dt. The time
    convention of the C engine (binding.Estimator.run, docs/discretisation.md): q0, v0 are the state at t = 0, so
    a first row at t = 0 (within dt/2) is corrected without a time update (`correct`)."""
    ekf = AugmentedEKF(sc, cfg, mech)
    n = len(t)
    xs = np.empty((n, ekf.n))
    Ps = np.empty((n, ekf.n, ekf.n))
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
    at_t0 = n > 0 and abs(float(t[0])) <= 0.5 * sc.dt
    t0 = time.perf_counter()
    with np.errstate(all="ignore"):  # a diverging filter is an outcome we record, not a crash
        for k in rng:
            fls[k], its[k] = ekf.step(u_list[k], y[k], predict=not (at_t0 and k == 0))
            xs[k], Ps[k] = ekf.physical()
    wall = time.perf_counter() - t0
    return EstimateResult(
        t=np.asarray(t, dtype=float),
        x=xs,
        p_norm=spectral_norms(Ps),
        p_gg=Ps[:, ekf.nx, ekf.nx].copy() if ekf.nc else np.zeros(n),
        flags=fls,
        newton_iters=its,
        P=Ps if keep_P else None,
        wall_time=wall,
        n_contacts=ekf.nc,
        p_ggs=Ps[:, ekf.ig, ekf.ig].copy(),
        n_law=len(ekf.law),
        law_names=law_column_names(ekf.law),
        n_mech=ekf.nm,
        mech_names=mech_column_names(ekf.mech),
    )
