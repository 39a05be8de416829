"""Fixtures of the DBC cross-check: the database (cantools) and the C codec (caekf_proto_dump).

The C side is the program built from tests/protocol/proto_dump.c: taken from $CAEKF_PROTO_DUMP when set
(CMake sets it for ctest), else compiled here with the system C compiler into a temporary folder."""
import os
import shutil
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
DBC = REPO / "firmware" / "protocol" / "caekf.dbc"


@pytest.fixture(scope="session")
def db():
    cantools = pytest.importorskip("cantools")
    return cantools.database.load_file(str(DBC), strict=True)


class Dump:
    """Batch runner: feeds commands to the C program, returns its answer lines."""

    def __init__(self, exe: str):
        self.exe = exe

    def run(self, commands: list[str]) -> list[str]:
        out = subprocess.run([self.exe], input="\n".join(commands) + "\n", capture_output=True, text=True,
                             check=True, timeout=120).stdout.splitlines()
        bad = [line for line in out if line.startswith("error:")]
        assert not bad, bad[:3]
        return out

    def one(self, command: str) -> str:
        return self.run([command])[0]

    def listing(self, command: str) -> list[str]:
        lines = self.run([command])
        assert lines[-1] == "end"
        return lines[:-1]


@pytest.fixture(scope="session")
def dump(tmp_path_factory):
    exe = os.environ.get("CAEKF_PROTO_DUMP")
    if exe:
        return Dump(exe)
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler and CAEKF_PROTO_DUMP not set")
    work = tmp_path_factory.mktemp("proto_dump")
    out = work / "caekf_proto_dump"
    proto = REPO / "firmware" / "protocol"
    from caekf_sim import codegen  # the C of caekf.dbc, as the build generates it

    codegen.write(work / "gen")
    sources = sorted(str(p) for d in (proto / "src", work / "gen" / "src") for p in d.glob("*.c"))
    includes = [f"-I{d}" for d in (proto / "include", proto / "src", work / "gen" / "include", work / "gen" / "src")]
    subprocess.run([cc, "-std=c99", "-O1", "-Wall", "-Wextra", "-Werror", *includes,
                    str(Path(__file__).with_name("proto_dump.c")), *sources, "-o", str(out)], check=True)
    return Dump(str(out))
