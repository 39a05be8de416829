#!/usr/bin/env python3
"""Generate every derived copy of the settings schema (settings.toml).

Run by CMake at build time (the outputs live in the build tree and are never edited by hand):

    codegen.py c-core   OUTDIR [MECH [PRESET]]
                                          caekf/caekf_settings_schema.h, caekf_settings_table.c,
                                          caekf/caekf_status.h (statuses and flags),
                                          caekf_settings_names.c (names of settings, flags, statuses),
                                          caekf/caekf_capacity.h (sized for MECH, a scenario, if given;
                                          with PRESET, a preset's name or `default` for
                                          the schema's defaults, also its step method)
    codegen.py c-host   OUTDIR            caekf_scenario_schema.h, caekf_scenario_schema.c (scenario
                                          reader table, presets)
    codegen.py c-fixture OUTDIR SCENARIO  caekf_fixture_settings.h (a scenario's values as parameter
                                          ids, values and CTRL_PARAM mantissa/exponent, for tests)
    codegen.py dbc DBC (--check|--write)  the DBC's PARAM_ID value table and range, its STEP_STATUS
                                          value tables (the [[status]] entries)

The committed DBC holds generated lines (VAL_ ... PARAM_ID, VAL_ ... STEP_STATUS); `dbc --check` fails when
one is stale.
Standard library only (tomllib; tomli before Python 3.11), so CMake can run it without the venv. The Python
package reads the schema with the same loader (caekf_sim.schema).
"""
from __future__ import annotations

import math
import re
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple

if sys.version_info >= (3, 11):
    import tomllib
else:  # Python 3.9/3.10 (Ubuntu 22.04): the same parser from PyPI
    import tomli as tomllib

SCHEMA_PATH = Path(__file__).with_name("settings.toml")
TYPES = ("real", "int", "enum", "bool")
KINDS = ("model", "noise", "estimator", "runtime", "truth")
# C rule codes; the same numbers are written into caekf_settings_schema.h.
RULES = {"finite": 0, "> 0": 1, ">= 0": 2, "(0, 1)": 3, "int": 4, ">= 1": 5}
RULE_MACROS = {"finite": "FINITE", "> 0": "POS", ">= 0": "NONNEG", "(0, 1)": "OPEN01", "int": "INT", ">= 1": "GE1"}
CAPACITIES = ("bodies", "springs", "inputs", "sensors", "contacts")
C_ENUMS = {"mode": ("caekf_mode_t", "CAEKF_MODE_"), "switchoff": ("caekf_switchoff_t", "CAEKF_SWITCHOFF_"),
           "cov_update": ("caekf_cov_update_t", "CAEKF_COV_"), "sensor_kind": ("caekf_sensor_kind_t", "CAEKF_SENSOR_"),
           "discretisation": ("caekf_discretisation_t", "CAEKF_DISCRETISATION_"),
           "input_kind": ("caekf_input_kind_t", "CAEKF_INPUT_")}
GENERATED = "GENERATED from sim/src/caekf_sim/schema/settings.toml by codegen.py: do not edit"


class SchemaError(ValueError):
    pass


@dataclass(frozen=True)
class Setting:
    name: str
    type: str
    unit: str
    kind: str
    doc: str
    id: Optional[int] = None
    count: int = 1
    keys: Tuple[str, ...] = ()
    values: Tuple[str, ...] = ()
    default: Any = None  # None: required
    range: str = "finite"
    lo: float = -math.inf
    hi: float = math.inf
    field: str = ""
    capacity: Optional[str] = None  # an array over the mechanism's bodies, springs, ... (count = its capacity)
    counts: Optional[str] = None  # this setting is the number of elements in use of that capacity
    in_use_by: Optional[str] = None  # name of the setting giving how many elements are in use
    aliases: Tuple[Tuple[str, int], ...] = ()  # (key, element index)

    @property
    def required(self) -> bool:
        return self.default is None

    def element_default(self, index: int) -> Any:
        """The default of one element (None: required when in use)."""
        if isinstance(self.default, list):
            return self.default[index] if index < len(self.default) else None
        return self.default

    def element_required(self, index: int) -> bool:
        return self.element_default(index) is None

    @property
    def on_wire(self) -> bool:
        return self.id is not None

    def element(self, index: int) -> str:
        return self.name if self.count == 1 else f"{self.name}[{index}]"

    def rule_text(self) -> str:
        """The rule as an error message states it ("must be > 0")."""
        if self.type == "enum":
            return "must be one of " + ", ".join(f"{i} ({v})" for i, v in enumerate(self.values))
        if self.type == "bool":
            return "must be 0 or 1"
        if self.type == "int":
            return f"must be an integer in [{int(self.lo)}, {int(self.hi)}]"
        if self.range == "finite":
            return "must be finite"
        if self.range == "(0, 1)":
            return "must be in (0, 1)"
        return f"must be finite and {self.range}"

    def check(self, v: float) -> bool:
        """The range rule (C applies the same: caekf_settings_table.c)."""
        if not math.isfinite(v):
            return False
        if self.type in ("int", "enum", "bool"):
            return v == math.floor(v) and self.lo <= v <= self.hi
        return {
            "finite": True,
            "> 0": v > 0,
            ">= 0": v >= 0,
            "(0, 1)": 0 < v < 1,
            ">= 1": v >= 1,
        }[self.range]

    def default_value(self, eps: float = sys.float_info.epsilon, index: int = 0) -> float:
        d = self.element_default(index)
        if d is None:
            return 0.0
        if isinstance(d, str):
            if self.type == "enum":
                return float(self.values.index(d))
            k, unit = d.split()
            assert unit == "eps"
            return float(k) * eps
        return float(d)


@dataclass(frozen=True)
class Preset:
    name: str
    doc: str
    values: Dict[str, float] = field(default_factory=dict)  # setting name -> numeric value


@dataclass(frozen=True)
class Flag:
    name: str
    bit: int
    doc: str
    layer: str = "core"  # core: the C estimator's report; reference: the numpy reference filter's only

    @property
    def mask(self) -> int:
        return 1 << self.bit


@dataclass(frozen=True)
class Status:
    name: str  # CAEKF_<name>
    value: int
    text: str  # caekf_status_str
    doc: str


FLAG_LAYERS = ("core", "reference")
WIRE_FLAG_BITS = 16  # EST_STEP.FLAGS: the core's bits below the application's, all within 16


