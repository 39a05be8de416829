#!/usr/bin/env bash
# tools/run-tests.sh [--list] [STAGE...]
#
# The project's test command (CI runs exactly this through .ci/run).
#   1. tools/bootstrap.sh (idempotent; installs toolchains, Unity, the Python venv)
#   2. the stages in STAGES, in order (all of them, or the ones named on the command line)
# Every stage runs even if an earlier one failed; the script exits non-zero if any failed.
# Each stage's output is shown and also kept in build/logs/<stage>.log. The last line is
#   run-tests: <N> passed, <M> failed
# where N and M count the tests that ctest and pytest reported, and M also counts each
# failed stage in which no test failed (a configure or build error, say).
#
# Adding a stage: write a function stage_<name> (dashes in <name> become underscores),
# append <name> to STAGES, and add any bootstrap flag it needs to BOOTSTRAP_FLAGS. A stage
# returns 0 (passed), 77 (skipped: nothing to run) or anything else (failed). Stages run
# in a subshell with `set -e`, from the repository root.
#
# Environment: CAEKF_SKIP_BOOTSTRAP=1 skips step 1. JOBS (default 2) is passed to builds.
set -uo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"

BOOTSTRAP_FLAGS=(--arm --hil)
STAGES=(host-double host-float host-asan lint pytest cortex-m4f cortex-m7 fuzz hil coverage misra)

JOBS="${JOBS:-2}"
VENV_PY="$REPO/.venv/bin/python"
export MPLBACKEND="${MPLBACKEND:-Agg}"
export PIP_DISABLE_PIP_VERSION_CHECK=1

# ---- stages -------------------------------------------------------------------------------
# cmake configure + build + ctest for one preset of CMakePresets.json.
run_preset() {
    local preset="$1"
    cmake --preset "$preset"
    cmake --build --preset "$preset" --parallel "$JOBS"
    ctest --preset "$preset"
}
stage_host_double() { run_preset host-double; }
stage_host_float()  { run_preset host-float; }
stage_host_asan()   { run_preset host-asan; }

# C static analysis: cppcheck over firmware/ and host/ (tools/lint-c.sh), with the flags of the host-double
# build (configured and built here if needed: the generated settings headers are included); the C layout
# (tools/format-c.py --check: clang-format with .clang-format over firmware/, host/, tests/; --apply fixes
# it); then ruff on sim/ and on the Python of tools/ and tests/, and mypy on sim/ (their configuration and
# pinned versions: sim/pyproject.toml). Zero
# findings, or an inline suppression that says why.
stage_lint() {
    cmake --preset host-double
    cmake --build --preset host-double --parallel "$JOBS"
    tools/lint-c.sh "$REPO/build/host-double"
    "$VENV_PY" tools/format-c.py --check
    ( cd sim && "$VENV_PY" -m ruff check src tests && "$VENV_PY" -m ruff check --config pyproject.toml ../tools ../tests &&
        "$VENV_PY" -m mypy )
}

# MCU targets: every Unity suite and the replay image under QEMU (the presets build the host tools that make
# their test data themselves: cmake/HostTools.cmake).
# The instructions-per-step goal is reported by tools/mcu-report.py, not asserted here (label icount).
run_target() {
    local preset="$1"
    cmake --preset "$preset"
    cmake --build --preset "$preset" --parallel "$JOBS"
    ctest --preset "$preset" -LE icount
}
stage_cortex_m4f() { run_target cortex-m4f; }
stage_cortex_m7()  { run_target cortex-m7; }

# The Python package's tests (sim/tests). Skipped only when there is no such folder; a
# folder whose tests pytest cannot find (exit 5) fails.
stage_pytest() {
    if [ ! -d sim/tests ]; then
        echo "no sim/tests folder: nothing to run"
        return 77
    fi
    [ -x "$VENV_PY" ] || { echo "no .venv (bootstrap failed?)"; return 1; }
    # test_c_tools.py compares the numpy model with the C tools of this build.
    CAEKF_BUILD_DIR="$REPO/build/host-double" "$VENV_PY" -m pytest sim/tests
}

# libFuzzer harnesses (tests/fuzz: app frames, estimator settings and inputs), FUZZ_SECONDS (default
# 20) each from the committed seeds, in build/fuzz with clang. Any finding fails the stage.
stage_fuzz() { tools/fuzz.sh --seconds "${FUZZ_SECONDS:-20}" --jobs "$JOBS"; }

# The HIL suite (tests/hil): the firmware app on vcan0 driven over CAN by the Python bench, in one
# vcan session (native vcan0, else one user-mode Linux boot). Never skipped: no vcan0 is a failure.
stage_hil() { tools/hil-tests.sh; }

