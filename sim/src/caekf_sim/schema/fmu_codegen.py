#!/usr/bin/env python3
"""Generate the FMUs' model descriptions and variable tables from the settings schema (settings.toml).

Run by CMake at build time (fmu/CMakeLists.txt); the outputs live in the build tree and are never edited:

    fmu_codegen.py ROLE OUTDIR SCENARIO VERSION
        ROLE      estimator | plant
        OUTDIR    gets caekf_fmu_vars.h (the C table of every variable: value reference = row),
                  fmi2/modelDescription.xml and fmi3/modelDescription.xml
        SCENARIO  the scenario whose values are the parameters' start values (the FMU's default
                  configuration; the plant also needs its truth-only keys)
        VERSION   the project's version (CMake's project(caekf VERSION ...))

The estimator's parameters are every wire setting of the schema (one per element, by its scenario key), the
plant's every setting of kind model or truth that the continuous truth reads. Inputs and outputs are sized by
the schema's [capacity] (entries beyond the mechanism's counts are ignored or 0), so one FMU serves every
mechanism within the capacity; its structure is fixed when the instance is initialised. Units, ranges,
descriptions and defaults come from the schema, the health flags from its [[flag]] entries.
Standard library only, like codegen.py.
"""
from __future__ import annotations

import math
import sys
import uuid
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple
from xml.sax.saxutils import quoteattr

if __package__:
    from .codegen import Schema, SchemaError, Setting, load, read_scenario_values
else:  # run as a script by CMake
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    from codegen import Schema, SchemaError, Setting, load, read_scenario_values  # type: ignore[no-redef,import-not-found]

GENERATED = "GENERATED from sim/src/caekf_sim/schema/settings.toml by fmu_codegen.py: do not edit"
ROLES = ("estimator", "plant")
MODEL_IDENTIFIER = {"estimator": "caekf_estimator", "plant": "caekf_plant"}
# Settings of kind model or truth that the continuous truth (host/common/truth.c, DOP853) does not read: the
# estimator's discretisation and uncertain mechanism parameters, the run length (the master's stop time) and
# the legacy backward-Euler truth's substeps. Every other model or truth setting is a plant parameter.
PLANT_IGNORES = ("discretisation", "m_sigma", "spring_k_sigma", "spring_c_sigma", "t_end", "truth_substeps")
INT32_MAX = 2**31 - 1


@dataclass(frozen=True)
class Var:
    name: str
    type: str  # real | int | bool | enum
    causality: str  # parameter | input | output
    variability: str  # fixed | continuous | discrete
    role: str  # the C role (CAEKF_FMU_<role>)
    index: int  # parameters: the key's row in caekf_scenario_keys; else the element (0-based)
    doc: str
    unit: str = ""
    start: Optional[float] = None
    lo: Optional[float] = None
    hi: Optional[float] = None
    enum: Optional[str] = None  # declared type of an enum


def _fmt(v: float) -> str:
    return repr(float(v)) if not float(v).is_integer() or abs(v) >= 1e16 else str(int(v))


def _range(s: Setting) -> Tuple[Optional[float], Optional[float]]:
    if s.type in ("int", "enum", "bool"):
        return s.lo, s.hi
    ranges: Dict[str, Tuple[Optional[float], Optional[float]]] = {
        "> 0": (0.0, None), ">= 0": (0.0, None), ">= 1": (1.0, None), "(0, 1)": (0.0, 1.0)}
    return ranges.get(s.range, (None, None))


def _param_type(s: Setting) -> str:
    # An integer beyond Int32 (the noise seed) travels as an integral Float64: FMI 2 has no wider integer.
    return "real" if s.type == "int" and s.hi > INT32_MAX else s.type


