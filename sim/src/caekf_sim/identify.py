"""Offline identification of a mechanism from its recordings: the prediction-error / maximum-likelihood
estimate of chosen scenario values, with Fisher-information and profile-likelihood intervals.

The predictor is the shipped C filter run through the binding (caekf_sim.binding.run, the loop in C). For
values theta of the chosen keys the filter runs over every record as a plain state estimator of a
mechanism whose parameters are theta: every contact's law is held fixed (gamma through a P0 of 1e-9 of
its value and no random walk, n, lambda and the gap as model values, not states; so is every mechanism
parameter the scenario declares uncertain, its `<key>_sigma` set to 0), the constraint and the
model-mismatch adaptation are off (both would make the predictor depend on its own innovations). Its
innovations nu_k, with covariance S_k, give the prediction-error decomposition of the likelihood:

    -log L(theta) = 1/2 sum_k [ log det S_k + nu_k' S_k^-1 nu_k ] + const      (tune.innovation_nll)

`identify` minimises it over theta within bounds from several starts (scipy's Nelder-Mead, bounded;
positive values searched as logarithms), then

  * Fisher information: the Hessian of -log L at the optimum by central differences, with each step the
    parameter's own one-sigma scale (found in two passes), so the objective's small-scale roughness (a
    contact's events move by a step as theta changes) does not enter; covariance C = H^-1. When the
    innovations are larger than the filter says (mean NIS / sensors = c > 1, the noise settings not
    identified), C is scaled by c (the quasi-likelihood correction);
  * the profile likelihood: -log L minimised over the others with one parameter held, at both ends of the
    Fisher interval; where the rise there is not 1.92 c within 20 % in sqrt (the intervals disagree) the
    profile's own end (rise 1.92 c, chi-square(1) at 95 %) is found by bracketing and scipy's brentq;
  * a polish: Nelder-Mead again from the best point in coordinates whitened by that Hessian (a
    preconditioned restart, so a correlated valley such as gamma and n does not stall the search).

A parameter is "not pinned down" when its 95 % interval reaches a bound of the search, or its Hessian
curvature is not positive (the data holds no information on it, or only together with another one).

Evaluations are independent: each start's search, the Hessian's points and each profile side run as
tasks on a local process pool (workers) or a Dask cluster (scheduler / client), as campaigns do.
"""
from __future__ import annotations

import math
import os
import re
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .measurements import Measurements
from .scenario import Scenario
from .schema import canonical
from .settings_adapter import TUNABLE_NOISE

CHI2_95 = 3.841458820694124  # chi-square(1) 95 % quantile: a profile interval is -log L rising by CHI2_95 / 2
Z95 = 1.959963984540054
FIXED_REL = 1e-9  # P0 of a gamma held fixed in the predictor, relative to its value
AGREE = 0.2  # Fisher and profile agree when sqrt(rise / threshold) at the Fisher end is within 20 % of 1
FAIL = 1e300  # the objective of settings the C validation refuses (outside the feasible set)
LAW = ("gamma", "n", "lambda", "gap")


class IdentifyError(ValueError):
    """A request identify cannot serve; one line naming the key."""


# --- the unknowns ------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Unknown:
    """One identified scenario value."""

    key: str  # the scenario key as identified: contact1_gamma, spring1_k, sigma_qx_v, ...
    kind: str  # "law", "mechanism" or "noise"
    start: float  # SI
    lower: float  # bounds of the search, SI
    upper: float
    log: bool  # searched as its logarithm (positive values)
    out_key: str  # where the written scenario holds the estimate (contact1_gamma -> contact1_gamma0)
    sigma_key: Optional[str]  # where it holds the interval as a P0 standard deviation (None: nowhere yet)

    def phi(self, v: float) -> float:
        return math.log(v) if self.log else v

    def inv(self, p: float) -> float:
        return math.exp(p) if self.log else p


_LAW_RE = re.compile(r"^contact(\d+)_(gamma|n|lambda|gap)$")
_MECH_RE = re.compile(r"^(m(\d+)|spring(\d+)_(k|c))$")
_MECH_SIGMA_RE = re.compile(r"^(m\d+|spring\d+_[kc])_sigma$")  # an augmented mechanism parameter's P0
MECH_FACTOR = 1.5  # default bounds of a mechanism parameter: start / 1.5 .. start * 1.5
LAW_FACTOR = 3.0  # of gamma and lambda: start / 3 .. start * 3
NOISE_DECADES = 3.0  # of a noise standard deviation: three decades either way
GAP_SPAN = 2e-6  # of a gap: start +- 2 um (the gap must be known to within the penetration)


def _value(sc: Scenario, key: str) -> float:
    values = sc.values()
    if key not in values:
        raise IdentifyError(f"{key}: not in use in this scenario's mechanism")
    return float(values[key])


def _law_start(sc: Scenario, c: int, name: str) -> float:
    """The value the filter starts from: gamma0, X0 where the scenario estimates X online, else the model's X."""
    if name == "gamma":
        return _value(sc, f"contact{c}_gamma0")
    if int(_value(sc, f"contact{c}_estimate_{name}")):
        return _value(sc, f"contact{c}_{name}0")
    return _value(sc, f"contact{c}_{name}")


