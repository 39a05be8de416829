"""tools/mutation.py's mutator (docs/mutation.md), without building anything: which C tokens it mutates and
which it leaves alone, that a mutant keeps the file's line count, and that docs/mutation-equivalent.md's rows
match the mutants they name."""
import importlib.util
import sys
from pathlib import Path

import pytest

TOOL = Path(__file__).resolve().parents[2] / "tools" / "mutation.py"

SRC = """\
/* a comment: a < b, x = 1; */
#include <stdint.h>
#define TWICE(x) \\
    ((x) * 2)
typedef char size_check[(sizeof(int) == 4) ? 1 : -1];
static const int table[3] = {10, 20, 30};

int f(int a, const int *p, uint8_t buf[8])
{
    int x = -a;
    const char *s = "a < b";
    uint8_t local[4];
    if (a < 3 && p != NULL) {
        x += *p * 2;
    }
    while (x > 0)
        x--;
    local[0] = (uint8_t)(a & 0xFF);
    (void)g(&x);
    buf[1] = !local[0];
    return x + table[1] + s[0];
}
"""


@pytest.fixture(scope="module")
def tool():
    spec = importlib.util.spec_from_file_location("caekf_mutation", TOOL)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["caekf_mutation"] = mod  # dataclasses look their module up by name
    spec.loader.exec_module(mod)
    yield mod
    del sys.modules["caekf_mutation"]


@pytest.fixture(scope="module")
def mutants(tool):
    return tool.generate("f.c", "core", SRC)


def by_line(mutants, line):
    return sorted((m.op, m.orig, m.repl) for m in mutants if m.line == line)


def test_comments_strings_and_directives_are_never_mutated(mutants):
    assert {m.line for m in mutants}.isdisjoint({1, 2, 3, 4, 11})


def test_typedefs_and_declared_array_sizes_are_not_code(mutants):
    assert by_line(mutants, 5) == []
    assert [m.orig for m in mutants if m.line == 6] == ["10", "10", "20", "20", "30", "30"]  # the data only
    assert by_line(mutants, 8) == []
    assert by_line(mutants, 12) == []


def test_unary_operators_and_pointer_declarators_are_left_alone(mutants):
    assert by_line(mutants, 10) == []  # int x = -a;
    line14 = by_line(mutants, 14)  # x += *p * 2;
    assert ("AOR", "*", "/") in line14 and ("AOR", "+=", "-=") in line14
    assert sum(1 for op, orig, _ in line14 if orig == "*") == 1  # the product, not the dereference
    assert all(orig != "&" for _, orig, _ in by_line(mutants, 19))  # (void)g(&x): address-of


def test_each_operator_class(mutants):
    line13 = by_line(mutants, 13)  # if (a < 3 && p != NULL) {
    assert ("ROR", "<", "<=") in line13
    assert ("ROR", "!=", "==") in line13
    assert ("LCR", "&&", "||") in line13
    assert ("CON", "3", "4") in line13 and ("CON", "3", "2") in line13
    assert ("NEG", "a < 3 && p != NULL", "!(a < 3 && p != NULL)") in line13
    assert ("NEG", "x > 0", "!(x > 0)") in by_line(mutants, 16)
    assert ("AOR", "--", "++") in by_line(mutants, 17)
    line18 = by_line(mutants, 18)  # local[0] = (uint8_t)(a & 0xFF);
    assert ("BOR", "&", "|") in line18
    assert ("CON", "0xFF", "0x100") in line18 and ("CON", "0xFF", "0xFE") in line18
    assert ("NOT", "!", "") in by_line(mutants, 20)


def test_statement_deletion_takes_assignments_and_calls_only(mutants):
    deleted = {m.line for m in mutants if m.op == "SDL"}
    assert deleted == {14, 17, 18, 19, 20}  # not the declarations (10-12), not the return (21)


