"""Families of beams hitting a stop (docs/structure.md): a spec of draws, its runs on a process pool or a Dask
cluster, and the issue's targets as a table.

Spec (TOML):

    [family]
    name = "beams"
    kind = "beam"            # what `caekf-sim campaign` dispatches on
    runs = 200
    seed = 20261129
    dt = 1.0e-4              # sampling and filter step [s]
    t_end = 5.0              # [s]
    truth_substeps = 10      # the full model's steps per sample

    [draw]                   # campaign.spec's distributions (uniform, loguniform, integers, choice, ...)
    length = { dist = "uniform", low = 0.25, high = 0.6 }
    ...

Keys of [draw]: length, width, thickness [m]; gap [m]; gamma [N/m^1.5]; modes (the filter's elastic modes, the
stop's attachment shape comes on top); closing (forcing amplitude over the static force that closes the gap);
freq_ratio (forcing frequency over the first natural frequency); noise_fraction (each sensor's white noise over
its rms); gamma0_ratio (the filter's initial gamma over the truth's).
"""
from __future__ import annotations

import dataclasses
import math
import tomllib
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Mapping, Optional, Sequence

import numpy as np

from .beam import BeamSpec, assemble, closing_force
from .example import admitted, run_beam

DRAWN = ("length", "width", "thickness", "gap", "gamma", "modes", "closing", "freq_ratio", "noise_fraction",
         "gamma0_ratio")
# The filter's modes: a count (`modes`), or every mode below a cutoff drawn as a fraction of the sampling rate
# (`cutoff`), as an FE user reduces to a frequency band; at least MIN_MODES either way.
MODE_KEYS = ("modes", "cutoff")
MIN_MODES = 4


@dataclass(frozen=True)
class BeamFamily:
    name: str
    runs: int
    seed: int
    dt: float
    t_end: float
    truth_substeps: int
    draws: Mapping[str, Any]


@dataclass(frozen=True)
class BeamCase:
    index: int
    spec: BeamSpec
    modes: int
    noise_fraction: float
    gamma0_ratio: float
    seed: int


def is_beam_spec(path: Path) -> bool:
    """Whether a family spec file describes beams ([family] kind = "beam")."""
    if not path.is_file():
        return False
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    return raw.get("family", {}).get("kind") == "beam"


def load_beam_family(path: Path, runs: Optional[int] = None, seed: Optional[int] = None,
                     t_end: Optional[float] = None) -> BeamFamily:
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    fam, draws = raw.get("family", {}), raw.get("draw", {})
    missing = [k for k in DRAWN if k not in draws and k != "modes"]
    if missing:
        raise ValueError(f"{path}: [draw] misses {missing[0]!r} (a beam family draws {', '.join(DRAWN)})")
    if sum(k in draws for k in MODE_KEYS) != 1:
        raise ValueError(f"{path}: [draw] gives the filter's modes by exactly one of {', '.join(MODE_KEYS)}")
    unknown = sorted(set(draws) - set(DRAWN) - set(MODE_KEYS))
    if unknown:
        raise ValueError(f"{path}: [draw] has unknown key {unknown[0]!r}")
    return BeamFamily(name=str(fam.get("name", path.stem)), runs=int(runs or fam.get("runs", 200)),
                      seed=int(seed if seed is not None else fam.get("seed", 1)), dt=float(fam.get("dt", 1e-4)),
                      t_end=float(t_end or fam.get("t_end", 5.0)), truth_substeps=int(fam.get("truth_substeps", 10)),
                      draws=draws)


def cases(family: BeamFamily) -> List[BeamCase]:
    """Run i draws from SeedSequence(seed).spawn(runs)[i], in DRAWN's order (as the campaigns do)."""
    from ..campaign.spec import draw

    out = []
    for i, ss in enumerate(np.random.SeedSequence(family.seed).spawn(family.runs)):
        rng = np.random.default_rng(ss)
        v = {k: draw(rng, k, family.draws[k]) for k in DRAWN + ("cutoff",) if k in family.draws}
        spec = BeamSpec(length=v["length"], width=v["width"], thickness=v["thickness"], gap=v["gap"],
                        gamma=v["gamma"])
        full, info = assemble(spec)
        if "cutoff" in v:  # every mode below the cutoff
            v["modes"] = max(MIN_MODES, int(np.sum(info.omega / (2 * math.pi) < v["cutoff"] / family.dt)))
        spec = dataclasses.replace(spec, force_amp=v["closing"] * closing_force(full, spec.gap),
                                   force_freq=v["freq_ratio"] * float(info.omega[0]) / (2 * math.pi))
        out.append(BeamCase(i, spec, int(v["modes"]), v["noise_fraction"], v["gamma0_ratio"],
                            int(rng.integers(1, 2**31 - 1))))
    return out


