"""Read a scenario file (flat `key = value` lines, `#` comments) into a frozen dataclass.

The keys, their defaults, types and valid ranges are the settings schema's (schema/settings.toml):
`Scenario` is generated from it, field by field, so no setting is listed here. The format is a tiny
subset of TOML that the C reader (host/common/scenario.c) parses the same way, with the same messages.
"""
from __future__ import annotations

import dataclasses
import math
from pathlib import Path
from typing import Any, Dict, List, Optional, Union

from .schema import ALIASES, SCHEMA, canonical, setting_of

PathLike = Union[str, Path]


class ScenarioError(ValueError):
    """A scenario file that cannot be used; the message is one line naming the file, key and rule."""


class _ScenarioBase:
    """Methods of the generated Scenario dataclass."""

    dt: float
    t_end: float

    @property
    def n_steps(self) -> int:
        """Number of recorded samples N = round(t_end / dt); samples are k = 1..N."""
        return int(round(self.t_end / self.dt))

    def replace(self, **changes: float) -> Any:
        """Copy with some values changed (handy for shortened test runs); checked like a file. Elements
        a change of a count leaves unused are dropped."""
        values = {**self.values(), **{canonical(k): v for k, v in changes.items()}}
        unused = [k for k, s, i in _KEYS if not SCHEMA.in_use(s, i, values)]
        out = scenario_from_values({k: v for k, v in values.items() if k not in unused}, self.source)
        if STRUCTURE_KEY in self.__dict__:  # the structure it names comes along
            object.__setattr__(out, STRUCTURE_KEY, self.__dict__[STRUCTURE_KEY])
        return out

    @property
    def source(self) -> str:
        """Where the values came from: the file's path (or "<text>", "replace()", ...)."""
        return str(self.__dict__.get("_source", "<scenario>"))

    def missing_truth(self) -> List[str]:
        """The truth-only keys in use that the file left out (NaN): a recording's scenario lacks them."""
        values = dict(dataclasses.asdict(self))  # type: ignore[call-overload]
        return [k for k, v in values.items() if _missing_truth(k, v) and SCHEMA.in_use(_SETTINGS[k], _INDEX[k], values)]

    @property
    def has_truth(self) -> bool:
        """Whether every truth-only key in use is given: the scenario can drive a simulated truth."""
        return not self.missing_truth()

    def require_truth(self) -> None:
        """For code that simulates a truth: ScenarioError naming the file and the first missing truth key."""
        missing = self.missing_truth()
        if missing:
            raise ScenarioError(f"{self.source}: missing key '{missing[0]}' (it has no default; simulating a truth "
                                "needs it)")

    def values(self) -> Dict[str, float]:
        """Every key's value, by scenario key; elements not in use (m5 of a 4-body mechanism) and truth-only keys
        the file left out (missing_truth) are left out, as a file would leave them."""
        values = dict(dataclasses.asdict(self))  # type: ignore[call-overload]
        return {k: v for k, v in values.items()
                if SCHEMA.in_use(_SETTINGS[k], _INDEX[k], values) and not _missing_truth(k, v)}


def _missing_truth(key: str, value: Any) -> bool:
    """A truth-only key the file left out: NaN in the Scenario (scenario_from_values)."""
    return _SETTINGS[key].kind == "truth" and isinstance(value, float) and math.isnan(value)


_KEYS = SCHEMA.keys()
_TYPES = {k: (float if s.type == "real" else int) for k, s, _ in _KEYS}
# The paper's flat names of single elements (k12 -> spring2_k): accepted in files and replace(), and
# readable as attributes.
_INDEX = {k: i for k, _, i in _KEYS}
_SETTINGS = {k: s for k, s, _ in _KEYS}


def _alias_property(key: str) -> property:
    return property(lambda self: getattr(self, key), doc=f"{key} (its paper name)")


Scenario: Any = dataclasses.make_dataclass(
    "Scenario", [(k, _TYPES[k]) for k, _, _ in _KEYS], bases=(_ScenarioBase,), frozen=True,
    namespace={"__doc__": "Every value of a scenario, SI units; the fields are the schema's keys.",
               **{a: _alias_property(k) for a, k in ALIASES.items()}})
Scenario.__module__ = __name__  # picklable (process pools, Dask): found as caekf_sim.scenario.Scenario


def parse_flat(text: str, source: str = "<text>") -> Dict[str, "tuple[int, str]"]:
    """Parse `key = value` lines into {key: (line number, text)}; drop comments and blank lines."""
    out: Dict[str, "tuple[int, str]"] = {}
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()  # values are plain numbers, so '#' never occurs inside one
        if not line:
            continue
        key, sep, value = line.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ScenarioError(f"{source}:{lineno}: expected 'key = value', got {raw.strip()!r}")
        if key in out:
            raise ScenarioError(f"{source}:{lineno}: duplicate key '{key}'")
        out[key] = (lineno, value)
    return out


def _check(key: str, v: float, where: str, text: str = "") -> Any:
    setting = setting_of(canonical(key))
    if not setting.check(v):
        raise ScenarioError(f"{where}: {key} = {text or format(v, 'g')}: {setting.rule_text()}")
    return int(v) if setting.type != "real" else float(v)


