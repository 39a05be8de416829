#!/usr/bin/env python3
"""Mutation testing of firmware/core and firmware/protocol against their Unity suites (docs/mutation.md).

    tools/mutation.py [--folders protocol core] [--files GLOB ...] [--sample N | FOLDER=N ...] [--seed S]
                      [--jobs J] [--report OUT.md] [--json OUT.json] [--no-coverage] [--also-app] [--list]

A mutant is one small change to one C file of the folder, made over its tokens (comments, strings and
preprocessor lines are never touched):
  ROR  relational boundary  <  <=  >  >=  and  ==  !=  (each to its partner)
  AOR  arithmetic  + -  * /  % -> *  (binary only), compound += -= *= /=, ++ --
  LCR  logical connector  && ||
  BOR  bitwise  & |  ^ -> |  << >>  &= |=
  NOT  a logical ! removed
  NEG  an if / while condition negated: if (c) -> if (!(c))
  CON  a literal: integer c -> c+1 and c-1 (c > 0), floating c -> c+1 and 0 (or 1 for 0)
  SDL  an expression statement (assignment, call, ++/--) deleted
The source tree (git's tracked and untracked, non-ignored files) is copied once into WORK/src; a build of
its own in WORK/build (double, -O2, warnings not fatal: a mutant that only warns is still a program) is
reused: each mutant is written into the copy, the suites' targets are rebuilt incrementally, the suites
whose executable changed are run (each with a timeout: a hang counts as killed), the file is restored.
The truth record and reference results the core suites compare against are built once from the unmutated
tree (WORK/ref) and frozen (CAEKF_FROZEN_TESTDATA), so a mutant never makes its own reference.

Outcome of a mutant:
  killed        a suite failed, crashed or timed out
  survived      every suite passed
  not covered   its line is executable and no suite of the folder runs it (gcov of WORK/cov, -O0
                --coverage): not built, counted as surviving in the score, listed separately
  build failed  the mutant does not compile: not counted
  identical     every suite's executable is byte-identical to the unmutated one (trivially equivalent,
                e.g. code compiled out in this configuration): not counted
  equivalent    listed in docs/mutation-equivalent.md (reviewed by hand): not counted; still run, and a
                listed mutant that is killed is reported as a stale entry
Score = killed / (killed + survived + not covered).

Suites: the Unity tests ctest registers under tests/unit (core) and tests/unit/protocol (protocol); with
--also-app the app's suites (tests/unit/app) are added to both. --sample draws a deterministic sample
(the smallest hashes of --seed and each mutant's file, line text and mutation: a mutant stays in or out while
its line is unchanged) of a folder's mutants; FOLDER=N samples that folder only.
Exit status: 0 when the run completed, 1 when the unmutated suites fail, 2 usage, 3 when a folder's score is
below its --min-score floor.
"""

from __future__ import annotations

import argparse
import concurrent.futures
import fnmatch
import hashlib
import io
import json
import os
import re
import shutil
import subprocess
import sys
import tarfile
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
EQUIV_DOC = REPO / "docs" / "mutation-equivalent.md"

FOLDERS = {
    "protocol": {"globs": ["firmware/protocol/src/*.c", "firmware/protocol/src/*.h"], "suites": "tests/unit/protocol"},
    "core": {"globs": ["firmware/core/*.c", "firmware/core/*.h"], "suites": "tests/unit"},
}
APP_SUITES = "tests/unit/app"
TESTDATA = ("paper_truth.bin", "paper_truth.csv", "reference_f64.h")

# ---- tokens ------------------------------------------------------------------------------------------------

KEYWORDS = {
    "auto", "break", "case", "char", "const", "continue", "default", "do", "double", "else", "enum", "extern",
    "float", "for", "goto", "if", "inline", "int", "long", "register", "restrict", "return", "short", "signed",
    "sizeof", "static", "struct", "switch", "typedef", "union", "unsigned", "void", "volatile", "while",
    "_Bool", "_Static_assert",
}
TYPE_KEYWORDS = {"char", "const", "double", "float", "int", "long", "short", "signed", "unsigned", "void",
                 "volatile", "restrict", "_Bool", "struct", "union", "enum"}
OPERATORS = sorted(
    ["...", "<<=", ">>=", "->", "++", "--", "<<", ">>", "<=", ">=", "==", "!=", "&&", "||", "+=", "-=", "*=",
     "/=", "%=", "&=", "|=", "^=", "##"] + list("{}[]();:,.?~!%^&*-+=<>|/#"),
    key=len, reverse=True)
TOKEN_RE = re.compile(
    r"(?P<ws>[ \t\r\n\f\v]+)"
    r"|(?P<comment>//[^\n]*|/\*.*?\*/)"
    r"|(?P<str>\"(?:\\.|[^\"\\\n])*\")"
    r"|(?P<chr>'(?:\\.|[^'\\\n])*')"
    r"|(?P<num>0[xX][0-9a-fA-F]+[uUlL]*|(?:\d+\.\d*|\.\d+|\d+)(?:[eE][+-]?\d+)?[fFlLuU]*)"
    r"|(?P<id>[A-Za-z_]\w*)"
    r"|(?P<op>" + "|".join(re.escape(o) for o in OPERATORS) + r")",
    re.S)


@dataclass
class Tok:
    kind: str
    text: str
    start: int
    end: int


