"""Noise tuning from data: the Q_x, Q_gamma and R that make the C estimator's innovations consistent.

Method: maximum likelihood of the innovation sequence (innovation-based estimation). For a filter whose
noise settings are right, the innovations nu_k are zero-mean Gaussian with covariance S_k, so the
settings that minimise

    J = sum_k [ log det S_k + nu_k' S_k^-1 nu_k ] = sum_k [ log det S_k + NIS_k ]

over the recorded runs are the maximum-likelihood ones. The C estimator reports NIS_k; log det S_k comes
from the binding's run (`log_det_s=True`, derived from the posterior covariance, see _caekf.c). The search
is Nelder-Mead over log10 of the chosen standard deviations (scipy.optimize), each evaluation one
`caekf_sim.run` per record (the whole loop in C).

Any mechanism (docs/mechanism.md): the searched settings are the noise standard deviations the
mechanism uses (settings_adapter.tunable_noise: the schema's noise settings that are standard
deviations, per contact where they are per contact), or a chosen subset.

Consistency is reported as the NIS statistics of a chi-square with one degree of freedom per sensor (d):
the mean NIS (d for a consistent filter; its 95 % band for N steps is chi2(d N)/N) and the fraction of
steps whose NIS lies in the per-step 95 % band [chi2.ppf(0.025, d), chi2.ppf(0.975, d)] (0.95 for a
consistent filter).

Records: CSVs with the mechanism's measurement columns (t, the inputs, one column per sensor: t,u,y1,y4
for the paper; extra columns ignored, a row with every sensor empty = lost measurement, bridged by
caekf_predict), and, for the paper's mechanism, candump -L logs of the CAN bench (BENCH_U with BENCH_Y1 /
BENCH_Y4, or BENCH_YP in the production profile; one record per configuration, i.e. from each CTRL_RESET on).
"""
from __future__ import annotations

import math

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from . import flags as fl
from .binding import run, settings_for
from .measurements import Measurements
from .mechanism import contact_values
from .scenario import Scenario
from .schema import canonical
from .settings_adapter import noise_of, scenario_with_noise, tunable_noise

PathLike = Union[str, Path]
NIS_DOF = 2  # the paper's two position sensors; in general one degree of freedom per sensor


# --- consistency -----------------------------------------------------------------------------------

def nis_band(p: float = 0.95, dof: int = NIS_DOF) -> Tuple[float, float]:
    """Per-step band of a chi-square NIS with `dof` degrees of freedom (the number of sensors)."""
    from scipy.stats import chi2

    return float(chi2.ppf((1 - p) / 2, dof)), float(chi2.ppf((1 + p) / 2, dof))


@dataclass
class Consistency:
    """NIS statistics and gamma error of one run (or several, pooled)."""

    steps: int  # steps with a correction
    nis_mean: float
    nis_mean_band: Tuple[float, float]  # 95 % band of the mean NIS of a consistent filter (chi2(d N)/N)
    in_band: float  # fraction of steps whose NIS lies in the per-step 95 % band
    nll: float  # mean of log det S + NIS per step (the tuning objective)
    gamma_final_err: float  # relative error of the last gamma estimate (NaN without gamma_true); RMS over contacts
    gamma_rms_err: float  # RMS relative gamma error over the last quarter of the run (and the contacts)
    dof: int = NIS_DOF  # degrees of freedom of the NIS: the number of sensors

    @property
    def consistent(self) -> bool:
        return self.nis_mean_band[0] <= self.nis_mean <= self.nis_mean_band[1]


def _corrected(res) -> np.ndarray:
    bad = fl.NO_MEASUREMENT | fl.INPUT_REJECTED | fl.NUMERIC_ROLLBACK
    return (res.status == 0) & ((res.flags & bad) == 0)