def unknowns(sc: Scenario, params: Sequence[str], bounds: Optional[Mapping[str, Tuple[float, float]]] = None
             ) -> List[Unknown]:
    """The chosen keys (scenario keys or their aliases: contact{i}_gamma/_n/_lambda/_gap, m{i},
    spring{i}_k/_c, the noise standard deviations) with start values and bounds; a one-line IdentifyError
    naming the key that cannot be identified."""
    if not params:
        raise IdentifyError("--params: no parameter chosen (e.g. --params contact1_gamma,contact1_n)")
    keys = list(sc.values())
    out: List[Unknown] = []
    seen: Dict[str, str] = {}
    bounds = dict(bounds or {})
    given_bounds = {}
    for k, b in bounds.items():
        given_bounds[canonical(k.strip())] = (k, b)
    for raw in params:
        name = raw.strip()
        try:
            key = canonical(name)
        except (KeyError, ValueError):
            key = name
        if key in seen:
            raise IdentifyError(f"{name}: chosen twice (as {seen[key]})")
        seen[key] = name
        law, mech = _LAW_RE.match(key), _MECH_RE.match(key)
        if law:
            c, what = int(law.group(1)), law.group(2)
            if not 1 <= c <= int(sc.contacts):
                raise IdentifyError(f"{name}: the scenario has contact(s) 1..{int(sc.contacts)}")
            start = _law_start(sc, c, what)
            kind, out_key = "law", f"contact{c}_{what}0"
            sigma_key: Optional[str] = f"contact{c}_sigma_{what}0"
            if what == "gamma":
                lo, hi, log = start / LAW_FACTOR, start * LAW_FACTOR, True
            elif what == "n":
                n_min = _value(sc, f"contact{c}_n_min")
                n_max = _value(sc, f"contact{c}_n_max")
                lo, hi, log = max(1.0, n_min), (n_max if n_max > 0 else 3.0), True
            elif what == "lambda":
                lo, hi, log = start / LAW_FACTOR, start * LAW_FACTOR, True
            else:
                lo, hi, log = max(0.0, start - GAP_SPAN), start + GAP_SPAN, False
        elif mech:
            if key not in keys:
                raise IdentifyError(f"{name}: not in use in this scenario's mechanism "
                                    f"(bodies = {int(sc.bodies)}, springs = {int(sc.springs)})")
            start = _value(sc, key)
            kind, out_key = "mechanism", key
            sigma_key = f"{key}_sigma" if f"{key}_sigma" in keys else None  # augmented mechanism parameters
            lo, hi, log = start / MECH_FACTOR, start * MECH_FACTOR, True
        elif key in TUNABLE_NOISE:
            if key not in keys:
                raise IdentifyError(f"{name}: not in use in this scenario's mechanism")
            start = _value(sc, key)
            kind, out_key, sigma_key = "noise", key, None
            lo, hi, log = start * 10 ** -NOISE_DECADES, start * 10 ** NOISE_DECADES, True
        elif key in keys or name in keys:
            raise IdentifyError(f"{name}: cannot be identified (identify takes contact{{i}}_gamma, _n, _lambda, "
                                f"_gap, m{{i}}, spring{{i}}_k, spring{{i}}_c and the noise settings "
                                f"{', '.join(TUNABLE_NOISE)})")
        else:
            raise IdentifyError(f"{name}: not a scenario key")
        user_bounds = key in given_bounds
        if user_bounds:
            lo, hi = given_bounds.pop(key)[1]
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise IdentifyError(f"{name}: bounds {lo:g}:{hi:g} must be finite with low < high")
            if not lo <= start <= hi:  # a start outside the given bounds: their middle (log: geometric)
                start = math.sqrt(lo * hi) if log and lo > 0 else (lo + hi) / 2
        if not math.isfinite(start):
            raise IdentifyError(f"{name}: its start value is not set in the scenario")
        if log and lo <= 0:
            if start > 0 and lo == 0:
                lo = start / 1e3
            else:
                raise IdentifyError(f"{name}: start value {start:g} and bounds {lo:g}:{hi:g} must be > 0 "
                                    "(searched as a logarithm; give --bounds KEY=LOW:HIGH with LOW > 0)")
        if not lo <= start <= hi:
            raise IdentifyError(f"{name}: start value {start:g} is outside its bounds {lo:g}:{hi:g}")
        out.append(Unknown(key, kind, start, lo, hi, log, out_key, sigma_key))
    if given_bounds:
        k = next(iter(given_bounds.values()))[0]
        raise IdentifyError(f"--bounds {k}: not one of --params")
    return out


# --- the problem: the objective as a picklable function of normalised coordinates ------------------

