#!/usr/bin/env bash
# The example mechanisms (sim/scenarios: valve, shuttle) through the C host tools: caekf-truth writes
# the columns the scenario's mechanism asks for, caekf-replay reads them back and every contact's gamma
# ends within a tenth of its initial error.
# usage: test_examples.sh TRUTH REPLAY SCENARIO...
set -u
truth=$1 replay=$2
shift 2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 passes=0
. "$(dirname "$0")/mechanism_lib.sh"

for scenario in "$@"; do
    name=$(basename "$scenario" .toml)
    "$truth" --scenario "$scenario" --out "$tmp/$name.csv" --quiet; rc=$?
    check "$name-truth-runs" "$rc" "exit $rc"
    want=$(expected_truth_header "$scenario")
    check "$name-truth-header" "$([[ $(head -1 "$tmp/$name.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/$name.csv")', want '$want'"
    "$replay" --scenario "$scenario" --in "$tmp/$name.csv" --out "$tmp/$name-est.csv"; rc=$?
    check "$name-replay-runs" "$rc" "exit $rc"
    want=$(expected_replay_header "$scenario")
    check "$name-replay-header" "$([[ $(head -1 "$tmp/$name-est.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/$name-est.csv")', want '$want'"
    check_gamma_converges "$scenario" "$tmp/$name-est.csv" 0.1
done
echo "examples: $passes passed, $fails failed"
[[ $fails -eq 0 && $passes -gt 0 ]]