# Line and branch coverage of firmware/ (tools/coverage.sh): the host-coverage preset (double, -O0 --coverage)
# runs its whole ctest (the Unity suites, the fuzz corpus replays, the host tools' tests) and gcovr (pinned in
# sim/pyproject.toml) prints the table per folder (core, protocol, app, port, the generated C). Fails on a
# build or test failure, or when protocol/ (which has reached 95 % of its branches) falls below 95 %; the
# figures and the untaken branches: docs/coverage.md.
stage_coverage() { tools/coverage.sh; }

# MISRA C:2012 (tools/misra.sh): cppcheck's misra addon over firmware/ and the firmware C the build generates
# (host-double's compile database; only its code generators are run here). Fails on any mandatory violation
# and on any required one not covered by a deviation recorded in docs/misra.md; advisory ones are counted.
stage_misra() {
    cmake --preset host-double
    cmake --build --preset host-double --parallel "$JOBS" --target caekf_settings_generated caekf_protocol_generated
    tools/misra.sh "$REPO/build/host-double"
}

# ---- driver -------------------------------------------------------------------------------
log() { printf '[run-tests] %s\n' "$*"; }

# count_tests LOG -> "<passed> <failed>" from ctest's summary lines or, in a log without
# any (a pytest stage), pytest's. (A pytest run by ctest prints its summary inside ctest's
# output; ctest's own count already covers it.)
count_tests() {
    awk '
        # ctest: "95% tests passed, 1 tests failed out of 20"
        /% tests passed, [0-9]+ tests? failed out of [0-9]+/ {
            for (i = 1; i <= NF; i++) if ($i == "out") { total = $(i + 2) }
            for (i = 1; i <= NF; i++) if ($(i + 1) == "tests" && $(i + 2) == "failed") { f = $i }
            CP += total - f; CF += f; C = 1; next
        }
        # pytest: "==== 12 passed, 1 failed, 2 skipped in 3.1s ====" (or without the =)
        / in [0-9.]+s/ && ($1 ~ /^=+$/ || $1 ~ /^[0-9]+$/) {
            for (i = 1; i < NF; i++) {
                w = $(i + 1); sub(/,$/, "", w)
                if ($i !~ /^[0-9]+$/) continue
                if (w == "passed") PP += $i
                else if (w == "failed" || w == "error" || w == "errors") PF += $i
            }
        }
        END { if (C) printf "%d %d\n", CP, CF; else printf "%d %d\n", PP, PF }' "$1"
}

if [ "${1:-}" = "--list" ]; then
    printf '%s\n' "${STAGES[@]}"
    exit 0
fi
SELECTED=("${STAGES[@]}")
if [ "$#" -gt 0 ]; then
    SELECTED=("$@")
    for s in "${SELECTED[@]}"; do
        declare -F "stage_${s//-/_}" >/dev/null || { log "unknown stage '$s' (have: ${STAGES[*]})"; exit 2; }
    done
fi

LOGDIR="$REPO/build/logs"
mkdir -p "$LOGDIR"
T_ALL=$SECONDS

if [ "${CAEKF_SKIP_BOOTSTRAP:-0}" != 1 ]; then
    log "==== bootstrap"
    t0=$SECONDS
    if ! tools/bootstrap.sh "${BOOTSTRAP_FLAGS[@]}"; then
        log "bootstrap FAILED after $((SECONDS - t0)) s; nothing else can run"
        echo "run-tests: 0 passed, 1 failed"
        exit 1
    fi
    log "bootstrap ok ($((SECONDS - t0)) s)"
fi

PASSED=0
FAILED=0
SUMMARY=()
for s in "${SELECTED[@]}"; do
    fn="stage_${s//-/_}"
    logf="$LOGDIR/$s.log"
    log "==== stage $s"
    t0=$SECONDS
    ( set -e; "$fn" ) 2>&1 | tee "$logf"
    rc=${PIPESTATUS[0]}
    dt=$((SECONDS - t0))
    read -r p f < <(count_tests "$logf")
    PASSED=$((PASSED + p))
    FAILED=$((FAILED + f))
    if [ "$rc" -eq 0 ]; then
        status="ok"
    elif [ "$rc" -eq 77 ]; then
        status="skipped"
    else
        status="FAILED (exit $rc)"
        [ "$f" -eq 0 ] && FAILED=$((FAILED + 1))
    fi
    SUMMARY+=("$(printf '%-14s %-18s %5d s   %4d passed, %d failed' "$s" "$status" "$dt" "$p" "$f")")
    log "stage $s: $status ($dt s)"
done

echo
log "==== summary (total $((SECONDS - T_ALL)) s; logs in build/logs/)"
printf '  %s\n' "${SUMMARY[@]}"
echo "run-tests: $PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
