#!/usr/bin/env bash
# The paper's four experiments over CAN (hardware-in-the-loop on a virtual bus): the firmware app
# (caekf-host) estimates, the Python bench (caekf-sim hil run) drives it with the truth and reads
# the estimates back from the bus.
#
#   tools/hil-main.sh [OUT_DIR]            (default out/hil)
#
# 1. builds the host-double preset and, on this machine, the truth (caekf-truth -> OUT_DIR/truth.csv);
# 2. in ONE run of tools/with-vcan.sh (native vcan0 if this kernel has it, else a QEMU VM):
#    starts caekf-host on vcan0, runs canonical, switched, switched-highq and
#    switched-highq-constrained back to back over the full 60 s scenario in strict lockstep,
#    saves the decoded estimates (OUT_DIR/runs.npz), stops caekf-host;
# 3. here (text and plotting are ~10x slower in the TCG VM): writes the CSVs, compares every
#    estimate with caekf-replay on the inputs the estimator decoded, draws Figs 3-6, prints the summary.
# Writes OUT_DIR/{<experiment>.csv, summary.txt, fig3..fig6 PNGs, caekf-host.log, inputs-seen.csv,
# replay-<experiment>.csv}.
#
# Environment: HIL_WINDOW (lockstep steps in flight, default 32), HIL_DURATION (seconds, default all),
# HIL_LOG=1 (also write OUT_DIR/bus.log, candump -L; ~3.6 M lines for the full run),
# HIL_EXPERIMENTS (space-separated subset). Exit status: 0, or non-zero when a step timed out, the CAN
# estimates differ from caekf-replay, or the bus could not be had.
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$root"
build=$root/build/host-double
scenario=$root/sim/scenarios/paper.toml
py=$root/.venv/bin/python

if [ "${1:-}" = "--inside" ]; then # internal: the part that needs vcan0 (runs in the VM)
	out=$2
	# a partial step can only come from the (emulated) machine stalling inside the bench's burst of a
	# step's three frames: wait a second for the rest instead of the real-time default of 20 ms
	"$build/host/caekf_host/caekf-host" --iface vcan0 --status-period-ms 0 --step-timeout-ms 1000 \
		>"$out/caekf-host.log" 2>&1 &
	host=$!
	trap 'kill -TERM $host 2>/dev/null || true' EXIT
	extra=()
	[ -n "${HIL_DURATION:-}" ] && extra+=(--duration "$HIL_DURATION")
	[ "${HIL_LOG:-0}" = 1 ] && extra+=(--log "$out/bus.log")
	# shellcheck disable=SC2206
	[ -n "${HIL_EXPERIMENTS:-}" ] && extra+=(--experiments ${HIL_EXPERIMENTS})
	rc=0
	# only the bus work here: CSVs, the replay comparison and figures are text/float heavy and ~10x
	# slower in the TCG VM, so `hil report` does them afterwards on this machine
	"$py" -m caekf_sim.cli hil run --iface vcan0 --scenario "$scenario" --truth "$out/truth.csv" \
		--outdir "$out" --mode lockstep --window "${HIL_WINDOW:-32}" --defer-outputs "${extra[@]}" || rc=$?
	kill -TERM "$host" 2>/dev/null || true
	wait "$host" || true
	trap - EXIT
	echo "== caekf-host (stopped):"
	sed -n '/counters/,$p' "$out/caekf-host.log" | grep -v ' 0$' || true
	exit "$rc"
fi

out=$(mkdir -p "${1:-$root/out/hil}" && cd "${1:-$root/out/hil}" && pwd -P)
case "$out/" in "$root"/*) ;; *) echo "hil-main: OUT_DIR must be inside the repository (shared with the VM)" >&2; exit 2 ;; esac
t0=$SECONDS
[ -x "$py" ] || { echo "hil-main: no $py: run tools/bootstrap.sh (or python3 -m venv .venv && .venv/bin/pip install -e 'sim[dev]')" >&2; exit 1; }
echo "== build (host-double)"
cmake --preset host-double >/dev/null
cmake --build --preset host-double
echo "== truth -> $out/truth.csv"
"$build/host/caekf-truth" --scenario "$scenario" --out "$out/truth.csv" --quiet
rm -f "$out"/fig*.png
echo "== HIL run on vcan0 (tools/with-vcan.sh: native vcan0 or a QEMU VM)"
rm -f "$out/runs.npz"
rc=0
"$root/tools/with-vcan.sh" -- "$root/tools/hil-main.sh" --inside "$out" || rc=$?
if [ -s "$out/runs.npz" ]; then
	echo "== results, comparison with caekf-replay, figures (caekf-sim hil report)"
	MPLBACKEND=Agg "$py" -m caekf_sim.cli hil report --scenario "$scenario" --outdir "$out" --truth "$out/truth.csv" \
		--compare-replay "$build/host/caekf-replay" || rc=$((rc | $?))
fi
echo "hil-main: exit status $rc after $((SECONDS - t0)) s"
exit "$rc"
