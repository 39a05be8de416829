#!/usr/bin/env bash
# Real time at the scenario's dt (1 kHz) over CAN, and the echo probe that shows what the machine and the
# bus cost without the estimator. One vcan0 session (tools/with-vcan.sh: native vcan0 or user-mode Linux) of
# `caekf-sim hil run --realtime --start-host --then-echo-probe`:
#   1. caekf-host (the firmware app) + the bench paced at dt (switched, HIL_RT_SECONDS, default 60 s): each step
#      sent at its absolute deadline; per 60 s: deadline misses, latency from the step's last input frame to the
#      frame that closes it (kernel timestamps of the bus), bus load seen; candump log kept (bus.log);
#   2. caekf-host --echo and the same pacing and measurement with the estimator replaced by an echo of the
#      step's last input frame (bus-echo.log).
# Then the bus load of the recorded log (`caekf-sim busload --log`). Output: OUT_DIR (default out/realtime):
# realtime.txt, realtime-echo.txt, busload.txt. A report, not a test: exit status 0 unless something could not run.
# HIL_PROFILE=production|fd (default diagnostics): caekf-host, the bench and the echo probe in that profile.
#   tools/hil-realtime.sh [OUT_DIR]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib/hil-common.sh"
hil_prepare hil-realtime "${1:-$root/out/realtime}"
profile=${HIL_PROFILE:-diagnostics}
rc=0
"$root/tools/with-vcan.sh" -- "$py" -m caekf_sim.cli hil run --iface vcan0 --profile "$profile" --scenario "$scenario" \
	--truth "$out/truth.csv" --outdir "$out" --start-host "$host_bin" --realtime --then-echo-probe \
	--experiments switched --duration "${HIL_RT_SECONDS:-60}" --defer-outputs --log "$out/bus.log" || rc=$?
[ "$rc" = 2 ] && rc=0 # steps unanswered in time: measured and reported, not an error
if [ -s "$out/bus.log" ]; then
	"$py" -m caekf_sim.cli busload --profile "$profile" --log "$profile=$out/bus.log" | tee "$out/busload.txt" || rc=$?
fi
echo "hil-realtime: exit status $rc; reports in $out (realtime.txt, realtime-echo.txt, busload.txt)"
exit "$rc"