def tokenize(src: str) -> list[Tok]:
    """Tokens of C source outside comments and preprocessor lines (continuations included)."""
    toks: list[Tok] = []
    pos = 0
    line_start = True  # nothing but blanks and comments since the last newline
    directive = re.compile(r"[ \t]*#")
    while pos < len(src):
        if line_start and directive.match(src, pos):
            while True:  # skip to the end of the directive's last continued line
                nl = src.find("\n", pos)
                if nl < 0:
                    pos = len(src)
                    break
                cont = src[nl - 1] == "\\"
                pos = nl + 1
                if not cont:
                    break
            continue
        m = TOKEN_RE.match(src, pos)
        if not m:
            raise ValueError(f"cannot tokenize at offset {pos}: {src[pos:pos + 20]!r}")
        kind = m.lastgroup or ""
        if kind == "ws":
            line_start = line_start or "\n" in m.group()
        elif kind != "comment":
            toks.append(Tok(kind, m.group(), m.start(), m.end()))
            line_start = False
        pos = m.end()
    return toks


# ---- mutants -----------------------------------------------------------------------------------------------

@dataclass
class Mutant:
    path: str  # repository-relative
    folder: str
    start: int
    end: int
    repl: str
    op: str
    line: int
    col: int
    orig: str
    text: str = ""  # the unmutated source line, stripped
    outcome: str = ""
    detail: str = ""
    seconds: float = 0.0
    equivalent_reason: str = field(default="", repr=False)

    @property
    def key(self) -> str:
        return f"{self.path}:{self.line}:{self.col}"

    @property
    def mutation(self) -> str:
        shown = "(deleted)" if self.op == "SDL" or not self.repl else squash(self.repl)
        return f"`{squash(self.orig)}` → `{shown}`"


def squash(s: str, limit: int = 90) -> str:
    s = re.sub(r"\s+", " ", s).strip()
    return s if len(s) <= limit else s[: limit - 3] + "..."


ROR = {"<": ["<="], "<=": ["<"], ">": [">="], ">=": [">"], "==": ["!="], "!=": ["=="]}
AOR = {"+": ["-"], "-": ["+"], "*": ["/"], "/": ["*"], "%": ["*"]}
ASG = {"+=": ["-="], "-=": ["+="], "*=": ["/="], "/=": ["*="], "++": ["--"], "--": ["++"]}
LCR = {"&&": ["||"], "||": ["&&"]}
BOR = {"&": ["|"], "|": ["&"], "^": ["|"], "<<": [">>"], ">>": ["<<"], "&=": ["|="], "|=": ["&="]}


def is_type_name(t: Tok) -> bool:
    return t.kind == "id" and (t.text in TYPE_KEYWORDS or t.text.endswith("_t") or t.text in ("size_t",))


def operand_before(toks: list[Tok], i: int) -> bool:
    """Whether token i (an operator that can be unary or binary) has a left operand: binary."""
    if i == 0:
        return False
    p = toks[i - 1]
    if p.kind in ("num", "str", "chr"):
        return True
    if p.kind == "id":
        return p.text not in KEYWORDS and not is_type_name(p)
    return p.text in (")", "]")


def number_mutants(text: str) -> list[str]:
    m = re.fullmatch(r"(0[xX][0-9a-fA-F]+|[0-9.]+(?:[eE][+-]?\d+)?)([fFlLuU]*)", text)
    if not m:
        return []
    body, suffix = m.groups()
    if body.lower().startswith("0x") or re.fullmatch(r"\d+", body):
        v = int(body, 0) if body.lower().startswith("0x") else int(body, 10)
        if body.lower().startswith("0x"):
            out = [f"0x{v + 1:X}{suffix}"] + ([f"0x{v - 1:X}{suffix}"] if v > 0 else [])
        else:
            out = [f"{v + 1}{suffix}"] + ([f"{v - 1}{suffix}"] if v > 0 else [])
        return out
    f = float(body)
    fsuffix = suffix if suffix.lower() in ("f", "l") else ""
    plus = repr(f + 1.0)
    if "e" not in plus and "." not in plus:
        plus += ".0"
    other = ("1.0" if f == 0.0 else "0.0") + fsuffix
    return [plus + fsuffix] + ([other] if other != plus + fsuffix else [])


def statement_spans(toks: list[Tok]) -> list[tuple[int, int]]:
    """(first, last) token indices of expression statements: assignments, calls, ++/--; never declarations
    or jumps. A statement starts after ; { } else, a case label, or the ) of an if/while/for header."""
    header_close: set[int] = set()
    stack: list[bool] = []
    depth_before = []
    for i, t in enumerate(toks):
        depth_before.append(len(stack))
        if t.text == "(":
            stack.append(i > 0 and toks[i - 1].text in ("if", "while", "for", "switch"))
        elif t.text == ")" and stack:
            if stack.pop():
                header_close.add(i)
    spans = []
    for i, t in enumerate(toks):
        if depth_before[i] != 0 or i == 0:
            continue
        prev = toks[i - 1]
        starts = prev.text in (";", "{", "}", "else") or (i - 1) in header_close
        if prev.text == ":":  # a case label's, not a conditional expression's
            for k in range(i - 2, -1, -1):
                if toks[k].text in ("case", "default"):
                    starts = True
                    break
                if toks[k].text in ("?", ";", "{", "}"):
                    break
        if not starts:
            continue
        j = i
        if t.text == "(" and i + 2 < len(toks) and toks[i + 1].text == "void" and toks[i + 2].text == ")":
            j = i + 3  # (void)call(...)
        elif t.text == "*":
            j = i + 1  # *p = ...
        if j + 1 >= len(toks):
            continue
        first, second = toks[j], toks[j + 1]
        if first.text in ("++", "--"):
            pass
        elif first.kind != "id" or first.text in KEYWORDS or is_type_name(first):
            continue
        elif second.text not in ("=", "+=", "-=", "*=", "/=", "%=", "&=", "|=", "^=", "<<=", ">>=", "(", "[", ".",
                                 "->", "++", "--"):
            continue
        d = 0
        k = i
        while k < len(toks):  # the statement's ; at depth 0
            x = toks[k].text
            if x in ("(", "[", "{"):
                d += 1
            elif x in (")", "]", "}"):
                d -= 1
                if d < 0:
                    break
            elif x == ";" and d == 0:
                break
            k += 1
        if k < len(toks) and toks[k].text == ";" and not any(toks[m].text == "{" for m in range(i, k)):
            spans.append((i, k))
    return spans