@dataclass(frozen=True)
class Schema:
    settings: Tuple[Setting, ...]
    presets: Tuple[Preset, ...]
    capacity: Dict[str, int] = field(default_factory=dict)
    flags: Tuple[Flag, ...] = ()  # lowest bit first
    structure_dofs: int = 0  # [structure] dofs: the degrees of freedom a host build takes from matrices
    statuses: Tuple[Status, ...] = ()

    @property
    def core_flags(self) -> List[Flag]:
        return [f for f in self.flags if f.layer == "core"]

    def by_name(self, name: str) -> Setting:
        for s in self.settings:
            if s.name == name:
                return s
        raise KeyError(name)

    @property
    def wire(self) -> List[Setting]:
        return [s for s in self.settings if s.on_wire]

    @property
    def param_count(self) -> int:
        return sum(s.count for s in self.wire)

    def keys(self) -> List[Tuple[str, Setting, int]]:
        """Every scenario key with its setting and element index (canonical keys, no aliases)."""
        return [(k, s, i) for s in self.settings for i, k in enumerate(s.keys)]

    def aliases(self) -> List[Tuple[str, str]]:
        """(alias, canonical key) of every alias."""
        return [(a, s.keys[i]) for s in self.settings for a, i in s.aliases]

    def in_use(self, s: Setting, index: int, values: Dict[str, float]) -> bool:
        """Whether element `index` of s is in use for these values (by key; absent: the default)."""
        if s.in_use_by is None:
            return True
        counter = self.by_name(s.in_use_by)
        return index < int(values.get(counter.keys[0], counter.default_value()))


def _parse_range(s: Setting, text: str) -> Tuple[str, float, float]:
    if s.type == "enum":
        return "int", 0, len(s.values) - 1
    if s.type == "bool":
        return "int", 0, 1
    m = re.fullmatch(r"\[\s*(-?\d+)\s*,\s*(-?\d+)\s*\]", text)
    if s.type == "int":
        if not m:
            raise SchemaError(f"{s.name}: an int needs a range '[lo, hi]'")
        return "int", float(m.group(1)), float(m.group(2))
    if text not in RULES or text == "int":
        raise SchemaError(f"{s.name}: unknown range {text!r}")
    return text, -math.inf, math.inf


def load(path: Path = SCHEMA_PATH) -> Schema:
    """Read and check the schema (unique names, ids and keys; ids dense from 0)."""
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    capacity = {k: int(v) for k, v in raw.get("capacity", {}).items()}
    if sorted(capacity) != sorted(CAPACITIES):
        raise SchemaError(f"[capacity] must give exactly {', '.join(CAPACITIES)}")
    settings: List[Setting] = []
    counters = {e["counts"]: e["name"] for e in raw.get("setting", []) if "counts" in e}
    for entry in raw.get("setting", []):
        e = dict(entry)
        name = e.pop("name")
        cap = e.pop("capacity", None)
        if cap is not None and (cap not in capacity or cap not in counters):
            raise SchemaError(f"{name}: capacity {cap!r} has no [capacity] entry or no setting counting it")
        count = capacity[cap] if cap is not None else int(e.pop("count", 1))
        pattern = e.pop("key", None)
        if pattern is not None:
            keys = tuple(pattern.format(i=i + 1) for i in range(count))
        else:
            keys = tuple(e.pop("keys", [name] if count == 1 else []))
        if len(keys) != count:
            raise SchemaError(f"{name}: {count} elements but {len(keys)} keys")
        aliases = tuple((a, int(i) - 1) for a, i in e.pop("aliases", {}).items())
        if any(not 0 <= i < count for _, i in aliases):
            raise SchemaError(f"{name}: an alias names an element out of 1..{count}")
        counts = e.pop("counts", None)
        if counts is not None and counts not in capacity:
            raise SchemaError(f"{name}: counts unknown capacity {counts!r}")
        typ = e.pop("type")
        if typ not in TYPES:
            raise SchemaError(f"{name}: unknown type {typ!r}")
        kind = e.pop("kind")
        if kind not in KINDS:
            raise SchemaError(f"{name}: unknown kind {kind!r}")
        s = Setting(name=name, type=typ, unit=e.pop("unit"), kind=kind, doc=e.pop("doc"),
                    id=e.pop("id", None), count=count, keys=keys,
                    values=tuple(e.pop("values", [])), default=e.pop("default", None),
                    field=e.pop("field", name if kind != "truth" else ""), capacity=cap, counts=counts,
                    in_use_by=counters[cap] if cap is not None else None, aliases=aliases)
        if isinstance(s.default, list) and len(s.default) > count:
            raise SchemaError(f"{name}: more defaults than elements")
        rng = e.pop("range", "finite")
        rule, lo, hi = _parse_range(s, rng)
        s = Setting(**{**s.__dict__, "range": rule if rule == "int" else rng, "lo": lo, "hi": hi})
        if e:
            raise SchemaError(f"{name}: unknown attributes {sorted(e)}")
        if (kind == "truth") == (s.id is not None):
            raise SchemaError(f"{name}: truth settings have no id, all others need one")
        settings.append(s)
    names = [s.name for s in settings]
    all_keys = [k for s in settings for k in s.keys] + [a for s in settings for a, _ in s.aliases]
    for what, items in (("name", names), ("key", all_keys)):
        dup = sorted({x for x in items if items.count(x) > 1})
        if dup:
            raise SchemaError(f"duplicate {what}s: {dup}")
    next_id = 0
    for s in sorted((s for s in settings if s.on_wire), key=lambda s: s.id or 0):
        if s.id != next_id:
            raise SchemaError(f"{s.name}: id {s.id}, expected {next_id} (ids are dense)")
        next_id += s.count
    # The C table is written in the file's order and looked up by id: the entries keep their ids' order.
    wire = [s for s in settings if s.on_wire]
    for before, after in zip(wire, wire[1:]):
        if (after.id or 0) < (before.id or 0):
            raise SchemaError(f"{after.name}: id {after.id} after {before.name}'s {before.id} (entries in id order)")
    presets = []
    for pname, p in raw.get("preset", {}).items():
        vals: Dict[str, float] = {}
        for k, v in p["values"].items():
            st = next((s for s in settings if s.name == k), None)
            if st is None or not st.on_wire or st.count != 1:
                raise SchemaError(f"preset {pname}: {k} is not a scalar wire setting")
            vals[k] = float(st.values.index(v)) if st.type == "enum" else float(v)
            if not st.check(vals[k]):
                raise SchemaError(f"preset {pname}: {k} = {v}: {st.rule_text()}")
        presets.append(Preset(name=pname, doc=p["doc"], values=vals))
    dofs = int(raw.get("structure", {}).get("dofs", capacity["bodies"]))
    if dofs < capacity["bodies"]:
        raise SchemaError(f"[structure] dofs = {dofs}: must be >= the bodies' capacity {capacity['bodies']}")
    return Schema(settings=tuple(settings), presets=tuple(presets), capacity=capacity,
                  flags=_load_flags(raw.get("flag", [])), statuses=_load_statuses(raw.get("status", [])),
                  structure_dofs=dofs)