@dataclass
class Problem:
    """Everything an evaluation needs (picklable: sent once to each worker)."""

    scenario: Scenario
    records: List[Measurements]
    unknowns: List[Unknown]
    experiment: Optional[str] = None
    precision: str = "double"
    burn_in: int = 0
    overrides: Dict[str, Any] = field(default_factory=dict)

    # z: normalised coordinates, z = (phi(v) - phi(start)) / w, w = half the width of the bounds in phi
    @property
    def width(self) -> np.ndarray:
        return np.array([(u.phi(u.upper) - u.phi(u.lower)) / 2 for u in self.unknowns])

    @property
    def z_bounds(self) -> List[Tuple[float, float]]:
        return [((u.phi(u.lower) - u.phi(u.start)) / w, (u.phi(u.upper) - u.phi(u.start)) / w)
                for u, w in zip(self.unknowns, self.width)]

    def values(self, z: Any) -> Dict[str, float]:
        return {u.key: u.inv(u.phi(u.start) + w * zi) for u, w, zi in zip(self.unknowns, self.width, z)}

    def z_of(self, values: Mapping[str, float]) -> np.ndarray:
        return np.array([(u.phi(values[u.key]) - u.phi(u.start)) / w for u, w in zip(self.unknowns, self.width)])

    def clip(self, z: Any) -> np.ndarray:
        lo, hi = np.array(self.z_bounds).T
        return np.clip(np.asarray(z, dtype=float), lo, hi)

    def predictor(self, values: Mapping[str, float]) -> Scenario:
        """The scenario the filter runs as the predictor at `values`: every contact's law fixed (module
        docstring), the chosen values set."""
        sc = self.scenario
        ch: Dict[str, float] = {}
        for c in range(1, int(sc.contacts) + 1):
            g = float(values.get(f"contact{c}_gamma", _law_start(sc, c, "gamma")))
            ch[f"contact{c}_gamma0"] = g
            ch[f"contact{c}_sigma_gamma0"] = FIXED_REL * g
            ch[f"contact{c}_sigma_q_gamma"] = 0.0
            for name in LAW[1:]:
                ch[f"contact{c}_{name}"] = float(values.get(f"contact{c}_{name}", _law_start(sc, c, name)))
                ch[f"contact{c}_estimate_{name}"] = 0
        for k in sc.values():  # mechanism parameters the scenario declares uncertain: held too
            if _MECH_SIGMA_RE.match(k):
                ch[k] = 0.0
        for k, v in values.items():
            if not _LAW_RE.match(k):
                ch[k] = float(v)
        return sc.replace(**ch)

    def run(self, values: Mapping[str, float]) -> List[Any]:
        from .tune import run_records

        over = {"constraint_enabled": 0, "mismatch_adapt": 0, **self.overrides}
        return run_records(self.predictor(values), self.records, self.experiment, self.precision, **over)

    def nll(self, z: Any) -> float:
        """-log L at normalised coordinates z (FAIL where the settings are refused or nothing is finite)."""
        from .tune import innovation_nll

        try:
            res = self.run(self.values(self.clip(z)))
        except ValueError:  # settings refused: outside the feasible set
            return FAIL
        f, steps = innovation_nll(res, self.burn_in)
        return f if steps and math.isfinite(f) else FAIL

    def nis_mean(self, z: Any) -> Tuple[float, int]:
        """Mean NIS per sensor of the predictor at z and the number of corrections (burn-in left out)."""
        from .tune import consistency

        c = consistency(self.run(self.values(self.clip(z))), None, self.burn_in)
        return c.nis_mean / c.dof, c.steps


# --- tasks (module level: they run in pools and on Dask) --------------------------------------------

def _task_nll(p: Problem, z: Any) -> float:
    return p.nll(z)


def _task_fit(p: Problem, arg: Tuple[np.ndarray, float, int]) -> Tuple[np.ndarray, float, int]:
    """A bounded Nelder-Mead search from z0 with a simplex of size `size`: (z, -log L, evaluations)."""
    from scipy.optimize import minimize

    z0, size, max_evals = arg
    n = len(z0)
    z0 = p.clip(z0)
    lo, hi = np.array(p.z_bounds).T
    simplex = [z0]
    for i in range(n):  # step inwards where a bound is nearer than `size`
        e = np.zeros(n)
        e[i] = size if z0[i] + size <= hi[i] else -size
        simplex.append(np.clip(z0 + e, lo, hi))
    opt = minimize(p.nll, z0, method="Nelder-Mead", bounds=list(zip(lo, hi)),
                   options={"initial_simplex": np.array(simplex), "xatol": 1e-4, "fatol": 1e-3,
                            "maxfev": max_evals})
    return np.asarray(opt.x, dtype=float), float(opt.fun), int(opt.nfev)


def _whitened_fit(p: Problem, z0: np.ndarray, L: np.ndarray, idx: Sequence[int], base: np.ndarray,
                  max_evals: int) -> Tuple[np.ndarray, float, int]:
    """Nelder-Mead over the coordinates `idx` of z, as z[idx] = z0[idx] + L w (w whitened: one unit is one
    sigma), the others at `base`; the simplex spans one sigma along each column of L."""
    from scipy.optimize import minimize

    idx = list(idx)

    def full(w: np.ndarray) -> np.ndarray:
        z = np.array(base, dtype=float)
        z[idx] = z0[idx] + L @ w
        return p.clip(z)

    def f(w: np.ndarray) -> float:
        return p.nll(full(w))

    m = len(idx)
    simplex = np.vstack([np.zeros(m), np.eye(m)])
    opt = minimize(f, np.zeros(m), method="Nelder-Mead",
                   options={"initial_simplex": simplex, "xatol": 1e-2, "fatol": 1e-3, "maxfev": max_evals})
    return full(np.asarray(opt.x)), float(opt.fun), int(opt.nfev)


