#!/usr/bin/env bash
# tools/lint-c.sh [BUILD_DIR]: cppcheck over the C of firmware/ and host/ (run-tests stage `lint`).
#
# The files and their flags come from BUILD_DIR's compile_commands.json (default build/host-double, which
# must be configured and built: the generated settings headers are included); the Cortex-M start-up
# files, which only an MCU build compiles, are added with the port's include folders. Checks: warning,
# style, performance, portability; C99. Zero findings is the rule: a finding that is not a defect is
# suppressed inline (`// cppcheck-suppress id` with the reason on the same line or the one above).
set -euo pipefail
REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="${1:-$REPO/build/host-double}"
command -v cppcheck >/dev/null || { echo "lint-c: cppcheck not installed (tools/bootstrap.sh installs it)"; exit 1; }
[ -f "$BUILD/compile_commands.json" ] || { echo "lint-c: no $BUILD/compile_commands.json (configure and build first)"; exit 1; }
work="$BUILD/lint"
mkdir -p "$work/cppcheck"
python3 - "$REPO" "$BUILD/compile_commands.json" "$work/compile_commands.json" <<'PY'
import glob, json, os, sys
repo, src, dst = sys.argv[1:]
mine = lambda f: f.startswith(os.path.join(repo, "firmware") + "/") or f.startswith(os.path.join(repo, "host") + "/")
seen, out = set(), []
for e in json.load(open(src)):
    f = os.path.normpath(os.path.join(e["directory"], e["file"]))
    if mine(f) and f not in seen:
        seen.add(f)
        out.append(e)
port = os.path.join(repo, "firmware/port/cortex-m")
incs = [os.path.join(repo, p) for p in ("firmware/include", "firmware/port/cortex-m", "firmware/port/cortex-m/can",
                                        "firmware/app/include", "firmware/protocol/include")]
gen = [os.path.join(os.path.dirname(src), "generated", g) for g in ("core", "protocol/include")]
for f in sorted(glob.glob(os.path.join(port, "**/*.c"), recursive=True)):
    if f not in seen:
        cmd = ["cc", "-std=c99", "-DCAEKF_USE_FLOAT=1", "-D__ARM_ARCH=7"] + ["-I" + i for i in incs + gen] + ["-c", f]
        out.append({"directory": repo, "command": " ".join(cmd), "file": f})
json.dump(out, open(dst, "w"), indent=1)
print(f"lint-c: cppcheck over {len(out)} files of firmware/ and host/")
PY
cppcheck --project="$work/compile_commands.json" --enable=warning,style,performance,portability --std=c99 \
    --inline-suppr --error-exitcode=1 --quiet -j "${JOBS:-2}" --cppcheck-build-dir="$work/cppcheck" \
    --suppress='*:*/.cache/*' --suppress='*:*/build/*' \
    --template='{file}:{line}: {severity} ({id}): {message}'
echo "lint-c: no findings"