def parameters(schema: Schema, role: str, given: Dict[str, float]) -> List[Var]:
    out = []
    for row, (key, s, i) in enumerate(schema.keys()):
        if role == "estimator" and not s.on_wire:
            continue
        if role == "plant" and (s.kind not in ("model", "truth") or s.name in PLANT_IGNORES):
            continue
        if key in given:
            start = given[key]
        elif s.element_required(i):
            if s.kind == "truth" and schema.in_use(s, i, given):
                raise SchemaError(f"the plant FMU needs the scenario's truth key {key!r}")
            start = 0.0  # not in use (the element's array count leaves it out): never read
        else:
            start = s.default_value(index=i)
        lo, hi = _range(s)
        if (lo is not None and start < lo) or (hi is not None and start > hi):
            lo = hi = None  # an element out of use at 0 where the rule starts above: no declared range
        default = s.element_default(i)
        doc = s.doc if s.count == 1 else f"{s.doc} Element {i + 1} ({s.element(i)})."
        doc += f" Rule: {s.rule_text()}."
        if default is not None and key in given:
            doc += f" Schema default: {default}."
        out.append(Var(name=key, type=_param_type(s), causality="parameter", variability="fixed", role="PARAM",
                       index=row, doc=doc, unit=s.unit, start=start, lo=lo, hi=hi,
                       enum=f"caekf_{s.name}" if s.type == "enum" else None))
    return out


def _unit(schema: Schema, name: str) -> str:
    return schema.by_name(name).unit


def _sq(unit: str) -> str:
    return f"({unit})^2" if unit else ""


def estimator_io(schema: Schema, given: Dict[str, float]) -> List[Var]:
    cap = schema.capacity
    uq, uv, un = _unit(schema, "q0"), _unit(schema, "v0"), _unit(schema, "input_amp")
    ug, ul, ugap = _unit(schema, "gamma0"), _unit(schema, "contact_lambda"), _unit(schema, "contact_gap")
    vel = schema.by_name("sensor_kind").values.index("velocity")
    v: List[Var] = []
    for i in range(cap["inputs"]):
        v.append(Var(f"u{i + 1}", "real", "input", "continuous", "IN_U", i,
                     f"Input {i + 1}'s force at the communication point (beyond `inputs`: ignored).", un, 0.0))
        v.append(Var(f"u{i + 1}_valid", "bool", "input", "discrete", "IN_U_VALID", i,
                     f"u{i + 1} is a fresh sample; false: the last valid u{i + 1} is held (0 before any).", start=1.0))
    for j in range(cap["sensors"]):
        kind = given.get(f"sensor{j + 1}_kind", 0.0)
        v.append(Var(f"y{j + 1}", "real", "input", "continuous", "IN_Y", j,
                     f"Sensor {j + 1}'s reading at the communication point: position [m] or velocity [m/s] as "
                     f"sensor{j + 1}_kind says (sensors beyond `sensors` are ignored).",
                     uv if kind == vel else uq, 0.0))
        v.append(Var(f"y{j + 1}_valid", "bool", "input", "discrete", "IN_Y_VALID", j,
                     f"y{j + 1} is a fresh sample; a step with any sensor in use not valid is a time update only "
                     "(caekf_predict).", start=1.0))
    o = []
    nb, nc = cap["bodies"], cap["contacts"]
    for i in range(nb):
        o.append(Var(f"q{i + 1}", "real", "output", "discrete", "OUT_Q", i, f"Estimated position of body {i + 1}.", uq))
    for i in range(nb):
        o.append(Var(f"v{i + 1}", "real", "output", "discrete", "OUT_V", i, f"Estimated velocity of body {i + 1}.", uv))
    for c in range(nc):
        o.append(Var(f"gamma{c + 1}", "real", "output", "discrete", "OUT_GAMMA", c,
                     f"Estimated stiffness gamma of contact {c + 1}.", ug))
        o.append(Var(f"n{c + 1}", "real", "output", "discrete", "OUT_N", c,
                     f"Contact {c + 1}'s exponent n: the estimate when estimated, else the setting."))
        o.append(Var(f"lambda{c + 1}", "real", "output", "discrete", "OUT_LAMBDA", c,
                     f"Contact {c + 1}'s damping lambda: the estimate when estimated, else the setting.", ul))
        o.append(Var(f"gap{c + 1}", "real", "output", "discrete", "OUT_GAP", c,
                     f"Contact {c + 1}'s gap: the estimate when estimated, else the setting.", ugap))
    for i in range(nb):
        o.append(Var(f"var_q{i + 1}", "real", "output", "discrete", "OUT_VAR_Q", i,
                     f"P's diagonal: variance of q{i + 1}.", _sq(uq)))
    for i in range(nb):
        o.append(Var(f"var_v{i + 1}", "real", "output", "discrete", "OUT_VAR_V", i,
                     f"P's diagonal: variance of v{i + 1}.", _sq(uv)))
    for c in range(nc):
        o.append(Var(f"var_gamma{c + 1}", "real", "output", "discrete", "OUT_VAR_GAMMA", c,
                     f"P's diagonal: variance of gamma{c + 1}.", _sq(ug)))
        for law, law_unit in (("n", ""), ("lambda", ul), ("gap", ugap)):
            o.append(Var(f"var_{law}{c + 1}", "real", "output", "discrete", f"OUT_VAR_{law.upper()}", c,
                         f"P's diagonal: variance of {law}{c + 1} (0 unless estimated).", _sq(law_unit)))
    mech = (("m_sigma", "m{i}", "bodies", "MASS"), ("spring_k_sigma", "spring{i}_k", "springs", "STIFFNESS"),
            ("spring_c_sigma", "spring{i}_c", "springs", "DAMPER"))
    for setting, pattern, capname, mech_kind in mech:
        schema.by_name(setting)  # the uncertain mechanism parameters of the schema (KeyError if renamed)
        for i in range(cap[capname]):
            name = pattern.format(i=i + 1)
            o.append(Var(f"var_ln_{name}", "real", "output", "discrete", f"OUT_VAR_MECH_{mech_kind}", i,
                         f"P's diagonal: variance of ln({name} / setting) (0 unless {setting} makes it a state)."))
    o += [
        Var("nis", "real", "output", "discrete", "OUT_NIS", 0, "Normalised innovation squared of the step's correction "
            "(0 without one)."),
        Var("p_norm", "real", "output", "discrete", "OUT_P_NORM", 0, "2-norm of P in physical units."),
        Var("delta", "real", "output", "discrete", "OUT_DELTA", 0, "Deepest predicted penetration over the contacts.",
            ugap),
        Var("t_sample", "real", "output", "discrete", "OUT_T_SAMPLE", 0,
            "Communication point of the sample the outputs are the estimate of (one communication step back).",
            _unit(schema, "dt")),
        Var("flags", "int", "output", "discrete", "OUT_FLAGS", 0, "Health flags of the step (bit mask, CAEKF_FLAG_*)."),
        Var("newton_iters", "int", "output", "discrete", "OUT_NEWTON", 0, "Newton iterations of the prediction."),
        Var("status", "int", "output", "discrete", "OUT_STATUS", 0, "Status of the step (caekf_status_t: 0 ok)."),
    ]
    for f in schema.core_flags:
        o.append(Var(f"flag_{f.name}", "bool", "output", "discrete", "OUT_FLAG", f.bit, f"Health flag bit {f.mask}: "
                     f"{f.doc}"))
    return v + o


