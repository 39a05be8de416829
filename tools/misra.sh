#!/usr/bin/env bash
# tools/misra.sh [BUILD_DIR]: MISRA C:2012 with cppcheck's misra addon over firmware/ (run-tests stage `misra`).
#
# The files and their flags come from BUILD_DIR's compile_commands.json (default build/host-double; it must be
# configured and its code generators run: the generated headers are included, and the generated C of the
# firmware, BUILD_DIR/generated/core and generated/protocol, is checked as well); the Cortex-M start-up files,
# which only an MCU build compiles, are added with the port's include folders (as tools/lint-c.sh does).
# tools/misra-check.py then sorts the findings by the rule's category and checks them against the deviations
# recorded in docs/misra.md: any mandatory violation, or a required one that no deviation covers, fails;
# advisory ones are counted. The addon runs without the rule texts (they are MISRA's): findings carry rule
# numbers only. Outputs: BUILD_DIR/misra/findings.txt (every finding), summary.txt (the tables).
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="$(cd "${1:-$REPO/build/host-double}" && pwd)"
command -v cppcheck >/dev/null || { echo "misra: cppcheck not installed (tools/bootstrap.sh installs it)"; exit 1; }
[ -f "$BUILD/compile_commands.json" ] || { echo "misra: no $BUILD/compile_commands.json (configure first)"; exit 1; }
work="$BUILD/misra"
mkdir -p "$work/cppcheck"
t0=$SECONDS
python3 - "$REPO" "$BUILD" "$work/compile_commands.json" <<'PY'
import glob, json, os, sys
repo, build, dst = sys.argv[1:]
gen = [os.path.join(build, "generated", g) + "/" for g in ("core", "protocol")]
mine = lambda f: f.startswith(os.path.join(repo, "firmware") + "/") or any(f.startswith(g) for g in gen)
seen, out = set(), []
for e in json.load(open(os.path.join(build, "compile_commands.json"))):
    f = os.path.normpath(os.path.join(e["directory"], e["file"]))
    if mine(f) and f not in seen:
        seen.add(f)
        out.append(e)
missing = [g for g in gen if not any(f.startswith(g) for f in seen)]
if missing:
    sys.exit(f"misra: no generated C under {missing} in the compile database")
port = os.path.join(repo, "firmware/port/cortex-m")
incs = [os.path.join(repo, p) for p in ("firmware/include", "firmware/port/cortex-m", "firmware/port/cortex-m/can",
                                        "firmware/app/include", "firmware/protocol/include")]
incs += [os.path.join(build, "generated", g) for g in ("core", "protocol/include")]
for f in sorted(glob.glob(os.path.join(port, "**/*.c"), recursive=True)):
    if f not in seen:
        cmd = ["cc", "-std=c99", "-DCAEKF_USE_FLOAT=1", "-D__ARM_ARCH=7"] + ["-I" + i for i in incs] + ["-c", f]
        out.append({"directory": repo, "command": " ".join(cmd), "file": f})
json.dump(out, open(dst, "w"), indent=1)
print(f"misra: cppcheck --addon=misra over {len(out)} files of firmware/ and the generated firmware C")
PY
# The generated headers are included: the build's code generators must have run (the stage builds them).
for h in "$BUILD/generated/core/caekf/caekf_status.h" "$BUILD/generated/protocol/include/caekf/caekf_proto_messages.h"; do
    [ -f "$h" ] || { echo "misra: $h missing (build the code generator targets first)"; exit 1; }
done
cppcheck --project="$work/compile_commands.json" --addon=misra --std=c99 --quiet -j "${JOBS:-2}" \
    --inline-suppr --cppcheck-build-dir="$work/cppcheck" --suppress='*:*/.cache/*' \
    --template='{file}:{line}:{column}: {id}: {message}' 2>"$work/findings.raw" ||
    { cat "$work/findings.raw"; echo "misra: cppcheck failed"; exit 1; }
# Anything else than a MISRA finding (a cppcheck error, a missing include the addon needs) is shown and fails.
grep -v ': misra-c2012-' "$work/findings.raw" | grep -v '^$' >"$work/other.txt" || true
grep ': misra-c2012-' "$work/findings.raw" | sort -u >"$work/findings.txt" || true
python3 "$REPO/tools/misra-check.py" "$work/findings.txt" --repo "$REPO" --build "$BUILD" \
    --deviations "$REPO/docs/misra.md" --other "$work/other.txt" | tee "$work/summary.txt"
rc=${PIPESTATUS[0]}
echo "misra: $((SECONDS - t0)) s"
exit "$rc"
