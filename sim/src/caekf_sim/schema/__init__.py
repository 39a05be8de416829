"""The settings schema (settings.toml): every setting and preset of caekf, described once.

The same loader serves the C generator (codegen.py, run by CMake) and the Python package, so the
Python `Scenario`, its validation and the bench's CTRL_PARAM ids come from the same description as
the firmware's tables.
"""
from __future__ import annotations

from typing import Dict, List, Optional, Tuple

from .codegen import Preset, Schema, SchemaError, Setting, load

SCHEMA: Schema = load()

__all__ = ["ALIASES", "SCHEMA", "canonical", "Preset", "Schema", "SchemaError", "Setting", "param_ids", "preset",
           "preset_names", "setting_of", "wire_values"]

_SETTING_OF_KEY: Dict[str, Setting] = {k: s for k, s, _ in SCHEMA.keys()}
ALIASES: Dict[str, str] = dict(SCHEMA.aliases())


def canonical(key: str) -> str:
    """The key a paper name stands for ("k12" -> "spring2_k"); other keys are returned as they are."""
    return ALIASES.get(key, key)

_SETTING_OF_KEY.update({a: _SETTING_OF_KEY[k] for a, k in SCHEMA.aliases()})


def setting_of(key: str) -> Setting:
    """The setting a scenario key belongs to ("m3" -> m); KeyError when there is none."""
    return _SETTING_OF_KEY[key]


def param_ids() -> Dict[str, int]:
    """CTRL_PARAM id of every wire key ("m3" -> 4); aliases are not wire keys (the DBC names ids by key)."""
    return {k: s.id + i for s in SCHEMA.wire for i, k in enumerate(s.keys)}  # type: ignore[operator]


def preset_names() -> List[str]:
    return [p.name for p in SCHEMA.presets]


def preset(name: str) -> Preset:
    for p in SCHEMA.presets:
        if p.name == name:
            return p
    raise KeyError(f"unknown preset {name!r}; choose from {', '.join(preset_names())}")


def wire_values(values: Dict[str, float], preset_name: Optional[str] = None,
                complete: bool = False) -> List[Tuple[str, float]]:
    """The CTRL_PARAM settings of a scenario (wire keys only) with a preset's values over them, in id
    order: exactly what the estimator needs to be configured over the bus. Enumerated settings at their
    default (mode, sensor kinds, ...) are left out unless `complete`: the bus configures from the running
    settings, so the bench sends them too, or a sensor kind or mode of an earlier configuration (another
    mechanism, another preset) would carry over."""
    ids = param_ids()
    out: Dict[str, float] = {}
    canonical = {**values, **{k: values[a] for a, k in SCHEMA.aliases() if a in values}}
    for key, setting, index in SCHEMA.keys():
        if key not in ids or key not in canonical or not SCHEMA.in_use(setting, index, canonical):
            continue
        # A default relative to the build's epsilon (newton_rtol) is the estimator's own business: it is
        # sent only when the scenario chose a value.
        if (isinstance(setting.default, str) and not (complete and setting.type == "enum")
                and float(canonical[key]) == setting.default_value()):
            continue
        out[key] = float(canonical[key])
    if preset_name is not None:
        for name, v in preset(preset_name).values.items():
            out[SCHEMA.by_name(name).keys[0]] = v
    return sorted(out.items(), key=lambda kv: ids[kv[0]])
