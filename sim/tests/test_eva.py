"""tools/eva.py (docs/eva.md): Frama-C EVA's proof of no run-time error over firmware/protocol for every frame, and
over the settings set and read by parameter id for every id and value.

The analysis runs when frama-c is installed (Debian's frama-c-base; tools/bootstrap.sh installs it) and must
end with no unjustified alarm. The justified-alarms table and the report reader are checked without frama-c.
"""
import importlib.util
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
TOOL = REPO / "tools" / "eva.py"


@pytest.fixture(scope="module")
def eva():
    spec = importlib.util.spec_from_file_location("caekf_eva", TOOL)
    mod = importlib.util.module_from_spec(spec)
    sys.modules["caekf_eva"] = mod
    spec.loader.exec_module(mod)
    return mod


def test_justified_table_reads_and_every_row_has_a_reason(eva):
    rules = eva.read_justified(eva.JUSTIFIED)
    for r in rules:
        assert r.reason.strip(), r
        assert (REPO / r.file).is_file() or r.file.startswith("generated/"), r.file


def test_report_reader_counts_unknown_and_invalid_only(eva, tmp_path):
    header = "directory\tfile\tline\tfunction\tproperty kind\tstatus\tproperty\n"
    rows = [
        "firmware/protocol/src\te2e.c\t10\tf\tmem_access\tValid\t\\valid(p)\n",
        "firmware/protocol/src\te2e.c\t11\tf\tmem_access\tUnknown\t\\valid(q)\n",
        "firmware/protocol/src\te2e.c\t12\tf\tsigned_overflow\tInvalid\tx + 1 ≤ 2147483647\n",
        "firmware/protocol/src\te2e.c\t13\tf\tprecondition of memset\tDead\tvalid_s: valid_or_empty(s, n)\n",
        "FRAMAC_SHARE/libc\tstring.h\t1\tmemcpy\tassigns clause\tConsidered valid\tassigns x;\n",
    ]
    report = tmp_path / "r.csv"
    report.write_text(header + "".join(rows), encoding="utf-8")
    alarms = eva.read_alarms(report, tmp_path)
    assert [(a.file, a.line, a.kind) for a in alarms] == [
        ("firmware/protocol/src/e2e.c", 11, "mem_access"), ("firmware/protocol/src/e2e.c", 12, "signed_overflow")]
    rules = [eva.Rule("firmware/protocol/src/e2e.c", "f", "signed_overflow", "x + 1 ≤ 2147483647", "because")]
    eva.justify(alarms, rules)
    assert [a.reason for a in alarms] == [None, "because"]
    assert rules[0].used == 1


@pytest.mark.skipif(shutil.which("frama-c") is None,
                    reason="frama-c not installed (Debian's frama-c-base: tools/bootstrap.sh installs it)")
@pytest.mark.parametrize("target", ["protocol", "settings"])
def test_target_has_no_unjustified_alarm(target, tmp_path):
    cmd = [sys.executable, str(TOOL), "--targets", target, "--out", str(tmp_path)]
    if os.environ.get("CAEKF_BUILD_DIR"):
        cmd += ["--build", os.environ["CAEKF_BUILD_DIR"]]
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=1200)
    out = proc.stdout + proc.stderr
    assert proc.returncode == 0, out
    rows = [line for line in out.splitlines() if line.startswith(f"| {target}/")]
    assert len(rows) == 2, out  # both data models
    for row in rows:
        cells = [c.strip() for c in row.strip("|").split("|")]
        assert cells[5] == "0", row  # unjustified
    assert "eva: ok" in out
