#!/usr/bin/env bash
# tools/run-tests.sh [--list] [STAGE...]
#
# The project's test command (CI runs exactly this through .ci/run).
#   1. tools/bootstrap.sh (idempotent; installs toolchains, Unity, the Python venv)
#   2. the stages in STAGES (all of them, or the ones named on the command line), STAGE_JOBS (default 2) side
#      by side: a stage starts as soon as a slot is free, in the order of STAGES, except that a stage of AFTER
#      waits for the stages it names to end (it uses their builds). STAGES lists the long stages first.
# Every stage runs even if an earlier one failed; the script exits non-zero if any failed.
# Each stage's output goes to build/logs/<stage>.log and is shown whole when the stage ends (stages that run
# side by side do not interleave). The last line is
#   run-tests: <N> passed, <M> failed
# where N and M count the tests that ctest and pytest reported, and M also counts each
# failed stage in which no test failed (a configure or build error, say).
#
# The CMake stages are workflow presets of CMakePresets.json (configure, build, test: the test presets say which
# tests, e.g. the MCU presets leave out the label icount); every preset the project ships is one stage.
#
# Adding a stage: write a function stage_<name> (dashes in <name> become underscores),
# add <name> to STAGES (and to AFTER if it needs another stage's build), and add any bootstrap flag it needs to
# BOOTSTRAP_FLAGS. A stage returns 0 (passed), 77 (skipped: nothing to run) or anything else (failed). Stages
# run in a subshell with `set -e`, from the repository root, with no standard input.
#
# Environment: CAEKF_SKIP_BOOTSTRAP=1 skips step 1. STAGE_JOBS (default 2): stages at a time (1: one after the
# other). JOBS (default 2) is passed to the fuzz harnesses, cppcheck and gcovr; the build presets build with 2
# jobs; pytest runs sim/tests in PYTEST_WORKERS (default 2) processes (pytest-xdist).
set -uo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
cd "$REPO"

BOOTSTRAP_FLAGS=(--arm --hil)
STAGES=(host-double host-float pytest hil fuzz host-asan cortex-m7 cortex-m4f cortex-m4f-default cortex-m4f-joint
        cortex-m4f-mech12 cortex-m4f-chain8 cortex-m4f-chain8-default coverage lint misra)
# stage -> the stages whose builds it uses (build/host-double: pytest runs its C tools and build/host-float's, the
# HIL suite its caekf-host, lint and misra its compile database); it starts when those have ended.
declare -A AFTER=([pytest]="host-double host-float" [hil]=host-double [lint]=host-double [misra]=host-double
                  [cortex-m4f]=host-double [cortex-m7]=host-double [cortex-m4f-default]=host-double
                  [cortex-m4f-joint]=host-double [cortex-m4f-mech12]=host-double)

JOBS="${JOBS:-2}"
STAGE_JOBS="${STAGE_JOBS:-2}"
VENV_PY="$REPO/.venv/bin/python"
export MPLBACKEND="${MPLBACKEND:-Agg}"
export PIP_DISABLE_PIP_VERSION_CHECK=1

# ---- stages -------------------------------------------------------------------------------
# build/host-double configured and built (nothing to do after the host-double stage). The stages that use it run
# side by side and tools/lib/hil-common.sh does the same: one at a time, under a lock.
build_host_double() {
    mkdir -p "$REPO/build"
    flock "$REPO/build/.host-double.lock" sh -c 'cmake --preset host-double && cmake --build --preset host-double "$@"' \
        sh "$@"
}

# One workflow preset of CMakePresets.json: configure, build and its test preset.
run_workflow() { cmake --workflow --preset "$1"; }
stage_host_double() {
    flock "$REPO/build/.host-double.lock" cmake --workflow --preset host-double
}
stage_host_float()  { run_workflow host-float; }
stage_host_asan()   { run_workflow host-asan; }

# C static analysis: cppcheck over firmware/ and host/ (tools/lint-c.sh), with the flags of the host-double
# build (configured and built here if needed: the generated settings headers are included); the C layout
# (tools/format-c.py --check: clang-format with .clang-format over firmware/, host/, tests/; --apply fixes
# it); then ruff on sim/ and on the Python of tools/ and tests/, and mypy on sim/ (their configuration and
# pinned versions: sim/pyproject.toml). Zero
# findings, or an inline suppression that says why.
stage_lint() {
    build_host_double
    tools/lint-c.sh "$REPO/build/host-double"
    "$VENV_PY" tools/format-c.py --check
    ( cd sim && "$VENV_PY" -m ruff check src tests && "$VENV_PY" -m ruff check --config pyproject.toml ../tools ../tests &&
        "$VENV_PY" -m mypy )
}

