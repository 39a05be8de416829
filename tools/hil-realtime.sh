#!/usr/bin/env bash
# Real time at the scenario's dt (1 kHz) over CAN, and the echo probe that shows what the machine and the
# bus cost without the estimator. One vcan0 session (tools/with-vcan.sh: native vcan0 or user-mode Linux):
#   1. caekf-host (the firmware app) + `caekf-sim hil run --realtime` (switched, HIL_RT_SECONDS, default 60 s):
#      the bench sends each step at its absolute deadline; per 60 s: deadline misses, latency from the step's
#      last input frame to its EST_STEP (kernel timestamps of the bus), bus load seen; candump log kept;
#   2. caekf-host --echo + `caekf-sim hil run --realtime --echo-probe`: the same pacing and measurement with
#      the estimator replaced by an echo of BENCH_Y4.
# Then the bus load of the recorded log (`caekf-sim busload --log`). Output: OUT_DIR (default out/realtime).
# A report, not a test: exit status 0 unless something could not run.
# HIL_PROFILE=production (default diagnostics): caekf-host, the bench and the echo probe in that profile.
#   tools/hil-realtime.sh [OUT_DIR]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$root"
build=$root/build/host-double
scenario=$root/sim/scenarios/paper.toml
py=$root/.venv/bin/python
secs=${HIL_RT_SECONDS:-60}
profile=${HIL_PROFILE:-diagnostics}

if [ "${1:-}" = "--inside" ]; then
	out=$2
	run_host() { # ARGS...: caekf-host in the background until stop_host
		"$build/host/caekf_host/caekf-host" --iface vcan0 --status-period-ms 0 --profile "$profile" "$@" >>"$out/caekf-host.log" 2>&1 &
		host=$!
		sleep 0.3
	}
	stop_host() { kill -TERM "$host" 2>/dev/null || true; wait "$host" || true; }
	trap 'kill -TERM $host 2>/dev/null || true' EXIT
	: >"$out/caekf-host.log"
	rc=0
	keep() { [ "$1" = 2 ] || rc=$1; } # 2 = steps unanswered in time: measured and reported, not an error
	run_host
	"$py" -m caekf_sim.cli hil run --iface vcan0 --profile "$profile" --scenario "$scenario" --truth "$out/truth.csv" --outdir "$out" \
		--realtime --experiments switched --duration "$secs" --defer-outputs --log "$out/bus.log" || keep $?
	stop_host
	run_host --echo
	"$py" -m caekf_sim.cli hil run --iface vcan0 --profile "$profile" --scenario "$scenario" --truth "$out/truth.csv" --outdir "$out" \
		--realtime --echo-probe --duration "$secs" --log "$out/bus-echo.log" || keep $?
	stop_host
	trap - EXIT
	exit "$rc"
fi

out=$(mkdir -p "${1:-$root/out/realtime}" && cd "${1:-$root/out/realtime}" && pwd -P)
[ -x "$py" ] || { echo "hil-realtime: no $py: run tools/bootstrap.sh --hil" >&2; exit 1; }
cmake --preset host-double >/dev/null
cmake --build --preset host-double >/dev/null
"$build/host/caekf-truth" --scenario "$scenario" --out "$out/truth.csv" --quiet
rc=0
"$root/tools/with-vcan.sh" -- "$root/tools/hil-realtime.sh" --inside "$out" || rc=$?
if [ -s "$out/bus.log" ]; then
	"$py" -m caekf_sim.cli busload --profile "$profile" --log "$profile=$out/bus.log" | tee "$out/busload.txt" || rc=$?
fi
echo "hil-realtime: exit status $rc; reports in $out (realtime.txt, realtime-echo.txt, busload.txt)"
exit "$rc"