def _load_statuses(entries: List[Dict[str, Any]]) -> Tuple[Status, ...]:
    """The [[status]] entries: OK = 0 first, then the errors -1, -2, ... (dense), names upper case."""
    out: List[Status] = []
    for entry in entries:
        e = dict(entry)
        st = Status(name=e.pop("name"), value=int(e.pop("value")), text=e.pop("text"), doc=e.pop("doc"))
        if e:
            raise SchemaError(f"status {st.name}: unknown attributes {sorted(e)}")
        if not re.fullmatch(r"[A-Z][A-Z0-9_]*", st.name) or '"' in st.text:
            raise SchemaError(f"status {st.name!r}: a name is upper case, digits and _; a text has no quote")
        if st.value != -len(out) or any(o.name == st.name for o in out):
            raise SchemaError(f"status {st.name}: value {st.value}, expected {-len(out)} (OK = 0, then -1, -2, ...; "
                              "names unique)")
        out.append(st)
    return tuple(out)


def _load_flags(entries: List[Dict[str, Any]]) -> Tuple[Flag, ...]:
    """The [[flag]] entries: unique names and bits; the core's dense from bit 0 and within the wire's
    bits, the reference's above them."""
    flags: List[Flag] = []
    for entry in entries:
        e = dict(entry)
        f = Flag(name=e.pop("name"), bit=int(e.pop("bit")), doc=e.pop("doc"), layer=e.pop("layer", "core"))
        if e:
            raise SchemaError(f"flag {f.name}: unknown attributes {sorted(e)}")
        if f.layer not in FLAG_LAYERS:
            raise SchemaError(f"flag {f.name}: unknown layer {f.layer!r}")
        if not re.fullmatch(r"[a-z][a-z0-9_]*", f.name):
            raise SchemaError(f"flag {f.name!r}: a name is lower case, digits and _")
        if any(g.name == f.name or g.bit == f.bit for g in flags):
            raise SchemaError(f"flag {f.name}: name or bit {f.bit} given twice")
        if (f.layer == "core") != (0 <= f.bit < WIRE_FLAG_BITS) or f.bit >= 32:
            raise SchemaError(f"flag {f.name}: bit {f.bit}: the core's bits are 0..{WIRE_FLAG_BITS - 1}, "
                              f"the reference's {WIRE_FLAG_BITS}..31")
        flags.append(f)
    flags.sort(key=lambda f: f.bit)  # lowest bit first, as every table of them lists them
    core = [f.bit for f in flags if f.layer == "core"]
    if core != list(range(len(core))):
        raise SchemaError(f"the core's flag bits must be 0..{len(core) - 1}, dense (got {core})")
    return tuple(flags)


# ---- C --------------------------------------------------------------------------------------------

def _macro(name: str) -> str:
    return re.sub(r"[^A-Z0-9]", "_", name.upper())


def _c_double(v: float) -> str:
    if math.isinf(v):
        return "HUGE_VAL" if v > 0 else "-HUGE_VAL"
    return repr(float(v))


# The contact-law parameters a filter may estimate besides gamma (settings contact{i}_estimate_<p>).
LAW_PARAMS = ("n", "lambda", "gap")


# The step method a build sized for one configuration fixes (CAEKF_SIZED_METHOD): these settings, as the
# scenario and the preset give them (or their defaults), become compile-time constants.
METHOD = ("discretisation", "contact_substeps", "contact_n", "gamma_log", "contact_slr_p", "cov_update", "switchoff")


# The configuration name of no preset: the schema's defaults under the scenario, i.e. the recommended
# default estimator (CAEKF_MECHANISM_PRESET=default sizes a build for its step method).
DEFAULT_CONFIGURATION = "default"


def preset_values(schema: Schema, preset: str) -> Dict[str, Any]:
    """The values a configuration sets over the scenario: a preset's, or none for `default`."""
    if preset == DEFAULT_CONFIGURATION:
        return {}
    p = next((q for q in schema.presets if q.name == preset), None)
    if p is None:
        raise SchemaError(f"unknown preset {preset!r} (known: {DEFAULT_CONFIGURATION}, "
                          f"{', '.join(q.name for q in schema.presets)})")
    return dict(p.values)


def sized_method(schema: Schema, mechanism: Path, preset: str, contacts: int) -> Dict[str, Any]:
    """The method settings of the scenario under the preset: {name: value} (contact_n: the exponent all
    contacts share, omitted when they differ)."""
    given = read_scenario_values(schema, mechanism, wire_only=False)
    values = preset_values(schema, preset)
    out: Dict[str, Any] = {}
    for name in METHOD:
        s = schema.by_name(name)
        elements = contacts if s.capacity is not None else 1
        vals = [float(values[name]) if name in values else float(given.get(s.keys[i], s.default_value(index=i)))
                for i in range(elements)]
        if vals and all(v == vals[0] for v in vals):
            out[name] = vals[0]
    return out


def c_sized_links(schema: Schema, given: Dict[str, float], counts: Dict[str, int]) -> List[str]:
    """The scenario's links (spring_a, spring_b) and the pattern they give K and C: row i's columns j,
    ascending, where a link couples bodies i and j (its diagonal included; ground ends drop out); the
    contacts' ends (contact_a, contact_b). A step path that evaluates the residual many times is written
    for them (CAEKF_FIXED_LINKS, caekf_config.h)."""
    ends = {}
    for name, cap in (("spring_a", "springs"), ("spring_b", "springs"), ("contact_a", "contacts"),
                      ("contact_b", "contacts")):
        st = schema.by_name(name)
        ends[name] = [int(given.get(st.keys[i], st.default_value(index=i))) for i in range(counts[cap])]
    nq = counts["bodies"]
    rows: List[List[int]] = [[] for _ in range(nq)]
    for a, b in zip(ends["spring_a"], ends["spring_b"]):
        for i in (a, b):
            for j in (a, b):
                if i > 0 and j > 0 and j - 1 not in rows[i - 1]:
                    rows[i - 1].append(j - 1)

    def arr(v: List[int]) -> str:
        return "{" + ", ".join(str(x) for x in (v or [0])) + "}"

    def table(name: str, pattern: List[List[int]], doc: str) -> List[str]:
        width = max([len(r) for r in pattern] + [1])
        nz = ", ".join("{" + ", ".join(str(j) for j in sorted(r) + [0] * (width - len(r))) + "}" for r in pattern)
        return [f"#define CAEKF_SIZED_{name}_NNZ {arr([len(r) for r in pattern])} /* {doc} */",
                f"#define CAEKF_SIZED_{name}_WIDTH {width}", f"#define CAEKF_SIZED_{name}_NZ {{{nz}}}"]

    # The Newton matrix M/hs + C + hs K_t: K and C's pattern, the diagonal and the contacts' couplings. Its
    # LU without row exchanges fills in, step k, every pair of k's later neighbours (symmetric, so row k's
    # later columns are column k's later rows too).
    lu = [set(r) | {i} for i, r in enumerate(rows)]
    for a, b in zip(ends["contact_a"], ends["contact_b"]):
        if a > 0 and b > 0:
            lu[a - 1].add(b - 1)
            lu[b - 1].add(a - 1)
    for k in range(nq):
        later = [j for j in lu[k] if j > k]
        for i in later:
            lu[i].update(later)
    return [f"#define CAEKF_SIZED_SPRING_A {arr(ends['spring_a'])} /* the links' ends */",
            f"#define CAEKF_SIZED_SPRING_B {arr(ends['spring_b'])}",
            *table("LINK", rows, "K and C's pattern, row by row"),
            f"#define CAEKF_SIZED_CONTACT_A {arr(ends['contact_a'])} /* the contacts' ends */",
            f"#define CAEKF_SIZED_CONTACT_B {arr(ends['contact_b'])}",
            *table("LU_UPPER", [[j for j in r if j > i] for i, r in enumerate(lu)],
                   "the Newton matrix's LU without exchanges: U's columns right of the diagonal, row by row"),
            *table("LU_LOWER", [[j for j in r if j < i] for i, r in enumerate(lu)],
                   "and L's left of it")]


