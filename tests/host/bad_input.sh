#!/usr/bin/env bash
# Runs the bad-input table (bad_input_cases.txt) against the C host tools. For every case: the exit
# code; exactly one line on stderr naming the problem (or, for exit 0, nothing on stderr and stdout's
# first line matching); and no file left behind: out/ stays empty and in/ holds only the inputs.
# usage: bad_input.sh CASES REPLAY BENCH REFERENCE SCENARIO TRUTH [GENERAL_SCENARIO]
# GENERAL_SCENARIO: a mechanism other than the paper's (cases whose scenario edit starts with "gen").
set -u
cases=$1 replay=$2 bench=$3 reference=$4 scenario=$5 truth=${6:-}
general=${7:-$(dirname "$0")/data/chain3_ground.toml}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 passes=0

good_csv() { awk 'BEGIN { print "t,u,y1,y4"; for (k = 1; k <= 20; k++) printf "%.17g,0.1,1e-6,0\n", k * 0.001 }'; }
# The general scenario's measurement columns (caekf-truth's header up to the sensors), 20 rows at its dt.
gen_csv() {
    local cols dt
    cols=$("$truth" --scenario "$general" --out - --quiet 2>/dev/null | head -1 | cut -d, -f1-4)
    dt=$(sed -nE 's/^dt[[:space:]]*=[[:space:]]*([^ #]+).*/\1/p' "$general")
    awk -v cols="$cols" -v dt="$dt" 'BEGIN { print cols; for (k = 1; k <= 20; k++) printf "%.17g,0.1,1e-6,0\n", k * dt }'
}

write_scenario() { # edit, dest
    case $1 in
        *\;*) local saved=$scenario
              write_scenario "${1%%;*}" "$2"; cp "$2" "$2.base"; scenario=$2.base
              write_scenario "${1#*;}" "$2"; rm -f "$2.base"; scenario=$saved; return ;;
        gen) cp "$general" "$2"; return ;;
        gen:*) local saved=$scenario; scenario=$general; write_scenario "${1#gen:}" "$2"; scenario=$saved; return ;;
    esac
    case $1 in
        -) cp "$scenario" "$2" ;;
        EMPTY) : > "$2" ;;
        -*) grep -Ev "^${1#-}[[:space:]]*=" "$scenario" > "$2" ;;
        *=*) local key=${1%%=*} value=${1#*=}
             if grep -Eq "^${key}[[:space:]]*=" "$scenario"; then
                 sed -E "s|^${key}[[:space:]]*=.*|${key} = ${value}|" "$scenario" > "$2"
             else
                 { cat "$scenario"; echo "${key} = ${value}"; } > "$2"
             fi ;;
    esac
}

write_csv() { # spec, dest
    case $1 in
        -) good_csv > "$2" ;;
        gen) gen_csv > "$2" ;;
        good+printf:*) { good_csv; printf '%b' "${1#good+printf:}"; } > "$2" ;;
        printf:*) printf '%b' "${1#printf:}" > "$2" ;;
        sh:*) bash -c "${1#sh:}" > "$2" ;;
    esac
}

trim() { local s=$1; s=${s#"${s%%[![:space:]]*}"}; printf '%s' "${s%"${s##*[![:space:]]}"}"; }

n=0
while IFS= read -r line; do
    [[ -z $line || $line == \#* ]] && continue
    IFS=$'\x1f' read -r name code re edit csv args <<< "${line//' | '/$'\x1f'}"
    name=$(trim "$name"); code=$(trim "$code"); re=$(trim "$re"); edit=$(trim "$edit"); csv=$(trim "$csv")
    args=$(trim "$args")
    n=$((n + 1))
    d="$tmp/$n-$name"
    mkdir -p "$d/in" "$d/out"
    write_scenario "$edit" "$d/in/sc.toml"
    write_csv "$csv" "$d/in/in.csv"
    read -r -a argv <<< "$args"
    case ${argv[0]} in
        replay) bin=$replay ;; bench) bin=$bench ;; reference) bin=$reference ;; truth) bin=$truth ;;
        *) echo "FAIL $name: unknown tool ${argv[0]}"; fails=$((fails + 1)); continue ;;
    esac
    argv=("${argv[@]:1}")
    for i in "${!argv[@]}"; do
        a=${argv[$i]}
        a=${a//@SC/$d/in/sc.toml}; a=${a//@IN/$d/in/in.csv}; a=${a//@OUT/$d/out/result}
        a=${a//@DIR/$d/in}; a=${a//@NONE/$d/nope.csv}
        argv[$i]=$a
    done
    "$bin" "${argv[@]}" > "$d/stdout" 2> "$d/stderr" < /dev/null
    rc=$?
    why=""
    lines=$(wc -l < "$d/stderr")
    if [[ $rc -ne $code ]]; then
        why="exit $rc, want $code"
    elif [[ $code -ne 0 ]]; then
        if [[ $lines -ne 1 || $(wc -c < "$d/stderr") -ne $(($(head -1 "$d/stderr" | wc -c))) ]]; then
            why="want exactly one line on stderr, got $lines"
        elif ! grep -Eq -- "$re" "$d/stderr"; then
            why="stderr does not match /$re/"
        elif [[ ${argv[0]:-} != --* && $(basename "$bin") != caekf-bench && -s $d/stdout ]]; then
            why="output on stdout"
        elif [[ -n $(ls -A "$d/out") ]]; then
            why="left in out/: $(ls -A "$d/out" | tr '\n' ' ')"
        fi
    else
        first=$(head -1 "$d/stdout")
        if [[ -s $d/stderr ]]; then
            why="stderr not empty"
        elif ! [[ $first =~ $re ]]; then
            why="stdout's first line '$first' does not match /$re/"
        elif [[ $args == *@OUT* && $(ls -A "$d/out") != result ]]; then
            why="out/ holds '$(ls -A "$d/out" | tr '\n' ' ')', want exactly 'result'"
        fi
    fi
    if [[ -z $why && $(ls -A "$d/in" | tr '\n' ' ') != "in.csv sc.toml " ]]; then
        why="left in in/: $(ls -A "$d/in" | tr '\n' ' ')"
    fi
    if [[ -z $why ]]; then
        passes=$((passes + 1))
    else
        echo "FAIL $name: $why; stderr: $(head -c 400 "$d/stderr")"
        fails=$((fails + 1))
    fi
    rm -rf "$d"
done < "$cases"
echo "bad-input table: $n cases, $passes passed, $fails failed"
[[ $fails -eq 0 && $n -gt 0 ]]
