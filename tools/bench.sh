#!/usr/bin/env bash
# Steps per second of the C estimator on the reference scenario, per experiment, double and float.
# A table, not a test: numbers depend on the machine. Usage: tools/bench.sh [REPEATS]
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
repeats=${1:-5}
for preset in host-double host-float; do
    cmake --preset "$preset" >/dev/null
    cmake --build --preset "$preset" --target caekf-bench caekf-truth >/dev/null
done
truth=$root/build/host-double/bench-truth.csv
"$root/build/host-double/host/caekf-truth" --scenario "$root/sim/scenarios/paper.toml" --out "$truth" --quiet
echo "C estimator, one core of $(nproc) ($(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'))"
"$root/build/host-double/host/caekf-bench" "$root/sim/scenarios/paper.toml" "$truth" "$repeats"
"$root/build/host-float/host/caekf-bench" "$root/sim/scenarios/paper.toml" "$truth" "$repeats" | tail -n +2