# MCU targets: every Unity suite and the replay image under QEMU. The instructions-per-step goal is reported by
# tools/mcu-report.py, not asserted here: the MCU test presets leave out the label icount.
# Their test data (the truth record, the double reference results) and the host caekf-replay come from a host
# double build: by themselves, an MCU preset builds one inside its folder (cmake/HostTools.cmake); here those
# replaying the paper's truth (the paper's mechanism and truth: paper.toml, paper-joint.toml, paper-mech12.toml)
# take build/host-double's instead, the same build (the presets read CAEKF_HOST_BUILD_DIR from the environment).
run_mcu_paper() { CAEKF_HOST_BUILD_DIR="$REPO/build/host-double" run_workflow "$1"; }
stage_cortex_m4f() { run_mcu_paper cortex-m4f; }
stage_cortex_m7()  { run_mcu_paper cortex-m7; }
# The other builds the project ships (tools/mcu-report.py and docs/mcu.md give their figures), each sized for one
# mechanism and configuration: the recommended default's on the paper's mechanism, the whole contact law
# estimated (sim/scenarios/paper-joint.toml), the 12 mechanism parameters estimated (tests/target/paper-mech12.toml),
# an 8-body, 2-contact chain (tests/target/chain8.toml) in the paper's and in the default's configuration. Each
# replays its scenario's truth on the MCU against the host's caekf-replay (tests/target/Replay.cmake: the replay
# image, the default's constructed worst case, stack and no-heap checks) and runs the target images and the
# protocol suites; the paper's Unity suites need the paper's fixture and presets (tests/CMakeLists.txt).
stage_cortex_m4f_default()        { run_mcu_paper cortex-m4f-default; }
stage_cortex_m4f_joint()          { run_mcu_paper cortex-m4f-joint; }
stage_cortex_m4f_mech12()         { run_mcu_paper cortex-m4f-mech12; }
stage_cortex_m4f_chain8()         { run_workflow cortex-m4f-chain8; }
stage_cortex_m4f_chain8_default() { run_workflow cortex-m4f-chain8-default; }

# The Python package's tests (sim/tests). Skipped only when there is no such folder; a
# folder whose tests pytest cannot find (exit 5) fails.
stage_pytest() {
    if [ ! -d sim/tests ]; then
        echo "no sim/tests folder: nothing to run"
        return 77
    fi
    [ -x "$VENV_PY" ] || { echo "no .venv (bootstrap failed?)"; return 1; }
    # test_c_tools.py compares the numpy model with the C tools of this build. pytest-xdist spreads the test files
    # over PYTEST_WORKERS processes (a file's tests in one, so that a module's fixtures are made once; the session
    # fixtures are made once in each).
    CAEKF_BUILD_DIR="$REPO/build/host-double" "$VENV_PY" -m pytest -n "${PYTEST_WORKERS:-2}" --dist loadfile sim/tests
}

# libFuzzer harnesses (tests/fuzz: app frames, estimator settings and inputs), FUZZ_SECONDS (default
# 20) each from the committed seeds, in build/fuzz with clang. Any finding fails the stage.
stage_fuzz() { tools/fuzz.sh --seconds "${FUZZ_SECONDS:-20}" --jobs "$JOBS"; }

# The HIL suite (tests/hil): the firmware app on vcan0 driven over CAN by the Python bench, three passes of one
# vcan session each (native vcan0, else one user-mode Linux boot each). Never skipped: no vcan0 is a failure.
stage_hil() { tools/hil-tests.sh; }

# Line and branch coverage of firmware/ (tools/coverage.sh): the host-coverage preset (double, -O0 --coverage)
# runs its whole ctest (the Unity suites, the fuzz corpus replays, the host tools' tests) and gcovr (pinned in
# sim/pyproject.toml) prints the table per folder (core, protocol, app, port, the generated C). Fails on a
# build or test failure, or when core/, protocol/ or app/ (each has reached 95 % of its branches) falls below
# 95 %; the figures and the untaken branches: docs/coverage.md.
stage_coverage() { tools/coverage.sh; }

