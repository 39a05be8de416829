"""Per-run metrics of one estimator run against the truth (gamma only)."""
from __future__ import annotations

from typing import Any, Dict

import numpy as np

from .. import flags as fl
from .estimate import Estimate

WITHIN_CONVERGED = 0.05  # time to converge: |error| within 5 % from then on
DIVERGED = 0.5  # |final error| above 50 %, or gamma <= 0, or NaN


def run_metrics(t: np.ndarray, gamma_true: float, delta: np.ndarray, est: Estimate) -> Dict[str, Any]:
    """Final and last-contact-exit gamma error, time to converge within 5 %, divergence, NEES of
    gamma against P_gamma,gamma, NIS statistics and the flags seen. NaN where undefined."""
    g = est.gamma
    err = g / gamma_true - 1.0
    final = float(err[-1])
    closed = delta > 0.0
    n = len(t)
    first = int(np.argmax(closed)) if closed.any() else -1
    exits = np.flatnonzero(closed[:-1] & ~closed[1:]) + 1
    within = np.abs(err) <= WITHIN_CONVERGED  # NaN compares False
    if within[-1]:
        bad = np.flatnonzero(~within)
        t_conv = float(t[bad[-1] + 1]) if bad.size else float(t[0])
    else:
        t_conv = float("nan")
    finite_g = np.isfinite(g[-1])
    diverged = (not finite_g) or g[-1] <= 0 or abs(final) > DIVERGED
    with np.errstate(all="ignore"):
        nees = (g - gamma_true) ** 2 / est.p_gg
    nees_after = nees[first:] if first >= 0 else nees[:0]
    nees_after = nees_after[np.isfinite(nees_after)]
    nis = est.nis
    nis_f = nis[np.isfinite(nis)]
    nis_free = nis[: first if first >= 0 else n]
    nis_free = nis_free[np.isfinite(nis_free)]
    seen = int(np.bitwise_or.reduce(est.flags)) if n else 0
    return {
        "final_err": final,
        "abs_final_err": abs(final) if np.isfinite(final) else float("inf"),
        "last_exit_err": float(err[exits[-1]]) if exits.size else float("nan"),
        "t_converge_5pct": t_conv,
        "diverged": bool(diverged),
        "gamma_ever_nonpositive": bool(np.any(g <= 0)),
        "min_gamma": float(np.nanmin(g)) if np.isfinite(g).any() else float("nan"),
        "nees_final": float(nees[-1]),
        "consistent_3sigma": bool(np.isfinite(nees[-1]) and nees[-1] <= 9.0),
        "nees_mean_after_contact": float(nees_after.mean()) if nees_after.size else float("nan"),
        "nis_mean": float(nis_f.mean()) if nis_f.size else float("nan"),
        "nis_max": float(nis_f.max()) if nis_f.size else float("nan"),
        "nis_steps": int(nis_f.size),
        "nis_mean_free_before_contact": float(nis_free.mean()) if nis_free.size else float("nan"),
        "t_first_contact": float(t[first]) if first >= 0 else float("nan"),
        "flags_seen": seen,
        "flags_seen_names": ",".join(fl.describe(seen)),
        "steps_newton_not_converged": int(np.count_nonzero(est.flags & 1)),
        "steps_gamma_gated": int(np.count_nonzero(est.flags & 2048)),
        "steps_constraint": int(np.count_nonzero(est.flags & 4)),
    }