def _task_polish(p: Problem, arg: Tuple[np.ndarray, np.ndarray, int]) -> Tuple[np.ndarray, float, int]:
    z0, L, max_evals = arg
    return _whitened_fit(p, z0, L, range(len(z0)), z0, max_evals)


@dataclass
class ProfileSide:
    """One side of one parameter's profile: the rise of -log L at the Fisher end, and the profile's end."""

    index: int
    side: int  # -1 low, +1 high
    fisher_d: float  # distance (z) of the Fisher end from the optimum; inf: no finite Fisher interval
    fisher_rise: float  # profile -log L at the Fisher end minus the optimum's (nan when not evaluated)
    profile_d: Optional[float]  # distance of the profile's end (None: where Fisher and profile agree)
    at_bound: bool  # the profile does not rise to the threshold within the bounds
    points: List[Tuple[float, float]]  # (z_i, rise) evaluated along the way
    evaluations: int


def _conditional(H: np.ndarray, i: int) -> Tuple[np.ndarray, np.ndarray, List[int]]:
    """For parameter i held: the others' shift per unit of z_i (the quadratic model's conditional optimum)
    and a whitening matrix of their conditional covariance."""
    n = len(H)
    others = [j for j in range(n) if j != i]
    if not others:
        return np.zeros(0), np.zeros((0, 0)), others
    Hoo = H[np.ix_(others, others)]
    w, V = np.linalg.eigh(Hoo)
    w = np.where(w > 1e-12 * max(1.0, float(np.max(np.abs(w)))), w, np.nan)
    inv_sqrt = np.where(np.isfinite(w), 1 / np.sqrt(np.abs(w)), 1.0)  # flat directions: one unit of z
    L = V * inv_sqrt
    Hinv = (V * np.where(np.isfinite(w), 1 / np.where(np.isfinite(w), w, 1.0), 0.0)) @ V.T
    shift = -Hinv @ H[others, i]
    return shift, L, others


def _profile_at(p: Problem, z_opt: np.ndarray, H: np.ndarray, i: int, zi: float, max_evals: int
                ) -> Tuple[float, int]:
    """The profile -log L at z_i = zi: minimised over the others (whitened Nelder-Mead from the quadratic
    model's conditional optimum); the evaluations used."""
    shift, L, others = _conditional(H, i)
    z = np.array(z_opt, dtype=float)
    z[i] = zi
    if not others:
        return p.nll(z), 1
    z[others] = z_opt[others] + shift * (zi - z_opt[i])
    z = p.clip(z)
    _, f, nfev = _whitened_fit(p, z, L, others, z, max_evals)
    return f, nfev


def _task_profile_side(p: Problem, arg: Tuple[np.ndarray, float, np.ndarray, int, int, float, float, int]
                       ) -> ProfileSide:
    """Check one side of parameter i's Fisher interval against its profile; find the profile's end where
    they disagree (bracket, then scipy's brentq)."""
    from scipy.optimize import brentq

    z_opt, f_opt, H, i, side, d_fisher, threshold, max_evals = arg
    lo, hi = p.z_bounds[i]
    d_max = (hi - z_opt[i]) if side > 0 else (z_opt[i] - lo)
    points: List[Tuple[float, float]] = []
    evals = 0

    def rise(d: float) -> float:
        nonlocal evals
        f, k = _profile_at(p, z_opt, H, i, z_opt[i] + side * d, max_evals)
        evals += k
        r = f - f_opt
        points.append((z_opt[i] + side * d, r))
        return r

    if d_max <= 0:
        return ProfileSide(i, side, d_fisher, float("nan"), 0.0, True, points, evals)
    d0 = min(d_fisher, d_max) if math.isfinite(d_fisher) else d_max
    r0 = rise(d0)
    if math.isfinite(d_fisher) and d_fisher <= d_max and r0 > 0 and abs(math.sqrt(r0 / threshold) - 1) <= AGREE:
        return ProfileSide(i, side, d_fisher, r0, None, False, points, evals)
    # bracket the profile's end: [a, b] with rise(a) < threshold <= rise(b)
    a, ra, b, rb = 0.0, 0.0, d0, r0
    for _ in range(8):
        if rb >= threshold or b >= d_max:
            break
        a, ra = b, rb
        b = min(d_max, b * (2.0 if rb <= 0 else min(4.0, max(1.25, math.sqrt(threshold / rb)))))
        rb = rise(b)
    if rb < threshold:
        return ProfileSide(i, side, d_fisher, r0 if math.isfinite(d_fisher) else float("nan"), b, True, points,
                           evals)
    if ra >= threshold:  # not expected (rise(0) = 0); keep the bracket honest
        a = 0.0
    d_end = brentq(lambda d: rise(d) - threshold, a, b, xtol=max(1e-9, 0.02 * b), maxiter=12)
    return ProfileSide(i, side, d_fisher, r0 if math.isfinite(d_fisher) else float("nan"), float(d_end), False,
                       points, evals)


def _task_profile_point(p: Problem, arg: Tuple[np.ndarray, np.ndarray, int, float, int]) -> float:
    z_opt, H, i, zi, max_evals = arg
    return _profile_at(p, z_opt, H, i, zi, max_evals)[0]


# --- parallel evaluation -----------------------------------------------------------------------------

_WORKER_PROBLEM: Optional[Problem] = None