def line_col(src: str, offset: int) -> tuple[int, int]:
    line = src.count("\n", 0, offset) + 1
    col = offset - (src.rfind("\n", 0, offset) + 1) + 1
    return line, col


def generate(path: str, folder: str, src: str) -> list[Mutant]:
    toks = tokenize(src)
    out: list[Mutant] = []

    def add(start: int, end: int, repl: str, op: str) -> None:
        line, col = line_col(src, start)
        a, b = src.rfind("\n", 0, start) + 1, src.find("\n", start)
        text = squash(src[a: b if b >= 0 else len(src)], 200)
        out.append(Mutant(path, folder, start, end, repl, op, line, col, src[start:end], text))

    # not code to mutate: typedefs, static asserts, the sizes of declared arrays
    skip: set[int] = set()
    decl = False  # the statement begins with a type: a declaration
    i = 0
    while i < len(toks):
        x = toks[i].text
        if i == 0 or toks[i - 1].text in (";", "{", "}"):
            decl = is_type_name(toks[i]) or x in ("static", "extern", "register")
        if x in ("typedef", "_Static_assert"):
            j = i
            while j < len(toks) and toks[j].text != ";":
                skip.add(j)
                j += 1
            i = j
        elif x == "[" and i >= 2 and toks[i - 1].kind == "id" and (
                (toks[i - 2].kind == "id" and toks[i - 2].text not in ("return", "case", "sizeof", "else"))
                or (toks[i - 2].text == "*" and i >= 3 and (is_type_name(toks[i - 3]) or toks[i - 3].text == "const"))
                or (decl and toks[i - 2].text in (",", "*"))):
            d = 0
            j = i
            while j < len(toks):  # this [..] and any that follow it: H[4][4]
                skip.add(j)
                d += (toks[j].text == "[") - (toks[j].text == "]")
                if d == 0 and not (j + 1 < len(toks) and toks[j + 1].text == "["):
                    break
                j += 1
            i = j
        i += 1

    for i, t in enumerate(toks):
        if i in skip:
            continue
        x = t.text
        if t.kind == "op":
            binary = operand_before(toks, i)
            if x in ROR:
                for r in ROR[x]:
                    add(t.start, t.end, r, "ROR")
            elif x in ASG:
                for r in ASG[x]:
                    add(t.start, t.end, r, "AOR")
            elif x in LCR:
                for r in LCR[x]:
                    add(t.start, t.end, r, "LCR")
            elif x in AOR and binary:
                for r in AOR[x]:
                    add(t.start, t.end, r, "AOR")
            elif x in BOR:
                if x == "&" and not binary:
                    continue  # address-of
                for r in BOR[x]:
                    add(t.start, t.end, r, "BOR")
            elif x == "!":
                add(t.start, t.end, "", "NOT")
        elif t.kind == "num":
            for r in number_mutants(x):
                add(t.start, t.end, r, "CON")
        elif t.kind == "id" and x in ("if", "while") and i + 1 < len(toks) and toks[i + 1].text == "(":
            d = 0
            for k in range(i + 1, len(toks)):
                if toks[k].text == "(":
                    d += 1
                elif toks[k].text == ")":
                    d -= 1
                    if d == 0:
                        a, b = toks[i + 2].start, toks[k - 1].end
                        add(a, b, "!(" + src[a:b] + ")", "NEG")
                        break
    for a, b in statement_spans(toks):
        if a in skip:
            continue
        start, end = toks[a].start, toks[b].end
        add(start, end, ";" + "\n" * src.count("\n", start, end), "SDL")
    out.sort(key=lambda m: (m.start, m.op, m.repl))
    return out


def apply(src: str, m: Mutant) -> str:
    return src[: m.start] + m.repl + src[m.end:]


# ---- reviewed equivalents ----------------------------------------------------------------------------------

@dataclass
class EquivalentRow:
    key: str  # path:line:col
    mutation: str
    text: str  # the source line
    why: str

    @property
    def path(self) -> str:
        return self.key.rsplit(":", 2)[0]


def md_cell(text: str) -> str:
    """Text for a markdown table cell: a pipe escaped."""
    return text.replace("|", "\\|")