# The settings that declare a mechanism parameter uncertain, and the capacity each spans.
MECH_SIGMAS = (("m_sigma", "bodies"), ("spring_k_sigma", "springs"), ("spring_c_sigma", "springs"))


def _enum_index(setting: "Setting", value: Any) -> int:
    """An enumerated setting's value as its number (a scenario gives the name or the number)."""
    return setting.values.index(value) if isinstance(value, str) else int(float(value))


def c_capacity(schema: Schema, mechanism: Optional[Path] = None, preset: Optional[str] = None) -> str:
    """caekf/caekf_capacity.h: the build's mechanism capacity. Without a mechanism, the wire's (any
    mechanism up to it, sizes at run time); with one (a scenario file), exactly its counts (CAEKF_SIZED:
    the sizes are constants, as nanopb sizes its structs from a .proto). With a preset as well, the build
    is sized for that configuration of the scenario: its step method is fixed too (CAEKF_SIZED_METHOD)."""
    lines = [f"/* {GENERATED}" + (f", and from {mechanism.name}" if mechanism else "") +
             (f" with the preset {preset}" if preset else "") + ". */",
             "#ifndef CAEKF_CAPACITY_H", "#define CAEKF_CAPACITY_H", ""]
    if mechanism is None:
        counts = dict(schema.capacity)
        lines.append("#define CAEKF_SIZED 0 /* any mechanism within the capacity, sizes at run time */")
    else:
        given = read_scenario_values(schema, mechanism, wire_only=False)
        counts = {}
        for cap in CAPACITIES:
            counter = next(s for s in schema.settings if s.counts == cap)
            counts[cap] = int(given.get(counter.keys[0], counter.default_value()))
        lines.append(f"#define CAEKF_SIZED 1 /* exactly the mechanism of {mechanism.name} */")
        for cap, n in counts.items():
            lines.append(f"#define CAEKF_SIZED_{_macro(cap)} {n}")
        pv = preset_values(schema, preset) if preset else {}
        flags = {f"contact{i}_estimate_{p}": int(float(pv.get(f"contact{i}_estimate_{p}",
                                                             given.get(f"contact{i}_estimate_{p}", 0))))
                 for i in range(1, counts["contacts"] + 1) for p in LAW_PARAMS}
        law = sum(flags.values())
        lines.append(f"#define CAEKF_SIZED_LAW_PARAMS {law} /* estimated n, lambda and gap */")
        mech = sum(1 for name, cap in MECH_SIGMAS for i in range(1, counts[cap] + 1)
                   if float(given.get(schema.by_name(name).keys[i - 1], 0.0)) > 0)
        lines.append(f"#define CAEKF_SIZED_MECH_PARAMS {mech} /* masses, stiffnesses, dampers estimated */")
        bias_key = schema.by_name("sensor_bias_sigma").keys
        biases = sum(1 for i in range(counts["sensors"]) if float(given.get(bias_key[i], 0.0)) > 0)
        lines.append(f"#define CAEKF_SIZED_BIASES {biases} /* sensor offsets estimated */")
        kind = schema.by_name("sensor_kind")
        kinds = [given.get(kind.keys[i], kind.default_value(index=i)) for i in range(counts["sensors"])]
        rows = biases > 0 or any(_enum_index(kind, k) >= 2 for k in kinds)
        lines.append(f"#define CAEKF_SIZED_SENSOR_ROWS {int(rows)} /* a sensor reads more than one state */")
        # Inputs that move a link's ground end (input{i}_kind = base_displacement): CAEKF_HAS_BASE_INPUTS.
        ikind = schema.by_name("input_kind")
        base = sum(1 for i in range(counts["inputs"])
                   if _enum_index(ikind, given.get(ikind.keys[i], ikind.default_value(index=i))) == 1)
        lines.append(f"#define CAEKF_SIZED_BASE_INPUTS {base} /* inputs that are a base displacement */")
        # Hunt-Crossley damping in any contact: a nonzero lambda, or lambda estimated (CAEKF_HAS_DAMPING).
        lam = schema.by_name("contact_lambda")
        damped = any(flags[f"contact{i + 1}_estimate_lambda"] or
                     float(pv.get(key, given.get(key, lam.default_value(index=i)))) != 0
                     for i, key in enumerate(lam.keys[:counts["contacts"]]))
        lines += c_sized_links(schema, given, counts)
    if mechanism is not None and preset:
        method = sized_method(schema, mechanism, preset, counts["contacts"])
        if any(v for k, v in flags.items() if k.endswith("_estimate_n")):
            method.pop("contact_n", None)  # an estimated exponent is a state, never a constant
        lines += ["", f"/* The step method of {mechanism.name} under the preset {preset}: constants of the build. */",
                  "#define CAEKF_SIZED_METHOD 1",
                  f"#define CAEKF_SIZED_DISCRETISATION {int(method['discretisation'])}",
                  f"#define CAEKF_SIZED_CONTACT_SUBSTEPS {int(method['contact_substeps'])}",
                  f"#define CAEKF_SIZED_GAMMA_LOG {int(method['gamma_log'])}"]
        if "contact_n" in method:
            lines.append(f"#define CAEKF_SIZED_CONTACT_N {_c_double(method['contact_n'])}")
        # Statistically linearised contacts or not is part of the method (their threshold stays a setting).
        lines.append(f"#define CAEKF_SIZED_SLR {int(method['contact_slr_p'] > 0)} /* contact_slr_p > 0 */")
        # The covariance correction's form and the gammas' switch-off: the other one compiles out.
        lines += [f"#define CAEKF_SIZED_COV_UPDATE {int(method['cov_update'])}",
                  f"#define CAEKF_SIZED_SWITCHOFF {int(method['switchoff'])}",
                  f"#define CAEKF_SIZED_DAMPED {int(damped)} /* a contact's lambda nonzero or estimated */"]
    else:
        lines.append("#define CAEKF_SIZED_METHOD 0 /* the step method is a run-time setting */")
    lines.append("")
    for cap, n in counts.items():
        # C has no zero-length arrays: a capacity of 0 stores one unused element.
        lines.append(f"#define CAEKF_MAX_{_macro(cap)} {max(n, 1)}")
    # The contact-law parameters estimated besides gamma (states after the gammas): every contact's n,
    # lambda and gap, or exactly the sized scenario's.
    # Degrees of freedom: a structure given as matrices (caekf_init_structure) in a build for any mechanism;
    # a sized build stores its bodies only.
    dofs = schema.structure_dofs if mechanism is None else max(counts["bodies"], 1)
    lines.append(f"#define CAEKF_MAX_DOFS {dofs}")
    law_cap = law if mechanism is not None else len(LAW_PARAMS) * counts["contacts"]
    lines.append(f"#define CAEKF_MAX_LAW_PARAMS {law_cap}")
    # The mechanism's parameters estimated (states after the law's): every mass, stiffness and damper, or
    # exactly those the sized scenario declares uncertain.
    mech_cap = mech if mechanism is not None else sum(counts[cap] for _, cap in MECH_SIGMAS)
    lines.append(f"#define CAEKF_MAX_MECH_PARAMS {mech_cap}")
    # The sensors' offsets estimated (states after the mechanism's): every sensor's, or the sized scenario's.
    lines.append(f"#define CAEKF_MAX_BIASES {biases if mechanism is not None else counts['sensors']}")
    return "\n".join(lines + ["", "#endif", ""])


