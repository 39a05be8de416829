#!/usr/bin/env bash
# The host tools on a mechanism other than the paper's (tests/host/data/chain3_ground.toml: 3 bodies, a
# contact to ground with a linear law, a position and a velocity sensor): caekf-truth's columns follow
# the scenario's inputs, sensors, bodies and contacts; the sensor columns are the right bodies' q or v;
# --inputs with the same sine as a time series gives the same motion; the backward-Euler truth agrees
# with the continuous one; caekf-replay reads the truth and moves gamma towards the true value; a
# mechanism without contacts and one with two inputs and two contacts get their columns.
# usage: test_general_mechanism.sh TRUTH REPLAY SCENARIO
set -u
truth=$1 replay=$2 scenario=$3
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 passes=0

. "$(dirname "$0")/mechanism_lib.sh"

# --- truth: columns, rows, sensors -------------------------------------------------------------
"$truth" --scenario "$scenario" --out "$tmp/truth.csv" --quiet; rc=$?
check truth-runs $rc "exit $rc"
want=$(expected_truth_header "$scenario")
check truth-header "$([[ $(head -1 "$tmp/truth.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/truth.csv")', want '$want'"
rows=$(($(wc -l < "$tmp/truth.csv") - 1))
want_rows=$(awk -v t="$(val "$scenario" t_end)" -v dt="$(val "$scenario" dt)" 'BEGIN { printf "%d", t / dt + 0.5 }')
check truth-rows "$([[ $rows -eq $want_rows ]]; echo $?)" "$rows rows, want $want_rows"
# every sensor column is its body's q (position) or v (velocity) within 6 noise standard deviations
ns=$(val "$scenario" sensors)
for ((i = 1; i <= ns; i++)); do
    kind=$(val "$scenario" "sensor${i}_kind") body=$(val "$scenario" "sensor${i}_body")
    if [[ $(kind_prefix "$kind") == y ]]; then src=q$body std=$(val "$scenario" noise_std); else src=v$body std=$(val "$scenario" noise_std_v); fi
    name=$(kind_prefix "$kind")$body
    worst=$(awk -F, -v a="$(col "$tmp/truth.csv" "$name")" -v b="$(col "$tmp/truth.csv" "$src")" \
        'NR > 1 { d = $a - $b; if (d < 0) d = -d; if (d > m) m = d } END { printf "%.6g", m }' "$tmp/truth.csv")
    ok=$(awk -v w="$worst" -v s="$std" 'BEGIN { print ((w <= 6 * s && w > 0) ? 0 : 1) }')
    check "truth-sensor-$name" "$ok" "max |$name - $src| = $worst, noise std $std"
done
# the contact closes at least once (else gamma cannot be estimated)
dmax=$(awk -F, -v a="$(col "$tmp/truth.csv" delta)" 'NR > 1 && $a > m { m = $a } END { printf "%.6g", m }' "$tmp/truth.csv")
check truth-contact "$(awk -v d="$dmax" 'BEGIN { print ((d > 0) ? 0 : 1) }')" "max delta $dmax"

# --- truth: the backward-Euler method and --inputs with the scenario's own sine agree with it -----
scale=$(awk -F, 'NR > 1 { a = $5 < 0 ? -$5 : $5; if (a > m) m = a } END { printf "%.6g", m }' "$tmp/truth.csv")
close_to_truth() { # name, csv, relative tolerance on the q1..v columns
    local d
    d=$(paste -d, "$tmp/truth.csv" "$2" | awk -F, -v n="$(head -1 "$tmp/truth.csv" | tr ',' '\n' | wc -l)" -v q="$(col "$tmp/truth.csv" q1)" \
        'NR > 1 { x = $q - $(n + q); if (x < 0) x = -x; if (x > m) m = x } END { printf "%.6g", m }')
    check "$1" "$(awk -v d="$d" -v s="$scale" -v r="$3" 'BEGIN { print ((d <= r * s) ? 0 : 1) }')" "max |q1 difference| $d, |q1| up to $scale"
}
"$truth" --scenario "$scenario" --method backward-euler --out "$tmp/be.csv" --quiet; rc=$?
check truth-be-runs $rc "exit $rc"
check truth-be-header "$([[ $(head -1 "$tmp/be.csv") == "$want" ]]; echo $?)" "header $(head -1 "$tmp/be.csv")"
close_to_truth truth-be-agrees "$tmp/be.csv" 1e-2
amp=$(val "$scenario" input1_amp) freq=$(val "$scenario" input1_freq) ph=$(val "$scenario" input1_phase)
awk -v a="$amp" -v f="$freq" -v p="$ph" -v T="$(val "$scenario" t_end)" 'BEGIN { print "t,u"; pi = atan2(0, -1);
    for (k = 0; k <= 20000; k++) { t = k * (T + 0.1) / 20000; printf "%.17g,%.17g\n", t, a * sin(2 * pi * f * t + p) } }' > "$tmp/u.csv"
