"""Family specs: randomised mechanism families drawn from a TOML file, or a folder of scenarios.

A spec (format in docs/family.md) names a base scenario, the distributions to draw ([draw], in
order), derived values ([set], small arithmetic expressions) and the splits of the family table.
Run i draws from numpy's generator on SeedSequence(seed).spawn(runs)[i]: the same spec gives the
same mechanisms, and run i does not depend on how many runs there are after it.
The sampler knows nothing of the mechanism: every name that is a Scenario field sets it, so the
family grows with the scenario format.
A [mismatch] table makes the truth differ from the filter's model (issue 27): every mass, spring and damper
of the truth off by a log-normal factor, the force the filter reads with white noise; both drawn from the
run's generator after the family's draws, so the filter's scenario is the one the spec gives without it.
"""
from __future__ import annotations

import ast
import dataclasses
import math
import operator
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Dict, List, Mapping, Optional, Tuple, Union

import numpy as np

from ..scenario import Scenario, load_scenario
from ..schema import ALIASES, SCHEMA, canonical, setting_of
from .structure import count_key, draw_structure, forcing

if sys.version_info >= (3, 11):
    import tomllib
else:  # pragma: no cover
    import tomli as tomllib

PathLike = Union[str, Path]
SCENARIO_FIELDS = {f.name: f for f in dataclasses.fields(Scenario)}
INT_FIELDS = {n for n, f in SCENARIO_FIELDS.items() if f.type in ("int", int)}


@dataclass(frozen=True)
class Split:
    """One split of the family table: bins over a run value (edges) or its distinct values."""

    name: str
    edges: Optional[Tuple[float, ...]] = None
    values: Optional[Tuple[float, ...]] = None

    def labels(self) -> List[str]:
        if self.values is not None:
            return [f"{self.name} = {v:g}" for v in self.values]
        e = self.edges or ()
        return [f"{self.name} {a:g}-{b:g}" for a, b in zip(e[:-1], e[1:])]

    def index(self, x: np.ndarray) -> np.ndarray:
        """Bin of each value (-1 outside every bin)."""
        x = np.asarray(x, dtype=float)
        if self.values is not None:
            out = np.full(x.shape, -1)
            for i, v in enumerate(self.values):
                out[np.isclose(x, v, rtol=1e-12, atol=0.0)] = i
            return out
        e = np.asarray(self.edges, dtype=float)
        idx = np.searchsorted(e, x, side="right") - 1
        idx[x == e[-1]] = len(e) - 2  # the last edge closes the last bin
        idx[(x < e[0]) | (x > e[-1])] = -1
        return idx


@dataclass(frozen=True)
class Run:
    """One mechanism of a family: its id, scenario (the filter's model, and the truth's unless [mismatch]
    says otherwise) and every drawn or set value by name.

    With [mismatch]: `truth_factors` multiply the truth's masses, springs and dampers ((key, factor), the
    scenario's keys); the filter reads each input i as the true force plus white noise of std
    `input_noise_std[i]` [N], drawn from default_rng(input_noise_seed)."""

    run: int
    scenario: Scenario
    values: Dict[str, float]
    source: str = ""
    truth_factors: Tuple[Tuple[str, float], ...] = ()
    input_noise_std: Tuple[float, ...] = ()
    input_noise_seed: Optional[int] = None

    @property
    def mismatched(self) -> bool:
        return bool(self.truth_factors) or any(s > 0 for s in self.input_noise_std)

    def truth_scenario(self) -> Scenario:
        """The scenario the truth simulates: the filter's with the truth factors applied."""
        if not self.truth_factors:
            return self.scenario
        return self.scenario.replace(**{k: getattr(self.scenario, k) * f for k, f in self.truth_factors})

    def input_noise(self, n: int) -> Optional[np.ndarray]:
        """The noise the filter's inputs carry, (n,) for one input else (n, inputs) [N]; None without."""
        if not any(s > 0 for s in self.input_noise_std):
            return None
        rng = np.random.default_rng(self.input_noise_seed)
        noise = rng.standard_normal((n, len(self.input_noise_std))) * np.asarray(self.input_noise_std, float)
        return noise[:, 0] if noise.shape[1] == 1 else noise


@dataclass(frozen=True)
class Family:
    name: str
    runs: Tuple[Run, ...]
    splits: Tuple[Split, ...] = ()
    drawn: Tuple[str, ...] = ()  # names varied across the family (plots against each)
    seed: Optional[int] = None
    targets: Tuple[Tuple[str, float], ...] = ()  # the spec's [targets]: (name, bound), checked over all runs
    mismatch: Tuple[Tuple[str, float], ...] = ()  # the spec's [mismatch]: how the truth differs from the model