def _all_bits_zero(s: "Setting", d: Any) -> bool:
    """A default that all-bits-zero storage already holds: 0, +0.0 or an enum's first value."""
    if isinstance(d, str) and d.endswith("eps"):
        return False
    if s.type == "enum":
        return s.values.index(str(d)) == 0
    if s.type == "real":
        return float(d) == 0.0 and math.copysign(1.0, float(d)) > 0
    return int(float(d)) == 0


def pair_ok(s: "Setting") -> int:
    """The larger bound of an integer rule (0 for other rules): the table stores them as uint16_t."""
    return 0 if s.range != "int" else (int(s.hi) if int(s.lo) >= 0 else -1)


# Settings whose nonzero default is a feature a build may compile out (caekf_config.h): there the
# default is its off value, 0, the one value such a build accepts.
COMPILED_IN = {"contact_slr_p": "CAEKF_HAS_SLR"}


def _c_comment(text: str) -> str:
    """A schema doc as a C comment (no comment terminator inside)."""
    return "/* " + text.replace("*/", "* /") + " */"


def c_types(schema: Schema) -> str:
    """caekf/caekf_settings_types.h: the settings' C types, caekf_model_params_t (the settings whose field
    is model.<name>) and caekf_settings_t (the model, then the others), members in parameter-id order, and
    the enums of the enumerated settings. Nothing else declares a setting: the table's offsetof() and the
    filter's uses are checked against these members by the compiler."""
    lines = [f"/* {GENERATED}. */", "#ifndef CAEKF_SETTINGS_TYPES_H", "#define CAEKF_SETTINGS_TYPES_H", "",
             '#include "caekf/caekf_config.h"', ""]
    for s in schema.wire:
        if s.type == "enum":
            ctype, prefix = C_ENUMS[s.name]
            values = ", ".join(f"{prefix}{_macro(v)} = {i}" for i, v in enumerate(s.values))
            lines += [_c_comment(f"{s.name}: {s.doc}"), f"typedef enum {{ {values} }} {ctype};", ""]

    def member(s: Setting, name: str) -> str:
        # Enums and bools are stored as int, so the table addresses them alike whatever size a compiler
        # gives an enum.
        ctype = "caekf_scalar_t" if s.type == "real" else "int"
        dim = f"[CAEKF_MAX_{_macro(s.capacity)}]" if s.capacity is not None else ""
        unit = f" [{s.unit}]" if s.unit else ""
        enum = f" ({C_ENUMS[s.name][0]})" if s.type == "enum" else ""
        return f"    {ctype} {name}{dim}; {_c_comment(s.doc + unit + enum)}"

    model = [s for s in schema.wire if s.field.startswith("model.")]
    rest = [s for s in schema.wire if not s.field.startswith("model.")]
    if any("." in s.field for s in rest) or any(s.field.count(".") != 1 for s in model):
        raise SchemaError("a setting's field is a member of caekf_settings_t or of its model")
    lines += ["/* The mechanism and the step method. Plain data, so a const instance can live in flash. Body numbers",
              " * are 1-based, 0 is the ground; only the first `bodies`, `springs`, ... elements of each array are",
              " * in use. */", "typedef struct {"]
    lines += [member(s, s.field.split(".", 1)[1]) for s in model]
    lines += ["} caekf_model_params_t;", "", "/* Every setting of the estimator: the model first. */", "typedef struct {",
              "    caekf_model_params_t model;"]
    lines += [member(s, s.field) for s in rest]
    lines += ["} caekf_settings_t;", "", "#endif", ""]
    return "\n".join(lines)


