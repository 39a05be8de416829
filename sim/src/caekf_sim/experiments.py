"""The paper's four experiments (docs/scenario.md): the settings schema's presets, run on the numpy
reference estimator, and their summary table."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional

import numpy as np

from . import flags as fl
from . import schema
from .estimator import CANONICAL, SWITCHED, EstimateResult, EstimatorConfig, run_estimator
from .scenario import Scenario
from .truth import Truth


def _config(preset: schema.Preset) -> EstimatorConfig:
    """The numpy estimator's configuration of a preset (the gate is the C estimator's alone: on clean
    data it never fires, see README)."""
    def value(name: str) -> float:
        return preset.values.get(name, schema.SCHEMA.by_name(name).default_value())

    def enum(name: str) -> str:
        return schema.SCHEMA.by_name(name).values[int(value(name))]

    return EstimatorConfig(mode=CANONICAL if enum("mode") == "canonical" else SWITCHED,
                           q_gamma_scale=value("q_gamma_scale"), constrained=bool(value("constraint_enabled")),
                           discretisation=enum("discretisation"), contact_substeps=int(value("contact_substeps")),
                           contact_slr_p=value("contact_slr_p"))


EXPERIMENTS: Dict[str, EstimatorConfig] = {p.name: _config(p) for p in schema.SCHEMA.presets}
DEFAULT = "default"  # no preset: the scenario's own settings (scenario_config)


def scenario_config(sc: Scenario, name: Optional[str] = None) -> EstimatorConfig:
    """The configuration the C tools run: the scenario's estimator settings (mode, switchoff, cov_update,
    q_gamma_scale, constraint_enabled, gamma_gate_nis (0: off), newton_max_iter, discretisation,
    contact_substeps, gamma_log, law_second_order, contact_slr_p, the mismatch monitor's) with preset
    `name`'s values over them (None or "default": no preset); for the cross-check of caekf-replay and the
    binding on any mechanism."""
    values = {s.name: float(getattr(sc, s.keys[0])) for s in schema.SCHEMA.settings
              if s.name in ("mode", "switchoff", "cov_update", "q_gamma_scale", "constraint_enabled",
                            "gamma_gate_nis", "newton_max_iter", "discretisation", "contact_substeps",
                            "gamma_log", "law_second_order", "contact_slr_p", "mismatch_window",
                            "mismatch_ratio", "mismatch_adapt", "input_trend_window")}
    if name == DEFAULT:
        name = None
    if name is not None:
        values.update(schema.preset(name).values)

    def enum(key: str) -> str:
        v = values[key]
        return v if isinstance(v, str) else schema.SCHEMA.by_name(key).values[int(v)]

    gate = float(values["gamma_gate_nis"])
    return EstimatorConfig(mode=CANONICAL if enum("mode") == "canonical" else SWITCHED,
                           switch_variant=enum("switchoff"), q_gamma_scale=float(values["q_gamma_scale"]),
                           constrained=bool(values["constraint_enabled"]), joseph=enum("cov_update") == "joseph",
                           newton_max_iter=int(values["newton_max_iter"]), gate_nis=gate if gate > 0 else math.inf,
                           discretisation=enum("discretisation"), contact_substeps=int(values["contact_substeps"]),
                           gamma_log=bool(values["gamma_log"]), law_second_order=bool(values["law_second_order"]),
                           contact_slr_p=float(values["contact_slr_p"]),
                           mismatch_window=int(values["mismatch_window"]),
                           input_trend_window=int(values["input_trend_window"]),
                           mismatch_ratio=float(values["mismatch_ratio"]),
                           mismatch_adapt=bool(values["mismatch_adapt"]))


def experiment_config(name: str, **overrides) -> EstimatorConfig:
    if name not in EXPERIMENTS:
        raise KeyError(f"unknown experiment {name!r}; choose from {sorted(EXPERIMENTS)}")
    base = EXPERIMENTS[name]
    if not overrides:
        return base
    from dataclasses import replace

    return replace(base, **overrides)


def run_experiment(
    sc: Scenario, truth: Truth, name: str, keep_P: bool = True, progress: bool = False, **overrides
) -> EstimateResult:
    return run_estimator(
        sc, experiment_config(name, **overrides), truth.t, truth.u, truth.y, keep_P=keep_P,
        progress=progress,
    )


@dataclass(frozen=True)
class Summary:
    name: str
    final_gamma_error: float  # gamma_N / gamma_true - 1
    min_gamma: float
    max_p_norm: float
    newton_mean: float
    newton_max: int
    flags_seen: int
    steps_per_second: float

    def row(self) -> List[str]:
        return [
            self.name,
            f"{100 * self.final_gamma_error:+.3f} %" if np.isfinite(self.final_gamma_error) else "-",
            f"{self.min_gamma:.4g}",
            f"{self.max_p_norm:.3g}",
            f"{self.newton_mean:.3f}",
            str(self.newton_max),
            ",".join(fl.describe(self.flags_seen)) or "-",
            f"{self.steps_per_second:.0f}" if np.isfinite(self.steps_per_second) else "-",
        ]


def summarize(name: str, res: EstimateResult, gamma_true: float) -> Summary:
    g = res.gamma
    finite = g[np.isfinite(g)]
    return Summary(
        name=name,
        final_gamma_error=float(g[-1] / gamma_true - 1.0),
        min_gamma=float(finite.min()) if finite.size else float("nan"),
        max_p_norm=float(np.nanmax(res.p_norm)) if np.isfinite(res.p_norm).any() else float("nan"),
        newton_mean=float(res.newton_iters.mean()),
        newton_max=int(res.newton_iters.max()),
        flags_seen=int(np.bitwise_or.reduce(res.flags)),
        steps_per_second=res.steps_per_second,
    )


HEADER = ["experiment", "final gamma err", "min gamma", "max ||P||", "newton mean", "max",
          "flags seen", "steps/s"]


def format_table(rows: Iterable[Summary]) -> str:
    cells = [HEADER] + [s.row() for s in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(HEADER))]
    lines = ["  ".join(c.ljust(w) for c, w in zip(r, widths)).rstrip() for r in cells]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def run_all(
    sc: Scenario, truth: Truth, names: Optional[Iterable[str]] = None, keep_P: bool = False,
    progress: bool = False,
) -> Dict[str, EstimateResult]:
    return {
        n: run_experiment(sc, truth, n, keep_P=keep_P, progress=progress)
        for n in (names or EXPERIMENTS)
    }
