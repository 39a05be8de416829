# Helpers of the host tests on general mechanisms (sourced): scenario keys, the column names a
# mechanism asks for (built from its keys, not from the tools), pass/fail counting.
# The caller sets fails=0 passes=0.

check() { # name, condition status (0 ok), detail
    if [[ $2 == 0 ]]; then passes=$((passes + 1)); else echo "FAIL $1: $3"; fails=$((fails + 1)); fi
}
val() { sed -nE "s/^$2[[:space:]]*=[[:space:]]*\"?([^ #\"]+)\"?.*/\\1/p" "$1"; } # file, key
kind_prefix() { case $1 in position|0) echo y ;; velocity|1) echo yv ;; esac; }

# The header the scenario's mechanism asks for, built from its keys (not from the tools).
expected_truth_header() { # scenario
    local f=$1 ni ns nq nc i h=t
    ni=$(val "$f" inputs); ns=$(val "$f" sensors); nq=$(val "$f" bodies); nc=$(val "$f" contacts)
    if [[ $ni -eq 1 ]]; then h+=",u"; else for ((i = 1; i <= ni; i++)); do h+=",u$i"; done; fi
    for ((i = 1; i <= ns; i++)); do h+=",$(kind_prefix "$(val "$f" "sensor${i}_kind")")$(val "$f" "sensor${i}_body")"; done
    for ((i = 1; i <= nq; i++)); do h+=",q$i"; done
    for ((i = 1; i <= nq; i++)); do h+=",v$i"; done
    if [[ $nc -eq 1 ]]; then h+=",delta"; else for ((i = 1; i <= nc; i++)); do h+=",delta$i"; done; fi
    echo "$h"
}
expected_replay_header() { # scenario
    local f=$1 nq nc i h=t
    nq=$(val "$f" bodies); nc=$(val "$f" contacts)
    for ((i = 1; i <= nq; i++)); do h+=",q$i"; done
    for ((i = 1; i <= nq; i++)); do h+=",v$i"; done
    for ((i = 1; i <= nc; i++)); do h+=",gamma$([[ $i -gt 1 ]] && echo $i)"; done
    h+=",p_norm"
    for ((i = 1; i <= nc; i++)); do h+=",p_gg$([[ $i -gt 1 ]] && echo $i)"; done
    echo "$h,flags,newton_iters,nis"
}
col() { head -1 "$1" | tr ',' '\n' | grep -nx "$2" | cut -d: -f1; } # file, column name -> index

# Every contact's final gamma (replay output est) must be closer to its true value than ratio times
# the initial estimate's error; prints the final errors.
check_gamma_converges() { # scenario, est.csv, ratio
    local f=$1 est=$2 ratio=$3 nc c name g_true g0 g_end ok
    nc=$(val "$f" contacts)
    for ((c = 1; c <= nc; c++)); do
        name=gamma$([[ $c -gt 1 ]] && echo $c)
        g_true=$(val "$f" "contact${c}_gamma") g0=$(val "$f" "contact${c}_gamma0")
        g_end=$(awk -F, -v g="$(col "$est" "$name")" 'NR > 1 { x = $g } END { printf "%.17g", x }' "$est")
        ok=$(awk -v e="$g_end" -v t="$g_true" -v s="$g0" -v r="$ratio" \
            'BEGIN { a = e - t; b = s - t; if (a < 0) a = -a; if (b < 0) b = -b; print ((a <= r * b) ? 0 : 1) }')
        check "$(basename "$f" .toml)-$name-converges" "$ok" "final $name $g_end, true $g_true, initial $g0"
        echo "$(basename "$f" .toml): final $name $g_end (true $g_true, initial $g0): error $(awk -v e="$g_end" -v t="$g_true" 'BEGIN { printf "%+.4f %%", 100 * (e / t - 1) }')"
    done
}
