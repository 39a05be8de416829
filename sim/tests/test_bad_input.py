"""caekf-sim's bad-input table (tests/data/bad_input_cases.txt): every case runs the installed command in a
fresh folder and checks the exit code, the one line on stderr, no traceback and no file left behind."""
from __future__ import annotations

import ast
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Set

import numpy as np
import pytest

from caekf_sim import schema
from caekf_sim.measurements import DT_TOL, MAX_ROWS
from caekf_sim.scenario import default_scenario_path

TABLE = Path(__file__).with_name("data") / "bad_input_cases.txt"
REPO = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class Case:
    name: str
    exit: int
    regex: str
    edit: str
    input: str
    args: str


def load_cases() -> List[Case]:
    cases = []
    for line in TABLE.read_text(encoding="utf-8").splitlines():
        if not line.strip() or line.startswith("#"):
            continue
        fields = [f.strip() for f in line.split(" | ")]
        assert len(fields) == 6, f"bad table line: {line}"
        cases.append(Case(fields[0], int(fields[1]), *fields[2:]))
    return cases


CASES = load_cases()


def _edit_scenario(text: str, edit: str) -> bytes:
    if edit == "EMPTY":
        return b""
    if edit == "BINARY":
        return b"\x00\x01\xff\xfe\x89PNG\r\n"
    lines = text.splitlines()
    truth_keys = {k for k, s, _ in schema.SCHEMA.keys() if s.kind == "truth"}
    for e in ([] if edit == "-" else edit.split(";")):
        e = e.strip()
        if e == "-truth":
            lines = [ln for ln in lines if ln.split("=")[0].strip() not in truth_keys]
        elif e.startswith("-"):
            lines = [ln for ln in lines if ln.split("=")[0].strip() != e[1:]]
        elif e.startswith("line:"):
            lines.append(e[5:])
        else:
            key, value = e.split("=", 1)
            new = f"{key} = {value}"
            hits = [i for i, ln in enumerate(lines) if ln.split("=")[0].strip() == key]
            if hits:
                lines[hits[0]] = new
            else:
                lines.append(new)
    return ("\n".join(lines) + "\n").encode()


def _good_csv(n: int = 20) -> str:
    rows = [f"{k * 1e-3:.17g},{0.1 * np.sin(k):.17g},{1e-6 * k:.17g},{-1e-7 * k:.17g}" for k in range(1, n + 1)]
    return "t,u,y1,y4\n" + "\n".join(rows) + "\n"


def _unescape(s: str) -> bytes:
    return ast.literal_eval("b'" + s.replace("'", "\\'") + "'")


def _write_log(csv: Path, log: Path, copies: int) -> None:
    """A candump -L log of the bench's frames for the CSV's samples (encoded with the DBC through cantools'
    signal layouts), `copies` runs separated by a CTRL_RESET."""
    from caekf_sim.bench.buslog import write_journal
    from caekf_sim.bench.codec import Codec, make_records
    from caekf_sim.measurements import read_measurements_csv

    m = read_measurements_csv(csv, 1e-3)
    codec = Codec()
    n = len(m.t)
    steps = np.arange(n) & 0xFFFF
    cols = {"BENCH_U": {"STEP": steps, "U": m.u}, "BENCH_Y1": {"STEP": steps, "Y1": m.y[:, 0]},
            "BENCH_Y4": {"STEP": steps, "Y4": m.y[:, 1]}}
    payloads = {k: codec.pack(k, c, counters=np.arange(n)) for k, c in cols.items()}
    reset = make_records(codec.messages["CTRL_RESET"].frame_id,
                         codec.pack("CTRL_RESET", {"N_PARAMS": np.array([0])})).tobytes()
    journal = []
    for c in range(copies):
        journal.append((c * 1.0, 0, reset))
        for k in range(n):
            for name in cols:
                rec = make_records(codec.messages[name].frame_id, payloads[name][k][None]).tobytes()
                journal.append((c * 1.0 + k * 1e-3, 0, rec))
    write_journal(journal, log, "vcan0", 1000.0)


@pytest.fixture(scope="module")
def assets(tmp_path_factory) -> Dict[str, Path]:
    """Inputs made once: a truth CSV, an estimate CSV, a results folder, candump logs."""
    d = tmp_path_factory.mktemp("assets")
    (d / "good.csv").write_text(_good_csv(), encoding="utf-8")
    run = [sys.executable, "-m", "caekf_sim"]
    subprocess.run(run + ["truth", "--t-end", "0.05", "--out", str(d / "truth.csv")], check=True,
                   capture_output=True)
    subprocess.run(run + ["estimate", "--measurements", str(d / "good.csv"), "--out", str(d / "res.csv")],
                   check=True, capture_output=True)
    _write_log(d / "good.csv", d / "one.log", 1)
    _write_log(d / "good.csv", d / "two.log", 2)
    return {"good": d / "good.csv", "truth": d / "truth.csv", "res": d / "res.csv", "log": d / "one.log",
            "log2": d / "two.log"}


