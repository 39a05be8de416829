#!/usr/bin/env python3
"""Frama-C EVA over the bus-facing firmware: a proof of no run-time error for every frame (docs/eva.md).

    tools/eva.py [--targets protocol ...] [--machdeps x86_64 x86_32] [--build BUILD] [--out DIR] [--timeout S]
                 [--precision N] [--list]

Each target is a driver in tests/eva/ (a main that calls the code under analysis with every input unknown:
Frama_C_make_unknown bytes, Frama_C_interval ranges, NULL-or-valid pointers) and the firmware sources it
reaches, analysed once per data model (machdep: x86_64 as the host, x86_32 as an ILP32 Cortex-M: 32-bit size_t,
int and pointers). The generated C (cantools' pack/unpack, the message tables) comes from BUILD's generated/
folder (default build/host-double, configured and its code generators run when the folder is missing).

Options given to frama-c for every target (docs/eva.md says why):
  -eva -eva-precision N, -warn-invalid-pointer (an invalid pointer is an alarm even if not dereferenced),
  -warn-special-float none (NaN and infinities are values the code handles on purpose; a float-to-integer
  conversion of a non-finite or out-of-range value stays an alarm), signed overflow, division by zero, out of
  bounds, uninitialised reads, invalid shifts: Frama-C's defaults (all on).

The report (frama-c -report-csv) is read property by property: an alarm is any property whose status is not
valid and not dead. Each alarm is matched against the reviewed table of tests/eva/justified-alarms.md (file,
function, kind, the property's text, the reason); the run prints a table (target, functions analysed, alarms,
justified, unjustified, seconds) and every alarm, and exits 1 on an unjustified alarm, on an analysis that did
not reach the end of main (degenerated, or a run-time error on every path), on frama-c's errors or on a time-out.
A table row that no alarm uses is printed as "covers nothing now".
Outputs: BUILD/eva/<target>-<machdep>.{log,csv} (--out DIR: there).
"""

from __future__ import annotations

import argparse
import csv
import os
import re
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
JUSTIFIED = REPO / "tests" / "eva" / "justified-alarms.md"
TABLE_START = "<!-- eva-justified"
TABLE_END = "<!-- /eva-justified -->"
MACHDEPS = ("x86_64", "x86_32")
# Statuses of a property that is not an alarm: proved, an assumption of a library specification, or unreachable.
NOT_ALARM = re.compile(r"^(Valid|Considered valid|Dead|Unreachable)|dead$", re.IGNORECASE)


@dataclass
class Target:
    name: str
    driver: str  # under tests/eva
    sources: list[str]  # repository paths (globs), or generated/... under BUILD
    includes: list[str]  # likewise
    defines: list[str] = field(default_factory=list)
    precision: int = 1
    options: list[str] = field(default_factory=list)  # more frama-c options (precision only, never soundness)


GEN_PROTO = "generated/protocol"
GEN_CORE = "generated/core"
TARGETS = {
    "protocol": Target(
        name="protocol",
        driver="protocol_main.c",
        sources=["firmware/protocol/src/*.c", f"{GEN_PROTO}/src/caekf_can.c",
                 f"{GEN_PROTO}/src/caekf_proto_messages.c"],
        includes=["firmware/protocol/include", f"{GEN_PROTO}/include", f"{GEN_PROTO}/src", "firmware/protocol/src"],
        defines=["NDEBUG"],
    ),
    "settings": Target(
        name="settings",
        driver="settings_main.c",
        sources=["firmware/core/caekf_settings.c", f"{GEN_CORE}/caekf_settings_table.c"],
        includes=["firmware/include", GEN_CORE, "firmware/core"],
        defines=["CAEKF_USE_FLOAT=0", "NDEBUG"],
        # locate() walks the table's rows: unrolled, each parameter id finds its own row
        options=["-eva-auto-loop-unroll", "100"],
    ),
}


@dataclass
class Alarm:
    file: str  # from the repository root; generated/... for the build's generated C
    line: int
    function: str
    kind: str
    prop: str
    status: str
    reason: str | None = None


@dataclass
class Rule:
    file: str
    function: str
    kind: str
    prop: str
    reason: str
    used: int = 0


def norm(text: str) -> str:
    return " ".join(text.replace("`", "").split())