def c_core(schema: Schema, mechanism: Optional[Path] = None, preset: Optional[str] = None) -> Dict[str, str]:
    wire = schema.wire
    h = [f"/* {GENERATED}. */", "#ifndef CAEKF_SETTINGS_SCHEMA_H", "#define CAEKF_SETTINGS_SCHEMA_H", "",
         "/* CTRL_PARAM parameter ids: an array setting takes ids ID .. ID+count-1 (element i at ID+i). */"]
    for s in wire:
        h.append(f"#define CAEKF_PARAM_{_macro(s.name)} {s.id}u /* {s.doc} */")
    h += [f"#define CAEKF_PARAM_COUNT {schema.param_count}u", f"#define CAEKF_SETTING_COUNT {len(wire)}u", "",
          "/* The mechanism's capacities on the wire (and the most a build may have: caekf_config.h). */"]
    h += [f"#define CAEKF_WIRE_MAX_{_macro(c)} {n}u" for c, n in schema.capacity.items()]
    h += ["", "/* Range rules of caekf_setting_rule_t.rule. */"]
    for text, code in RULES.items():
        h.append(f"#define CAEKF_RULE_{RULE_MACROS[text]} {code}u")
    h += ["", "/* Storage of a setting in caekf_settings_t. */",
          "#define CAEKF_SETTING_REAL 0u /* caekf_scalar_t */",
          "#define CAEKF_SETTING_INT 1u  /* int or an enum (int-sized) */", "",
          "/* Element kinds of the table: one element, or an array over each capacity. */",
          f"#define CAEKF_SETTING_KIND_COUNT {1 + len(CAPACITIES)}u", "",
          "#endif", ""]
    c = [f"/* {GENERATED}. */", '#include "caekf/caekf.h"', "", "#include <stddef.h>", ""]
    # The table is compact (4 bytes a setting, caekf_setting_row_t): what settings share is said once, by
    # the kind of their elements (one element, or an array over a capacity: its wire count, stored count
    # and in-use count) and by the integer ranges; ids are dense, so a row's id is the sum of the counts
    # before it. caekf_setting_rule (caekf_settings.c) decodes a row.
    ranges: List[Tuple[int, int]] = []
    c += ["", "/* The element kinds: 0 one element, 1 + i an array over the i-th capacity. */",
          "const caekf_setting_kind_t caekf_setting_kinds[CAEKF_SETTING_KIND_COUNT] = {",
          "    {CAEKF_ALL_IN_USE, 1u, 1u},"]
    for cap in CAPACITIES:
        counter = next(x for x in wire if x.counts == cap)
        c.append(f"    {{(uint16_t)offsetof(caekf_settings_t, {counter.field}), {schema.capacity[cap]}u, "
                 f"CAEKF_MAX_{_macro(cap)}}}, /* {cap} */")
    rows = []
    for s in wire:
        counted = schema.by_name(s.in_use_by).counts if s.in_use_by is not None else None
        if (s.capacity is None) != (s.in_use_by is None) or (s.capacity is None and s.count != 1) or (
                s.capacity is not None and (s.count != schema.capacity[s.capacity] or counted != s.capacity)):
            raise SchemaError(f"{s.name}: an array's count, capacity and in-use count must agree")
        if (s.range == "int") != (s.type != "real"):
            raise SchemaError(f"{s.name}: integer storage exactly for the integer rule")
        kind = 0 if s.capacity is None else 1 + CAPACITIES.index(s.capacity)
        counts = 0 if s.counts is None else 1 + CAPACITIES.index(s.counts)
        rng = 0
        if s.range == "int":
            pair = (int(s.lo), int(s.hi))
            if pair not in ranges:
                ranges.append(pair)
            rng = ranges.index(pair)
        if rng > 15 or not 0 <= pair_ok(s) <= 65535:
            raise SchemaError(f"{s.name}: the table's integer ranges exceed its encoding")
        rows.append(f"    {{(uint16_t)offsetof(caekf_settings_t, {s.field}), {kind | counts << 4}u, "
                    f"CAEKF_RULE_{RULE_MACROS[s.range]} | {rng << 4}u}}, /* {s.name} */")
    c += ["};", "", "/* The integer ranges [lo, hi] of CAEKF_RULE_INT (a row's rule >> 4). */",
          f"const uint16_t caekf_setting_ranges[{len(ranges)}][2] = {{"]
    c += [f"    {{{lo}u, {hi}u}}," for lo, hi in ranges]
    c += ["};", "", "/* One row a setting, in parameter-id order: offset, kind (low nibble; high nibble: 1 + the capacity",
          " * a count setting counts), rule (low nibble; high nibble: the range of an integer rule). */",
          "const caekf_setting_row_t caekf_setting_rows[CAEKF_SETTING_COUNT] = {"]
    c += rows
    # caekf_settings_default zeroes the settings first (all bits zero: 0, 0.0 and the first enumerator), so
    # only the defaults that differ from it are written.
    c += ["};", "", "caekf_status_t caekf_settings_schema_defaults(caekf_settings_t *s)", "{",
          "    unsigned i;", "    if (s == 0) {", "        return CAEKF_ERR_NULL;", "    }"]
    for s in wire:
        for i in range(s.count):
            d = s.element_default(i)
            if d is None or _all_bits_zero(s, d):
                continue
            if isinstance(d, str) and d.endswith("eps"):
                expr = f"(caekf_scalar_t){d.split()[0]} * CAEKF_EPS"
            elif s.type == "enum":
                expr = f"{C_ENUMS[s.name][1]}{_macro(str(d))}"
            elif s.type == "real":
                expr = f"(caekf_scalar_t){_c_double(float(d))}"
            else:
                expr = str(int(s.default_value(index=i)))
            if s.name in COMPILED_IN:  # a default that needs its feature: off (zero) where it is compiled out
                c += [f"#if {COMPILED_IN[s.name]}", f"    s->{s.field} = {expr};", "#endif"]
            elif s.capacity is None:
                c.append(f"    s->{s.field}{f'[{i}]' if s.count > 1 else ''} = {expr};")
            elif isinstance(s.default, list) or i == 0:
                # Arrays over a capacity: the build may store fewer elements than the wire carries.
                lhs = f"s->{s.field}[{i}]" if isinstance(s.default, list) else f"s->{s.field}[i]"
                guard = (f"    if (CAEKF_MAX_{_macro(s.capacity)} > {i}u) {{" if isinstance(s.default, list)
                         else f"    for (i = 0; i < CAEKF_MAX_{_macro(s.capacity)}; ++i) {{")
                c += [guard, f"        {lhs} = {expr};", "    }"]
    # A build sized for one configuration (CAEKF_SIZED_METHOD) runs one step method: its defaults.
    fixed = {"discretisation": "CAEKF_SIZED_DISCRETISATION", "contact_substeps": "CAEKF_SIZED_CONTACT_SUBSTEPS",
             "gamma_log": "CAEKF_SIZED_GAMMA_LOG", "cov_update": "CAEKF_SIZED_COV_UPDATE",
             "switchoff": "CAEKF_SIZED_SWITCHOFF"}
    c += ["#if CAEKF_SIZED_METHOD"]
    c += [f"    s->{schema.by_name(k).field} = {v};" for k, v in fixed.items()]
    c += ["#ifdef CAEKF_SIZED_CONTACT_N", "    for (i = 0; i < CAEKF_MAX_CONTACTS; ++i) {",
          f"        s->{schema.by_name('contact_n').field}[i] = (caekf_scalar_t)CAEKF_SIZED_CONTACT_N;", "    }",
          "#endif", "#endif"]
    c += ["    (void)i;", "    return CAEKF_OK;", "}", ""]
    # Names: only host tools and messages need them; a separate object the MCU links only if used.
    n = [f"/* {GENERATED}. */", '#include "caekf/caekf.h"', "",
         "static const char *const setting_names[CAEKF_SETTING_COUNT] = {"]
    n += [f'    "{s.name}",' for s in wire] + ["};", "",
          "static const char *const param_keys[CAEKF_PARAM_COUNT] = {"]
    n += [f'    "{k}",' for s in wire for k in s.keys] + ["};", "",
          "static const char *const setting_rules[CAEKF_SETTING_COUNT] = {"]
    n += [f'    "{s.rule_text()}",' for s in wire] + ["};", "", """const char *caekf_setting_name(unsigned setting)
{
    return setting < CAEKF_SETTING_COUNT ? setting_names[setting] : 0;
}

const char *caekf_setting_rule_text(unsigned setting)
{
    return setting < CAEKF_SETTING_COUNT ? setting_rules[setting] : 0;
}

const char *caekf_param_key(unsigned param_id)
{
    return param_id < CAEKF_PARAM_COUNT ? param_keys[param_id] : 0;
}
"""]
    core = schema.core_flags
    n += ["static const char *const flag_names[CAEKF_FLAG_COUNT] = {"]
    n += [f'    "{f.name}",' for f in core] + ["};", "", """const char *caekf_flag_name(unsigned bit_index)
{
    return bit_index < CAEKF_FLAG_COUNT ? flag_names[bit_index] : "unknown";
}
""", "const char *caekf_status_str(caekf_status_t st)", "{", "    switch (st) {"]
    n += [f'    case CAEKF_{st.name}: return "{st.text}";' for st in schema.statuses]
    n += ['    default: return "unknown status";', "    }", "}", ""]
    return {"caekf/caekf_settings_schema.h": "\n".join(h), "caekf_settings_table.c": "\n".join(c),
            "caekf/caekf_settings_types.h": c_types(schema), "caekf/caekf_status.h": c_status(schema),
            "caekf_settings_names.c": "\n".join(n), "caekf/caekf_capacity.h": c_capacity(schema, mechanism, preset)}