def _init_worker(p: Problem) -> None:
    global _WORKER_PROBLEM
    _WORKER_PROBLEM = p


def _pool_call(fn: Callable[[Problem, Any], Any], arg: Any) -> Any:
    assert _WORKER_PROBLEM is not None
    return fn(_WORKER_PROBLEM, arg)


def _dask_call(p: Problem, fn: Callable[[Problem, Any], Any], arg: Any) -> Any:
    return fn(p, arg)


class Runner:
    """Maps tasks fn(problem, arg) over args: in this process (workers = 1), on a local process pool that
    holds the problem once per worker, or on Dask (scheduler address or a Client), the problem scattered."""

    def __init__(self, problem: Problem, workers: Optional[int] = None, scheduler: Optional[str] = None,
                 client: Any = None) -> None:
        self.problem = problem
        self._pool: Optional[ProcessPoolExecutor] = None
        self._client = client
        self._own_client = False
        self._scattered = None
        if client is not None or scheduler is not None:
            if client is None:
                from distributed import Client

                self._client = Client(scheduler)
                self._own_client = True
            self._scattered = self._client.scatter(problem, broadcast=True)
            self.workers = len(self._client.scheduler_info().get("workers", {})) or 1
        else:
            self.workers = workers or os.cpu_count() or 1
            if self.workers > 1:
                self._pool = ProcessPoolExecutor(max_workers=self.workers, initializer=_init_worker,
                                                 initargs=(problem,))

    def map(self, fn: Callable[[Problem, Any], Any], args: Sequence[Any]) -> List[Any]:
        args = list(args)
        if self._client is not None:
            futures = self._client.map(_dask_call, [self._scattered] * len(args), [fn] * len(args), args,
                                       pure=False)
            return list(self._client.gather(futures))
        if self._pool is not None and len(args) > 1:
            return list(self._pool.map(_pool_call, [fn] * len(args), args))
        return [fn(self.problem, a) for a in args]

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
        if self._client is not None and self._own_client:
            self._client.close()

    def __enter__(self) -> "Runner":
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()


# --- the Hessian ---------------------------------------------------------------------------------------

def _hessian(runner: Runner, z: np.ndarray, f0: float, D: np.ndarray) -> Tuple[np.ndarray, int]:
    """Central-difference Hessian of -log L at z along the columns of D (unit steps along each, every point
    in one parallel batch), returned in z: H = D^-T G D^-1 with G the Hessian in y, z = z0 + D y. With D's
    columns the one-sigma directions of a first estimate, each step moves -log L by about 1/2 even along a
    narrow correlated valley (gamma and n)."""
    n = len(z)
    pts: List[np.ndarray] = []
    for i in range(n):
        for s in (1, -1):
            pts.append(z + s * D[:, i])
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    for i, j in pairs:
        for si, sj in ((1, 1), (1, -1), (-1, 1), (-1, -1)):
            pts.append(z + si * D[:, i] + sj * D[:, j])
    f = runner.map(_task_nll, pts)
    G = np.zeros((n, n))
    for i in range(n):
        G[i, i] = f[2 * i] - 2 * f0 + f[2 * i + 1]
    for k, (i, j) in enumerate(pairs):
        a, b, c, d = f[2 * n + 4 * k: 2 * n + 4 * k + 4]
        G[i, j] = G[j, i] = (a - b - c + d) / 4
    Dinv = np.linalg.inv(D)
    return Dinv.T @ G @ Dinv, len(pts)


def _steps(runner: Runner, z: np.ndarray, f0: float, rounds: int = 3) -> Tuple[np.ndarray, int]:
    """Each parameter's one-sigma step (its curvature alone), in a few rounds from 0.01: a step that moves
    -log L by about 1/2 sees the curvature, not the objective's roughness."""
    n = len(z)
    lo, hi = np.array(runner.problem.z_bounds).T
    room = np.maximum(np.minimum(z - lo, hi - z), 0.0)
    h = np.minimum(np.full(n, 1e-2), np.where(room > 0, room, 1e-2))
    evals = 0
    for _ in range(rounds):
        pts = [z + s * h[i] * np.eye(n)[i] for i in range(n) for s in (1, -1)]
        f = runner.map(_task_nll, pts)
        evals += len(pts)
        curv = np.array([(f[2 * i] - 2 * f0 + f[2 * i + 1]) / h[i] ** 2 for i in range(n)])
        new = np.where(curv > 0, 1 / np.sqrt(np.where(curv > 0, curv, 1.0)), 4 * h)
        new = np.clip(new, 1e-7, 0.5)
        new = np.minimum(new, np.where(room > 1e-7, room, new))  # stay inside the bounds where possible
        done = np.all(np.abs(np.log(new / h)) < math.log(2))
        h = new
        if done:
            break
    return h, evals


def _fisher(runner: Runner, z: np.ndarray, f0: float) -> Tuple[np.ndarray, np.ndarray, int]:
    """The Hessian of -log L at z (the observed Fisher information in z) and its whitening L (L L' = H^-1
    on the curved directions): each parameter's one-sigma step first, then the Hessian along the axes with
    those steps, then once more along its own one-sigma eigen-directions."""
    h, evals = _steps(runner, z, f0)
    H, k = _hessian(runner, z, f0, np.diag(h))
    evals += k
    L = _whitening(H, h)
    lo, hi = np.array(runner.problem.z_bounds).T
    inside = np.all((z + L.T >= lo) & (z + L.T <= hi)) and np.all((z - L.T >= lo) & (z - L.T <= hi))
    if inside and np.isfinite(L).all() and abs(np.linalg.det(L)) > 0:
        H2, k = _hessian(runner, z, f0, L)
        evals += k
        if np.all(np.isfinite(H2)):
            H = H2
            L = _whitening(H, h)
    return H, L, evals