def read_justified(path: Path) -> list[Rule]:
    """The table between the eva-justified markers: | file | function | kind | property | reason |."""
    text = path.read_text(encoding="utf-8")
    if TABLE_START not in text or TABLE_END not in text:
        raise SystemExit(f"eva: {path}: no table between '{TABLE_START}' and '{TABLE_END}'")
    body = text.split(TABLE_START, 1)[1].split(TABLE_END, 1)[0]
    rules: list[Rule] = []
    for n, line in enumerate(body.splitlines()):
        line = line.strip()
        if not line.startswith("|") or set(line) <= set("|-: "):
            continue
        cells = [c.strip() for c in re.split(r"(?<!\\)\|", line.strip("|"))]
        cells = [c.replace("\\|", "|") for c in cells]
        if cells[:2] == ["file", "function"]:
            continue
        if len(cells) != 5 or not all(cells):
            raise SystemExit(f"eva: {path}: table row {n}: five non-empty cells wanted (file | function | kind | "
                             f"property | reason): {line}")
        rules.append(Rule(*(norm(c) for c in cells[:4]), reason=cells[4]))
    return rules


def repo_path(directory: str, name: str, build: Path) -> str:
    path = Path(directory) / name
    if not path.is_absolute():
        path = REPO / path
    try:
        return "generated/" + str(path.resolve().relative_to((build / "generated").resolve()))
    except ValueError:
        pass
    try:
        return str(path.resolve().relative_to(REPO))
    except ValueError:
        return str(path)


def read_alarms(csv_path: Path, build: Path) -> list[Alarm]:
    alarms = []
    with csv_path.open(encoding="utf-8", newline="") as f:
        for row in csv.DictReader(f, delimiter="\t"):
            if NOT_ALARM.search(row["status"]):
                continue
            directory = row["directory"]
            name = row["file"]
            if directory.startswith("FRAMAC_SHARE"):
                file = f"{directory}/{name}"
            else:
                file = repo_path(directory, name, build)
            alarms.append(Alarm(file, int(row["line"] or 0), row["function"], row["property kind"],
                                norm(row["property"]), row["status"]))
    return alarms


def justify(alarms: list[Alarm], rules: list[Rule]) -> None:
    for a in alarms:
        for r in rules:
            if (r.file == a.file and r.function == a.function and r.kind == a.kind and r.prop == a.prop):
                a.reason = r.reason
                r.used += 1
                break


def ensure_generated(build: Path) -> None:
    wanted = (build / GEN_PROTO / "src" / "caekf_can.c", build / GEN_CORE / "caekf_settings_table.c")
    if all(p.is_file() for p in wanted):
        return
    if build.resolve() != (REPO / "build" / "host-double").resolve():
        raise SystemExit(f"eva: {build}/generated missing: configure that build and run its code generators")
    print("eva: configuring host-double and running its code generators", flush=True)
    (REPO / "build").mkdir(exist_ok=True)
    lock = str(REPO / "build" / ".host-double.lock")
    subprocess.run(["flock", lock, "sh", "-c", "cmake --preset host-double >/dev/null && cmake --build --preset "
                    "host-double --target caekf_settings_generated caekf_protocol_generated"], cwd=REPO, check=True)


def expand(patterns: list[str], build: Path) -> list[str]:
    out: list[str] = []
    for p in patterns:
        base = build if p.startswith("generated/") else REPO
        hits = sorted(str(x) for x in base.glob(p))
        if not hits:
            raise SystemExit(f"eva: no file matches {p} (under {base})")
        out += hits
    return out


@dataclass
class Result:
    label: str
    functions: str = "?"
    statements: str = "?"
    alarms: list[Alarm] = field(default_factory=list)
    seconds: float = 0.0
    errors: list[str] = field(default_factory=list)