"$truth" --scenario "$scenario" --inputs "$tmp/u.csv" --out "$tmp/series.csv" --quiet; rc=$?
check truth-inputs-runs $rc "exit $rc"
close_to_truth truth-inputs-agrees "$tmp/series.csv" 1e-3
# and a different series gives a different motion (the series is used)
awk 'BEGIN { print "t,u"; print "0,0"; print "100,0" }' > "$tmp/zero.csv"
"$truth" --scenario "$scenario" --inputs "$tmp/zero.csv" --out "$tmp/zero_out.csv" --quiet
moved=$(awk -F, -v q="$(col "$tmp/zero_out.csv" q1)" 'NR > 1 && $q != 0 { n++ } END { print n + 0 }' "$tmp/zero_out.csv")
check truth-inputs-zero "$([[ $moved -eq 0 ]]; echo $?)" "$moved rows with q1 != 0 under a zero input"

# --- replay: columns, and gamma moves towards the truth -----------------------------------------
"$replay" --scenario "$scenario" --in "$tmp/truth.csv" --out "$tmp/est.csv" --summary 2> "$tmp/summary"; rc=$?
check replay-runs $rc "exit $rc: $(cat "$tmp/summary")"
want=$(expected_replay_header "$scenario")
check replay-header "$([[ $(head -1 "$tmp/est.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/est.csv")', want '$want'"
check_gamma_converges "$scenario" "$tmp/est.csv" 0.1

# --- no contacts: no delta, gamma or p_gg columns -------------------------------------------------
grep -Ev '^contact1_' "$scenario" | sed -E 's/^contacts[[:space:]]*=.*/contacts = 0/' > "$tmp/free.toml"
"$truth" --scenario "$tmp/free.toml" --out "$tmp/free.csv" --quiet; rc=$?
check free-truth-runs $rc "exit $rc"
want=$(expected_truth_header "$tmp/free.toml")
check free-truth-header "$([[ $(head -1 "$tmp/free.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/free.csv")', want '$want'"
"$replay" --scenario "$tmp/free.toml" --in "$tmp/free.csv" --out "$tmp/free_est.csv"; rc=$?
check free-replay-runs $rc "exit $rc"
want=$(expected_replay_header "$tmp/free.toml")
check free-replay-header "$([[ $(head -1 "$tmp/free_est.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/free_est.csv")', want '$want'"

# --- two inputs and two contacts (body 2 against body 1's far side): u1,u2, delta1,delta2, gamma2 -
sed -E -e 's/^inputs[[:space:]]*=.*/inputs = 2/' -e 's/^contacts[[:space:]]*=.*/contacts = 2/' "$scenario" > "$tmp/two.toml"
cat >> "$tmp/two.toml" <<'TOML'
input2_body = 3
input2_amp = 0.5
input2_freq = 1.0
input2_phase = 0.0
contact2_a = 2
contact2_b = 1
contact2_gap = 5.0e-5
contact2_n = 1.5
contact2_lambda = 0.0
contact2_gamma = 1.0e8
contact2_gamma0 = 8.0e7
contact2_sigma_gamma0 = 2.0e7
contact2_sigma_q_gamma = 1.0e4
contact2_gamma_min = 1.0e6
TOML
"$truth" --scenario "$tmp/two.toml" --out "$tmp/two.csv" --quiet; rc=$?
check two-truth-runs $rc "exit $rc"
want=$(expected_truth_header "$tmp/two.toml")
check two-truth-header "$([[ $(head -1 "$tmp/two.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/two.csv")', want '$want'"
"$replay" --scenario "$tmp/two.toml" --in "$tmp/two.csv" --out "$tmp/two_est.csv" --summary 2> "$tmp/two_summary"; rc=$?
check two-replay-runs $rc "exit $rc: $(cat "$tmp/two_summary")"
want=$(expected_replay_header "$tmp/two.toml")
check two-replay-header "$([[ $(head -1 "$tmp/two_est.csv") == "$want" ]]; echo $?)" "header '$(head -1 "$tmp/two_est.csv")', want '$want'"
check two-replay-summary "$(grep -q ' gamma2 [+-][0-9]' "$tmp/two_summary"; echo $?)" "summary: $(cat "$tmp/two_summary")"

echo "general mechanism: $passes passed, $fails failed"
[[ $fails -eq 0 && $passes -gt 0 ]]
