#!/usr/bin/env bash
# The paper's four experiments over CAN (hardware-in-the-loop on a virtual bus): the firmware app
# (caekf-host) estimates, the Python bench (caekf-sim hil run) drives it with the truth and reads
# the estimates back from the bus.
#
#   tools/hil-main.sh [OUT_DIR]            (default out/hil)
#
# 1. builds the host-double preset and the truth (caekf-truth -> OUT_DIR/truth.csv; tools/lib/hil-common.sh);
# 2. in ONE vcan0 session (tools/with-vcan.sh: native vcan0 if this kernel has it, else user-mode Linux),
#    `caekf-sim hil run --start-host` starts caekf-host on vcan0, runs canonical, switched, switched-highq and
#    switched-highq-constrained back to back over the full 60 s scenario in lockstep, saves the decoded
#    estimates (OUT_DIR/runs.npz) and stops caekf-host;
# 3. `caekf-sim hil report`: the CSVs, the comparison of every estimate with caekf-replay on the inputs the
#    estimator decoded, Figs 3-6, the summary.
# Writes OUT_DIR/{<experiment>.csv, summary.txt, fig3..fig6 PNGs, caekf-host.log, inputs-seen.csv,
# replay-<experiment>.csv}.
#
# Environment: HIL_WINDOW (lockstep steps in flight, default 32), HIL_DURATION (seconds, default all),
# HIL_LOG=1 (also write OUT_DIR/bus.log, candump -L; ~3.6 M lines for the full run),
# HIL_EXPERIMENTS (space-separated subset), HIL_PROFILE (diagnostics, production or fd; default diagnostics).
# Exit status: 0, or non-zero when a step timed out, the CAN estimates differ from caekf-replay, or the bus
# could not be had.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib/hil-common.sh"
t0=$SECONDS
hil_prepare hil-main "${1:-$root/out/hil}"
rm -f "$out"/fig*.png "$out/runs.npz"
profile=${HIL_PROFILE:-diagnostics}
extra=()
[ -n "${HIL_DURATION:-}" ] && extra+=(--duration "$HIL_DURATION")
[ "${HIL_LOG:-0}" = 1 ] && extra+=(--log "$out/bus.log")
# shellcheck disable=SC2206
[ -n "${HIL_EXPERIMENTS:-}" ] && extra+=(--experiments ${HIL_EXPERIMENTS})
echo "== HIL run on vcan0 (tools/with-vcan.sh: native vcan0 or user-mode Linux), profile $profile"
rc=0
# a partial step can only come from the guest stalling inside the bench's burst of a step's frames: caekf-host
# waits a second for the rest instead of the real-time default of 20 ms
"$root/tools/with-vcan.sh" -- "$py" -m caekf_sim.cli hil run --iface vcan0 --profile "$profile" --scenario "$scenario" \
	--truth "$out/truth.csv" --outdir "$out" --start-host "$host_bin" --host-args='--step-timeout-ms 1000' \
	--mode lockstep --window "${HIL_WINDOW:-32}" --defer-outputs "${extra[@]}" || rc=$?
if [ -s "$out/runs.npz" ]; then
	echo "== results, comparison with caekf-replay, figures (caekf-sim hil report)"
	MPLBACKEND=Agg "$py" -m caekf_sim.cli hil report --profile "$profile" --scenario "$scenario" --outdir "$out" \
		--truth "$out/truth.csv" --compare-replay "$build/host/caekf-replay" || rc=$((rc | $?))
fi
echo "hil-main: exit status $rc after $((SECONDS - t0)) s"
exit "$rc"