def c_status(schema: Schema) -> str:
    """The estimator's status codes (caekf_status_t) and health flags (caekf_report_t.flags, a bit mask,
    PX4-style)."""
    core = schema.core_flags
    last = len(schema.statuses) - 1
    h = [f"/* {GENERATED}. */", "#ifndef CAEKF_STATUS_H", "#define CAEKF_STATUS_H", "",
         "/* Status of every public call (errno-like: 0 is success, negative is an error). */", "typedef enum {"]
    h += [f"    CAEKF_{st.name} = {st.value}{',' if i < last else ''} {_c_comment(st.doc)}"
          for i, st in enumerate(schema.statuses)]
    h += ["} caekf_status_t;", "",
          "/* Health flags of one step (caekf_report_t.flags; several may be set at once). */", "enum {"]
    h += [f"    CAEKF_FLAG_{_macro(f.name)} = 1u << {f.bit}{',' if i + 1 < len(core) else ''} {_c_comment(f.doc)}"
          for i, f in enumerate(core)]
    h += ["};", f"#define CAEKF_FLAG_COUNT {len(core)}",
          f"#define CAEKF_FLAG_MASK 0x{(1 << len(core)) - 1:X}u /* every flag above */", "", "#endif", ""]
    return "\n".join(h)


def c_host(schema: Schema) -> Dict[str, str]:
    keys = schema.keys()
    row_of = {k: n for n, (k, _, _) in enumerate(keys)}
    rows = [(k, k, s, i) for k, s, i in keys] + [(a, k, *next((s, i) for kk, s, i in keys if kk == k))
                                                 for a, k in schema.aliases()]
    h = [f"/* {GENERATED}. */", "#ifndef CAEKF_SCENARIO_SCHEMA_H", "#define CAEKF_SCENARIO_SCHEMA_H", "",
         f"#define CAEKF_SCENARIO_KEY_COUNT {len(keys)}u /* canonical keys: one double each */",
         f"#define CAEKF_SCENARIO_ROW_COUNT {len(rows)}u /* the keys, then their aliases */", "",
         "/* Every scenario key, in schema order (array elements by their own keys). */",
         "typedef struct {"]
    h += [f"    double {k}; /* {s.unit or '-'}: {s.doc if i == 0 else s.element(i)} */" for k, s, i in keys]
    h += ["    unsigned char given[CAEKF_SCENARIO_KEY_COUNT]; /* the file set key i (else: its default) */",
          "} caekf_scenario_t;", "",
          "typedef struct {",
          "    const char *key;",
          "    unsigned canonical;   /* the key this row sets (an alias row names another) */",
          "    unsigned offset;      /* of the double in caekf_scenario_t */",
          "    int param_id;         /* CTRL_PARAM id, or -1 for a truth-only key */",
          "    int required;         /* no default: the file must give it when it is in use; a truth-only key",
          "                           * (param_id -1) only to simulate a truth (caekf_scenario_need_truth) */",
          "    double default_value; /* when not required (newton_rtol: double epsilon based); NAN for a",
          "                           * required truth-only key, which estimating from recorded data never reads */",
          "    int is_integer;       /* int, enum or bool */",
          "    const char *rule;     /* the range rule as a message states it */",
          "    int rule_code;        /* CAEKF_RULE_* of caekf_settings_schema.h */",
          "    double lo, hi;        /* integer range */",
          "    const char *enum_names; /* an enum's value names, '|'-separated (a file may write \"name\"), or 0 */",
          "    int in_use_key;       /* key giving how many elements of this array are in use, or -1 */",
          "    unsigned index;       /* element of an array setting */",
          "} caekf_scenario_key_t;", "",
          "extern const caekf_scenario_key_t caekf_scenario_keys[CAEKF_SCENARIO_ROW_COUNT];", "",
          "typedef struct {",
          "    const char *name;",
          "    const char *doc;",
          "    unsigned n_values;",
          "    unsigned param_id[8];",
          "    double value[8];",
          "} caekf_preset_t;", "",
          f"#define CAEKF_PRESET_COUNT {len(schema.presets)}u",
          "extern const caekf_preset_t caekf_presets[CAEKF_PRESET_COUNT];", "", "#endif", ""]
    c = [f"/* {GENERATED}. */", '#include "caekf_scenario_schema.h"', "", "#include <math.h>", "#include <stddef.h>", "",
         "const caekf_scenario_key_t caekf_scenario_keys[CAEKF_SCENARIO_ROW_COUNT] = {"]
    for k, canon, s, i in rows:
        pid = -1 if s.id is None else s.id + i
        req = s.element_required(i)
        dv = ("NAN" if s.kind == "truth" else "0.0") if req else repr(s.default_value(index=i))
        rule = RULES[s.range]
        lo = 0.0 if s.range != "int" else s.lo
        hi = 0.0 if s.range != "int" else s.hi
        names = '"' + "|".join(s.values) + '"' if s.type == "enum" else "0"
        in_use = row_of[schema.by_name(s.in_use_by).keys[0]] if s.in_use_by else -1
        c.append(f'    {{"{k}", {row_of[canon]}u, (unsigned)offsetof(caekf_scenario_t, {canon}), {pid}, {int(req)}, '
                 f'{dv}, {int(s.type != "real")}, "{s.rule_text()}", {rule}, {lo!r}, {hi!r}, {names}, {in_use}, {i}u}},')
    c += ["};", "", "const caekf_preset_t caekf_presets[CAEKF_PRESET_COUNT] = {"]
    for p in schema.presets:
        if len(p.values) > 8:
            raise SchemaError(f"preset {p.name}: more than 8 values")
        ids = ", ".join(str(schema.by_name(k).id) for k in p.values)
        vals = ", ".join(repr(v) for v in p.values.values())
        c.append(f'    {{"{p.name}", "{p.doc}", {len(p.values)}u, {{{ids}}}, {{{vals}}}}},')
    c += ["};", ""]
    return {"caekf_scenario_schema.h": "\n".join(h), "caekf_scenario_schema.c": "\n".join(c)}


def shortest_decimal(v: float) -> Tuple[int, int]:
    """(mantissa, exp10) with v == mantissa * 10^exp10, from the shortest repr that round-trips."""
    m = re.fullmatch(r"(-?)(\d+)(?:\.(\d*))?(?:e([+-]?\d+))?", repr(float(v)))
    if m is None:
        raise SchemaError(f"cannot write {v!r} as mantissa * 10^exp")
    sign, whole, frac, exp = m.group(1), m.group(2), m.group(3) or "", int(m.group(4) or 0)
    digits = (whole + frac).lstrip("0") or "0"
    exp -= len(frac)
    while digits != "0" and digits.endswith("0"):
        digits, exp = digits[:-1], exp + 1
    mant = int(digits) * (-1 if sign else 1)
    return mant, (0 if mant == 0 else exp)