def plant_io(schema: Schema, given: Dict[str, float]) -> List[Var]:
    cap = schema.capacity
    uq, uv, un = _unit(schema, "q0"), _unit(schema, "v0"), _unit(schema, "input_amp")
    ugap = _unit(schema, "contact_gap")
    vel = schema.by_name("sensor_kind").values.index("velocity")
    o = []
    for i in range(cap["inputs"]):
        o.append(Var(f"u{i + 1}", "real", "output", "continuous", "OUT_U", i,
                     f"Input {i + 1}'s force: amp sin(2 pi freq t + phase) of input{i + 1}_amp, _freq, _phase.", un))
    for j in range(cap["sensors"]):
        kind = given.get(f"sensor{j + 1}_kind", 0.0)
        o.append(Var(f"y{j + 1}", "real", "output", "discrete", "OUT_Y", j,
                     f"Sensor {j + 1}'s sample (position or velocity of sensor{j + 1}_body) plus its noise.",
                     uv if kind == vel else uq))
    o.append(Var("y_valid", "bool", "output", "discrete", "OUT_Y_VALID", 0,
                 "The sensors hold a sample (false at the start time: the truth samples t = k dt, k >= 1)."))
    for i in range(cap["bodies"]):
        o.append(Var(f"q{i + 1}", "real", "output", "continuous", "OUT_Q", i, f"True position of body {i + 1}.", uq))
    for i in range(cap["bodies"]):
        o.append(Var(f"v{i + 1}", "real", "output", "continuous", "OUT_V", i, f"True velocity of body {i + 1}.", uv))
    for c in range(cap["contacts"]):
        o.append(Var(f"delta{c + 1}", "real", "output", "continuous", "OUT_DELTA", c,
                     f"True penetration of contact {c + 1} (> 0 in contact).", ugap))
    o += [Var("events", "int", "output", "discrete", "OUT_EVENTS", 0, "Contact events located so far."),
          Var("steps", "int", "output", "discrete", "OUT_STEPS", 0, "DOP853 steps taken so far.")]
    return o


