"""Per-run metrics of one estimator run against the truth: per contact, and over the contacts.

Contact 1's columns have the plain names (`final_err`, `nees_final`, ...: the paper's one contact),
contact c >= 2's the suffix `_c<c>` (`final_err_c2`). The `_worst` columns are the worst contact's:
the largest |final error| and final NEES, diverged if any contact diverged, within 3 sigma if every
contact is; the family table reports them (for one contact they equal contact 1's)."""
from __future__ import annotations

from typing import Any, Dict, Optional, Sequence, Union

import numpy as np

from .. import flags as fl
from .estimate import Estimate

WITHIN_CONVERGED = 0.05  # time to converge: |error| within 5 % from then on
# The whole law's targets (docs/contact-law.md): |final error| of gamma and n relative, lambda relative,
# the gap absolute [m].
JOINT_TOL = {"gamma": 0.02, "n": 0.02, "lambda": 0.10, "gap": 1e-7}
DIVERGED = 0.5  # |final error| above 50 %, or gamma <= 0, or NaN
NEES_3SIGMA = 9.0  # final NEES of a chi-square(1) within 3 sigma
MISMATCH_FLAG = "model_mismatch"  # the health flag saying the model does not fit the data (issue 27)


def mismatch_flag_mask() -> Optional[int]:
    """The bit of the `model_mismatch` flag, read by its name from caekf_sim.flags (the schema's); None while
    the schema has no such flag (then `flagged_mismatch_end` is unavailable)."""
    try:
        return fl.mask(MISMATCH_FLAG)
    except KeyError:
        return None


def contact_suffix(c: int) -> str:
    """Column suffix of contact c (0-based): "" for contact 1, "_c2", "_c3", ... for the others."""
    return "" if c == 0 else f"_c{c + 1}"


def _contact_metrics(t: np.ndarray, gamma_true: float, delta: np.ndarray, g: np.ndarray,
                     p_gg: np.ndarray) -> Dict[str, Any]:
    """One contact's gamma metrics: final and last-exit error, time to converge, divergence, NEES."""
    err = g / gamma_true - 1.0
    final = float(err[-1])
    closed = delta > 0.0
    first = int(np.argmax(closed)) if closed.any() else -1
    exits = np.flatnonzero(closed[:-1] & ~closed[1:]) + 1
    within = np.abs(err) <= WITHIN_CONVERGED  # NaN compares False
    if within[-1]:
        bad = np.flatnonzero(~within)
        t_conv = float(t[bad[-1] + 1]) if bad.size else float(t[0])
    else:
        t_conv = float("nan")
    diverged = (not np.isfinite(g[-1])) or g[-1] <= 0 or abs(final) > DIVERGED
    with np.errstate(all="ignore"):
        nees = (g - gamma_true) ** 2 / p_gg
    nees_after = nees[first:] if first >= 0 else nees[:0]
    nees_after = nees_after[np.isfinite(nees_after)]
    return {
        "final_err": final,
        "abs_final_err": abs(final) if np.isfinite(final) else float("inf"),
        "last_exit_err": float(err[exits[-1]]) if exits.size else float("nan"),
        "t_converge_5pct": t_conv,
        "diverged": bool(diverged),
        "gamma_ever_nonpositive": bool(np.any(g <= 0)),
        "min_gamma": float(np.nanmin(g)) if np.isfinite(g).any() else float("nan"),
        "nees_final": float(nees[-1]),
        "consistent_3sigma": bool(np.isfinite(nees[-1]) and nees[-1] <= NEES_3SIGMA),
        "nees_mean_after_contact": float(nees_after.mean()) if nees_after.size else float("nan"),
        "t_first_contact": float(t[first]) if first >= 0 else float("nan"),
    }


def law_metrics(est: Estimate, law_true: Dict[str, float], gamma_final_err: Sequence[float]) -> Dict[str, Any]:
    """The estimated law parameters' final errors ("<key>_final_err": relative for n and lambda, in metres
    for the gap), 3-sigma consistency, and the run's verdict against JOINT_TOL: `joint_ok` when every
    estimated parameter (and the gammas) meets its target, `joint_diverged` when any is non-finite or off
    by more than DIVERGED (the gap: by more than its own value)."""
    out: Dict[str, Any] = {}
    ok = all(abs(e) <= JOINT_TOL["gamma"] for e in gamma_final_err)
    div = any(not np.isfinite(e) or abs(e) > DIVERGED for e in gamma_final_err)
    for key, series in est.law.items():
        name = key.split("_", 1)[1]
        truth, final = law_true[key], float(series[-1])
        err = final - truth if name == "gap" else final / truth - 1.0
        var = est.law_var.get(key)
        out[f"{key}_final"] = final
        out[f"{key}_final_err"] = err
        out[f"{key}_consistent_3sigma"] = bool(var is not None and (final - truth) ** 2 <= NEES_3SIGMA * var[-1])
        ok = ok and bool(abs(err) <= JOINT_TOL[name])
        div = div or not np.isfinite(err) or abs(err) > (abs(truth) if name == "gap" else DIVERGED)
    out["joint_ok"] = bool(ok)
    out["joint_diverged"] = bool(div)
    return out