# [targets]: what a family must reach, each a bound on one column of the family tables over the group "all":
# a fraction of the runs (at least) or a count (at most); the joint ones count the runs whose bound allows
# the targets.
TARGETS: Dict[str, str] = {
    "within_1pct": "fraction", "within_5pct": "fraction", "diverged": "count", "consistent_3sigma": "fraction",
    "joint_ok": "fraction", "joint_diverged": "count",
    # issue 27: a run is silently wrong when it ends neither within 3 sigma nor flagged model_mismatch
    "not_silent_wrong": "fraction",
    # issue 27: over the runs the Cramer-Rao bound of gamma, every declared parameter unknown, admits
    # (--observability; runner.admission_verdict): the fraction within 2 % and the count diverged
    "within_2pct_admitted": "fraction", "diverged_admitted": "count",
}

# [mismatch]: how the truth differs from the filter's model (docs/family.md).
MISMATCH_KEYS = ("params_lognormal_sigma", "input_noise_rel")
# the settings whose every element in use the truth draws a factor for, in this order
MISMATCH_SETTINGS = ("m", "spring_k", "spring_c")


# ---------------------------------------------------------------- expressions

_BINOPS: Dict[type, Callable[[float, float], float]] = {
    ast.Add: operator.add, ast.Sub: operator.sub, ast.Mult: operator.mul, ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_FUNCS: Dict[str, Callable[..., float]] = {"min": min, "max": max, "sqrt": math.sqrt, "exp": math.exp,
                                          "log": math.log, "log10": math.log10, "abs": abs}


def evaluate(expr: str, names: Mapping[str, float]) -> float:
    """Value of a small arithmetic expression over known names (no attribute access, no calls
    other than min, max, sqrt, exp, log, log10, abs; constant pi)."""

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Expression):
            return ev(node.body)
        if isinstance(node, ast.Constant) and isinstance(node.value, (int, float)):
            return float(node.value)
        if isinstance(node, ast.Name):
            if node.id == "pi":
                return math.pi
            if node.id not in names:
                raise ValueError(f"unknown name {node.id!r} in {expr!r}")
            return float(names[node.id])
        if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
            return _BINOPS[type(node.op)](ev(node.left), ev(node.right))
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, (ast.USub, ast.UAdd)):
            v = ev(node.operand)
            return -v if isinstance(node.op, ast.USub) else v
        if (isinstance(node, ast.Call) and isinstance(node.func, ast.Name) and node.func.id in _FUNCS
                and not node.keywords):
            return float(_FUNCS[node.func.id](*[ev(a) for a in node.args]))
        raise ValueError(f"unsupported expression {expr!r}")

    return ev(ast.parse(expr, mode="eval"))


# ---------------------------------------------------------------- distributions

def draw(rng: np.random.Generator, name: str, d: Mapping[str, Any]) -> float:
    """One value of distribution d (uniform, loguniform, choice, integers, normal, fixed)."""
    kind = d.get("dist")
    extra = sorted(set(d) - {"dist", "low", "high", "values", "mean", "std", "value", "over"})
    if extra:
        raise ValueError(f"{name}: unknown key(s) {', '.join(extra)} in its distribution")
    if kind == "uniform":
        return float(rng.uniform(float(d["low"]), float(d["high"])))
    if kind == "loguniform":
        lo, hi = float(d["low"]), float(d["high"])
        if not 0 < lo <= hi:
            raise ValueError(f"{name}: loguniform needs 0 < low <= high")
        return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))
    if kind == "choice":
        vals = [float(v) for v in d["values"]]
        return vals[int(rng.integers(len(vals)))]
    if kind == "integers":
        return float(rng.integers(int(d["low"]), int(d["high"])))
    if kind == "normal":
        return float(rng.normal(float(d["mean"]), float(d["std"])))
    if kind == "fixed":
        return float(d["value"])
    raise ValueError(f"{name}: unknown dist {kind!r} (uniform, loguniform, choice, integers, normal, fixed)")


# ---------------------------------------------------------------- loading

def scenario_from_values(base: Scenario, values: Mapping[str, float]) -> Scenario:
    """base with the drawn values of its keys (aliases such as k12 included; other names are ignored), checked
    against the schema's ranges (ScenarioError)."""
    changes: Dict[str, Any] = {}
    for k, v in values.items():
        key = canonical(k)
        if key in SCENARIO_FIELDS:
            changes[key] = int(round(v)) if key in INT_FIELDS else float(v)
    return base.replace(**changes)


