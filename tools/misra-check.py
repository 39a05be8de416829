#!/usr/bin/env python3
"""MISRA C:2012 findings of cppcheck's misra addon against the deviations of docs/misra.md (tools/misra.sh).

    misra-check.py FINDINGS --repo REPO --build BUILD --deviations docs/misra.md [--other FILE]

FINDINGS: lines `file:line:column: misra-c2012-R.N: message`. Each rule's category (mandatory, required,
advisory) is MISRA C:2012's with amendments 1 and 2 (the table below: numbers and categories only, the rule
texts are MISRA's). A file of the build's generated/ folder is named `generated/...`, any other by its path
from the repository root.
Fails (exit 1) on: any mandatory violation; any required violation that no deviation of docs/misra.md covers
(same rule, path matching one of the deviation's globs); a rule the table does not know; a deviation row that
is malformed, names a mandatory or advisory rule, or has no reason; an inline `cppcheck-suppress misra...`
comment in firmware/ (a deviation lives in docs/misra.md, nowhere else). Advisory violations are counted.
"""

from __future__ import annotations

import argparse
import fnmatch
import os
import re
import sys
from collections import Counter, defaultdict

M, R, A = "mandatory", "required", "advisory"
# MISRA C:2012 (third edition, first revision: amendments 1 and 2 folded in): rule -> category.
CATEGORY: dict[str, str] = {}


def _cat(cat: str, rules: str) -> None:
    for r in rules.split():
        CATEGORY[r] = cat


_cat(M, "9.1 12.5 13.6 17.3 17.4 17.6 19.1 21.13 21.17 21.18 21.19 21.20 22.2 22.4 22.5 22.6")
_cat(A, "1.2 2.3 2.4 2.5 2.6 2.7 4.2 5.9 8.7 8.9 8.11 8.13 10.5 11.4 11.5 12.1 12.3 12.4 13.3 13.4 15.1 15.4 "
        "15.5 17.5 17.8 18.4 18.5 19.2 20.1 20.5 20.10 21.12")
_cat(R, "1.1 1.3 1.4 2.1 2.2 3.1 3.2 4.1 5.1 5.2 5.3 5.4 5.5 5.6 5.7 5.8 6.1 6.2 7.1 7.2 7.3 7.4 "
        "8.1 8.2 8.3 8.4 8.5 8.6 8.8 8.10 8.12 8.14 9.2 9.3 9.4 9.5 10.1 10.2 10.3 10.4 10.6 10.7 10.8 "
        "11.1 11.2 11.3 11.6 11.7 11.8 11.9 12.2 13.1 13.2 13.5 14.1 14.2 14.3 14.4 15.2 15.3 15.6 15.7 "
        "16.1 16.2 16.3 16.4 16.5 16.6 16.7 17.1 17.2 17.7 18.1 18.2 18.3 18.6 18.7 18.8 "
        "20.2 20.3 20.4 20.6 20.7 20.8 20.9 20.11 20.12 20.13 20.14 "
        "21.1 21.2 21.3 21.4 21.5 21.6 21.7 21.8 21.9 21.10 21.11 21.14 21.15 21.16 21.21 "
        "22.1 22.3 22.7 22.8 22.9 22.10")

FINDING = re.compile(r"^(?P<file>.+?):(?P<line>\d+):(?P<col>\d+): misra-c2012-(?P<rule>[\d.]+): ")
TABLE_START = "<!-- misra-deviations"
TABLE_END = "<!-- /misra-deviations -->"


def rule_key(r: str) -> list[int]:
    return [int(x) for x in r.split(".")]


def folder(path: str) -> str:
    parts = path.split("/")
    if parts[0] == "generated":
        return "generated/" + parts[1]
    if parts[0] == "firmware" and len(parts) > 2:
        return "firmware/" + parts[1]
    return parts[0]


