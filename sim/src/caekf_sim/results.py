"""Estimate CSV (same columns as the C `caekf-replay` output) and its reader.

A general mechanism (nq bodies, nc contacts) writes q1..q<nq>, v1..v<nq>, then `gamma` (contact 1) and
gamma2..gamma<nc>, then the estimated law parameters (n, lambda, gap; n2.. for contact 2) and mechanism
parameters (m2, spring1_k, ..., their variances p_m2, ... after p_gg), as caekf-replay does; the paper's
columns are RESULT_COLUMNS. The reader keeps q, v and the gammas."""
from __future__ import annotations

import warnings
from pathlib import Path
from typing import Mapping, Optional, Tuple, Union

import numpy as np

from .estimator import EstimateResult

RESULT_COLUMNS = (
    "t", "q1", "q2", "q3", "q4", "v1", "v2", "v3", "v4", "gamma", "p_norm", "p_gg", "flags",
    "newton_iters",
)

PathLike = Union[str, Path]


def result_columns(nq: int, nc: int, law: Tuple[str, ...] = (), variances: Tuple[str, ...] = ()
                   ) -> Tuple[str, ...]:
    """The columns for nq bodies, nc contacts and the names of the parameter states after the gammas (the law's:
    n, lambda, gap, n2..; then the estimated mechanism parameters': m2, spring1_k, ...), and of the variance
    columns after p_gg (the mechanism parameters': p_m2, p_spring1_k, ...), as caekf-replay orders them."""
    gammas = ["gamma"][:nc] + [f"gamma{i}" for i in range(2, nc + 1)]
    return ("t", *[f"q{i}" for i in range(1, nq + 1)], *[f"v{i}" for i in range(1, nq + 1)], *gammas, *law,
            "p_norm", "p_gg", *variances, "flags", "newton_iters")


def write_result_csv(res: EstimateResult, path: PathLike, variances: Optional[Mapping[str, np.ndarray]] = None
                     ) -> None:
    """%.17g for the floats so a reader gets the bits back; flags and iterations as integers. `variances`:
    further variance columns by name, written after p_gg (the estimated mechanism parameters' p_m2, ...)."""
    var = dict(variances or {})
    with open(path, "w", encoding="utf-8") as f:
        nc = res.n_contacts
        f.write(",".join(result_columns((res.x.shape[1] - nc - res.n_law) // 2, nc, res.law_names, tuple(var)))
                + "\n")
        floats = np.column_stack([res.t, res.x, res.p_norm, res.p_gg, *var.values()])
        for row, flag, it in zip(floats, res.flags, res.newton_iters):
            f.write(",".join("%.17g" % v for v in row) + f",{int(flag)},{int(it)}\n")


def read_result_csv(path: PathLike) -> EstimateResult:
    """Read an estimate CSV (ours or caekf-replay's); columns matched by header name (any mechanism: q1..,
    v1.., gamma, gamma2..). A file that is not one is a one-line MeasurementError naming it (a missing
    file: OSError)."""
    from .measurements import MeasurementError, check_input_file

    p = check_input_file(path)
    try:
        with open(p, encoding="utf-8") as f:
            header = [c.strip() for c in f.readline().split(",")]
        nq = sum(1 for c in header if c[:1] == "q" and c[1:].isdigit())
        nc = ("gamma" in header) + sum(1 for c in header if c.startswith("gamma") and c[5:].isdigit())
        want = result_columns(nq, nc)
        # no body at all: name the paper's columns, what an estimate CSV is most often expected to hold
        missing = [c for c in (want if nq > 0 else RESULT_COLUMNS) if c not in header]
        if missing:
            raise MeasurementError(f"{p}: not an estimate CSV: missing columns {', '.join(missing)}")
        with warnings.catch_warnings():  # an empty body is reported below, not as numpy's warning
            warnings.simplefilter("ignore")
            data = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2)
    except MeasurementError:
        raise
    except ValueError as exc:  # numpy's parse errors, UnicodeDecodeError
        raise MeasurementError(f"{p}: not an estimate CSV: {' '.join(str(exc).split())}") from None
    if data.shape[0] == 0 or data.shape[1] != len(header):
        raise MeasurementError(f"{p}: not an estimate CSV: no rows" if data.shape[0] == 0 else
                               f"{p}: {data.shape[1]} columns, the header has {len(header)}")
    col = {name: data[:, header.index(name)] for name in want}
    x = np.column_stack([col[c] for c in want[1 : 1 + 2 * nq + nc]])
    # caekf-replay's P_gamma,gamma of every contact: p_gg, p_gg2.. (other writers: p_gg alone)
    pgg_names = ["p_gg"] + [f"p_gg{i}" for i in range(2, nc + 1)]
    p_ggs = (np.column_stack([data[:, header.index(c)] for c in pgg_names])
             if nc > 1 and all(c in header for c in pgg_names) else None)
    return EstimateResult(
        t=col["t"],
        x=x,
        p_norm=col["p_norm"],
        p_gg=col["p_gg"],
        flags=col["flags"].astype(np.int64),
        newton_iters=col["newton_iters"].astype(np.int64),
        n_contacts=nc,
        p_ggs=p_ggs,
    )
