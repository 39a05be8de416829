#!/usr/bin/env bash
# tools/fuzz.sh [--seconds N] [--jobs J] [--keep-corpus] [HARNESS...]
#
# Builds the libFuzzer harnesses of tests/fuzz (clang, -fsanitize=fuzzer,address,undefined) in
# build/fuzz, a CMake build of its own (the presets are not touched), runs each harness for N seconds
# (default 300) starting from its committed seeds, and prints a table:
#   harness, seconds, executions, exec/s, cov and ft (libFuzzer's final coverage and features),
#   corpus (units/bytes at the end), findings (how many files libFuzzer wrote, by kind: crash, leak, timeout,
#   oom, slow-unit). The table is also written to build/fuzz/report.txt.
# Exit status: 0 with no findings, 1 with findings (each is listed with its first report lines and the
# command that reproduces it), 2 on a usage or build error.
#
#   --seconds N     run time per harness (CI runs --seconds 20)
#   --jobs J        harnesses run side by side (default 1; each uses one core)
#   --keep-corpus   grow build/fuzz/work/<harness>/corpus across runs instead of starting from the seeds
#   HARNESS...      a subset of: fuzz_app fuzz_app_f32 fuzz_estimator fuzz_estimator_f32 fuzz_settings
#                   fuzz_settings_f32 fuzz_frames
#
# Findings land in build/fuzz/findings/<harness>/. To keep one as a regression input, copy it to
# tests/fuzz/corpus/<corpus>/crash-<what>, where ctest's fuzz_corpus_* replays it in every host preset.
# Needs clang and its runtime libraries (Debian: clang libclang-rt-dev).
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD="$REPO/build/fuzz"
ALL=(fuzz_app fuzz_app_f32 fuzz_estimator fuzz_estimator_f32 fuzz_settings fuzz_settings_f32 fuzz_frames)

SECONDS_PER=300
JOBS=1
KEEP=0
SELECTED=()
while [ "$#" -gt 0 ]; do
    case "$1" in
        --seconds) SECONDS_PER="${2:?--seconds needs a value}"; shift 2 ;;
        --jobs) JOBS="${2:?--jobs needs a value}"; shift 2 ;;
        --keep-corpus) KEEP=1; shift ;;
        -h|--help) sed -n '2,23p' "${BASH_SOURCE[0]}"; exit 0 ;;
        -*) echo "fuzz.sh: unknown option $1" >&2; exit 2 ;;
        *) SELECTED+=("$1"); shift ;;
    esac
done
[ "${#SELECTED[@]}" -gt 0 ] || SELECTED=("${ALL[@]}")
for h in "${SELECTED[@]}"; do
    case " ${ALL[*]} " in *" $h "*) ;; *) echo "fuzz.sh: unknown harness $h (have: ${ALL[*]})" >&2; exit 2 ;; esac
done
case "$SECONDS_PER$JOBS" in *[!0-9]*) echo "fuzz.sh: --seconds and --jobs take integers" >&2; exit 2 ;; esac
[ "$JOBS" -ge 1 ] || JOBS=1

log() { printf '[fuzz] %s\n' "$*"; }

CC_FUZZ="${CC_FUZZ:-clang}"
command -v "$CC_FUZZ" >/dev/null 2>&1 || { log "no $CC_FUZZ: install clang libclang-rt-dev (tools/bootstrap.sh)"; exit 2; }

log "configure + build ($BUILD, $CC_FUZZ)"
cmake -S "$REPO/tests/fuzz" -B "$BUILD" -G Ninja -DCMAKE_C_COMPILER="$CC_FUZZ" >/dev/null \
    || { log "configure failed"; exit 2; }
cmake --build "$BUILD" --parallel 2 -- "${SELECTED[@]}" >"$BUILD/build.log" 2>&1 \
    || { cat "$BUILD/build.log"; log "build failed (libFuzzer runtime missing? apt install libclang-rt-dev)"; exit 2; }

corpus_of() { echo "${1%_f32}"; } # the _f32 harnesses share the double ones' seeds