def read_equivalents(path: Path) -> list[EquivalentRow]:
    """The table rows of docs/mutation-equivalent.md: | `path:line:col` | mutation | `source line` | why |
    (a pipe inside a cell escaped as \\|)."""
    rows = []
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            cells = [c.strip().replace("\\|", "|") for c in re.split(r"(?<!\\)\|", line)]
            if len(cells) != 6 or cells[0] or cells[5]:
                continue
            key, mutation, text, why = cells[1:5]
            if re.fullmatch(r"`[^`]+:\d+:\d+`", key) and text.startswith("`") and text.endswith("`"):
                rows.append(EquivalentRow(key.strip("`"), squash(mutation), squash(text[1:-1], 200), why))
    return rows


def moved_to(r: EquivalentRow, same: list[Mutant]) -> Mutant | None:
    """The mutant a row names after its line moved: of those with its mutation on a line of its text, the one
    (at its column, if any is) nearest its old line; None when two are as near."""
    line, col = (int(v) for v in r.key.rsplit(":", 2)[1:])
    same = [m for m in same if m.col == col] or same
    if not same:
        return None
    dist = sorted((abs(m.line - line), i) for i, m in enumerate(same))
    return same[dist[0][1]] if len(dist) == 1 or dist[0][0] < dist[1][0] else None


def match_equivalents(rows: list[EquivalentRow], population: list[Mutant]) -> tuple[dict[int, EquivalentRow],
                                                                                   list[EquivalentRow]]:
    """({id(mutant): row}, rows naming no mutant) for the rows of the files in population. A row names the mutant
    at its place with its mutation; else, when its line moved, the nearest mutant of its file with that mutation
    on a line of that text (moved_to)."""
    by_key = {(m.key, squash(m.mutation)): m for m in population}
    by_text: dict[tuple[str, str, str], list[Mutant]] = {}
    for m in population:
        by_text.setdefault((m.path, squash(m.mutation), m.text), []).append(m)
    files = {m.path for m in population}
    found: dict[int, EquivalentRow] = {}
    stale = []
    for r in rows:
        if r.path not in files:
            continue
        m = by_key.get((r.key, r.mutation))
        if m is None or m.text != r.text:
            m = moved_to(r, by_text.get((r.path, r.mutation, r.text), []))
        if m is None:
            stale.append(r)
        else:
            found[id(m)] = r
    return found, stale


# ---- the build ---------------------------------------------------------------------------------------------

def log(msg: str) -> None:
    print(f"[mutation] {msg}", flush=True)


