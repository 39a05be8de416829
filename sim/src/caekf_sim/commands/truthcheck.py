"""`caekf-sim truth-check`: the truths' error against a tight-tolerance reference solver, any mechanism."""
from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Dict, List, Optional, Union

import numpy as np

from ..mechanism import Mechanism
from ..scenario import Scenario, default_scenario_path, load_scenario

REF_RTOL = 1e-11
REF_ATOL_Q = 1e-17  # [m], 100x below the truths' default
REF_ATOL_V = 1e-15  # [m/s]


def reference(sc: Scenario, integrator: str = "DOP853", t_end: Optional[float] = None):
    """(q, v) of the reference: scipy solve_ivp at rtol 1e-11, tight atol, restarted at every event."""
    from ..truth import continuous_states

    q, v, _ = continuous_states(sc, integrator=integrator, rtol=REF_RTOL, atol_q=REF_ATOL_Q, atol_v=REF_ATOL_V,
                                t_end=t_end)
    return q, v


def errors(q: np.ndarray, v: np.ndarray, q_ref: np.ndarray, v_ref: np.ndarray,
           contacts: Union[float, "Mechanism"]) -> Dict[str, float]:
    """max |dq| [m], max |dv| [m/s], and max |d delta| over samples in contact relative to max delta (worst
    contact). `contacts`: the mechanism (any contacts), or the paper's gap (its contact between bodies 2
    and 3)."""
    n = min(len(q), len(q_ref))
    dq = np.abs(q[:n] - q_ref[:n])
    if isinstance(contacts, Mechanism):
        d_ref, d = contacts.penetrations(q_ref[:n]), contacts.penetrations(q[:n])
    else:
        d_ref = (q_ref[:n, 1] - q_ref[:n, 2] - contacts)[:, None]
        d = (q[:n, 1] - q[:n, 2] - contacts)[:, None]
    dmax = float(d_ref.max()) if d_ref.size else float("nan")
    rels = [float(np.max(np.abs(d[:, c] - d_ref[:, c])[d_ref[:, c] > 0]) / d_ref[:, c].max())
            for c in range(d_ref.shape[1]) if d_ref[:, c].max() > 0]
    return {"dq": float(dq.max()), "dv": float(np.abs(v[:n] - v_ref[:n]).max()),
            "ddelta_rel": max(rels) if rels else float("nan"), "max_delta": dmax}


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("truth-check", help="error of caekf-truth / numpy truth / backward Euler against a "
                                           "tight-tolerance reference (scipy, restarted at contact events)")
    p.add_argument("--spec", type=Path, default=None, help="also check a sample of this family spec")
    p.add_argument("--runs", type=int, default=10, help="family runs to check (default 10)")
    p.add_argument("--seed", type=int, default=None, help="override the family spec's seed")
    p.add_argument("--t-end", type=float, default=None, help="override t_end [s]")
    p.add_argument("--integrator", choices=("DOP853", "Radau"), default="DOP853", help="reference method")
    p.add_argument("--no-paper", action="store_true", help="skip the paper's scenario")
    p.add_argument("--numpy", action="store_true", help="also the numpy truth (slower)")
    p.set_defaults(func=cmd_truth_check)


def cmd_truth_check(args: argparse.Namespace) -> int:
    from ..campaign.runner import truth_arrays
    from ..campaign.spec import load_spec
    from ..truth import simulate

    cases: List[tuple] = []
    if not args.no_paper:
        sc = load_scenario(default_scenario_path())
        cases.append(("paper", sc.replace(t_end=args.t_end) if args.t_end else sc))
    if args.spec is not None:
        fam = load_spec(args.spec, runs=args.runs, seed=args.seed, t_end=args.t_end)
        cases += [(f"run {r.run}", r.scenario) for r in fam.runs]
    head = f"{'case':<10} {'gamma':>9} {'max delta':>10} {'truth':<16} {'max|dq| m':>10} {'max|dv| m/s':>11} " \
           f"{'|d delta|/max':>13} {'failed':>6} {'wall s':>7}"
    print(f"reference: scipy {args.integrator}, rtol {REF_RTOL:g}, atol {REF_ATOL_Q:g} m / {REF_ATOL_V:g} m/s, "
          f"restarted at every contact event")
    print(head)
    worst = {"c": 0.0, "numpy": 0.0}
    failures = {"c": 0, "c-backward-euler": 0}
    for name, sc in cases:
        t0 = time.perf_counter()
        q_ref, v_ref = reference(sc, args.integrator)
        ref_s = time.perf_counter() - t0
        truths = ["c", "c-backward-euler"] + (["numpy"] if args.numpy else [])
        for tr_name in truths:
            t0 = time.perf_counter()
            if tr_name == "numpy":
                tr = simulate(sc)
                q, v, failed = tr.q, tr.v, False
            else:
                ta = truth_arrays(sc, tr_name)
                q, v, failed = ta.q, ta.v, ta.failed
            wall = time.perf_counter() - t0
            e = errors(q, v, q_ref, v_ref, Mechanism.from_scenario(sc))
            if tr_name in worst:
                worst[tr_name] = max(worst[tr_name], e["dq"])
            if failed:
                failures[tr_name] = failures.get(tr_name, 0) + 1
            print(f"{name:<10} {sc.gamma:9.3g} {e['max_delta']:10.3g} {tr_name:<16} {e['dq']:10.2e} "
                  f"{e['dv']:11.2e} {e['ddelta_rel']:13.2e} {'yes' if failed else 'no':>6} {wall:7.2f}")
        print(f"{'':<10} reference took {ref_s:.1f} s")
    print(f"worst max|dq|: caekf-truth {worst['c']:.2e} m" + (f", numpy {worst['numpy']:.2e} m" if args.numpy else ""))
    print(f"failures: caekf-truth {failures['c']}/{len(cases)}, backward Euler (Newton) "
          f"{failures['c-backward-euler']}/{len(cases)}")
    return 0