def load_deviations(md: str, errors: list[str]) -> list[dict]:
    text = open(md, encoding="utf-8").read()
    if TABLE_START not in text or TABLE_END not in text:
        errors.append(f"{md}: no deviation table ({TABLE_START} ... {TABLE_END})")
        return []
    body = text.split(TABLE_START, 1)[1].split(TABLE_END, 1)[0]
    devs = []
    for no, row in enumerate(body.splitlines()):
        row = row.strip()
        if not row.startswith("|") or set(row) <= set("|-: "):
            continue
        cells = [c.strip() for c in row.strip("|").split("|")]
        if cells[0].lower() == "id":
            continue
        if len(cells) != 4:
            errors.append(f"{md}: deviation row {row!r}: want | id | rule | where | reason |")
            continue
        did, rule, where, reason = cells
        rule = rule.replace("Rule", "").strip()
        globs = [g.strip().strip("`") for g in where.split(",") if g.strip()]
        if CATEGORY.get(rule) != R:
            errors.append(f"{md}: deviation {did}: rule {rule} is {CATEGORY.get(rule, 'unknown')}; "
                          "only a required rule can be deviated")
        if not globs or len(reason) < 20:
            errors.append(f"{md}: deviation {did}: a place and a reason are needed")
        devs.append({"id": did, "rule": rule, "globs": globs, "reason": reason, "used": 0})
    if not devs:
        errors.append(f"{md}: the deviation table has no rows")
    return devs


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("findings")
    ap.add_argument("--repo", required=True)
    ap.add_argument("--build", required=True)
    ap.add_argument("--deviations", required=True)
    ap.add_argument("--other", help="cppcheck's own findings (not MISRA): shown, they are the lint stage's")
    args = ap.parse_args()
    repo = os.path.abspath(args.repo)
    gen = os.path.join(os.path.abspath(args.build), "generated") + "/"
    errors: list[str] = []
    devs = load_deviations(args.deviations, errors)

    findings = []
    for line in open(args.findings, encoding="utf-8"):
        m = FINDING.match(line.strip())
        if not m:
            continue
        f = os.path.normpath(m["file"])
        if f.startswith(gen):
            rel = "generated/" + f[len(gen):]
        else:
            rel = os.path.relpath(f, repo)
        findings.append((rel, int(m["line"]), m["rule"]))

    counts: dict[str, Counter] = defaultdict(Counter)  # category -> folder -> n
    by_rule: Counter = Counter()
    undeviated: list[str] = []
    for rel, line, rule in findings:
        cat = CATEGORY.get(rule)
        if cat is None:
            errors.append(f"{rel}:{line}: rule {rule} has no category in tools/misra-check.py")
            continue
        by_rule[rule] += 1
        status = cat
        if cat == R:
            dev = next((d for d in devs if d["rule"] == rule and any(fnmatch.fnmatch(rel, g) for g in d["globs"])),
                       None)
            if dev is None:
                undeviated.append(f"{rel}:{line}: required rule {rule}, no deviation in docs/misra.md")
            else:
                dev["used"] += 1
                status = "required (deviated)"
        counts[status][folder(rel)] += 1
        if cat == M:
            errors.append(f"{rel}:{line}: mandatory rule {rule}")
    errors += undeviated

    for root, _dirs, files in os.walk(os.path.join(repo, "firmware")):
        for name in files:
            if name.endswith((".c", ".h")):
                p = os.path.join(root, name)
                for no, text in enumerate(open(p, encoding="utf-8", errors="replace"), 1):
                    if re.search(r"cppcheck-suppress\s*\[?\s*misra", text):
                        errors.append(f"{os.path.relpath(p, repo)}:{no}: inline MISRA suppression "
                                      "(record a deviation in docs/misra.md instead)")

    folders = sorted({f for c in counts.values() for f in c})
    cats = [M, "required (deviated)", R, A]
    print(f"MISRA C:2012 (cppcheck misra addon), {len(findings)} findings")
    heads = [f.replace("firmware/", "").replace("generated/", "gen/")[:12] for f in folders]
    print(f"{'category':22}" + "".join(f"{h:>13}" for h in heads) + f"{'total':>8}")
    for c in cats:
        row = counts.get(c, Counter())
        label = "required (undeviated)" if c == R else c
        print(f"{label:22}" + "".join(f"{row[f]:13d}" for f in folders) + f"{sum(row.values()):8d}")
    print("(columns: firmware/<folder>; generated/<folder> is the build's generated C)")
    print("by rule: " + ", ".join(f"{r} {CATEGORY.get(r, '?')[0].upper()} {n}"
                                  for r, n in sorted(by_rule.items(), key=lambda kv: rule_key(kv[0]))))
    print("deviations used: " + ", ".join(f"{d['id']} ({d['rule']}) {d['used']}" for d in devs))
    unused = [d["id"] for d in devs if d["used"] == 0]
    if unused:
        print("deviations that cover nothing now (remove them): " + ", ".join(unused))
    if args.other and os.path.exists(args.other):
        other = [ln.rstrip() for ln in open(args.other) if ln.strip()]
        if other:
            print(f"cppcheck's own findings (the lint stage's, not failing here): {len(other)}")
            for ln in other[:20]:
                print("  " + ln)
    if errors:
        print(f"misra: FAILED, {len(errors)} problems:")
        for e in errors:
            print("  " + e)
        return 1
    print(f"misra: ok: 0 mandatory, 0 undeviated required, {sum(counts[A].values())} advisory")
    return 0


if __name__ == "__main__":
    sys.exit(main())
