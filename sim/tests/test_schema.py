"""The settings schema is the single description: the committed DBC's value table is generated from it,
ids are dense, presets name only wire settings, and the generated C agrees with the Python view."""
from pathlib import Path

import pytest

from caekf_sim import schema
from caekf_sim.schema import codegen

REPO = Path(__file__).resolve().parents[2]
DBC = REPO / "firmware" / "protocol" / "caekf.dbc"


def test_committed_dbc_value_table_is_not_stale():
    text = DBC.read_text()
    assert codegen.dbc_update(schema.SCHEMA, text) == text, "run codegen.py dbc firmware/protocol/caekf.dbc --write"


def test_stale_dbc_is_detected(tmp_path):
    stale = DBC.read_text().replace('"sigma_r"', '"sigma_rr"')
    p = tmp_path / "caekf.dbc"
    p.write_text(stale)
    assert codegen.main(["dbc", str(p), "--check"]) == 1
    assert codegen.main(["dbc", str(p), "--write"]) == 0 and p.read_text() == DBC.read_text()


def test_ids_are_dense_and_keys_unique():
    ids = schema.param_ids()
    assert sorted(ids.values()) == list(range(schema.SCHEMA.param_count))
    assert len(set(ids)) == len(ids)


def test_schema_errors_are_one_line(tmp_path):
    bad = (codegen.SCHEMA_PATH.read_text()).replace("id = 10\n", "id = 11\n", 1)
    p = tmp_path / "s.toml"
    p.write_text(bad)
    with pytest.raises(codegen.SchemaError, match="dense"):
        codegen.load(p)


def test_settings_out_of_id_order_are_refused(tmp_path):
    """The C table is looked up by id in the file's order: a block of settings moved ahead of lower ids (the
    mechanism's sigmas once sat before the mismatch monitor's) made caekf_settings_set refuse a preset's value."""
    text = codegen.SCHEMA_PATH.read_text()
    start = text.index('[[setting]]\nname = "mismatch_window"')
    block = text[start:text.index('[[setting]]\nname = "m_sigma"')]
    moved = text.replace(block, "", 1)
    at = moved.index("# --- truth only")
    p = tmp_path / "s.toml"
    p.write_text(moved[:at] + block + moved[at:])
    with pytest.raises(codegen.SchemaError, match="id order"):
        codegen.load(p)


def test_generated_c_tables_follow_the_schema(tmp_path):
    files = codegen.c_core(schema.SCHEMA)
    header = files["caekf/caekf_settings_schema.h"]
    for s in schema.SCHEMA.wire:
        assert f"#define CAEKF_PARAM_{s.name.upper()} {s.id}u" in header
    table = files["caekf_settings_table.c"]
    rows = table.split("caekf_setting_rows[CAEKF_SETTING_COUNT] = {")[1].split("};")[0]
    assert rows.count("{(uint16_t)offsetof(caekf_settings_t,") == len(schema.SCHEMA.wire)
    assert [line.split("/* ")[1].split(" */")[0] for line in rows.strip().splitlines()[0:]
            if "offsetof" in line] == [s.name for s in schema.SCHEMA.wire]
    ints = {(int(s.lo), int(s.hi)) for s in schema.SCHEMA.wire if s.range == "int"}
    assert f"caekf_setting_ranges[{len(ints)}][2]" in table  # each distinct integer range once


def test_the_settings_c_types_are_generated_and_declared_nowhere_else():
    """caekf_settings_t and caekf_model_params_t have exactly one member per wire setting, of its storage
    type and capacity, and no hand-written header declares them (adding a setting is the schema entry and
    its use in the filter)."""
    import re

    types = codegen.c_core(schema.SCHEMA)["caekf/caekf_settings_types.h"]
    model = types.split("typedef struct {")[1].split("} caekf_model_params_t;")[0]
    rest = types.split("} caekf_model_params_t;")[1].split("} caekf_settings_t;")[0]
    decl = re.compile(r"^    (caekf_scalar_t|int) (\w+)(?:\[CAEKF_MAX_(\w+)\])?;", re.M)
    members = {("model." if body is model else "") + m[1]: (m[0], m[2]) for body in (model, rest)
               for m in decl.findall(body)}
    want = {s.field: ("caekf_scalar_t" if s.type == "real" else "int", (s.capacity or "").upper())
            for s in schema.SCHEMA.wire}
    assert members == want
    for v in schema.SCHEMA.by_name("mode").values:
        assert f"CAEKF_MODE_{v.upper()} = {schema.SCHEMA.by_name('mode').values.index(v)}" in types
    for header in (REPO / "firmware").rglob("*.h"):
        text = header.read_text()
        assert "} caekf_settings_t;" not in text and "} caekf_model_params_t;" not in text, header


def test_shortest_decimal_round_trips():
    for v in (1e-3, 7.5e7, 2.5e7, -1.5e-3, 1000.0, 0.0, 123456789.0, 1e-9):
        m, e = codegen.shortest_decimal(v)
        assert float(f"{m}e{e}") == v