def run_metrics(t: np.ndarray, gamma_true: Union[float, Sequence[float], np.ndarray], delta: np.ndarray,
                est: Estimate, law_true: Optional[Dict[str, float]] = None) -> Dict[str, Any]:
    """Per contact (gamma_true (contacts,), delta (N, contacts), est.gamma (N, contacts); one contact may
    be given as a number and (N,) arrays): final and last-contact-exit gamma error, time to converge within
    5 %, divergence, NEES of gamma against its P_gamma,gamma; over the contacts the `_worst` columns; NIS
    statistics (NIS_mean_free_before_contact: before any contact first closes) and the flags seen. NaN
    where undefined."""
    n = len(t)
    g_true = np.atleast_1d(np.asarray(gamma_true, dtype=float))
    nc = len(g_true)
    gam = np.asarray(est.gamma, dtype=float).reshape(n, nc)
    pgg = np.asarray(est.p_gg, dtype=float).reshape(n, nc)
    dl = np.asarray(delta, dtype=float).reshape(n, nc)
    out: Dict[str, Any] = {}
    per = [_contact_metrics(t, float(g_true[c]), dl[:, c], gam[:, c], pgg[:, c]) for c in range(nc)]
    for c, m in enumerate(per):
        out.update({k + contact_suffix(c): v for k, v in m.items()})
    abs_err = np.array([m["abs_final_err"] for m in per])
    nees = np.array([m["nees_final"] for m in per])
    worst = int(np.argmax(np.nan_to_num(abs_err, nan=np.inf)))
    out.update({
        "worst_contact": worst + 1,
        "abs_final_err_worst": float(abs_err[worst]),
        "nees_final_worst": float(np.max(np.nan_to_num(nees, nan=np.inf))),
        "diverged_worst": any(m["diverged"] for m in per),
        "consistent_3sigma_worst": all(m["consistent_3sigma"] for m in per),
    })
    closed_any = (dl > 0.0).any(axis=1)
    first = int(np.argmax(closed_any)) if closed_any.any() else -1
    nis = est.nis
    nis_f = nis[np.isfinite(nis)]
    nis_free = nis[: first if first >= 0 else n]
    nis_free = nis_free[np.isfinite(nis_free)]
    seen = int(np.bitwise_or.reduce(est.flags)) if n else 0
    out.update({
        "nis_mean": float(nis_f.mean()) if nis_f.size else float("nan"),
        "nis_max": float(nis_f.max()) if nis_f.size else float("nan"),
        "nis_steps": int(nis_f.size),
        "nis_mean_free_before_contact": float(nis_free.mean()) if nis_free.size else float("nan"),
        "flags_seen": seen,
        "flags_seen_names": ",".join(fl.describe(seen)),
        "steps_newton_not_converged": int(np.count_nonzero(est.flags & fl.NEWTON_NOT_CONVERGED)),
        "steps_gamma_gated": int(np.count_nonzero(est.flags & fl.GAMMA_GATED)),
        "steps_constraint": int(np.count_nonzero(est.flags & fl.CONSTRAINT_APPLIED)),
    })
    # issue 27: does the last step say the model does not fit, and is the run silently wrong (neither within
    # 3 sigma of its own P at the end nor flagged at the end)? Without the flag in the schema nothing can
    # flag a run: flagged_mismatch_end is None (unavailable) and silent_wrong counts every inconsistent run.
    bit = mismatch_flag_mask()
    flagged = None if bit is None or n == 0 else bool(int(est.flags[-1]) & bit)
    out["flagged_mismatch_end"] = flagged
    out["silent_wrong"] = not out["consistent_3sigma_worst"] and not flagged
    if est.law:
        out.update(law_metrics(est, law_true or {}, [m["final_err"] for m in per]))
    return out


def truth_stats(delta: np.ndarray, n_contacts: int) -> Dict[str, Any]:
    """Per contact: contact onsets, fraction of samples in contact, largest penetration (suffixes as above)."""
    dl = np.asarray(delta, dtype=float).reshape(-1, n_contacts)
    out: Dict[str, Any] = {}
    for c in range(n_contacts):
        closed = dl[:, c] > 0
        s = contact_suffix(c)
        out[f"truth_contact_onsets{s}"] = int(np.count_nonzero(closed[1:] & ~closed[:-1]) + int(closed[0]))
        out[f"truth_contact_fraction{s}"] = float(closed.mean())
        out[f"truth_max_delta{s}"] = float(np.nanmax(dl[:, c])) if np.isfinite(dl[:, c]).any() else float("nan")
    return out
