"""Estimator settings for the C binding, by the settings schema.

A :class:`Settings` holds one value per CTRL_PARAM parameter id (the schema's ids; the C module sets them
with caekf_settings_set), read and changed by the scenario keys (``s.sigma_r``, ``s.m3``,
``s.replace(mode="canonical")``). No setting is listed here: the names, enum values and defaults are the
schema's (caekf_sim.schema), and a scenario maps to settings through the C function caekf-replay runs
(caekf_scenario_settings, host/common/scenario.c). TUNABLE_NOISE names the noise settings
`caekf-sim tune` may change.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, Dict, Mapping, Optional, Sequence, Tuple

from . import schema
from .scenario import Scenario

PRECISIONS = ("double", "float")


@dataclass(frozen=True)
class Settings:
    """caekf_settings_t of one precision as values by parameter id (SI units, enums as their numbers).

    Read a value by its scenario key (``s.gamma0``, ``s.m2``); :meth:`as_dict` gives them all. Build one
    with caekf_sim.binding's :func:`settings_for` (a scenario and an optional preset) or
    :func:`default_settings`, which ask the C module.
    ``precision`` records the build the values were made for (``newton_rtol`` defaults to 256 machine
    epsilons of that scalar type).
    """

    values: Tuple[float, ...]
    precision: str = "double"

    def __getattr__(self, key: str) -> float:
        ids = schema.param_ids()
        key = schema.canonical(key)
        if key in ids:
            return self.values[ids[key]]
        raise AttributeError(f"no setting {key!r}")

    def as_dict(self) -> Dict[str, float]:
        """Every setting by its scenario key."""
        return {k: self.values[i] for k, i in schema.param_ids().items()}

    def replace(self, **changes: Any) -> "Settings":
        """Copy with some settings changed, by scenario key; enums by name or number. Unknown keys are a
        one-line error; ranges are the C validation's business (at Estimator construction)."""
        ids = schema.param_ids()
        values = list(self.values)
        for key, v in changes.items():
            key = schema.canonical(key)
            if key not in ids:
                raise ValueError(f"unknown setting {key!r}")
            setting = schema.setting_of(key)
            if isinstance(v, str):
                if v not in setting.values:
                    raise ValueError(f"{key} = {v!r}: {setting.rule_text()}")
                v = setting.values.index(v)
            values[ids[key]] = float(v)
        return Settings(tuple(values), self.precision)

    def to_c(self) -> Tuple[float, ...]:
        """The values the C module reads (one per parameter id)."""
        return self.values


def field_names() -> Tuple[str, ...]:
    """The settings' scenario keys, in parameter-id order."""
    return tuple(schema.param_ids())


def check_precision(precision: str) -> str:
    if precision not in PRECISIONS:
        raise ValueError(f"precision must be 'double' or 'float', got {precision!r}")
    return precision


def scenario_dict(sc: Scenario) -> Dict[str, float]:
    """The scenario as the C struct caekf_scenario_t holds it (all doubles)."""
    return {k: float(v) for k, v in dataclasses.asdict(sc).items()}


# --- noise tuning (caekf-sim tune) ------------------------------------------------------------------

# The noise standard deviations tune may change: the schema's noise settings that are standard
# deviations (sigma_*, and the measured inputs' input{i}_sigma; not the factor q_gamma_scale), by scenario key
# (per contact: contact{i}_sigma_q_gamma).
TUNABLE_NOISE: Tuple[str, ...] = tuple(k for k, s, _ in schema.SCHEMA.keys()
                                       if s.kind == "noise" and (s.name.startswith("sigma_")
                                                                 or s.name.endswith("_sigma")))


def tunable_noise(sc: Scenario) -> Tuple[str, ...]:
    """The noise keys `tune` searches by default for scenario `sc`: those of TUNABLE_NOISE its mechanism
    uses (contact{i}_sigma_q_gamma for its contacts) and sets > 0 (the search is on a log scale; a 0,
    e.g. sigma_rv without velocity sensors or input1_sigma for an exact force, stays off); sigma_q_mech only
    when a mechanism parameter is declared uncertain."""
    from .mechanism import mech_layout

    values = sc.values()
    declared = bool(mech_layout(sc))  # the mechanism parameters' drift acts only on declared ones
    return tuple(k for k in TUNABLE_NOISE if k in values and float(values[k]) > 0
                 and (k != "sigma_q_mech" or declared))


def noise_of(sc: Scenario, keys: Optional[Sequence[str]] = None) -> Dict[str, float]:
    """Values of noise keys (default: every key of TUNABLE_NOISE the scenario uses)."""
    values = sc.values()
    keys = [k for k in TUNABLE_NOISE if k in values] if keys is None else [schema.canonical(k) for k in keys]
    return {k: float(values[k]) for k in keys}


def scenario_with_noise(sc: Scenario, noise: Mapping[str, float]) -> Scenario:
    """The scenario with some of TUNABLE_NOISE replaced (what `tune` writes); keys or their aliases."""
    bad = sorted(k for k in noise if schema.canonical(k) not in TUNABLE_NOISE)
    if bad:
        raise ValueError(f"not a tunable noise setting: {', '.join(bad)}")
    return sc.replace(**{k: float(v) for k, v in noise.items()})


def scenario_toml(sc: Scenario, header: str = "") -> str:
    """The scenario as a flat `key = value` file, the format of sim/scenarios/paper.toml that the C
    reader (host/common/scenario.c) and the bench load as they are. Values keep every bit (repr); a
    default relative to the build's epsilon is left to the build."""
    lines = [f"# {line}" if line else "#" for line in header.splitlines()]
    wire = dict(schema.wire_values(sc.values()))
    for k, v in sc.values().items():
        if k in schema.param_ids() and k not in wire:
            continue
        lines.append(f"{k} = {int(v) if isinstance(v, int) else repr(float(v))}")
    return "\n".join(lines) + "\n"
