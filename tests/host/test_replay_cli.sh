#!/usr/bin/env bash
# caekf-replay's input handling: malformed CSVs are reported with their line number and exit 3
# (the whole table of bad inputs is bad_input_cases.txt); a good CSV (with extra columns) replays; --allow-nonfinite hands NaN to the estimator,
# which rejects that step with the input_rejected flag (2).
set -u
replay=$1
scenario=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fails=0 passes=0

expect_error() { # name, expected exit, expected message regex, csv content
    local name=$1 code=$2 re=$3
    printf '%b' "$4" > "$tmp/in.csv"
    "$replay" --scenario "$scenario" --in "$tmp/in.csv" --out "$tmp/out.csv" 2> "$tmp/err"
    local rc=$?
    if [[ $rc -eq $code ]] && grep -Eq "$re" "$tmp/err"; then
        passes=$((passes + 1))
    else
        echo "FAIL $name: exit $rc (want $code), stderr: $(cat "$tmp/err")"
        fails=$((fails + 1))
    fi
}

expect_error bad-header 3 'in.csv:1: bad header' 't,u,y2,y4\n0.001,0,0,0\n'
expect_error empty 3 'empty input' ''
expect_error column-count 3 'in.csv:3: wrong column count' 't,u,y1,y4\n0.001,0,0,0\n0.002,0,0\n'
expect_error non-numeric 3 'in.csv:2: column 3' 't,u,y1,y4\n0.001,0,abc,0\n'
expect_error non-finite 3 'in.csv:3: column 2: non-finite' 't,u,y1,y4\n0.001,0,0,0\n0.002,nan,0,0\n'
expect_error trailing-junk 3 'in.csv:2: column 4' 't,u,y1,y4\n0.001,0,0,1e-3x\n'
"$replay" --scenario "$scenario" --in "$tmp/nope.csv" 2>/dev/null; [[ $? -eq 4 ]] && passes=$((passes + 1)) || { echo "FAIL missing-file exit"; fails=$((fails + 1)); }
"$replay" --scenario "$tmp/none.toml" --in /dev/null 2>/dev/null; [[ $? -eq 4 ]] && passes=$((passes + 1)) || { echo "FAIL bad scenario exit"; fails=$((fails + 1)); }
"$replay" --bogus 2>/dev/null; [[ $? -eq 2 ]] && passes=$((passes + 1)) || { echo "FAIL usage exit"; fails=$((fails + 1)); }

# Good input with extra columns, then NaN passed through to the estimator.
printf 't,u,y1,y4,extra\n0.001,0.1,1e-6,0,7\n0.002,nan,1e-6,0,7\n0.003,0.1,2e-6,0,7\n' > "$tmp/ok.csv"
if "$replay" --scenario "$scenario" --in "$tmp/ok.csv" --out "$tmp/out.csv" --allow-nonfinite 2>"$tmp/err"; then
    rows=$(($(wc -l < "$tmp/out.csv") - 1))
    flags2=$(sed -n 3p "$tmp/out.csv" | awk -F, '{print $13}')
    if [[ $rows -eq 3 && $(head -1 "$tmp/out.csv") == t,q1,q2,q3,q4,v1,v2,v3,v4,gamma,p_norm,p_gg,flags,newton_iters,nis && $flags2 -eq 2 ]]; then
        passes=$((passes + 1))
    else
        echo "FAIL good-input: rows=$rows flags(row2)=$flags2"; fails=$((fails + 1))
    fi
else
    echo "FAIL good-input exit: $(cat "$tmp/err")"; fails=$((fails + 1))
fi
# Rows without measurement (both y empty) are prediction-only steps with --missing-y-predict (flag 1024).
printf 't,u,y1,y4\n0.001,0.1,1e-6,0\n0.002,0.1,,\n0.003,0.1,2e-6,0\n' > "$tmp/gap.csv"
if "$replay" --scenario "$scenario" --in "$tmp/gap.csv" --out "$tmp/out.csv" --missing-y-predict 2>"$tmp/err"; then
    f2=$(sed -n 3p "$tmp/out.csv" | awk -F, '{print $13}')
    if (( (f2 & 1024) != 0 )); then passes=$((passes + 1)); else echo "FAIL missing-y flags=$f2"; fails=$((fails + 1)); fi
else
    echo "FAIL missing-y exit: $(cat "$tmp/err")"; fails=$((fails + 1))
fi
expect_error missing-without-flag 3 'in.csv:3: column 3' 't,u,y1,y4\n0.001,0.1,1e-6,0\n0.002,0.1,,\n'
printf 't,u,y1,y4\n0.001,0.1,,0\n' > "$tmp/half.csv"
"$replay" --scenario "$scenario" --in "$tmp/half.csv" --missing-y-predict >/dev/null 2>"$tmp/err"
if [[ $? -eq 3 ]] && grep -q "both be present" "$tmp/err"; then passes=$((passes + 1)); else echo "FAIL half-missing"; fails=$((fails + 1)); fi
# An output that is not a regular file (/dev/null, a FIFO) is written in place: renaming a temporary file
# over it would replace the device (found: --out /dev/null turned /dev/null into a regular file). Checked
# on a FIFO of our own, never on /dev/null.
mkfifo "$tmp/fifo"
timeout 20 cat "$tmp/fifo" > "$tmp/fifo.got" &
reader=$!
"$replay" --scenario "$scenario" --in "$tmp/ok.csv" --out "$tmp/fifo" --allow-nonfinite 2>"$tmp/err"
rc=$?
[[ -p $tmp/fifo ]] || { rm -f "$tmp/fifo"; mkfifo "$tmp/fifo"; kill "$reader" 2>/dev/null; }
wait "$reader"
if [[ $rc -eq 0 && -p $tmp/fifo && $(wc -l < "$tmp/fifo.got") -eq 4 ]]; then
    passes=$((passes + 1))
else
    echo "FAIL out-fifo: exit $rc, still a FIFO: $([[ -p $tmp/fifo ]] && echo yes || echo no), $(wc -l < "$tmp/fifo.got") lines read"
    fails=$((fails + 1))
fi
echo "$passes passed, $fails failed"
[[ $fails -eq 0 ]]