def run(cmd: list[str], cwd: Path | None = None, timeout: float | None = None,
        check: bool = True) -> subprocess.CompletedProcess[str]:
    p = subprocess.run(cmd, cwd=cwd, timeout=timeout, text=True, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    if check and p.returncode != 0:
        sys.stdout.write(p.stdout[-4000:])
        raise SystemExit(f"mutation: command failed ({p.returncode}): {' '.join(cmd)}")
    return p


def tree_files(rev: str | None, overlay: list[str]) -> dict[str, tuple[bytes, int]]:
    """{path: (content, mode)} of the tree: git's tracked and untracked, non-ignored files of the working
    tree, or the files of commit REV with the working tree's OVERLAY paths (files or folders) over them."""
    out: dict[str, tuple[bytes, int]] = {}

    def from_worktree(paths: list[str]) -> None:
        files = run(["git", "ls-files", "-co", "--exclude-standard", "-z", "--", *paths], cwd=REPO).stdout
        for f in files.split("\0"):
            if f and (REPO / f).is_file():
                out[f] = ((REPO / f).read_bytes(), (REPO / f).stat().st_mode & 0o777)

    if rev is None:
        from_worktree([])
        return out
    tar = subprocess.run(["git", "archive", "--format=tar", rev], cwd=REPO, stdout=subprocess.PIPE, check=True).stdout
    with tarfile.open(fileobj=io.BytesIO(tar)) as tf:
        for member in tf.getmembers():
            if member.isfile():
                data = tf.extractfile(member)
                if data is not None:
                    out[member.name] = (data.read(), member.mode & 0o777)
    if overlay:
        from_worktree(overlay)
    return out


def sync_tree(dst: Path, files: dict[str, tuple[bytes, int]]) -> None:
    """Write the tree into dst, only what differs (the build stays incremental); remove what it does not
    hold; link the venv and the Unity cache."""
    dst.mkdir(parents=True, exist_ok=True)
    for f in sorted(files):
        data, mode = files[f]
        d = dst / f
        if not d.exists() or d.read_bytes() != data:
            d.parent.mkdir(parents=True, exist_ok=True)
            d.write_bytes(data)
            d.chmod(mode)
    for root, dirs, names in os.walk(dst):
        rel_root = Path(root).relative_to(dst)
        if rel_root == Path("."):
            dirs[:] = [x for x in dirs if x not in (".venv", ".cache")]
        for n in names:
            rel = (rel_root / n).as_posix()
            if rel not in files and not (Path(root) / n).is_symlink():
                (Path(root) / n).unlink()
    for link in (".venv", ".cache"):
        if (REPO / link).exists() and not (dst / link).exists():
            (dst / link).symlink_to(REPO / link)


def configure(src: Path, build: Path, extra: list[str]) -> None:
    query = build / ".cmake" / "api" / "v1" / "query" / "codemodel-v2"  # the targets, for discover_suites
    query.parent.mkdir(parents=True, exist_ok=True)
    query.touch()
    args = ["cmake", "-S", str(src), "-B", str(build), "-G", "Ninja", "-DCAEKF_SCALAR=double",
            "-DCAEKF_WERROR=OFF", "-DCAEKF_BUILD_FMU=OFF"] + extra
    run(args)


def build_targets(build: Path, targets: list[str], check: bool = True,
                  timeout: float = 600) -> subprocess.CompletedProcess[str]:
    return run(["cmake", "--build", str(build), "--parallel", "1", "--target", *targets], check=check,
               timeout=timeout)


@dataclass
class Suite:
    name: str
    exe: str  # path relative to the build folder
    folder: str  # tests/unit, tests/unit/protocol, tests/unit/app


def discover_suites(build: Path) -> list[Suite]:
    """ctest's tests labelled unit that are executables of the build (CMake's file API: the target of the
    same name, its artifact and its source folder)."""
    info = json.loads(run(["ctest", "--test-dir", str(build), "--show-only=json-v1"]).stdout)
    unit = set()
    for t in info.get("tests", []):
        for p in t.get("properties", []):
            if p.get("name") == "LABELS" and "unit" in p.get("value", []):
                unit.add(t["name"])
    reply = build / ".cmake" / "api" / "v1" / "reply"
    index = json.loads(max(reply.glob("index-*.json")).read_text())
    model = json.loads((reply / index["reply"]["codemodel-v2"]["jsonFile"]).read_text())
    suites = []
    for target in model["configurations"][0]["targets"]:
        if target["name"] not in unit:
            continue
        t = json.loads((reply / target["jsonFile"]).read_text())
        if t.get("type") == "EXECUTABLE" and t.get("artifacts"):
            suites.append(Suite(t["name"], t["artifacts"][0]["path"], t["paths"]["source"]))
    return sorted(suites, key=lambda s: s.name)


def sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


UNITY_OK = re.compile(r"^\d+ Tests 0 Failures \d+ Ignored\s*$", re.M)


def suite_passes(build: Path, s: Suite, timeout: float) -> tuple[bool, str]:
    exe = build / s.exe
    try:
        p = subprocess.run([str(exe)], cwd=exe.parent, timeout=timeout, stdout=subprocess.PIPE,
                           stderr=subprocess.STDOUT)
    except subprocess.TimeoutExpired:
        return False, f"{s.name}: timeout ({timeout:.0f} s)"
    out = p.stdout.decode("utf-8", "replace")
    if p.returncode != 0:
        fail = re.search(r"^(?:.*/)?([^/:\n]+:\d+):(\w+):FAIL", out, re.M)  # Unity: file:line:test:FAIL: ...
        why = f"exit {p.returncode}" if p.returncode > 0 else f"signal {-p.returncode}"
        return False, f"{s.name}: {why}" + (f", {fail.group(2)} ({fail.group(1)})" if fail else "")
    if not UNITY_OK.search(out):
        return False, f"{s.name}: no Unity summary"
    return True, ""


# ---- coverage ------------------------------------------------------------------------------------------------

def coverage_lines(work: Path, src: Path, testdata: Path, suites_by_folder: dict[str, list[Suite]]
                   ) -> dict[str, dict[str, dict[int, int]]]:
    """{folder: {path: {line: count}}}: gcov's executable lines of each folder's files under its suites."""
    cov = work / "cov"
    configure(src, cov, ["-DCMAKE_BUILD_TYPE=Debug", "-DCMAKE_C_FLAGS=-O0 --coverage",
                         "-DCMAKE_EXE_LINKER_FLAGS=--coverage", "-DCAEKF_CORE_STACK_LIMIT=16384",
                         f"-DCAEKF_FROZEN_TESTDATA={testdata}"])
    all_suites = sorted({s.name for ss in suites_by_folder.values() for s in ss})
    build_targets(cov, all_suites)
    result: dict[str, dict[str, dict[int, int]]] = {}
    for folder, suites in suites_by_folder.items():
        for g in cov.rglob("*.gcda"):
            g.unlink()
        for s in suites:
            ok, why = suite_passes(cov, s, 600)
            if not ok:
                raise SystemExit(f"mutation: the coverage build's {why}")
        out = work / f"cov-{folder}.json"
        py = REPO / ".venv" / "bin" / "python"
        run([str(py) if py.exists() else sys.executable, "-m", "gcovr", "--root", str(src),
             "--object-directory", str(cov), "--filter", str(src / "firmware") + "/",
             "--exclude-directories", str(cov / "CMakeFiles"), "--json", str(out), "-j", "1"])
        lines: dict[str, dict[int, int]] = {}
        for f in json.loads(out.read_text())["files"]:
            d = lines.setdefault(f["file"], {})
            for ln in f["lines"]:
                d[ln["line_number"]] = d.get(ln["line_number"], 0) + ln["count"]
        result[folder] = lines
    return result


# ---- a worker: one copy of the tree and one build --------------------------------------------------------

class Worker:
    def __init__(self, wid: int, work: Path, testdata: Path, suites: dict[str, list[Suite]],
                 targets: list[str], tree: dict[str, tuple[bytes, int]]) -> None:
        self.wid = wid
        self.src = work / ("src" if wid == 0 else f"src{wid}")
        self.build = work / ("build" if wid == 0 else f"build{wid}")
        self.testdata = testdata
        self.suites = suites
        self.targets = targets
        self.base_hash: dict[str, str] = {}
        self.base_time: dict[str, float] = {}
        self.tree = tree

    def prepare(self) -> None:
        if self.wid != 0:
            sync_tree(self.src, self.tree)
        configure(self.src, self.build, ["-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG",
                                         f"-DCAEKF_FROZEN_TESTDATA={self.testdata}"])
        build_targets(self.build, self.targets)
        for ss in self.suites.values():
            for s in ss:
                t0 = time.monotonic()
                ok, why = suite_passes(self.build, s, 600)
                if not ok:
                    raise SystemExit(f"mutation: the unmutated {why}")
                self.base_time[s.name] = time.monotonic() - t0
                self.base_hash[s.name] = sha(self.build / s.exe)

    def run_mutant(self, m: Mutant) -> None:
        t0 = time.monotonic()
        path = self.src / m.path
        original = path.read_bytes()
        try:
            path.write_bytes(apply(original.decode("utf-8"), m).encode("utf-8"))
            suites = self.suites[m.folder]
            p = build_targets(self.build, sorted({s.name for s in suites}), check=False)
            if p.returncode != 0:
                err = re.search(r"error: .*", p.stdout)
                m.outcome, m.detail = "build failed", squash(err.group(), 120) if err else "build failed"
                return
            changed = [s for s in suites if sha(self.build / s.exe) != self.base_hash[s.name]]
            if not changed:
                m.outcome, m.detail = "identical", "every suite's executable unchanged"
                return
            for s in sorted(changed, key=lambda s: self.base_time[s.name]):
                ok, why = suite_passes(self.build, s, max(10.0, 20 * self.base_time[s.name]))
                if not ok:
                    m.outcome, m.detail = "killed", why
                    return
            m.outcome, m.detail = "survived", f"{len(changed)} suites passed"
        finally:
            path.write_bytes(original)
            m.seconds = time.monotonic() - t0


# ---- report ----------------------------------------------------------------------------------------------

COUNTED = ("killed", "survived", "not covered")


def score(ms: list[Mutant]) -> tuple[int, int, float]:
    k = sum(m.outcome == "killed" for m in ms)
    n = sum(m.outcome in COUNTED for m in ms)
    return k, n, (100.0 * k / n if n else float("nan"))


def table(mutants: list[Mutant], by: str) -> list[str]:
    heads = ["mutants", "killed", "survived", "not covered", "score", "equivalent", "identical", "build failed"]
    rows = [f"| {by} | " + " | ".join(heads) + " |", "|---" * (len(heads) + 1) + "|"]
    groups: dict[str, list[Mutant]] = {}
    for m in mutants:
        groups.setdefault(m.path if by == "file" else m.folder, []).append(m)
    for g in sorted(groups, key=lambda g: (FOLDERS_ORDER.get(groups[g][0].folder, 9), g)):
        ms = groups[g]
        k, n, pct = score(ms)
        c = {o: sum(m.outcome == o for m in ms) for o in
             ("survived", "not covered", "equivalent", "identical", "build failed")}
        name = g.replace("firmware/", "") if by == "file" else g
        rows.append(f"| {name} | {len(ms)} | {k} | {c['survived']} | {c['not covered']} | "
                    f"{pct:.1f} % ({k}/{n}) | {c['equivalent']} | {c['identical']} | {c['build failed']} |")
    return rows


FOLDERS_ORDER = {"protocol": 0, "core": 1}


def report(mutants: list[Mutant], header: list[str], stale: list[str]) -> str:
    lines = header + ["", "## Per folder", ""] + table(mutants, "folder")
    lines += ["", "## Per file", ""] + table(mutants, "file")
    for title, outcome in (("Survivors", "survived"), ("Not covered (no suite runs the line)", "not covered")):
        ms = [m for m in mutants if m.outcome == outcome]
        lines += ["", f"## {title}: {len(ms)}", ""]
        if ms:
            lines += ["| mutant | mutation | op | line after the mutation |", "|---|---|---|---|"]
        for m in ms:
            lines.append(f"| `{m.key}` | {md_cell(m.mutation)} | {m.op} | `{md_cell(squash(m.detail, 100))}` |")
    eq = [m for m in mutants if m.outcome == "equivalent"]
    lines += ["", f"## Reviewed equivalents met: {len(eq)} (docs/mutation-equivalent.md)", ""]
    for m in eq:
        lines.append(f"- `{m.key}` {m.mutation}")
    if stale:
        lines += ["", "## Stale entries of docs/mutation-equivalent.md", ""] + [f"- {s}" for s in stale]
    killed = [m for m in mutants if m.outcome == "killed"]
    by_suite: dict[str, int] = {}
    for m in killed:
        by_suite[m.detail.split(":")[0]] = by_suite.get(m.detail.split(":")[0], 0) + 1
    lines += ["", "## Killed, by the first suite that failed", ""]
    lines += [f"- {s}: {n}" for s, n in sorted(by_suite.items(), key=lambda kv: -kv[1])]
    return "\n".join(lines) + "\n"


def mutated_line(src: str, m: Mutant) -> str:
    new = apply(src, m)
    a = new.rfind("\n", 0, m.start) + 1
    b = new.find("\n", m.start + len(m.repl))
    return new[a: b if b >= 0 else len(new)].strip()


# ---- main --------------------------------------------------------------------------------------------------

def sample(ms: list[Mutant], n: int, seed: int) -> list[Mutant]:
    """The n mutants with the smallest hash of (seed, file, source line, mutation, occurrence): deterministic, and
    stable when other lines of the file change (a mutant keeps its rank as long as its line reads the same)."""
    seen: dict[tuple[str, str, str, str, str], int] = {}
    ranked = []
    for m in ms:
        ident = (m.path, m.text, m.op, m.orig, m.repl)
        seen[ident] = seen.get(ident, 0) + 1
        h = hashlib.sha256(repr((seed,) + ident + (seen[ident],)).encode()).hexdigest()
        ranked.append((h, m.start, m))
    return [m for _, _, m in sorted(ranked, key=lambda r: r[0])[:n]]


def parse_sample(values: list[str], folders: list[str]) -> dict[str, int]:
    out: dict[str, int] = {}
    for v in values:
        if "=" in v:
            f, n = v.split("=", 1)
            if f not in FOLDERS:
                raise SystemExit(f"mutation: --sample: unknown folder '{f}' (have {', '.join(FOLDERS)})")
            out[f] = int(n)
        else:
            for f in folders:
                out[f] = int(v)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--folders", nargs="+", choices=list(FOLDERS), default=list(FOLDERS))
    ap.add_argument("--files", nargs="+", default=[], help="only files matching these globs (repository paths)")
    ap.add_argument("--ops", nargs="+", default=[], help="only these operators (ROR AOR LCR BOR NOT NEG CON SDL)")
    ap.add_argument("--sample", nargs="+", default=[], metavar="N|FOLDER=N",
                    help="a random sample of N mutants per folder (FOLDER=N: that folder only)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=1, help="workers, each with its own copy and build (default 1)")
    ap.add_argument("--work", type=Path, default=REPO / "build" / "mutation")
    ap.add_argument("--report", type=Path, help="write the report (markdown) here")
    ap.add_argument("--json", type=Path, help="write every mutant and its outcome here")
    ap.add_argument("--no-coverage", action="store_true", help="build every mutant, whether a suite runs its line")
    ap.add_argument("--also-app", action="store_true", help="run the app's Unity suites too")
    ap.add_argument("--min-score", nargs="+", default=[], metavar="FOLDER=PCT",
                    help="exit 3 when a folder's score is below PCT (the CI sample's floor)")
    ap.add_argument("--list", action="store_true", help="list the mutants (after sampling) and stop")
    ap.add_argument("--only", nargs="+", default=[], metavar="PATH:LINE[:COL]",
                    help="only the mutants at these places (to check that a test kills them)")
    ap.add_argument("--rev", help="mutate the files of this commit instead of the working tree")
    ap.add_argument("--overlay", nargs="+", default=[], metavar="PATH",
                    help="with --rev: these paths (files or folders) from the working tree over the commit")
    args = ap.parse_args(argv)
    t_start = time.monotonic()

    # the tree, and the mutants of its files
    work = args.work.resolve()
    work.mkdir(parents=True, exist_ok=True)
    # the commit, resolved once: the tree and the report's header are the same one whatever is committed meanwhile
    commit = run(["git", "rev-parse", args.rev or "HEAD"], cwd=REPO).stdout.strip()
    tree = tree_files(commit if args.rev else None, args.overlay)
    log(f"copying the tree ({args.rev or 'working tree'}{' + ' + ' '.join(args.overlay) if args.overlay else ''}) "
        f"into {work / 'src'}")
    sync_tree(work / "src", tree)
    files: list[tuple[str, str]] = []
    for folder in args.folders:
        for g in FOLDERS[folder]["globs"]:
            for rel in sorted(f for f in tree if fnmatch.fnmatch(f, g)):
                if not args.files or any(fnmatch.fnmatch(rel, x) or rel.endswith("/" + x) for x in args.files):
                    files.append((folder, rel))
    if not files:
        print("mutation: no file selected", file=sys.stderr)
        return 2
    sources = {rel: tree[rel][0].decode("utf-8") for _, rel in files}
    population: dict[str, list[Mutant]] = {}
    for folder, rel in files:
        ms = generate(rel, folder, sources[rel])
        if args.ops:
            ms = [m for m in ms if m.op in args.ops]
        if args.only:
            ms = [m for m in ms if m.key in args.only or f"{m.path}:{m.line}" in args.only]
        population.setdefault(folder, []).extend(ms)
    samples = parse_sample(args.sample, args.folders)
    mutants: list[Mutant] = []
    for folder, ms in population.items():
        if folder in samples and samples[folder] < len(ms):
            ms = sample(ms, samples[folder], args.seed)
        mutants.extend(sorted(ms, key=lambda m: (m.path, m.start, m.op, m.repl)))
    pop_desc = ", ".join(
        f"{f}: {len([m for m in mutants if m.folder == f])} of {len(ms)}" for f, ms in population.items())
    log(f"{len(mutants)} mutants ({pop_desc}; seed {args.seed})")
    if args.list:
        for m in mutants:
            print(f"{m.key}\t{m.op}\t{m.mutation}")
        return 0
    if not mutants:
        return 0

    # equivalents
    everything = [m for ms in population.values() for m in ms]
    found, stale_rows = match_equivalents(read_equivalents(EQUIV_DOC), everything)
    for m in mutants:
        if id(m) in found:
            m.equivalent_reason = found[id(m)].why
    stale = [f"`{r.key}` {r.mutation} (`{r.text}`): no such mutant" for r in stale_rows]

    # the builds
    log("building the unmutated reference data (ref)")
    configure(work / "src", work / "ref", ["-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG"])
    build_targets(work / "ref", ["caekf_testdata"])
    testdata = work / "testdata"
    testdata.mkdir(exist_ok=True)
    for f in TESTDATA:
        s, d = work / "ref" / "testdata" / f, testdata / f
        if not d.exists() or d.read_bytes() != s.read_bytes():
            shutil.copyfile(s, d)
    configure(work / "src", work / "build", ["-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS_RELEASE=-O2 -DNDEBUG",
                                             f"-DCAEKF_FROZEN_TESTDATA={testdata}"])
    found = discover_suites(work / "build")
    suites: dict[str, list[Suite]] = {}
    for folder in args.folders:
        dirs = {FOLDERS[folder]["suites"]} | ({APP_SUITES} if args.also_app else set())
        suites[folder] = [s for s in found if s.folder in dirs]
        log(f"{folder}: suites {' '.join(s.name for s in suites[folder])}")
        if not suites[folder]:
            raise SystemExit(f"mutation: no Unity suite found for {folder}")
    targets = sorted({s.name for ss in suites.values() for s in ss})

    covered: dict[str, dict[str, dict[int, int]]] = {}
    if not args.no_coverage:
        log("line coverage of the suites (cov: -O0 --coverage)")
        covered = coverage_lines(work, work / "src", testdata, suites)

    workers = [Worker(i, work, testdata, suites, targets, tree) for i in range(max(1, args.jobs))]
    log(f"baseline build and run ({len(workers)} worker(s))")
    for w in workers:
        w.prepare()

    todo: list[Mutant] = []
    for m in mutants:
        lines = covered.get(m.folder, {}).get(m.path, {})
        known = [lines[ln] for ln in range(m.line, m.line + m.orig.count("\n") + 1) if ln in lines]
        if known and not any(known):
            m.outcome, m.detail = "not covered", "line never run by the folder's suites"
        else:
            todo.append(m)
    log(f"{len(todo)} mutants to build, {len(mutants) - len(todo)} on lines no suite runs")

    # work split: whole files per worker (a file switch costs one more compile)
    queues: list[list[Mutant]] = [[] for _ in workers]
    by_file: dict[str, list[Mutant]] = {}
    for m in todo:
        by_file.setdefault(m.path, []).append(m)
    for fpath in sorted(by_file, key=lambda f: -len(by_file[f])):
        min(queues, key=len).extend(by_file[fpath])
    done = 0
    lock = threading.Lock()

    def work_on(w: Worker, q: list[Mutant]) -> None:
        nonlocal done
        for m in q:
            w.run_mutant(m)
            with lock:
                done += 1
                print(f"[{done:4d}/{len(todo)}] {m.key} {m.op} {squash(m.mutation, 60)}: {m.outcome}"
                      f"{' (' + m.detail + ')' if m.outcome == 'killed' else ''} {m.seconds:.1f} s", flush=True)

    with concurrent.futures.ThreadPoolExecutor(len(workers)) as ex:
        futs = [ex.submit(work_on, w, q) for w, q in zip(workers, queues)]
        for f in futs:
            f.result()

    stale_killed = []
    for m in mutants:
        m_detail_line = mutated_line(sources[m.path], m)
        if m.outcome in ("survived", "not covered"):
            m.detail = m_detail_line
        if m.equivalent_reason:
            if m.outcome == "killed":
                stale_killed.append(f"`{m.key}` {m.mutation}: listed as equivalent but killed ({m.detail})")
            elif m.outcome in ("survived", "not covered"):
                m.outcome = "equivalent"
    stale += stale_killed

    elapsed = time.monotonic() - t_start
    dirty = args.overlay if args.rev else run(["git", "status", "--porcelain", "--", "firmware", "tests/unit"],
                                              cwd=REPO).stdout.strip()
    cmd = "tools/mutation.py " + " ".join(argv if argv is not None else sys.argv[1:])
    header = [
        "# Mutation testing: report",
        "",
        f"`{cmd}` at {commit[:10]}{' (with local changes)' if dirty else ''}, {time.strftime('%Y-%m-%d')}: "
        f"{len(mutants)} mutants ({pop_desc}; seed {args.seed}), {len(workers)} worker(s), "
        f"{elapsed:.0f} s. Score = killed / (killed + survived + not covered); method: docs/mutation.md.",
    ]
    text = report(mutants, header, stale)
    print()
    print("\n".join(table(mutants, "folder")))
    print()
    print("\n".join(table(mutants, "file")))
    for m in mutants:
        if m.outcome == "survived":
            print(f"survived: {m.key} {m.op} {m.mutation}   | {m.detail}")
    for s in stale:
        print(f"stale equivalent entry: {s}")
    if args.report:
        args.report.parent.mkdir(parents=True, exist_ok=True)
        args.report.write_text(text, encoding="utf-8")
        log(f"report: {args.report}")
    if args.json:
        args.json.write_text(json.dumps([asdict(m) for m in mutants], indent=1), encoding="utf-8")
    log(f"done in {elapsed:.0f} s")
    rc = 0
    for spec in args.min_score:
        folder, _, pct = spec.partition("=")
        k, n, score_pct = score([m for m in mutants if m.folder == folder])
        if n and score_pct < float(pct):
            log(f"{folder}: score {score_pct:.1f} % ({k}/{n}) is below its floor {float(pct):.1f} %")
            rc = 3
    return rc


if __name__ == "__main__":
    sys.exit(main())
