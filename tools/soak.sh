#!/usr/bin/env bash
# tools/soak.sh [--steps N] [--scalar double|float|both] [--quiet]
#
# Builds the soak program (tests/soak/soak.c) in the host-double and/or host-float preset and runs the
# reference scenario looped to N steps (default 10^7, i.e. 166 laps of the 60 s truth and a partial one)
# with the switched-highq-constrained experiment, checking P (finite, symmetric, PSD), gamma >= gamma_min
# and Newton's iteration count after every step. Prints one line per 60 s lap (unless --quiet) and the
# summary table of each scalar type; exits non-zero if any check failed. CI runs the short version as
# the ctest soak_short (300,000 steps) in every host preset.
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"
STEPS=10000000
SCALAR=both
QUIET=()
while [ "$#" -gt 0 ]; do
    case "$1" in
        --steps) STEPS="${2:?--steps needs a value}"; shift 2 ;;
        --scalar) SCALAR="${2:?--scalar needs a value}"; shift 2 ;;
        --quiet) QUIET=(--quiet); shift ;;
        -h|--help) sed -n '2,10p' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "soak.sh: unknown argument $1" >&2; exit 2 ;;
    esac
done
case "$SCALAR" in
    double) PRESETS=(host-double) ;;
    float) PRESETS=(host-float) ;;
    both) PRESETS=(host-double host-float) ;;
    *) echo "soak.sh: --scalar takes double, float or both" >&2; exit 2 ;;
esac

status=0
SUMMARIES=()
for preset in "${PRESETS[@]}"; do
    echo "[soak] build $preset"
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset" --target caekf-soak caekf_testdata >/dev/null
    log="$REPO/build/$preset/soak.log"
    if "$REPO/build/$preset/tests/soak/caekf-soak" --steps "$STEPS" "${QUIET[@]}" | tee "$log"; then
        :
    else
        status=1
    fi
    SUMMARIES+=("$log")
    echo
done
if [ "${#PRESETS[@]}" -gt 1 ]; then
    echo "[soak] summaries"
    for log in "${SUMMARIES[@]}"; do
        sed -n '/^soak summary/,$p' "$log"
        echo
    done
fi
exit "$status"
