#!/usr/bin/env bash
# Steps per second on the reference scenario: the C estimator (caekf-bench), the numpy AEKF, FilterPy's
# EKF (measured here), and HIL lockstep over CAN (caekf-host on vcan0, measured in ONE vcan0 session:
# natively when this kernel has vcan, else in the QEMU VM; there it is TCG-emulated and says so).
# A table, not a test. Usage: tools/hil-bench.sh [HIL_STEPS]      (default 10000 per HIL run)
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$root"
out=$root/out/bench
py=$root/.venv/bin/python
[ -x "$py" ] || { echo "hil-bench: no $py: run tools/bootstrap.sh" >&2; exit 1; }
cmake --preset host-double >/dev/null
cmake --build --preset host-double >/dev/null
mkdir -p "$out"
"$root/build/host-double/host/caekf-truth" --scenario "$root/sim/scenarios/paper.toml" --out "$out/truth.csv" --quiet
echo "== on this machine ($(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'))"
"$py" -m caekf_sim.cli bench --truth "$out/truth.csv" --no-hil --save "$out/host.json"
echo "== HIL over vcan0 (tools/with-vcan.sh)"
"$root/tools/with-vcan.sh" -- "$py" -m caekf_sim.cli bench --truth "$out/truth.csv" --hil-only \
	--hil-steps "${1:-10000}" --save "$out/hil.json" --merge "$out/host.json"
