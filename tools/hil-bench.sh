#!/usr/bin/env bash
# Steps per second on the reference scenario: the C estimator (caekf-bench), the numpy AEKF, FilterPy's
# EKF (measured here), and HIL lockstep over CAN (caekf-host on vcan0, measured in ONE vcan0 session:
# natively when this kernel has vcan, else in user-mode Linux).
# A table, not a test. Usage: tools/hil-bench.sh [HIL_STEPS]      (default 10000 per HIL run)
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib/hil-common.sh"
hil_prepare hil-bench "$root/out/bench"
echo "== on this machine ($(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'))"
"$py" -m caekf_sim.cli bench --truth "$out/truth.csv" --no-hil --save "$out/host.json"
echo "== HIL over vcan0 (tools/with-vcan.sh)"
"$root/tools/with-vcan.sh" -- "$py" -m caekf_sim.cli bench --truth "$out/truth.csv" --hil-only \
	--hil-steps "${1:-10000}" --save "$out/hil.json" --merge "$out/host.json"