def consistency(results: Sequence, gamma_true: Union[None, float, Sequence[float], np.ndarray] = None,
                burn_in: int = 0) -> Consistency:
    """Pooled NIS consistency of runs (RunResult) after `burn_in` steps each, and the gamma error of
    every contact (gamma_true: a number for one contact, else one per contact)."""
    from scipy.stats import chi2

    dof = int(results[0].settings.sensors) if results else NIS_DOF
    lo, hi = nis_band(dof=dof)
    nis = np.concatenate([r.nis[burn_in:][_corrected(r)[burn_in:]] for r in results])
    ld = np.concatenate([r.log_det_s[burn_in:] for r in results if r.log_det_s is not None]) \
        if all(r.log_det_s is not None for r in results) else np.array([np.nan])
    ok = np.isfinite(ld)
    n = len(nis)
    nll = float(np.mean(ld[ok]) + np.mean(nis)) if ok.any() and n else float("nan")
    gf, gr = float("nan"), float("nan")
    g_true = None if gamma_true is None else np.atleast_1d(np.asarray(gamma_true, dtype=float))
    if g_true is not None and g_true.size and np.all(g_true != 0) and np.all(np.isfinite(g_true)):
        errs = [r.gammas / g_true - 1.0 for r in results]
        gf = float(np.sqrt(np.mean([e[-1] ** 2 for e in errs])))
        gr = float(np.sqrt(np.mean(np.concatenate([e[-max(1, len(e) // 4):].ravel() ** 2 for e in errs]))))
    return Consistency(
        steps=n,
        nis_mean=float(np.mean(nis)) if n else float("nan"),
        nis_mean_band=(float(chi2.ppf(0.025, dof * n) / n), float(chi2.ppf(0.975, dof * n) / n))
        if n else (float("nan"), float("nan")),
        in_band=float(np.mean((nis >= lo) & (nis <= hi))) if n else float("nan"),
        nll=nll,
        gamma_final_err=gf,
        gamma_rms_err=gr,
        dof=dof,
    )


def run_records(sc: Scenario, records: Sequence[Measurements], experiment: Optional[str] = None,
                precision: str = "double", log_det_s: bool = True, **overrides) -> List:
    s = settings_for(sc, experiment, precision, **overrides)
    return [run(s, r.u, r.y, t=r.t, p_diag=False, log_det_s=log_det_s) for r in records]


def innovation_nll(results: Sequence, burn_in: int = 0) -> Tuple[float, int]:
    """The negative log-likelihood of the innovations of runs (RunResult with log_det_s), up to a constant:
    1/2 sum_k (log det S_k + NIS_k) over the steps after `burn_in` with a plain correction (finite log det S),
    and the number of those steps. `identify` minimises it over model parameters (caekf_sim.identify)."""
    total, steps = 0.0, 0
    for r in results:
        ld, nis = r.log_det_s[burn_in:], r.nis[burn_in:]
        ok = np.isfinite(ld) & _corrected(r)[burn_in:]
        total += 0.5 * float(np.sum(ld[ok] + nis[ok]))
        steps += int(np.count_nonzero(ok))
    return total, steps


# --- tuning ----------------------------------------------------------------------------------------

@dataclass
class TuneResult:
    noise_before: Dict[str, float]
    noise_after: Dict[str, float]
    scenario: Scenario  # the input scenario with noise_after
    train_before: Consistency
    train_after: Consistency
    holdout_before: Optional[Consistency]
    holdout_after: Optional[Consistency]
    evaluations: int


def tune(sc: Scenario, records: Sequence[Measurements], params: Optional[Sequence[str]] = None,
         holdout: Sequence[Measurements] = (), experiment: Optional[str] = None, precision: str = "double",
         gamma_true: Union[None, float, Sequence[float]] = None, burn_in_s: float = 0.5, max_evals: int = 400,
         decades: float = 4.0, **overrides) -> TuneResult:
    """Maximum-likelihood noise for `params` (scenario keys of TUNABLE_NOISE or their aliases; default:
    tunable_noise(sc), every noise std the mechanism uses) over `records`, any mechanism, for the estimator
    `experiment` (a preset; None: the recommended one with the scenario's settings).

    The search starts from the scenario's values and stays within `decades` orders of magnitude of
    them. `gamma_true` (default: the scenario's gamma of every contact) is only used for the reported
    gamma error.
    """
    from scipy.optimize import minimize

    usable = tuple(noise_of(sc))
    params = list(tunable_noise(sc) if params is None else [canonical(p) for p in params])
    bad = sorted(set(params) - set(usable))
    if bad or not params:
        raise ValueError(f"tunable noise settings of this mechanism are {', '.join(usable)}; "
                         f"got {', '.join(bad) or 'none'}")
    if not records:
        raise ValueError("no records to tune on")
    g_true = contact_values(sc, "gamma", int(sc.contacts)) if gamma_true is None else gamma_true  # NaN: no truth
    burn_in = int(round(burn_in_s / sc.dt))
    before = noise_of(sc)
    x0 = np.log10([before[p] for p in params])
    if not np.all(np.isfinite(x0)):
        raise ValueError(f"start values of {', '.join(params)} must be > 0 (log-scale search)")
    evals = 0

    def scenario_at(x: np.ndarray) -> Scenario:
        return scenario_with_noise(sc, {p: 10.0 ** v for p, v in zip(params, x)})

    def objective(x: np.ndarray) -> float:
        nonlocal evals
        evals += 1
        try:
            res = run_records(scenario_at(x), records, experiment, precision, **overrides)
        except ValueError:  # settings refused (e.g. an overflow in float): outside the feasible set
            return 1e300
        c = consistency(res, None, burn_in)
        return c.nll if np.isfinite(c.nll) else 1e300

    opt = minimize(objective, x0, method="Nelder-Mead",
                   bounds=[(v - decades, v + decades) for v in x0],
                   options={"xatol": 1e-3, "fatol": 1e-6, "maxfev": max_evals, "initial_simplex":
                            np.vstack([x0] + [x0 + np.eye(len(x0))[i] for i in range(len(x0))])})
    tuned = scenario_at(opt.x)

    def measure(s: Scenario, recs: Sequence[Measurements]) -> Optional[Consistency]:
        return consistency(run_records(s, recs, experiment, precision, **overrides), g_true, burn_in) \
            if recs else None

    return TuneResult(
        noise_before=before, noise_after=noise_of(tuned), scenario=tuned,
        train_before=measure(sc, records), train_after=measure(tuned, records),  # type: ignore[arg-type]
        holdout_before=measure(sc, holdout), holdout_after=measure(tuned, holdout), evaluations=evals)



def _percent(err: float) -> str:
    """An error in percent, or "-" without a truth to compare with (a real recording), as caekf-replay prints it."""
    return f"{100 * err:.3f} %" if math.isfinite(err) else "-"

def report_text(r: TuneResult, params: Sequence[str]) -> str:
    from .bench.results import format_table

    dof = r.train_before.dof
    lo, hi = nis_band(dof=dof)
    tuned = {canonical(p) for p in params}
    w = max(16, max(len(p) for p in r.noise_before))
    lines = [f"{'noise (std)':<{w}}   before        after"]
    for p in r.noise_before:
        mark = "" if p in tuned else "  (kept)"
        lines.append(f"{p:<{w}} {r.noise_before[p]:>12.4e} {r.noise_after[p]:>12.4e}{mark}")
    rows = []
    for label, c in (("train, before", r.train_before), ("train, after", r.train_after),
                     ("held-out, before", r.holdout_before), ("held-out, after", r.holdout_after)):
        if c is None:
            continue
        rows.append([label, str(c.steps), f"{c.nis_mean:.3f}", f"[{c.nis_mean_band[0]:.3f}, {c.nis_mean_band[1]:.3f}]",
                     f"{100 * c.in_band:.1f} %", f"{c.nll:.4f}", _percent(c.gamma_final_err),
                     _percent(c.gamma_rms_err)])
    lines.append("")
    lines.append(format_table(["runs", "steps", "mean NIS", "95 % band of mean", f"NIS in [{lo:.3f}, {hi:.2f}]",
                               "mean log det S + NIS", "gamma err final", "gamma err RMS last 1/4"], rows))
    lines.append(f"(consistent filter: mean NIS {dof} (one per sensor), 95 % of steps in the band; "
                 f"{r.evaluations} evaluations)")
    return "\n".join(lines)