def run(target: Target, machdep: str, build: Path, out: Path, timeout: float, precision: int | None) -> Result:
    res = Result(f"{target.name}/{machdep}")
    out.mkdir(parents=True, exist_ok=True)
    stem = out / f"{target.name}-{machdep}"
    csv_path = stem.with_suffix(".csv")
    log_path = stem.with_suffix(".log")
    csv_path.unlink(missing_ok=True)
    incs = [f"-I{p}" for p in expand(target.includes, build)]
    defs = [f"-D{d}" for d in target.defines]
    cmd = ["frama-c", "-eva", "-machdep", machdep, "-c11", "-cpp-extra-args=" + " ".join(incs + defs),
           "-warn-invalid-pointer", "-warn-special-float", "none",
           "-eva-precision", str(precision if precision is not None else target.precision),
           *target.options, "-eva-no-show-progress", "-eva-msg-key=-final-states", "-report-csv", str(csv_path),
           str(REPO / "tests" / "eva" / target.driver), *expand(target.sources, build)]
    t0 = time.monotonic()
    try:
        with log_path.open("w", encoding="utf-8") as log:
            log.write(" ".join(cmd) + "\n")
            log.flush()
            proc = subprocess.run(cmd, cwd=REPO, stdout=log, stderr=subprocess.STDOUT, timeout=timeout)
    except subprocess.TimeoutExpired:
        res.seconds = time.monotonic() - t0
        res.errors.append(f"timed out after {timeout:.0f} s ({log_path})")
        return res
    res.seconds = time.monotonic() - t0
    text = log_path.read_text(encoding="utf-8", errors="replace")
    if proc.returncode != 0:
        res.errors.append(f"frama-c exited {proc.returncode} ({log_path})")
    m = re.search(r"(\d+) functions analyzed \(out of (\d+)\)", text)
    if m:
        res.functions = m.group(1)
    m = re.search(r"(\d+) statements reached \(out of (\d+)\): (\d+)%", text)
    if m:
        res.statements = f"{m.group(3)} %"
    if "done for function main" not in text:
        res.errors.append(f"the analysis did not complete ({log_path})")
    if re.search(r"degenerat|NON TERMINATING", text, re.IGNORECASE):
        res.errors.append(f"the analysis degenerated or main does not terminate ({log_path})")
    m = re.search(r"by the Eva analyzer:\s+(\d+) errors", text)
    if m and m.group(1) != "0":
        res.errors.append(f"EVA reported {m.group(1)} errors ({log_path})")
    if not csv_path.is_file():
        res.errors.append(f"no report {csv_path}")
        return res
    res.alarms = read_alarms(csv_path, build)
    return res


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--targets", nargs="+", default=sorted(TARGETS), help="targets (default: all)")
    ap.add_argument("--machdeps", nargs="+", default=list(MACHDEPS), choices=MACHDEPS)
    ap.add_argument("--build", type=Path, default=REPO / "build" / "host-double")
    ap.add_argument("--out", type=Path, default=None, help="folder of the logs and reports (default BUILD/eva)")
    ap.add_argument("--timeout", type=float, default=300.0, help="seconds per analysis (default 300)")
    ap.add_argument("--precision", type=int, default=None, help="-eva-precision (default: the target's)")
    ap.add_argument("--justified", type=Path, default=JUSTIFIED)
    ap.add_argument("--list", action="store_true", help="list the targets and exit")
    args = ap.parse_args()
    if args.list:
        for t in TARGETS.values():
            print(f"{t.name}: tests/eva/{t.driver} over {', '.join(t.sources)}")
        return 0
    unknown = [t for t in args.targets if t not in TARGETS]
    if unknown:
        print(f"eva: unknown target(s) {', '.join(unknown)} (known: {', '.join(sorted(TARGETS))})", file=sys.stderr)
        return 2
    if shutil.which("frama-c") is None:
        print("eva: frama-c not found (Debian's frama-c-base; tools/bootstrap.sh installs it)", file=sys.stderr)
        return 2
    build = args.build.resolve()
    out = (args.out or build / "eva").resolve()
    rules = read_justified(args.justified)
    ensure_generated(build)
    version = subprocess.run(["frama-c", "-version"], capture_output=True, text=True).stdout.strip()
    print(f"eva: frama-c {version}", flush=True)

    results = []
    for name in args.targets:
        for machdep in args.machdeps:
            res = run(TARGETS[name], machdep, build, out, args.timeout, args.precision)
            justify(res.alarms, rules)
            results.append(res)
            print(f"eva: {res.label} done in {res.seconds:.1f} s", flush=True)

    failed = False
    print()
    print("| target | functions analysed | statements reached | alarms | justified | unjustified | seconds |")
    print("|---|---|---|---|---|---|---|")
    for res in results:
        just = sum(1 for a in res.alarms if a.reason)
        unjust = len(res.alarms) - just
        failed |= unjust > 0 or bool(res.errors)
        print(f"| {res.label} | {res.functions} | {res.statements} | {len(res.alarms)} | {just} | {unjust} "
              f"| {res.seconds:.1f} |")
    print()
    for res in results:
        for e in res.errors:
            print(f"eva: {res.label}: ERROR: {e}")
        for a in sorted(res.alarms, key=lambda a: (a.file, a.line)):
            tag = "justified" if a.reason else "UNJUSTIFIED"
            print(f"eva: {res.label}: {tag}: {a.file}:{a.line}: {a.function}: {a.kind} ({a.status}): {a.prop}")
    for r in rules:
        if r.used == 0:
            print(f"eva: {args.justified.name}: row covers nothing now: {r.file} | {r.function} | {r.kind} | {r.prop}")
    by_kind: dict[str, int] = {}
    for res in results:
        for a in res.alarms:
            by_kind[a.kind] = by_kind.get(a.kind, 0) + 1
    if by_kind:
        print("eva: alarms by kind: " + ", ".join(f"{k} {v}" for k, v in sorted(by_kind.items())))
    print(f"eva: {'FAILED' if failed else 'ok'}")
    return 1 if failed else 0


if __name__ == "__main__":
    os.environ.setdefault("LC_ALL", "C.UTF-8")
    sys.exit(main())
