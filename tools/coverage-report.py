#!/usr/bin/env python3
"""Line and branch coverage of firmware/ per folder, from gcovr's JSON (tools/coverage.sh writes it).

    coverage-report.py GCOVR_JSON [--build BUILD_DIR] [--uncovered FILE]

Prints one row per folder: firmware/core (with firmware/include), protocol, app, port, and the generated C
of the build (BUILD_DIR/generated: the schema's settings tables, the DBC's pack/unpack by cantools), then
the three folders of issue 31 (core, protocol, app) together. A line counts once however many functions or
translation units gcovr saw it in (headers' static inline functions); a branch is (function, block,
branch number) of gcov, taken when any run of any test took it.
--min-branch FOLDER=PCT fails when a folder that reached the issue's 95 % falls below it again.
--uncovered FILE writes every line of core/, protocol/ and app/ with a branch never taken: file:line, the
taken/total branches of the line, its function and its source text (docs/coverage.md lists them).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from collections import defaultdict

FOLDERS = [
    ("core", ("firmware/core/", "firmware/include/")),
    ("protocol", ("firmware/protocol/",)),
    ("app", ("firmware/app/",)),
    ("port", ("firmware/port/",)),
    ("generated core (schema)", ("generated/core/",)),
    ("generated protocol (cantools)", ("generated/protocol/",)),
    ("generated other", ("generated/",)),
]
ISSUE_FOLDERS = ("core", "protocol", "app")


def folder_of(path: str, build_rel: str) -> str | None:
    rel = path
    if build_rel and rel.startswith(build_rel + "/"):
        rel = rel[len(build_rel) + 1 :]
    for name, prefixes in FOLDERS:
        if any(rel.startswith(p) for p in prefixes):
            return name
    return None


def per_line(file_entry: dict) -> dict[int, dict]:
    """line number -> {"count": hits, "branches": {key: hits}, "function": name}"""
    lines: dict[int, dict] = {}
    for ln in file_entry["lines"]:
        if ln.get("gcovr/noncode"):
            continue
        rec = lines.setdefault(ln["line_number"], {"count": 0, "branches": defaultdict(int), "function": ""})
        rec["count"] += ln["count"]
        rec["function"] = rec["function"] or ln.get("function_name") or ""
        for b in ln.get("branches", []):
            if b.get("throw"):
                continue
            key = (ln.get("function_name"), b.get("source_block_id"), b["branchno"])
            rec["branches"][key] += b["count"]
    return lines


def pct(num: int, den: int) -> str:
    return f"{100.0 * num / den:6.1f} %" if den else "     - "


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("json")
    ap.add_argument("--build", default="", help="build folder (its generated/ gets rows of its own)")
    ap.add_argument("--uncovered", help="write the lines with an untaken branch of core/, protocol/, app/ here")
    ap.add_argument("--min-branch", action="append", default=[], metavar="FOLDER=PCT",
                    help="fail (exit 1) when FOLDER's branch coverage is below PCT (a floor once reached)")
    args = ap.parse_args()
    data = json.load(open(args.json))
    repo = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    build_rel = os.path.relpath(os.path.abspath(args.build), repo) if args.build else ""

    tot: dict[str, list[int]] = defaultdict(lambda: [0, 0, 0, 0, 0])  # files, lines hit, lines, br hit, br
    uncovered: list[str] = []
    for fe in sorted(data["files"], key=lambda f: f["file"]):
        folder = folder_of(fe["file"], build_rel)
        if folder is None:
            continue
        lines = per_line(fe)
        t = tot[folder]
        t[0] += 1
        t[1] += sum(1 for r in lines.values() if r["count"] > 0)
        t[2] += len(lines)
        for r in lines.values():
            t[3] += sum(1 for c in r["branches"].values() if c > 0)
            t[4] += len(r["branches"])
        if folder in ISSUE_FOLDERS and args.uncovered:
            src_path = os.path.join(repo, fe["file"])
            try:
                src = open(src_path, encoding="utf-8").read().splitlines()
            except OSError:
                src = []
            for no in sorted(lines):
                br = lines[no]["branches"]
                taken = sum(1 for c in br.values() if c > 0)
                if br and taken < len(br):
                    text = src[no - 1].strip() if 0 < no <= len(src) else ""
                    uncovered.append(f"{fe['file']}:{no}: {taken}/{len(br)} ({lines[no]['function']}) {text}")

    print(f"{'folder':31} {'files':>5} {'lines':>13} {'line %':>8} {'branches':>13} {'branch %':>8}")
    for name, _ in FOLDERS:
        if name not in tot:
            continue
        f, lh, lt, bh, bt = tot[name]
        print(f"{name:31} {f:5d} {lh:6d}/{lt:<6d} {pct(lh, lt)} {bh:6d}/{bt:<6d} {pct(bh, bt)}")
    agg = [sum(tot[n][i] for n in ISSUE_FOLDERS if n in tot) for i in range(5)]
    print(f"{'core + protocol + app':31} {agg[0]:5d} {agg[1]:6d}/{agg[2]:<6d} {pct(agg[1], agg[2])} "
          f"{agg[3]:6d}/{agg[4]:<6d} {pct(agg[3], agg[4])}")
    failed = 0
    for spec in args.min_branch:
        name, _, floor = spec.partition("=")
        _f, _lh, _lt, bh, bt = tot.get(name, [0, 0, 0, 0, 0])
        got = 100.0 * bh / bt if bt else 0.0
        if got < float(floor):
            print(f"coverage: FAILED: {name} branch coverage {got:.1f} % is below its floor {floor} %")
            failed = 1
        else:
            print(f"coverage: {name} branch coverage {got:.1f} % >= its floor {floor} %")
    if args.uncovered:
        with open(args.uncovered, "w") as fh:
            fh.write("\n".join(uncovered) + ("\n" if uncovered else ""))
        print(f"coverage: {len(uncovered)} lines with an untaken branch in core/, protocol/, app/ -> {args.uncovered}")
    return failed


if __name__ == "__main__":
    sys.exit(main())