def load_spec(path: PathLike, runs: Optional[int] = None, seed: Optional[int] = None,
              t_end: Optional[float] = None) -> Family:
    """Family of a spec file; runs, seed and t_end override the spec's."""
    path = Path(path)
    with open(path, "rb") as f:
        try:
            spec = tomllib.load(f)
        except (UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
            raise ValueError(f"{path}: not a TOML family spec: {exc}") from None
    unknown = sorted(set(spec) - {"family", "structure", "draw", "set", "split", "targets", "mismatch"})
    if unknown:
        raise ValueError(f"{path}: unknown tables {unknown} (family, structure, draw, set, split, targets, "
                         "mismatch)")
    mismatch = _mismatch_table(spec.get("mismatch", {}), path)
    targets = spec.get("targets", {})
    unknown = sorted(set(targets) - set(TARGETS))
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)} in [targets] ({', '.join(TARGETS)})")
    for k, v in targets.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not v >= 0 or \
                (TARGETS[k] == "fraction" and v > 1):
            raise ValueError(f"{path}: [targets] {k} = {v!r}: must be a "
                             + ("fraction in [0, 1]" if TARGETS[k] == "fraction" else "count >= 0"))
    if "family" not in spec:
        raise ValueError(f"{path}: no [family] table (docs/family.md)")
    fam = spec["family"]
    unknown = sorted(set(fam) - {"name", "runs", "seed", "base"})
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)} in [family] (name, runs, seed, base)")
    base_path = fam.get("base")
    if base_path is None:
        from ..scenario import default_scenario_path

        base_file = default_scenario_path()
    else:
        base_file = (path.parent / base_path).resolve()
    base = load_scenario(base_file)
    if t_end is not None:
        base = base.replace(t_end=t_end)
    n = int(runs if runs is not None else fam.get("runs", 100))
    root = int(seed if seed is not None else fam.get("seed", 0))
    structure: Optional[Dict[str, Any]] = spec.get("structure")
    draws: Dict[str, Any] = spec.get("draw", {})
    sets: Dict[str, str] = spec.get("set", {})
    out = []
    for i, ss in enumerate(np.random.SeedSequence(root).spawn(n)):
        rng = np.random.default_rng(ss)
        values: Dict[str, float] = {}
        try:
            if structure is not None:
                values.update(draw_structure(rng, structure, draw, f"{path}: run {i}"))
            for name, d in draws.items():
                for k, _ in _expand(name, d, {**base.values(), **values}, path):
                    values[k] = draw(rng, k, d)
            if structure is not None and "closing" in values:
                mech_values = {**base.values(), **{canonical(k): v for k, v in values.items()}}
                values.update(forcing(mech_values, values["closing"]))
            known = {**{k: float(v) for k, v in base.values().items()},
                     **{a: float(getattr(base, a)) for a in ALIASES}, **values}
            for name, expr in sets.items():
                for k, idx in _expand(name, None, known, path):
                    v = evaluate(str(expr) if idx is None else str(expr).replace("{i}", str(idx)), known)
                    values[k] = known[k] = v
            sc = scenario_from_values(base, values)
            run = _mismatched(Run(run=i, scenario=sc, values=values, source=str(path)), mismatch, rng)
            run.truth_scenario()  # the truth's values must be valid too
        except ValueError as exc:
            # a drawn value's refusal names the base scenario (Scenario.replace keeps its source): the spec's run
            # is the place to look
            msg = str(exc).replace(f"{base.source}: ", "")
            raise ValueError(msg if msg.startswith(f"{path}: run") else f"{path}: run {i}: {msg}") from None
        out.append(run)
    splits = tuple(
        Split(name=s["name"], edges=tuple(float(e) for e in s["edges"]) if "edges" in s else None,
              values=tuple(float(v) for v in s["values"]) if "values" in s else None)
        for s in spec.get("split", [])
    )
    varied = [k for k in (structure or {}) if k in ("bodies", "contacts", "closing")]
    varied += [name.replace("{i}", "1") for name in draws]  # a template: its first element
    return Family(name=str(fam.get("name", path.stem)), runs=tuple(out), splits=splits,
                  drawn=tuple(varied), seed=root, targets=tuple((k, float(v)) for k, v in targets.items()),
                  mismatch=tuple(mismatch.items()))


def _mismatch_table(table: Mapping[str, Any], path: Path) -> Dict[str, float]:
    """The spec's [mismatch] values, checked (each a number >= 0)."""
    unknown = sorted(set(table) - set(MISMATCH_KEYS))
    if unknown:
        raise ValueError(f"{path}: unknown key(s) {', '.join(unknown)} in [mismatch] ({', '.join(MISMATCH_KEYS)})")
    out = {}
    for k, v in table.items():
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (v >= 0 and math.isfinite(v)):
            raise ValueError(f"{path}: [mismatch] {k} = {v!r}: must be a number >= 0")
        out[k] = float(v)
    return out