# --- the result ---------------------------------------------------------------------------------------

@dataclass
class Estimate:
    key: str
    start: float
    value: float
    fisher: Tuple[float, float]  # 95 % interval from the Fisher information (SI; +-inf: none)
    profile: Tuple[Optional[float], Optional[float]]  # the profile's ends where they disagree with Fisher
    interval: Tuple[float, float]  # the reported 95 % interval: the profile's end where they disagree
    sigma: float  # the P0 standard deviation written: the interval's larger half / 1.96 (SI)
    pinned: bool
    reason: str  # why not pinned down ("" when pinned)
    truth: Optional[float] = None


@dataclass
class IdentifyResult:
    unknowns: List[Unknown]
    estimates: List[Estimate]
    nll_before: float
    nll_after: float
    steps: int  # corrections counted in the likelihood
    nis_before: float  # mean NIS per sensor of the predictor, before and after
    nis_after: float
    nis_scale: float  # the factor the Fisher covariance was scaled by (1: none)
    correlation: np.ndarray
    hessian: np.ndarray  # of -log L in the normalised coordinates z
    z: np.ndarray
    starts: List[Tuple[np.ndarray, float, float]]  # (start z, -log L there, -log L after its search)
    evaluations: int
    scenario: Scenario  # the input scenario with the estimates (write_scenario writes it)
    profiles: Dict[str, List[Tuple[float, float]]]  # key -> [(value SI, rise of -log L)]
    threshold: float  # the rise that bounds the 95 % profile interval (1.92 x nis_scale)

    def estimate(self, key: str) -> Estimate:
        key = canonical(key)
        for e in self.estimates:
            if e.key == key:
                return e
        raise KeyError(key)

    @property
    def not_pinned(self) -> List[str]:
        return [e.key for e in self.estimates if not e.pinned]