def _tree(root: Path) -> Set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.mark.parametrize("case", CASES, ids=[c.name for c in CASES])
def test_bad_input(case: Case, assets: Dict[str, Path], tmp_path: Path) -> None:
    inp, out = tmp_path / "in", tmp_path / "out"
    inp.mkdir()
    out.mkdir()
    (inp / "sc.toml").write_bytes(_edit_scenario(default_scenario_path().read_text(encoding="utf-8"), case.edit))
    (inp / "file.txt").write_text("a regular file\n")
    shutil.copy(assets["res"], inp / "res.csv")
    (inp / "resdir").mkdir()
    shutil.copy(assets["res"], inp / "resdir" / "switched.csv")
    src = inp / ("in.log" if case.input in ("log", "log2") else "in.csv")
    if case.input == "-":
        shutil.copy(assets["good"], src)
    elif case.input in ("truth", "log", "log2"):
        shutil.copy(assets[case.input], src)
    elif case.input.startswith("good+printf:"):
        src.write_bytes(assets["good"].read_bytes() + _unescape(case.input[len("good+printf:"):]))
    elif case.input.startswith("printf:"):
        src.write_bytes(_unescape(case.input[len("printf:"):]))
    else:
        raise AssertionError(f"{case.name}: unknown input {case.input!r}")
    subst = {"@SC": inp / "sc.toml", "@IN": src, "@OUTDIR": out / "dir", "@OUT": out / "result.csv",
             "@PNG": out / "fig.png", "@DIR": inp, "@FILE": inp / "file.txt", "@NONE": tmp_path / "nope.toml",
             "@RESDIR": inp / "resdir", "@RES": inp / "res.csv"}
    args = []
    for a in case.args.split():
        for k, v in subst.items():
            a = a.replace(k, str(v))
        args.append(a)
    before = _tree(tmp_path)
    p = subprocess.run([sys.executable, "-m", "caekf_sim", *args], capture_output=True, text=True,
                       stdin=subprocess.DEVNULL, cwd=tmp_path, timeout=300)
    added = _tree(tmp_path) - before
    assert "Traceback" not in p.stderr, p.stderr
    if case.exit == 0:
        assert p.returncode == 0, p.stderr
        assert re.search(case.regex, p.stdout, re.M), p.stdout
        assert not [a for a in added if Path(a).name.startswith(".")], f"temporary files left: {added}"
        return
    assert p.returncode == case.exit, f"exit {p.returncode}, stderr: {p.stderr}"
    lines = p.stderr.splitlines()
    assert len(lines) == 1, f"not one line on stderr: {p.stderr!r}"
    assert lines[0].startswith("caekf-sim"), lines[0]
    assert re.search(case.regex, lines[0]), f"{lines[0]!r} !~ {case.regex!r}"
    assert p.stdout == "", p.stdout
    assert not added, f"left behind: {sorted(added)}"


def test_table_covers_every_exit_code_and_command() -> None:
    codes = {c.exit for c in CASES}
    assert {0, 2, 3, 4} <= codes
    commands = {c.args.split()[0] for c in CASES}
    assert {"truth", "estimate", "experiments", "plot", "tune", "campaign", "family"} <= commands


def test_limits_are_the_c_readers() -> None:
    """MAX_ROWS and DT_TOL are host/common/csv.h's (the Python reader applies the C reader's rules)."""
    text = (REPO / "host" / "common" / "csv.h").read_text(encoding="utf-8")
    rows = re.search(r"#define CAEKF_CSV_MAX_ROWS (\d+)L", text)
    tol = re.search(r"#define CAEKF_CSV_DT_TOL ([0-9.eE+-]+)", text)
    assert rows and tol
    assert MAX_ROWS == int(rows.group(1)) and DT_TOL == float(tol.group(1))


def test_atomic_output_leaves_nothing_on_failure_and_writes_devices_in_place(tmp_path: Path) -> None:
    from caekf_sim.outputs import atomic_output

    target = tmp_path / "out.csv"
    with pytest.raises(RuntimeError):
        with atomic_output(target) as tmp:
            tmp.write_text("half a file")
            raise RuntimeError("failed mid-way")
    assert list(tmp_path.iterdir()) == []
    with atomic_output(target) as tmp:
        tmp.write_text("whole\n")
    assert target.read_text() == "whole\n" and [p.name for p in tmp_path.iterdir()] == ["out.csv"]
    with atomic_output("/dev/null") as tmp:  # not a regular file: written in place, never replaced
        assert tmp == Path("/dev/null")
    assert Path("/dev/null").is_char_device()