def read_scenario_values(schema: Schema, path: Path, wire_only: bool = True) -> Dict[str, float]:
    """The settings a scenario file gives (flat `key = value`), by key: the wire ones or all."""
    raw = tomllib.loads(path.read_text(encoding="utf-8"))
    canonical = {**{k: k for k, _, _ in schema.keys()}, **dict(schema.aliases())}
    setting = {k: s for k, s, _ in schema.keys()}
    unknown = sorted(set(raw) - set(canonical))
    if unknown:
        raise SchemaError(f"{path}: unknown keys {unknown}")
    out: Dict[str, float] = {}
    for k, v in raw.items():
        s = setting[canonical[k]]
        if s.on_wire or not wire_only:
            out[k] = float(s.values.index(v)) if isinstance(v, str) else float(v)
    return out


def c_fixture(schema: Schema, scenario: Path) -> Dict[str, str]:
    given = read_scenario_values(schema, scenario)
    ids = {k: s.id + i for k, s, i in schema.keys() if s.on_wire}  # type: ignore[operator]
    ids.update({a: ids[k] for a, k in schema.aliases() if k in ids})
    rows = []
    for k, v in given.items():
        mant, e10 = shortest_decimal(v)
        rows.append(f"    {{{ids[k]}u, {e10}, {mant}, {v!r}}}, /* {k} */")
    name = "".join(ch if ch.isalnum() else "_" for ch in scenario.stem)  # a C identifier (paper-joint)
    h = [f"/* {GENERATED}, and from {scenario.name}. */",
         f"/* The wire settings {scenario.name} gives, as the bench sends them (CTRL_PARAM: value = mantissa",
         " * 10^exp10, shortest decimal form) and as values. One table for every C test that configures the",
         " * estimator or the app from this scenario. */",
         "#ifndef CAEKF_FIXTURE_SETTINGS_H", "#define CAEKF_FIXTURE_SETTINGS_H", "", "#include <stdint.h>", "",
         "typedef struct {", "    uint8_t id;", "    int8_t exp10;", "    int64_t mantissa;", "    double value;",
         "} caekf_fixture_param_t;", "",
         f"static const caekf_fixture_param_t caekf_{name}_params[] = {{"] + rows + [
         "};",
         f"#define CAEKF_N_{_macro(name)}_PARAMS ((unsigned)(sizeof caekf_{name}_params / sizeof caekf_{name}_params[0]))",
         "/* The same under a name that does not depend on the scenario's file name. */",
         f"#define caekf_scenario_params caekf_{name}_params",
         f"#define CAEKF_N_SCENARIO_PARAMS CAEKF_N_{_macro(name)}_PARAMS",
         "", "/* The presets, as (id, value) lists. */",
         "typedef struct {", "    const char *name;", "    unsigned n;", "    uint8_t id[8];", "    double value[8];",
         "} caekf_fixture_preset_t;", "", "static const caekf_fixture_preset_t caekf_fixture_presets[] = {"]
    for p in schema.presets:
        pids = ", ".join(str(schema.by_name(k).id) for k in p.values)
        vals = ", ".join(repr(v) for v in p.values.values())
        h.append(f'    {{"{p.name}", {len(p.values)}u, {{{pids}}}, {{{vals}}}}},')
    h += ["};", f"#define CAEKF_N_FIXTURE_PRESETS {len(schema.presets)}u", "",
          f"/* Every value {scenario.name} gives, truth keys included. */"]
    for k, v in read_scenario_values(schema, scenario, wire_only=False).items():
        h.append(f"#define CAEKF_{_macro(name)}_{_macro(k)} ({v!r})")
    h.append("")
    for p in schema.presets:
        h.append(f"#define CAEKF_FIXTURE_PRESET_{_macro(p.name)} {schema.presets.index(p)}u")
    h += ["", "#endif", ""]
    return {"caekf_fixture_settings.h": "\n".join(h)}


# ---- DBC ------------------------------------------------------------------------------------------

def dbc_lines(schema: Schema) -> Tuple[str, str]:
    pairs = " ".join(f'{s.id + i} "{k}"' for s in schema.wire for i, k in enumerate(s.keys))  # type: ignore[operator]
    return (f"VAL_ 193 PARAM_ID {pairs} ;", f"[0|{schema.param_count - 1}]")


def dbc_update(schema: Schema, text: str) -> str:
    val, rng = dbc_lines(schema)
    out, n = re.subn(r"^VAL_ 193 PARAM_ID .*;$", val, text, flags=re.M)
    if n != 1:
        raise SchemaError("the DBC has no 'VAL_ 193 PARAM_ID' line")
    out, n = re.subn(r"^( SG_ PARAM_ID : \d+\|\d+@1\+ \(1,0\) )\[0\|\d+\]", lambda m: m.group(1) + rng, out, flags=re.M)
    if n != 1:
        raise SchemaError("the DBC has no PARAM_ID signal")
    statuses = " ".join(f'{st.value} "{st.name}"' for st in schema.statuses)
    out, n = re.subn(r"^VAL_ (\d+) STEP_STATUS .*;$", lambda m: f"VAL_ {m.group(1)} STEP_STATUS {statuses} ;", out,
                     flags=re.M)
    if n == 0:
        raise SchemaError("the DBC has no 'VAL_ <id> STEP_STATUS' line")
    return out


def _write(outdir: Path, files: Dict[str, str]) -> None:
    for rel, text in files.items():
        p = outdir / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(text, encoding="utf-8")  # always: the build tool compares timestamps


def main(argv: Sequence[str]) -> int:
    try:
        schema = load()
        if len(argv) >= 2 and argv[0] == "c-core":
            mech = Path(argv[2]) if len(argv) >= 3 and argv[2] else None
            preset = argv[3] if len(argv) >= 4 and argv[3] and mech is not None else None
            _write(Path(argv[1]), c_core(schema, mech, preset))
        elif len(argv) >= 2 and argv[0] == "c-host":
            _write(Path(argv[1]), c_host(schema))
        elif len(argv) >= 3 and argv[0] == "c-fixture":
            _write(Path(argv[1]), c_fixture(schema, Path(argv[2])))
        elif len(argv) == 3 and argv[0] == "dbc" and argv[2] in ("--check", "--write"):
            path = Path(argv[1])
            text = path.read_text(encoding="utf-8")
            new = dbc_update(schema, text)
            if argv[2] == "--write":
                if new != text:
                    path.write_text(new, encoding="utf-8")
            elif new != text:
                print(f"codegen: {path} is stale: run codegen.py dbc {path} --write", file=sys.stderr)
                return 1
        else:
            print(__doc__, file=sys.stderr)
            return 2
    except (SchemaError, OSError, KeyError, tomllib.TOMLDecodeError) as exc:
        print(f"codegen: {exc}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