def _mismatched(run: Run, mismatch: Mapping[str, float], rng: np.random.Generator) -> Run:
    """run with the spec's [mismatch] drawn from its generator (after every draw of the family): a factor
    exp(sigma N(0,1)) for each mass, spring and damper in use (MISMATCH_SETTINGS, element by element), then
    the input-noise seed. The filter's scenario is left as it is; the values gain `truth_factor_<key>`, the
    [mismatch] values and `input_noise_seed`."""
    if not mismatch:
        return run
    sc, values = run.scenario, dict(run.values)
    factors: List[Tuple[str, float]] = []
    sigma = mismatch.get("params_lognormal_sigma")
    if sigma is not None:
        in_use = sc.values()
        keys = [k for name in MISMATCH_SETTINGS for k in SCHEMA.by_name(name).keys if k in in_use]
        for k in keys:
            factors.append((k, float(math.exp(sigma * rng.standard_normal()))))
        values["params_lognormal_sigma"] = sigma
        values.update({f"truth_factor_{k}": f for k, f in factors})
    rel = mismatch.get("input_noise_rel")
    std: Tuple[float, ...] = ()
    seed = None
    if rel is not None:
        seed = int(rng.integers(1, 2**31 - 1))
        std = tuple(rel * abs(float(getattr(sc, k))) for k in SCHEMA.by_name("input_amp").keys[:int(sc.inputs)])
        values["input_noise_rel"] = rel
        values["input_noise_seed"] = float(seed)
    return dataclasses.replace(run, values=values, truth_factors=tuple(factors), input_noise_std=std,
                               input_noise_seed=seed)


def _expand(name: str, d: Any, known: Mapping[str, float], path: Path) -> List[Tuple[str, Optional[int]]]:
    """The names a [draw] or [set] entry stands for: itself, or for a template with "{i}" (`m{i}`,
    `contact{i}_gamma0`) one name per element in use, i = 1..count; the count is that of the schema setting
    the key belongs to (bodies, springs, inputs, sensors, contacts), or of the capacity named by `over`
    for an auxiliary name (`gamma0_ratio{i} = {..., over = "contacts"}`)."""
    if "{i}" not in name:
        return [(name, None)]
    over = d.get("over") if isinstance(d, Mapping) else None
    if over is not None:
        if over not in SCHEMA.capacity:
            raise ValueError(f"{path}: {name}: over = {over!r}, not one of {', '.join(SCHEMA.capacity)}")
        counter = count_key(over)
    else:
        try:
            setting = setting_of(canonical(name.replace("{i}", "1")))
        except KeyError:
            raise ValueError(f"{path}: {name}: not a scenario key pattern; an auxiliary template needs "
                             "over = \"bodies\" | \"springs\" | \"inputs\" | \"sensors\" | \"contacts\"") from None
        if setting.in_use_by is None:
            raise ValueError(f"{path}: {name}: {setting.name} is not an array over the mechanism's elements")
        counter = SCHEMA.by_name(setting.in_use_by).keys[0]
    count = int(known.get(counter, SCHEMA.by_name(counter).default_value()))
    return [(name.replace("{i}", str(i)), i) for i in range(1, count + 1)]


def load_folder(folder: PathLike, t_end: Optional[float] = None) -> Family:
    """Family of every *.toml scenario in a folder (sorted by name); values are the scenario's."""
    files = sorted(Path(folder).glob("*.toml"))
    if not files:
        raise ValueError(f"{folder}: no *.toml scenario files")
    runs = []
    for i, f in enumerate(files):
        sc = load_scenario(f)
        if t_end is not None:
            sc = sc.replace(t_end=t_end)
        values = {k: float(getattr(sc, k)) for k in SCENARIO_FIELDS}
        values["gamma0_ratio"] = sc.gamma0 / sc.gamma
        runs.append(Run(run=i, scenario=sc, values=values, source=str(f)))
    varied = tuple(k for k in SCENARIO_FIELDS if len({r.values[k] for r in runs}) > 1)
    return Family(name=Path(folder).name, runs=tuple(runs), drawn=varied)


def load_family(spec_or_folder: PathLike, runs: Optional[int] = None, seed: Optional[int] = None,
                t_end: Optional[float] = None) -> Family:
    p = Path(spec_or_folder)
    if p.is_dir():
        return load_folder(p, t_end=t_end)
    if not p.exists():
        raise ValueError(f"{p}: no such spec file or folder")
    return load_spec(p, runs=runs, seed=seed, t_end=t_end)


def scenario_text(sc: Scenario) -> str:
    """A scenario file (flat key = value, %.17g) for the C tools."""
    lines = []
    for name, v in sc.values().items():
        lines.append(f"{name} = {int(v):d}" if name in INT_FIELDS else f"{name} = {float(v):.17g}")
    return "\n".join(lines) + "\n"