run_one() {
    local h="$1"
    local work="$BUILD/work/$h" seeds
    seeds="$REPO/tests/fuzz/corpus/$(corpus_of "$h")"
    [ "$KEEP" -eq 1 ] || rm -rf "$work/corpus"
    rm -rf "$BUILD/findings/$h"
    mkdir -p "$work/corpus" "$BUILD/findings/$h"
    # The first corpus folder receives new units; the committed seeds are only read.
    ( cd "$work" && "$BUILD/$h" "$work/corpus" "$seeds" \
        -max_total_time="$SECONDS_PER" -max_len=4096 -timeout=20 -rss_limit_mb=2048 \
        -print_final_stats=1 -artifact_prefix="$BUILD/findings/$h/" ) >"$work/log" 2>&1 || true
}

log "running ${SELECTED[*]} for ${SECONDS_PER} s each, $JOBS at a time"
running=0
for h in "${SELECTED[@]}"; do
    run_one "$h" &
    running=$((running + 1))
    if [ "$running" -ge "$JOBS" ]; then
        wait -n
        running=$((running - 1))
    fi
done
wait

FINDINGS=0
REPORT="$BUILD/report.txt"
{
echo "# tools/fuzz.sh --seconds $SECONDS_PER --jobs $JOBS ${SELECTED[*]} ($(date -u +%Y-%m-%dT%H:%MZ), $(nproc) cores)"
printf '%-20s %7s %12s %8s %6s %7s %14s  %s\n' harness seconds executions exec/s cov ft corpus findings
for h in "${SELECTED[@]}"; do
    logf="$BUILD/work/$h/log"
    execs=$(awk '/^stat::number_of_executed_units:/ {print $NF}' "$logf" | tail -1)
    rate=$(awk '/^stat::average_exec_per_sec:/ {print $NF}' "$logf" | tail -1)
    # last status line: "#123 DONE cov: 559 ft: 2842 corp: 569/5688b ..."
    read -r cov ft corp < <(awk '/ cov: [0-9]+ ft: [0-9]+ corp: / {
            for (i = 1; i < NF; i++) { if ($i == "cov:") c = $(i + 1); if ($i == "ft:") f = $(i + 1); if ($i == "corp:") p = $(i + 1) }
        } END { print (c == "" ? "-" : c), (f == "" ? "-" : f), (p == "" ? "-" : p) }' "$logf")
    n=$(find "$BUILD/findings/$h" -type f | wc -l)
    if [ -z "$execs" ] && [ "$n" -eq 0 ]; then
        n=1 # the harness did not even report: count it as a finding
        echo "crashed before reporting; see $logf" >"$BUILD/findings/$h/no-report"
    fi
    FINDINGS=$((FINDINGS + n))
    # by kind: libFuzzer names its artifacts crash-*, leak-*, timeout-*, oom-*, slow-unit-*
    kinds=$(find "$BUILD/findings/$h" -type f -printf '%f\n' | sed -E 's/-[0-9a-f]+$//' | sort | uniq -c \
        | awk '{ printf "%s%s %s", (NR > 1 ? ", " : ""), $2, $1 }')
    printf '%-20s %7s %12s %8s %6s %7s %14s  %s\n' "$h" "$SECONDS_PER" "${execs:--}" "${rate:--}" "$cov" "$ft" "$corp" \
        "$n${kinds:+ ($kinds)}"
done
} >"$REPORT"
echo
cat "$REPORT"
echo

if [ "$FINDINGS" -gt 0 ]; then
    for h in "${SELECTED[@]}"; do
        for f in "$BUILD/findings/$h"/*; do
            [ -e "$f" ] || continue
            log "FINDING $h: $f"
            grep -m3 -E 'FUZZ INVARIANT|runtime error|ERROR: AddressSanitizer|ERROR: libFuzzer|SUMMARY' \
                "$BUILD/work/$h/log" | sed 's/^/    /' || true
            log "  reproduce: $BUILD/$h $f"
        done
    done
    log "$FINDINGS finding(s)"
    exit 1
fi
log "no findings"
