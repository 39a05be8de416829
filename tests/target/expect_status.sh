#!/bin/sh
# expect_status.sh EXPECTED command... - runs the command, succeeds iff its exit status is EXPECTED.
# Used by tests/target to prove that tools/qemu-run.sh reports the guest's status (exit, fault,
# timeout).
expected="$1"
shift
status=0
"$@" || status=$?
if [ "$status" -ne "$expected" ]; then
    echo "expect_status.sh: exit status $status, expected $expected" >&2
    exit 1
fi
echo "expect_status.sh: exit status $status as expected"