def test_a_mutant_keeps_the_line_count_and_changes_only_its_span(tool, mutants):
    for m in mutants:
        out = tool.apply(SRC, m)
        assert out.count("\n") == SRC.count("\n")
        assert out[: m.start] == SRC[: m.start]


def test_float_constants_and_suffixes(tool):
    assert tool.number_mutants("0.5") == ["1.5", "0.0"]
    assert tool.number_mutants("0.0f") == ["1.0f"]
    assert tool.number_mutants("1e-12") == ["1.000000000001", "0.0"]
    assert tool.number_mutants("0u") == ["1u"]
    assert tool.number_mutants("8U") == ["9U", "7U"]


def test_equivalent_rows_name_their_mutant_also_after_the_line_moved(tool, mutants, tmp_path):
    m = next(m for m in mutants if m.op == "SDL" and m.line == 19)
    assert m.mutation == "`(void)g(&x);` → `(deleted)`"
    doc = tmp_path / "eq.md"
    doc.write_text(f"| mutant | mutation | source line | why |\n|---|---|---|---|\n"
                   f"| `{m.key}` | {m.mutation} | `{m.text}` | g ignores it |\n")
    rows = tool.read_equivalents(doc)
    assert [(r.key, r.text, r.why) for r in rows] == [(m.key, "(void)g(&x);", "g ignores it")]
    found, stale = tool.match_equivalents(rows, mutants)
    assert found == {id(m): rows[0]} and stale == []
    # two lines inserted above: the row still names it, by its text
    moved = tool.generate("f.c", "core", SRC.replace("{\n    int x", "{\n\n\n    int x", 1))
    found, stale = tool.match_equivalents(rows, moved)
    (name,) = [x for x in moved if id(x) in found]
    assert (name.line, name.mutation) == (21, m.mutation) and stale == []
    # the line changed: stale
    changed = tool.generate("f.c", "core", SRC.replace("(void)g(&x);", "(void)g(&x, 1);"))
    assert tool.match_equivalents(rows, changed) == ({}, rows)


def test_pipes_in_cells_are_escaped_and_a_row_takes_the_nearest_same_line(tool, tmp_path):
    src = ("int f(int a, int b)\n{\n    if (a && b) {\n        a = 1;\n    }\n"
           "    if (a && b) {\n        b = 2;\n    }\n    return a;\n}\n")
    lcr = [m for m in tool.generate("g.c", "core", src) if m.op == "LCR"]
    assert [m.line for m in lcr] == [3, 6] and lcr[0].mutation == "`&&` → `||`"
    doc = tmp_path / "eq.md"
    doc.write_text(f"| `g.c:6:11` | {tool.md_cell(lcr[1].mutation)} | `{tool.md_cell(lcr[1].text)}` | why |\n")
    rows = tool.read_equivalents(doc)
    assert [(r.mutation, r.text) for r in rows] == [("`&&` → `||`", "if (a && b) {")]
    moved = tool.generate("g.c", "core", "/* one line more */\n" + src)
    found, stale = tool.match_equivalents(rows, moved)
    assert [m.line for m in moved if id(m) in found] == [7] and stale == []  # the second `if`, moved down one


def test_the_repository_equivalents_are_well_formed(tool):
    """Every table row of docs/mutation-equivalent.md is read (none dropped by a stray pipe) and names a file of
    the folders mutated. Whether a row still names its mutant is the tool's own report ("Stale entries"): the
    core changes often, and a row then wants a review, not a failing test suite."""
    repo = TOOL.parents[1]
    doc = repo / "docs" / "mutation-equivalent.md"
    table_rows = [line for line in doc.read_text(encoding="utf-8").splitlines() if line.startswith("| `firmware/")]
    rows = tool.read_equivalents(doc)
    assert len(rows) == len(table_rows) > 0
    for r in rows:
        assert (repo / r.path).is_file() and r.path.startswith(("firmware/core/", "firmware/protocol/src/"))
        assert r.mutation.startswith("`") and r.why