def identify(sc: Scenario, records: Sequence[Measurements], params: Sequence[str],
             bounds: Optional[Mapping[str, Tuple[float, float]]] = None, experiment: Optional[str] = None,
             precision: str = "double", burn_in_s: float = 0.0, starts: int = 4, seed: int = 0,
             max_evals: int = 600, workers: Optional[int] = 1, scheduler: Optional[str] = None,
             client: Any = None, truth: Optional[Mapping[str, float]] = None, profile_points: int = 0,
             **overrides: Any) -> IdentifyResult:
    """Maximum-likelihood values of `params` (scenario keys) from `records` of one mechanism (module
    docstring). `starts` searches: the scenario's values and starts-1 Sobol points in the middle half of the
    bounds (`seed`). `truth` (key -> value) is only reported. `profile_points` > 0 also evaluates each
    parameter's profile at that many points across 1.5 times its interval (for the figure)."""
    from scipy.stats import qmc

    if not records:
        raise IdentifyError("no records to identify from")
    if starts < 1:
        raise IdentifyError(f"--starts {starts}: must be >= 1")
    us = unknowns(sc, params, bounds)
    problem = Problem(sc, list(records), us, experiment, precision, int(round(burn_in_s / sc.dt)), dict(overrides))
    n = len(us)
    lo, hi = np.array(problem.z_bounds).T
    z_starts = [np.zeros(n)]
    if starts > 1:
        pts = qmc.Sobol(n, scramble=True, seed=seed).random(max(2, 1 << math.ceil(math.log2(starts - 1))))
        for q in pts[:starts - 1]:
            z_starts.append(np.clip(lo / 2 + q * (hi - lo) / 2, lo, hi))
    # settings the filter refuses are a bad input: check the start once, here, with its message
    from .binding import settings_for, Estimator

    Estimator(settings_for(problem.predictor(problem.values(np.zeros(n))), experiment, precision,
                           constraint_enabled=0, mismatch_adapt=0, **overrides))
    evals = 0
    with Runner(problem, workers, scheduler, client) as runner:
        f_start = runner.map(_task_nll, z_starts)
        evals += len(z_starts)
        nll_before = f_start[0]
        if nll_before >= FAIL:
            raise IdentifyError("the filter gives no innovations at the start values (no correction counted: "
                                "records shorter than the burn-in?)")
        fits = runner.map(_task_fit, [(z, 0.1, max_evals) for z in z_starts])
        evals += sum(f[2] for f in fits)
        best = int(np.argmin([f[1] for f in fits]))
        z, f_opt = fits[best][0], fits[best][1]
        # Hessian, polish in its whitened coordinates, again while the polish moves
        H, L = np.zeros((n, n)), np.eye(n)
        for _ in range(3):
            H, L, k = _fisher(runner, z, f_opt)
            evals += k
            z_new, f_new, k = runner.map(_task_polish, [(z, L, max_evals)])[0]
            evals += k
            if f_new >= f_opt - 1e-3:
                break
            moved = float(np.linalg.norm(np.linalg.lstsq(L, z_new - z, rcond=None)[0]))
            z, f_opt = z_new, f_new
            if moved < 0.5:
                H, L, k = _fisher(runner, z, f_opt)
                evals += k
                break
        nis_before, _ = problem.nis_mean(np.zeros(n))
        nis_after, steps = problem.nis_mean(z)
        noise_fitted = any(u.kind == "noise" for u in us)
        scale = 1.0 if noise_fitted else max(1.0, nis_after)
        cov, curv_ok = _covariance(H)
        cov = cov * scale
        var = np.diag(cov)
        sd = np.sqrt(np.where(var > 0, var, np.inf))
        with np.errstate(invalid="ignore", divide="ignore"):
            corr = cov / np.outer(sd, sd)
        corr[~np.isfinite(corr)] = np.nan
        np.fill_diagonal(corr, 1.0)
        threshold = CHI2_95 / 2 * scale
        sides = [(z, f_opt, H, i, s, Z95 * sd[i], threshold, max_evals) for i in range(n) for s in (-1, 1)]
        prof = runner.map(_task_profile_side, sides)
        evals += sum(p.evaluations for p in prof)
        profiles: Dict[str, List[Tuple[float, float]]] = {u.key: [] for u in us}
        for ps in prof:
            profiles[us[ps.index].key] += [(problem.values(_with(z, ps.index, zi))[us[ps.index].key], r)
                                           for zi, r in ps.points]
        if profile_points > 0:
            args = []
            for i in range(n):
                ends = [ps for ps in prof if ps.index == i]
                span = max((ps.profile_d if ps.profile_d is not None else ps.fisher_d) for ps in ends)
                span = 1.5 * (span if math.isfinite(span) else 1.0)
                for zi in np.linspace(z[i] - span, z[i] + span, profile_points):
                    if lo[i] <= zi <= hi[i]:
                        args.append((i, float(zi)))
            vals = runner.map(_task_profile_point, [(z, H, i, zi, max_evals) for i, zi in args])
            evals += len(args)
            for (j, zj), fj in zip(args, vals):
                profiles[us[j].key].append((problem.values(_with(z, j, zj))[us[j].key], fj - f_opt))
        for key in profiles:
            profiles[key].sort()
    estimates = []
    values = problem.values(z)
    for i, u in enumerate(us):
        side_of = {ps.side: ps for ps in prof if ps.index == i}
        fisher = tuple(_to_si(problem, z, i, z[i] + s * Z95 * sd[i]) for s in (-1, 1))
        prof_ends: List[Optional[float]] = []
        chosen: List[float] = []
        reasons = []
        for s in (-1, 1):
            ps = side_of[s]
            if ps.profile_d is None:
                prof_ends.append(None)
                chosen.append(fisher[0 if s < 0 else 1])
            else:
                v = _to_si(problem, z, i, z[i] + s * ps.profile_d)
                prof_ends.append(v)
                chosen.append(v)
            if ps.at_bound:
                reasons.append(f"the profile stays below the threshold up to the {'lower' if s < 0 else 'upper'} "
                               "bound")
        if not curv_ok[i]:
            reasons.insert(0, "no curvature of -log L along it")
        iv = (min(chosen[0], values[u.key]), max(chosen[1], values[u.key]))
        sigma = max(values[u.key] - iv[0], iv[1] - values[u.key]) / Z95
        estimates.append(Estimate(u.key, u.start, values[u.key], (fisher[0], fisher[1]),
                                  (prof_ends[0], prof_ends[1]), iv, sigma, not reasons, "; ".join(reasons),
                                  None if truth is None or u.key not in truth else float(truth[u.key])))
    out_sc = scenario_with_estimates(sc, us, estimates)
    return IdentifyResult(us, estimates, nll_before, f_opt, steps, nis_before, nis_after, scale, corr, H, z,
                          [(zs, fs, fit[1]) for zs, fs, fit in zip(z_starts, f_start, fits)], evals, out_sc,
                          profiles, threshold)


def _with(z: np.ndarray, i: int, zi: float) -> np.ndarray:
    out = np.array(z, dtype=float)
    out[i] = zi
    return out


def _to_si(p: Problem, z: np.ndarray, i: int, zi: float) -> float:
    if not math.isfinite(zi):
        return math.copysign(math.inf, zi)
    return p.values(_with(z, i, zi))[p.unknowns[i].key]


def _whitening(H: np.ndarray, h: np.ndarray) -> np.ndarray:
    """L with L L' = H^-1 on its positive eigen-directions (a flat direction: the step h's size)."""
    w, V = np.linalg.eigh(H)
    ok = w > 1e-12 * max(1.0, float(np.max(np.abs(w))))
    scale = np.where(ok, 1 / np.sqrt(np.where(ok, w, 1.0)), float(np.max(h)))
    return V * scale


def _covariance(H: np.ndarray) -> Tuple[np.ndarray, np.ndarray]:
    """H^-1 over its positive eigen-directions (pseudo-inverse), and which parameters have curvature (their
    variance finite): a parameter with a component along a non-positive direction has infinite variance."""
    n = len(H)
    w, V = np.linalg.eigh(H)
    ok = w > 1e-10 * max(1.0, float(np.max(np.abs(w))))
    cov = (V[:, ok] / w[ok]) @ V[:, ok].T
    bad = np.any(np.abs(V[:, ~ok]) > 1e-3, axis=1) if (~ok).any() else np.zeros(n, dtype=bool)
    cov[bad, :] = np.nan
    cov[:, bad] = np.nan
    cov[bad, bad] = np.inf
    return cov, ~bad


