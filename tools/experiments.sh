#!/usr/bin/env bash
# The paper's four experiments through the C replay tool: truth, then canonical / switched /
# switched-highq / switched-highq-constrained, then a summary table. Usage:
#   tools/experiments.sh [BUILD_DIR] [OUT_DIR]      (defaults: build/host-double, out/experiments)
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/host-double}
out=${2:-$root/out/experiments}
scenario=$root/sim/scenarios/paper.toml
mkdir -p "$out"

for tool in caekf-truth caekf-replay; do
    [[ -x $build/host/$tool ]] || { echo "experiments: $build/host/$tool missing (build first)" >&2; exit 1; }
done

echo "== truth: $scenario"
"$build/host/caekf-truth" --scenario "$scenario" --out "$out/truth.csv" 2> "$out/truth.log"
tail -n 1 "$out/truth.log"

echo "== experiments (C estimator, caekf-replay; results in $out)"
printf '%-28s %-6s %7s %5s %10s %12s %12s %6s %4s %s\n' experiment scalar steps rej "gamma_err%" \
    min_gamma "max_||P||" it_avg it_max flags_seen
for e in canonical switched switched-highq switched-highq-constrained; do
    "$build/host/caekf-replay" --scenario "$scenario" --in "$out/truth.csv" --out "$out/$e.csv" \
        --experiment "$e" --summary 2>&1 >/dev/null
done | tee "$out/summary.txt"