def test_presets_reproduce_the_paper_experiments_rule():
    """Table 1 and Sec. 4: canonical has no gate; highq multiplies Q_gamma by 1000; the last is constrained."""
    p = {x.name: x.values for x in schema.SCHEMA.presets}
    modes = schema.SCHEMA.by_name("mode").values
    assert [modes[int(p[n]["mode"])] for n in p] == ["canonical", "switched", "switched", "switched"]
    assert p["canonical"]["gamma_gate_nis"] == 0.0 and "gamma_gate_nis" not in p["switched"]
    assert [p[n]["q_gamma_scale"] for n in p] == [1.0, 1.0, 1000.0, 1000.0]
    assert [p[n]["constraint_enabled"] for n in p] == [0, 0, 0, 1]


SCENARIOS = REPO / "sim" / "scenarios"


def test_a_mechanism_sizes_counts_only_and_a_preset_fixes_the_step_method(tmp_path):
    """CAEKF_MECHANISM alone: the counts are constants, the step method stays a run-time setting; with a
    preset (CAEKF_MECHANISM_PRESET) the method the scenario and the preset give is fixed, and the schema's
    defaults follow it."""
    cap = codegen.c_capacity(schema.SCHEMA, SCENARIOS / "paper.toml")
    assert "#define CAEKF_SIZED 1" in cap and "#define CAEKF_SIZED_BODIES 4" in cap
    assert "#define CAEKF_SIZED_METHOD 0" in cap and "CAEKF_SIZED_DISCRETISATION" not in cap
    files = codegen.c_core(schema.SCHEMA, SCENARIOS / "paper.toml", "switched-highq-constrained")
    cap = files["caekf/caekf_capacity.h"]
    be = schema.SCHEMA.by_name("discretisation").values.index("backward_euler")
    assert "#define CAEKF_SIZED_METHOD 1" in cap
    assert f"#define CAEKF_SIZED_DISCRETISATION {be}" in cap
    assert "#define CAEKF_SIZED_CONTACT_SUBSTEPS 1" in cap
    assert "#define CAEKF_SIZED_CONTACT_N 1.5" in cap
    table = files["caekf_settings_table.c"]
    assert "s->model.discretisation = CAEKF_SIZED_DISCRETISATION;" in table
    assert "s->contact_substeps = CAEKF_SIZED_CONTACT_SUBSTEPS;" in table
    # Contacts with different exponents: the exponent stays a run-time setting.
    two = tmp_path / "two.toml"
    two.write_text("contacts = 2\ncontact2_a = 3\ncontact2_b = 4\ncontact2_n = 1.0\n")
    cap = codegen.c_capacity(schema.SCHEMA, two, "canonical")
    assert "#define CAEKF_SIZED_CONTACTS 2" in cap and "CAEKF_SIZED_CONTACT_N" not in cap
    with pytest.raises(codegen.SchemaError, match="unknown preset"):
        codegen.c_capacity(schema.SCHEMA, SCENARIOS / "paper.toml", "no-such-preset")


def test_the_default_configuration_sizes_a_build_for_the_recommended_estimator():
    """CAEKF_MECHANISM_PRESET=default: no preset's values, the schema's defaults under the scenario (the
    recommended estimator: trapezoidal, contact substeps, statistically linearised contacts, so
    CAEKF_SIZED_SLR 1; the paper's presets 0); with the whole contact law estimated (paper-joint.toml) the
    law's states and ln gamma are sized and the exponent is no constant. The links' and the contacts' ends
    are the scenario's, with the pattern they give K and C (CAEKF_FIXED_LINKS)."""
    trap = schema.SCHEMA.by_name("discretisation").values.index("trapezoidal")
    cap = codegen.c_capacity(schema.SCHEMA, SCENARIOS / "paper.toml", "default")
    assert "#define CAEKF_SIZED_METHOD 1" in cap and f"#define CAEKF_SIZED_DISCRETISATION {trap}" in cap
    substeps = int(schema.SCHEMA.by_name("contact_substeps").default_value())
    assert substeps > 1 and f"#define CAEKF_SIZED_CONTACT_SUBSTEPS {substeps}" in cap
    assert "#define CAEKF_SIZED_LAW_PARAMS 0" in cap
    assert "#define CAEKF_SIZED_SLR 1" in cap
    # paper.toml's links 1-ground, 1-2, 3-4, 4-ground and its contact 2-3
    assert "#define CAEKF_SIZED_SPRING_A {1, 1, 3, 4}" in cap and "#define CAEKF_SIZED_SPRING_B {0, 2, 4, 0}" in cap
    assert "#define CAEKF_SIZED_LINK_NNZ {2, 2, 2, 2}" in cap
    assert "#define CAEKF_SIZED_LINK_NZ {{0, 1}, {0, 1}, {2, 3}, {2, 3}}" in cap
    assert "#define CAEKF_SIZED_CONTACT_A {2}" in cap and "#define CAEKF_SIZED_CONTACT_B {3}" in cap
    for preset in ("canonical", "switched", "switched-highq", "switched-highq-constrained"):
        paper = codegen.c_capacity(schema.SCHEMA, SCENARIOS / "paper.toml", preset)
        assert "#define CAEKF_SIZED_SLR 0" in paper
        # the standard covariance form, the consistent switch-off, no damping in paper.toml's contact
        for name, macro in (("cov_update", "COV_UPDATE"), ("switchoff", "SWITCHOFF")):
            st = schema.SCHEMA.by_name(name)
            assert f"#define CAEKF_SIZED_{macro} {st.values.index(st.default)}" in paper
        assert "#define CAEKF_SIZED_DAMPED 0" in paper
    # damped: a nonzero lambda (valve.toml), or lambda estimated over an undamped truth (paper-joint.toml)
    assert "#define CAEKF_SIZED_DAMPED 1" in codegen.c_capacity(schema.SCHEMA, SCENARIOS / "valve.toml", "default")
    cap = codegen.c_capacity(schema.SCHEMA, SCENARIOS / "paper-joint.toml", "default")
    assert "#define CAEKF_SIZED_LAW_PARAMS 3" in cap and "#define CAEKF_MAX_LAW_PARAMS 3" in cap
    assert "#define CAEKF_SIZED_GAMMA_LOG 1" in cap and "CAEKF_SIZED_CONTACT_N" not in cap
    assert "#define CAEKF_SIZED_DAMPED 1" in cap
    # the fixture of a scenario whose file name is no C identifier, and its name-independent alias
    fixture = codegen.c_fixture(schema.SCHEMA, SCENARIOS / "paper-joint.toml")["caekf_fixture_settings.h"]
    assert "caekf_paper_joint_params[] = {" in fixture
    assert "#define caekf_scenario_params caekf_paper_joint_params" in fixture