# --- the scenario written ----------------------------------------------------------------------------

def scenario_with_estimates(sc: Scenario, us: Sequence[Unknown], estimates: Sequence[Estimate]) -> Scenario:
    """The input scenario with each estimate under the key the online filter starts from (contact1_gamma ->
    contact1_gamma0, contact1_n -> contact1_n0, ...; a mechanism or noise value under its own key) and its
    interval as the P0 standard deviation (contact1_sigma_gamma0, contact1_sigma_n0, ...; a mechanism
    parameter's `<key>_sigma` where the schema has it). A law parameter the scenario does not estimate
    online is a model value of the filter: its own key (contact1_n) gets the estimate too."""
    ch: Dict[str, float] = {}
    for u, e in zip(us, estimates):
        ch[u.out_key] = e.value
        if u.sigma_key is not None and math.isfinite(e.sigma) and e.sigma > 0:
            ch[u.sigma_key] = e.sigma
        m = _LAW_RE.match(u.key)
        if m and m.group(2) != "gamma" and not int(_value(sc, f"contact{m.group(1)}_estimate_{m.group(2)}")):
            ch[u.key] = e.value
    return sc.replace(**ch)


# --- the report ----------------------------------------------------------------------------------------

def _fmt(v: Optional[float]) -> str:
    if v is None:
        return "-"
    return f"{v:.6g}" if math.isfinite(v) else ("inf" if v > 0 else "-inf")


def report_text(r: IdentifyResult) -> str:
    from .bench.results import format_table

    has_truth = any(e.truth is not None for e in r.estimates)
    rows = []
    for e in r.estimates:
        rel = ""
        if math.isfinite(e.interval[0]) and math.isfinite(e.interval[1]) and e.value != 0:
            half = (e.interval[1] - e.interval[0]) / 2
            rel = f"+-{100 * half / abs(e.value):.3g} %"
        row = [e.key, _fmt(e.start), _fmt(e.value), f"[{_fmt(e.interval[0])}, {_fmt(e.interval[1])}]", rel,
               f"[{_fmt(e.fisher[0])}, {_fmt(e.fisher[1])}]",
               "agrees" if e.profile == (None, None) else f"[{_fmt(e.profile[0])}, {_fmt(e.profile[1])}]",
               "yes" if e.pinned else "NO"]
        if has_truth:
            t = e.truth
            row += [_fmt(t), "-" if t is None else ("yes" if e.interval[0] <= t <= e.interval[1] else "NO")]
        rows.append(row)
    head = ["parameter", "start", "estimate", "95 % interval", "half-width", "Fisher 95 %", "profile 95 %",
            "pinned down"] + (["truth", "truth inside"] if has_truth else [])
    lines = [format_table(head, rows)]
    n = len(r.estimates)
    if n > 1:
        w = max(len(e.key) for e in r.estimates)
        lines.append("")
        lines.append("correlation")
        for i, e in enumerate(r.estimates):
            lines.append(f"  {e.key:<{w}} " + " ".join(f"{r.correlation[i, j]:+.3f}" for j in range(n)))
    lines.append("")
    lines.append(f"-log L (1/2 sum log det S + NIS over {r.steps} corrections): before {r.nll_before:.6g}, "
                 f"after {r.nll_after:.6g} (change {r.nll_after - r.nll_before:+.6g})")
    lines.append(f"mean NIS per sensor: before {r.nis_before:.4g}, after {r.nis_after:.4g} (1 for a consistent "
                 "filter)" + (f"; Fisher covariance scaled by {r.nis_scale:.4g}" if r.nis_scale != 1 else ""))
    lines.append(f"starts: {len(r.starts)}, -log L after each search: "
                 + ", ".join(f"{s[2]:.6g}" for s in r.starts) + f"; {r.evaluations} filter runs")
    bad = [e for e in r.estimates if not e.pinned]
    lines.append("not pinned down by the data: " + ("none" if not bad else
                                                      "; ".join(f"{e.key} ({e.reason})" for e in bad)))
    return "\n".join(lines)


def write_scenario(r: IdentifyResult, path: Any, header: str = "") -> None:
    from .outputs import write_text_atomic
    from .settings_adapter import scenario_toml

    write_text_atomic(path, scenario_toml(r.scenario, header))


def parse_bounds(items: Sequence[str]) -> Dict[str, Tuple[float, float]]:
    """--bounds KEY=LOW:HIGH ... -> {key: (low, high)}; one-line errors naming the item."""
    out: Dict[str, Tuple[float, float]] = {}
    for item in items:
        key, sep, rest = item.partition("=")
        lo_s, sep2, hi_s = rest.partition(":")
        try:
            if not sep or not sep2:
                raise ValueError
            out[key.strip()] = (float(lo_s), float(hi_s))
        except ValueError:
            raise IdentifyError(f"--bounds {item}: expected KEY=LOW:HIGH") from None
    return out