def variables(schema: Schema, role: str, scenario: Path) -> Tuple[List[Var], Dict[str, float]]:
    raw = read_scenario_values(schema, scenario, wire_only=False)
    aliases = dict(schema.aliases())
    given = {aliases.get(k, k): v for k, v in raw.items()}
    io = estimator_io(schema, given) if role == "estimator" else plant_io(schema, given)
    return parameters(schema, role, given) + io, given


FMI3_TYPE = {"real": "Float64", "int": "Int32", "bool": "Boolean", "enum": "Enumeration"}
FMI2_TYPE = {"real": "Real", "int": "Integer", "bool": "Boolean", "enum": "Enumeration"}


def _start_text(v: Var) -> str:
    assert v.start is not None
    if v.type == "bool":
        return "true" if v.start else "false"
    if v.type in ("int", "enum"):
        return str(int(v.start))
    return repr(float(v.start))


def _enum_types(schema: Schema, vs: List[Var]) -> List[Setting]:
    names = sorted({v.enum for v in vs if v.enum})
    return [schema.by_name(n.removeprefix("caekf_")) for n in names]


def _units(vs: List[Var]) -> List[str]:
    return sorted({v.unit for v in vs if v.unit})


def _attrs(v: Var, vr: int, fmi: int) -> str:
    a = f"name={quoteattr(v.name)} valueReference=\"{vr}\" causality=\"{v.causality}\" variability=\"{v.variability}\""
    if v.causality == "output":
        a += ' initial="calculated"'
    a += f" description={quoteattr(v.doc)}"
    return a