def run_case(case: BeamCase, dt: float, t_end: float, substeps: int) -> Dict[str, Any]:
    """One run's metrics (never raises for a failed estimate: the failure is a row)."""
    try:
        r = run_beam(case.spec, case.modes, dt=dt, t_end=t_end, substeps=substeps,
                     noise_fraction=case.noise_fraction, gamma0_ratio=case.gamma0_ratio, seed=case.seed)
        row = dict(r.metrics)
    except (ValueError, RuntimeError, np.linalg.LinAlgError) as exc:
        row = {"error": f"{type(exc).__name__}: {exc}", "diverged_worst": True, "consistent_3sigma_worst": False,
               "abs_final_err_worst": math.inf, "flagged_mismatch_end": False, "modes": case.modes}
    row["run"] = case.index
    row["admitted"] = admitted(row)
    return row


def run_family(family: BeamFamily, workers: Optional[int] = None, scheduler: Optional[str] = None,
               progress: bool = True) -> List[Dict[str, Any]]:
    todo = cases(family)
    args = (family.dt, family.t_end, family.truth_substeps)
    if scheduler:
        from dask.distributed import Client

        with Client(scheduler) as client:
            futures = client.map(run_case, todo, *[[a] * len(todo) for a in args], pure=False)
            rows = client.gather(futures)
    else:
        from tqdm import tqdm

        with ProcessPoolExecutor(max_workers=workers) as pool:
            it = pool.map(run_case, todo, *[[a] * len(todo) for a in args])
            rows = list(tqdm(it, total=len(todo), disable=not progress, desc=family.name))
    return sorted(rows, key=lambda r: r["run"])


def summary(rows: Sequence[Dict[str, Any]]) -> Dict[str, Any]:
    """The issue's figures over the rows: admitted runs within 2 %, diverged, within 3 sigma over every run."""
    n = len(rows)
    adm = [r for r in rows if r.get("admitted")]
    err = lambda r: float(r.get("abs_final_err_worst", math.inf))  # noqa: E731
    return {"runs": n, "admitted": len(adm),
            "admitted_within_2pct": sum(err(r) <= 0.02 for r in adm),
            "admitted_diverged": sum(bool(r.get("diverged_worst")) for r in adm),
            "within_1pct": sum(err(r) <= 0.01 for r in rows), "within_2pct": sum(err(r) <= 0.02 for r in rows),
            "diverged": sum(bool(r.get("diverged_worst")) for r in rows),
            "within_3sigma": sum(bool(r.get("consistent_3sigma_worst")) for r in rows),
            "flagged_mismatch": sum(bool(r.get("flagged_mismatch_end")) for r in rows),
            "silent_wrong": sum(bool(r.get("silent_wrong", True)) for r in rows)}


def format_targets(s: Dict[str, Any]) -> str:
    """The targets table (issue: any linear structure with contacts)."""
    def pct(k: int, n: int) -> str:
        return f"{k}/{n} ({100.0 * k / n:.1f} %)" if n else "0/0"

    a, n = s["admitted"], s["runs"]
    rows = [("runs the bound admits (3 CRB <= 2 %)", pct(a, n), "printed", "-"),
            ("admitted within 2 %", pct(s["admitted_within_2pct"], a), ">= 90 %",
             "met" if a and s["admitted_within_2pct"] >= 0.9 * a else "NOT met"),
            ("admitted diverged", str(s["admitted_diverged"]), "0",
             "met" if s["admitted_diverged"] == 0 else "NOT met"),
            ("within 3 sigma of P (every run)", pct(s["within_3sigma"], n), ">= 95 %",
             "met" if n and s["within_3sigma"] >= 0.95 * n else "NOT met")]
    w = [max(len(r[i]) for r in rows + [("target", "value", "needs", "verdict")]) for i in range(4)]
    line = lambda r: "| " + " | ".join(c.ljust(w[i]) for i, c in enumerate(r)) + " |"  # noqa: E731
    out = [line(("target", "value", "needs", "verdict")), "|" + "|".join("-" * (x + 2) for x in w) + "|"]
    out += [line(r) for r in rows]
    out.append(f"also: within 1 % {s['within_1pct']}, within 2 % {s['within_2pct']}, diverged {s['diverged']}, "
               f"flagged model_mismatch at the end {s['flagged_mismatch']}, silent wrong {s['silent_wrong']} "
               f"(of {n})")
    return "\n".join(out)


def by_modes(rows: Sequence[Dict[str, Any]]) -> str:
    """Within 2 % and within 3 sigma per filter mode count."""
    out = ["| modes | runs | within 2 % | within 3 sigma | flagged | diverged |", "|---|---|---|---|---|---|"]
    for m in sorted({int(r.get("modes", 0)) for r in rows}):
        g = [r for r in rows if int(r.get("modes", 0)) == m]
        out.append(f"| {m} | {len(g)} | {sum(float(r.get('abs_final_err_worst', math.inf)) <= 0.02 for r in g)} | "
                   f"{sum(bool(r.get('consistent_3sigma_worst')) for r in g)} | "
                   f"{sum(bool(r.get('flagged_mismatch_end')) for r in g)} | "
                   f"{sum(bool(r.get('diverged_worst')) for r in g)} |")
    return "\n".join(out)