# MISRA C:2012 (tools/misra.sh): cppcheck's misra addon over firmware/ and the firmware C the build generates
# (host-double's compile database; only its code generators are run here). Fails on any mandatory violation
# and on any required one not covered by a deviation recorded in docs/misra.md; advisory ones are counted.
stage_misra() {
    build_host_double --target caekf_settings_generated caekf_protocol_generated
    tools/misra.sh "$REPO/build/host-double"
}

# ---- driver -------------------------------------------------------------------------------
log() { printf '[run-tests] %s\n' "$*"; }

# count_tests LOG -> "<passed> <failed>" from ctest's summary lines or, in a log without
# any (a pytest stage), pytest's. (A pytest run by ctest prints its summary inside ctest's
# output; ctest's own count already covers it.)
count_tests() {
    awk '
        # ctest: "95% tests passed, 1 tests failed out of 20" (CMake 4: "100% tests passed out of 20" when none failed)
        /% tests passed(, [0-9]+ tests? failed)? out of [0-9]+/ {
            f = 0
            for (i = 1; i <= NF; i++) if ($i == "out") { total = $(i + 2) }
            for (i = 1; i <= NF; i++) if ($(i + 1) ~ /^tests?$/ && $(i + 2) == "failed") { f = $i }
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
# The distribution's cmake older than 3.25: bootstrap linked a newer one here.
if [ -d "$REPO/.cache/cmake/bin" ]; then export PATH="$REPO/.cache/cmake/bin:$PATH"; fi

PASSED=0
FAILED=0
declare -A STATUS DT PASS FAIL T0 PID_STAGE
pending=("${SELECTED[@]}")
running=0

# A stage waits only for the stages of this run that have not ended.
ready() {
    local dep
    for dep in ${AFTER[$1]:-}; do
        case " ${SELECTED[*]} " in *" $dep "*) [ -n "${STATUS[$dep]:-}" ] || return 1 ;; esac
    done
}

start_stage() {
    local s="$1"
    log "==== stage $s: started"
    T0[$s]=$SECONDS
    set -m # its own process group: interrupted, the whole stage is stopped
    ( set -e; "stage_${s//-/_}" ) </dev/null >"$LOGDIR/$s.log" 2>&1 &
    set +m
    PID_STAGE[$!]=$s
    running=$((running + 1))
}

end_stage() {
    local s="$1" rc="$2" logf="$LOGDIR/$1.log" p f status
    DT[$s]=$((SECONDS - T0[$s]))
    read -r p f < <(count_tests "$logf")
    if [ "$rc" -eq 0 ]; then
        status="ok"
    elif [ "$rc" -eq 77 ]; then
        status="skipped"
    else
        status="FAILED (exit $rc)"
        [ "$f" -eq 0 ] && FAILED=$((FAILED + 1)) # a failed stage in which no test failed counts as one failure
    fi
    STATUS[$s]=$status PASS[$s]=$p FAIL[$s]=$f
    PASSED=$((PASSED + p))
    FAILED=$((FAILED + f))
    log "==== stage $s: output"
    cat "$logf"
    log "stage $s: $status (${DT[$s]} s)"
}

interrupted() {
    local pid
    for pid in "${!PID_STAGE[@]}"; do kill -TERM -- "-$pid" 2>/dev/null; done
    log "interrupted"
    exit 130
}
trap interrupted INT TERM

while [ "${#pending[@]}" -gt 0 ] || [ "$running" -gt 0 ]; do
    # Start what may start, in the order of STAGES.
    left=()
    for s in "${pending[@]}"; do
        if [ "$running" -lt "$STAGE_JOBS" ] && ready "$s"; then
            start_stage "$s"
        else
            left+=("$s")
        fi
    done
    pending=("${left[@]}")
    if [ "$running" -eq 0 ]; then # waiting for a stage that is not in this run cannot happen; be safe
        for s in "${pending[@]}"; do start_stage "$s"; done
        pending=()
    fi
    wait -n -p done_pid
    rc=$?
    s="${PID_STAGE[$done_pid]:-}"
    [ -n "$s" ] || continue
    unset "PID_STAGE[$done_pid]"
    running=$((running - 1))
    end_stage "$s" "$rc"
done

echo
log "==== summary (total $((SECONDS - T_ALL)) s; logs in build/logs/)"
for s in "${SELECTED[@]}"; do
    printf '  %-26s %-18s %5d s   %4d passed, %d failed\n' "$s" "${STATUS[$s]}" "${DT[$s]}" "${PASS[$s]}" "${FAIL[$s]}"
done
echo "run-tests: $PASSED passed, $FAILED failed"
[ "$FAILED" -eq 0 ]