def scenario_from_values(values: Dict[str, Any], source: str) -> Any:
    """A Scenario from {key: number}; defaults for absent keys, the schema's rules checked. A truth-only key
    without a default (gamma, u_amp, t_end, ...: the simulated plant, kind "truth" in the schema) may be
    absent or NaN: it is NaN in the Scenario. Estimating from measurements needs none of them; code that
    simulates a truth calls Scenario.require_truth()."""
    unknown = sorted(set(values) - set(_TYPES) - set(ALIASES))
    if unknown:
        raise ScenarioError(f"{source}: unknown key '{unknown[0]}'")
    given: Dict[str, Any] = {}
    for key, v in values.items():
        name = canonical(key)
        if name in given:
            raise ScenarioError(f"{source}: duplicate key '{key}' (or another name of it)")
        given[name] = v
    out: Dict[str, Any] = {}
    for key, setting, index in _KEYS:
        used = SCHEMA.in_use(setting, index, given)
        if key in given and not used:
            counter = SCHEMA.by_name(setting.in_use_by or "").keys[0]
            raise ScenarioError(f"{source}: {key} is given, but {counter} = {given.get(counter, 'its default')} "
                                "leaves it unused")
        if setting.kind == "truth" and setting.element_required(index) and used \
                and (key not in given or math.isnan(float(given[key]))):
            out[key] = math.nan
        elif key in given:
            out[key] = _check(key, float(given[key]), source)
        elif setting.element_required(index) and used:
            raise ScenarioError(f"{source}: missing key '{key}' (it has no default)")
        else:
            out[key] = _check(key, setting.default_value(index=index), source) if not setting.element_required(
                index) else (0 if setting.type != "real" else 0.0)
    sc = Scenario(**out)
    object.__setattr__(sc, "_source", source)  # not a field: the file named in require_truth's message
    return sc


def require_truth(sc: Any) -> None:
    """For code that simulates a truth from a Scenario or a dict of values: Scenario.require_truth (a dict, built
    in code, is not checked here)."""
    if isinstance(sc, _ScenarioBase):
        sc.require_truth()


STRUCTURE_KEY = "structure"  # a structure given as matrices: its folder, relative to the scenario (docs/structure.md)


def _attach_structure(sc: Any, folder: str, source: str) -> None:
    """Load the structure folder a scenario names (relative to the scenario file) onto it as sc.structure."""
    from .structure.files import load_structure  # the structure's reader: numpy only, loaded when used
    base = Path(source).parent if source and not source.startswith("<") else Path.cwd()
    object.__setattr__(sc, STRUCTURE_KEY, load_structure(base / folder))


def scenario_from_text(text: str, source: str = "<text>") -> Any:
    """Build a Scenario; unknown keys are an error (typo guard), keys without a default are required (truth-only
    keys excepted: see scenario_from_values). `structure = "folder"` names a structure given as matrices
    (docs/structure.md), loaded onto the Scenario as its `structure` (the bodies, links and ends then go
    unread)."""
    values: Dict[str, float] = {}
    structure: Optional[str] = None
    for key, (lineno, value) in parse_flat(text, source).items():
        if key == STRUCTURE_KEY:
            if len(value) < 3 or value[0] != '"' or value[-1] != '"':
                raise ScenarioError(f"{source}:{lineno}: structure = {value}: expected a quoted folder name")
            structure = value[1:-1]
            continue
        if key not in _TYPES and key not in ALIASES:
            raise ScenarioError(f"{source}:{lineno}: unknown key '{key}'")
        setting = setting_of(canonical(key))
        try:
            if setting.type == "enum" and len(value) >= 2 and value[0] == value[-1] == '"' \
                    and value[1:-1] in setting.values:
                v = float(setting.values.index(value[1:-1]))  # an enum by name
            else:
                v = float(value)
        except ValueError:
            v = math.nan
        if not math.isfinite(v):
            raise ScenarioError(f"{source}:{lineno}: {key} = {value}: not a finite number")
        _check(key, v, f"{source}:{lineno}", value)
        values[key] = v
    sc = scenario_from_values(values, source)
    if structure is not None:
        _attach_structure(sc, structure, source)
    return sc


def load_scenario(path: PathLike) -> Any:
    """Read and check a scenario file (truth-only keys may be left out: see scenario_from_values)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected a scenario file")
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ScenarioError(f"{p}: not a text file (bytes that are not UTF-8)") from None
    except OSError as exc:  # a missing or unreadable file: an I/O error (exit 4), as the C tools say
        raise OSError(f"{p}: cannot open: {exc.strerror}") from None
    return scenario_from_text(text, str(p))


def default_scenario_path() -> Path:
    """The reference scenario: the copy installed with the package (caekf_sim/scenarios/paper.toml, put there
    by sim/CMakeLists.txt from sim/scenarios/paper.toml), else the source tree's (an editable install)."""
    here = Path(__file__).resolve().parent
    for p in (here / "scenarios" / "paper.toml", here.parents[1] / "scenarios" / "paper.toml"):
        if p.is_file():
            return p
    raise FileNotFoundError(f"the reference scenario is not installed ({here / 'scenarios' / 'paper.toml'}): "
                            "give --scenario")
