"""Estimator settings for the C binding, and the one place that knows their names.

Everything of caekf_sim that depends on the names of the C settings (caekf_settings_t) or on how a
scenario and an experiment map to settings goes through this module:

* :class:`Settings` mirrors caekf_settings_t field by field (model parameters flattened), in SI units;
* :func:`settings_for` maps (scenario, experiment) to settings by calling the C builder that caekf-replay
  runs (host/common/experiment.c, through the binding), so the rule is never written twice;
* :data:`TUNABLE_NOISE` names the noise settings `caekf-sim tune` may change, and :func:`scenario_with_noise`
  writes them back into a scenario.

When the settings schema and its generated dataclass land, this module is what changes.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Tuple

from .scenario import Scenario

PRECISIONS = ("double", "float")

# C enums <-> names. An unknown name maps to -1, which caekf_settings_validate refuses with the field's
# name, so the message is the C code's.
_ENUMS: Dict[str, Tuple[str, ...]] = {
    "mode": ("canonical", "switched"),
    "switchoff": ("consistent", "paper"),
    "cov_update": ("standard", "joseph"),
}
_BOOLS = ("constraint_enabled", "cov_repair_enabled")

Vec4 = Tuple[float, float, float, float]


@dataclass(frozen=True)
class Settings:
    """caekf_settings_t in SI units, for one precision of the C core.

    Defaults and ranges are the C code's (caekf_settings_default / caekf_settings_validate); build a
    complete instance with :func:`settings_for` or :func:`default_settings`. ``precision`` records the
    build the values were made for: ``newton_rtol`` defaults to 256 machine epsilons of that scalar type.
    """

    # model (caekf_model_params_t)
    m: Vec4  # masses [kg]
    k1: float  # springs [N/m]
    k12: float
    k34: float
    k4: float
    c1: float  # dampers [N s/m]
    c12: float
    c34: float
    c4: float
    gap: float  # contact gap [m]
    dt: float  # step [s]
    # initial estimate and its standard deviations (P0 diagonal)
    q0: Vec4  # [m]
    v0: Vec4  # [m/s]
    gamma0: float  # [N/m^1.5]
    sigma_q0: float  # [m]
    sigma_v0: float  # [m/s]
    sigma_gamma0: float  # [N/m^1.5]
    # process noise std per step (Q diagonal) and measurement noise std (R diagonal)
    sigma_qx_q: float  # [m]
    sigma_qx_v: float  # [m/s]
    sigma_q_gamma: float  # [N/m^1.5]; Q_gamma = q_gamma_scale * sigma_q_gamma^2
    q_gamma_scale: float
    sigma_r: float  # [m]
    mode: str  # "canonical" | "switched"
    switchoff: str  # "consistent" | "paper"
    cov_update: str  # "standard" | "joseph"
    constraint_enabled: bool  # gamma >= gamma_min by perfect measurement
    gamma_min: float  # [N/m^1.5]
    cov_repair_enabled: bool
    psd_check_period: int  # steps
    gamma_gate_nis: float  # NIS above which gamma is held (0: off)
    newton_max_iter: int
    newton_rtol: float
    precision: str = "double"  # the C build these values are for: "double" | "float"

    def replace(self, **changes: Any) -> "Settings":
        """Copy with some fields changed; unknown names are a one-line error."""
        bad = sorted(set(changes) - set(field_names()))
        if bad:
            raise ValueError(f"unknown setting(s) {', '.join(bad)}")
        return dataclasses.replace(self, **changes)

    def to_c(self) -> Dict[str, Any]:
        """The dict the C module reads (enums as their C values)."""
        d: Dict[str, Any] = {}
        for f in dataclasses.fields(self):
            if f.name == "precision":
                continue
            v = getattr(self, f.name)
            if f.name in _ENUMS:
                v = _ENUMS[f.name].index(v) if v in _ENUMS[f.name] else -1
            elif f.name in _BOOLS:
                v = int(v)
            d[f.name] = v
        return d

    @classmethod
    def from_c(cls, d: Mapping[str, Any], precision: str) -> "Settings":
        """From the C module's dict (as caekf_settings_t holds them, read back as Python floats)."""
        v: Dict[str, Any] = dict(d)
        for name, names in _ENUMS.items():
            v[name] = names[v[name]] if 0 <= v[name] < len(names) else str(v[name])
        for name in _BOOLS:
            v[name] = bool(v[name])
        for name in ("m", "q0", "v0"):
            v[name] = tuple(v[name])
        return cls(precision=precision, **v)


def field_names() -> Tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(Settings))


def check_precision(precision: str) -> str:
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}")
    return precision


def scenario_dict(sc: Scenario) -> Dict[str, float]:
    """The scenario as the C struct caekf_scenario_t holds it (all doubles)."""
    return {f.name: float(getattr(sc, f.name)) for f in dataclasses.fields(sc)}


def settings_for(sc: Scenario, experiment: str = "switched", precision: str = "double", **overrides: Any) -> Settings:
    """Settings of one of the paper's experiments on scenario `sc`, as caekf-replay builds them.

    The mapping is the C function caekf_experiment_settings (host/common/experiment.c) of the `precision`
    build, called through the binding: experiment in canonical | switched | switched-highq |
    switched-highq-constrained. `overrides` then change single fields (e.g. gamma_gate_nis=0).
    """
    from .binding import _module  # the binding imports this module: import here, not at the top

    c = _module(check_precision(precision))
    s = Settings.from_c(c.experiment_settings(scenario_dict(sc), experiment), precision)
    return s.replace(**overrides) if overrides else s


def default_settings(precision: str = "double", **values: Any) -> Settings:
    """caekf_settings_default of the `precision` build (zero model: fill it through `values`)."""
    from .binding import _module

    s = Settings.from_c(_module(check_precision(precision)).settings_default(), precision)
    return s.replace(**values) if values else s


# --- noise tuning (caekf-sim tune) ------------------------------------------------------------------

# The noise standard deviations tune may change: the same names in Settings and in the scenario file.
TUNABLE_NOISE: Tuple[str, ...] = ("sigma_qx_q", "sigma_qx_v", "sigma_q_gamma", "sigma_r")


def noise_of(sc: Scenario) -> Dict[str, float]:
    return {n: float(getattr(sc, n)) for n in TUNABLE_NOISE}


def scenario_with_noise(sc: Scenario, noise: Mapping[str, float]) -> Scenario:
    """The scenario with some of TUNABLE_NOISE replaced (what `tune` writes)."""
    bad = sorted(set(noise) - set(TUNABLE_NOISE))
    if bad:
        raise ValueError(f"not a tunable noise setting: {', '.join(bad)}")
    return sc.replace(**{k: float(v) for k, v in noise.items()})


def scenario_toml(sc: Scenario, header: str = "") -> str:
    """The scenario as a flat `key = value` file, the format of sim/scenarios/paper.toml that the C
    reader (host/common/scenario.c) and the bench load as they are. Values keep every bit (repr)."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    for f in dataclasses.fields(sc):
        v = getattr(sc, f.name)
        lines.append(f"{f.name} = {int(v) if isinstance(v, int) else repr(float(v))}")
    return "\n".join(lines) + "\n"