def test_flags_are_generated_once_and_their_bits_checked(tmp_path):
    """The [[flag]] entries give the C enum and caekf_flag_name's table; no hand-written C names a flag's bit,
    and the loader refuses a core bit given twice or out of the dense 0..count-1."""
    import re

    files = codegen.c_core(schema.SCHEMA)
    core = schema.SCHEMA.core_flags
    assert [f.bit for f in core] == list(range(len(core)))
    enum = re.findall(r"CAEKF_FLAG_(\w+) = 1u << (\d+)", files["caekf/caekf_status.h"])
    assert enum == [(f.name.upper(), str(f.bit)) for f in core]
    assert f"#define CAEKF_FLAG_COUNT {len(core)}" in files["caekf/caekf_status.h"]
    assert f"#define CAEKF_FLAG_MASK 0x{sum(f.mask for f in core):X}u" in files["caekf/caekf_status.h"]
    names = files["caekf_settings_names.c"].split("flag_names[CAEKF_FLAG_COUNT] = {")[1].split("};")[0]
    assert re.findall(r'"(\w+)"', names) == [f.name for f in core]
    for src in list((REPO / "firmware").rglob("*.[ch]")):
        assert not re.search(r"CAEKF_FLAG_\w+ = ", src.read_text()), src
    text = codegen.SCHEMA_PATH.read_text()
    for old, new, match in (('name = "input_rejected"\nbit = 1\n', 'name = "input_rejected"\nbit = 0\n', "twice"),
                            ('name = "model_mismatch"\nbit = 12\n', 'name = "model_mismatch"\nbit = 13\n', "dense"),
                            ('name = "non_finite"\nbit = 16\n', 'name = "non_finite"\nbit = 15\n', "reference")):
        assert old in text, old
        p = tmp_path / "s.toml"
        p.write_text(text.replace(old, new, 1))
        with pytest.raises(codegen.SchemaError, match=match):
            codegen.load(p)


def test_statuses_are_generated_once_into_c_and_the_dbc(tmp_path):
    """The [[status]] entries give caekf_status_t, caekf_status_str's texts and every STEP_STATUS value table of
    the DBC (kept by `codegen.py dbc`); the loader refuses a value out of 0, -1, -2, ..."""
    import re

    files = codegen.c_core(schema.SCHEMA)
    enum = re.findall(r"CAEKF_(\w+) = (-?\d+)", files["caekf/caekf_status.h"].split("} caekf_status_t;")[0])
    assert enum == [(st.name, str(st.value)) for st in schema.SCHEMA.statuses]
    for st in schema.SCHEMA.statuses:
        assert f'case CAEKF_{st.name}: return "{st.text}";' in files["caekf_settings_names.c"]
    for src in list((REPO / "firmware").rglob("*.[ch]")):
        assert not re.search(r"CAEKF_(OK|ERR_\w+) = ", src.read_text()), src
    tables = re.findall(r"^VAL_ \d+ STEP_STATUS (.*) ;$", DBC.read_text(), flags=re.M)
    assert len(tables) == 2
    assert all(t == " ".join(f'{st.value} "{st.name}"' for st in schema.SCHEMA.statuses) for t in tables)
    text = codegen.SCHEMA_PATH.read_text()
    old = 'name = "ERR_INPUT"\nvalue = -4\n'
    assert old in text
    p = tmp_path / "s.toml"
    p.write_text(text.replace(old, 'name = "ERR_INPUT"\nvalue = -7\n', 1))
    with pytest.raises(codegen.SchemaError, match="expected -4"):
        codegen.load(p)