def fmi3_xml(schema: Schema, role: str, vs: List[Var], token: str, version: str) -> str:
    mid = MODEL_IDENTIFIER[role]
    x = ['<?xml version="1.0" encoding="UTF-8"?>', f"<!-- {GENERATED} -->",
         f'<fmiModelDescription fmiVersion="3.0" modelName="{mid}" instantiationToken="{token}" '
         f'description={quoteattr(_description(role))} generationTool="caekf fmu_codegen.py" version="{version}" '
         'variableNamingConvention="flat">',
         f'  <CoSimulation modelIdentifier="{mid}" canHandleVariableCommunicationStepSize="false" '
         'canGetAndSetFMUState="false" canSerializeFMUState="false" providesIntermediateUpdate="false" '
         'canReturnEarlyAfterIntermediateUpdate="false" hasEventMode="false" '
         f'fixedInternalStepSize={quoteattr(repr(_dt(vs)))}/>',
         "  <UnitDefinitions>"] + [f"    <Unit name={quoteattr(u)}/>" for u in _units(vs)] + ["  </UnitDefinitions>"]
    enums = _enum_types(schema, vs)
    if enums:
        x.append("  <TypeDefinitions>")
        for s in enums:
            x.append(f'    <EnumerationType name="caekf_{s.name}">')
            x += [f'      <Item name={quoteattr(n)} value="{k}"/>' for k, n in enumerate(s.values)]
            x.append("    </EnumerationType>")
        x.append("  </TypeDefinitions>")
    x += ["  <DefaultExperiment startTime=\"0\" stepSize=" + quoteattr(repr(_dt(vs))) + "/>", "  <ModelVariables>",
          '    <Float64 name="time" valueReference="' + str(len(vs)) + '" causality="independent" '
          'variability="continuous" description="Simulation time"/>']
    for vr, v in enumerate(vs):
        t = FMI3_TYPE[v.type]
        a = _attrs(v, vr, 3)
        if v.enum:
            a += f' declaredType="{v.enum}"'
        if v.unit and v.type == "real":
            a += f" unit={quoteattr(v.unit)}"
        if v.type != "bool":
            if v.lo is not None and not v.enum:
                a += f' min="{_fmt(v.lo)}"'
            if v.hi is not None and not v.enum:
                a += f' max="{_fmt(v.hi)}"'
        if v.start is not None:
            a += f' start="{_start_text(v)}"'
        x.append(f"    <{t} {a}/>")
    x += ["  </ModelVariables>", "  <ModelStructure>"]
    outs = [vr for vr, v in enumerate(vs) if v.causality == "output"]
    x += [f'    <Output valueReference="{vr}" dependencies=""/>' for vr in outs]
    x += [f'    <InitialUnknown valueReference="{vr}"/>' for vr in outs]
    x += ["  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(x)


def fmi2_xml(schema: Schema, role: str, vs: List[Var], token: str, version: str) -> str:
    mid = MODEL_IDENTIFIER[role]
    x = ['<?xml version="1.0" encoding="UTF-8"?>', f"<!-- {GENERATED} -->",
         f'<fmiModelDescription fmiVersion="2.0" modelName="{mid}" guid="{token}" '
         f'description={quoteattr(_description(role))} generationTool="caekf fmu_codegen.py" version="{version}" '
         'variableNamingConvention="flat" numberOfEventIndicators="0">',
         f'  <CoSimulation modelIdentifier="{mid}" canHandleVariableCommunicationStepSize="false" '
         'canInterpolateInputs="false" maxOutputDerivativeOrder="0" canRunAsynchronuously="false" '
         'canBeInstantiatedOnlyOncePerProcess="false" canNotUseMemoryManagementFunctions="true" '
         'canGetAndSetFMUstate="false" canSerializeFMUstate="false" providesDirectionalDerivative="false"/>',
         "  <UnitDefinitions>"] + [f"    <Unit name={quoteattr(u)}/>" for u in _units(vs)] + ["  </UnitDefinitions>"]
    enums = _enum_types(schema, vs)
    if enums:
        x.append("  <TypeDefinitions>")
        for s in enums:
            x.append(f'    <SimpleType name="caekf_{s.name}">')
            x.append("      <Enumeration>")
            x += [f'        <Item name={quoteattr(n)} value="{k}"/>' for k, n in enumerate(s.values)]
            x += ["      </Enumeration>", "    </SimpleType>"]
        x.append("  </TypeDefinitions>")
    x += ["  <DefaultExperiment startTime=\"0\" stepSize=" + quoteattr(repr(_dt(vs))) + "/>", "  <ModelVariables>"]
    for vr, v in enumerate(vs):
        x.append(f"    <!-- index {vr + 1} -->")
        x.append(f"    <ScalarVariable {_attrs(v, vr, 2)}>")
        t = FMI2_TYPE[v.type]
        a = ""
        if v.enum:
            a += f' declaredType="{v.enum}"'
        if v.unit and v.type == "real":
            a += f" unit={quoteattr(v.unit)}"
        if v.type in ("real", "int"):
            if v.lo is not None:
                a += f' min="{_fmt(v.lo)}"'
            if v.hi is not None:
                a += f' max="{_fmt(v.hi)}"'
        if v.start is not None:
            a += f' start="{_start_text(v)}"'
        x += [f"      <{t}{a}/>", "    </ScalarVariable>"]
    x += ["  </ModelVariables>", "  <ModelStructure>", "    <Outputs>"]
    outs = [vr for vr, v in enumerate(vs) if v.causality == "output"]
    x += [f'      <Unknown index="{vr + 1}" dependencies=""/>' for vr in outs]
    x += ["    </Outputs>", "    <InitialUnknowns>"]
    x += [f'      <Unknown index="{vr + 1}"/>' for vr in outs]
    x += ["    </InitialUnknowns>", "  </ModelStructure>", "</fmiModelDescription>", ""]
    return "\n".join(x)


def _description(role: str) -> str:
    if role == "estimator":
        return ("caekf: contact-parameter estimation by a switched, constrained augmented EKF; one communication "
                "step per sample dt")
    return "caekf plant: the continuous mechanism with contact events (DOP853), sampled every dt with sensor noise"


def _dt(vs: List[Var]) -> float:
    return float(next(v.start for v in vs if v.name == "dt" and v.start is not None))


C_TYPE = {"real": "CAEKF_FMU_REAL", "int": "CAEKF_FMU_INT", "bool": "CAEKF_FMU_BOOL", "enum": "CAEKF_FMU_ENUM"}


def c_table(role: str, vs: List[Var], given: Dict[str, float], schema: Schema, token: str) -> str:
    rows = {k: n for n, (k, _, _) in enumerate(schema.keys())}
    h = [f"/* {GENERATED}. */", "/* The variables of the " + role + " FMU: value reference = row. */",
         "#ifndef CAEKF_FMU_VARS_H", "#define CAEKF_FMU_VARS_H", "", '#include "fmu_roles.h"', "",
         f'#define CAEKF_FMU_MODEL_IDENTIFIER "{MODEL_IDENTIFIER[role]}"',
         f'#define CAEKF_FMU_TOKEN "{token}"', f"#define CAEKF_FMU_VAR_COUNT {len(vs)}u",
         f"#define CAEKF_FMU_TIME_VR {len(vs)}u /* FMI 3's independent variable */",
         f"#define CAEKF_FMU_IS_PLANT {int(role == 'plant')}", "",
         "static const caekf_fmu_var_t caekf_fmu_vars[CAEKF_FMU_VAR_COUNT] = {"]
    for vr, v in enumerate(vs):
        start = 0.0 if v.start is None else v.start
        h.append(f'    {{"{v.name}", {C_TYPE[v.type]}, CAEKF_FMU_{v.role}, {v.index}u, {float(start)!r}}}, /* {vr} */')
    h += ["};", "", "/* The scenario's values (the parameters' start values): key row, value. */",
          "static const caekf_fmu_given_t caekf_fmu_scenario[] = {"]
    for k, val in given.items():
        h.append(f"    {{{rows[k]}u, {float(val)!r}}}, /* {k} */")
    h += ["};", "#define CAEKF_FMU_SCENARIO_COUNT (sizeof caekf_fmu_scenario / sizeof caekf_fmu_scenario[0])", "",
          "#endif", ""]
    return "\n".join(h)


def generate(role: str, scenario: Path, version: str, schema: Optional[Schema] = None) -> Dict[str, str]:
    schema = schema or load()
    if role not in ROLES:
        raise SchemaError(f"unknown FMU role {role!r} ({', '.join(ROLES)})")
    vs, given = variables(schema, role, scenario)
    # The token names this exact interface: the variables, their starts and the version.
    ident = "\n".join(f"{v.name}:{v.type}:{v.causality}:{v.start!r}" for v in vs) + version + role
    token = "{" + str(uuid.uuid5(uuid.NAMESPACE_URL, "caekf-fmu:" + ident)) + "}"
    for v in vs:
        if v.start is not None and not math.isfinite(v.start):
            raise SchemaError(f"{v.name}: start value {v.start} is not finite")
    return {"caekf_fmu_vars.h": c_table(role, vs, given, schema, token),
            "fmi3/modelDescription.xml": fmi3_xml(schema, role, vs, token, version),
            "fmi2/modelDescription.xml": fmi2_xml(schema, role, vs, token, version)}


def main(argv: Sequence[str]) -> int:
    if len(argv) != 4:
        print(__doc__, file=sys.stderr)
        return 2
    try:
        files = generate(argv[0], Path(argv[2]), argv[3])
        for rel, text in files.items():
            p = Path(argv[1]) / rel
            p.parent.mkdir(parents=True, exist_ok=True)
            p.write_text(text, encoding="utf-8")
    except (SchemaError, OSError, KeyError) as exc:
        print(f"fmu_codegen: {exc}", file=sys.stderr)
        return 3
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
