#!/usr/bin/env bash
# The HIL fault-injection matrix (tests/hil/test_hil_fault_matrix.py) in one vcan0 session (one user-mode Linux
# boot when this kernel has no CAN), then its table (out/hil-tests/fault-matrix.txt).
#
#   tools/fault-matrix.sh [PYTEST ARGS...]
#
# Exit status: pytest's (as tools/hil-tests.sh).
set -uo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
table=$root/out/hil-tests/fault-matrix.txt
rm -f "$table"
"$root/tools/hil-tests.sh" -k fault_matrix "$@"
rc=$?
if [ -s "$table" ]; then
	echo "=== fault matrix ($table) ==="
	cat "$table"
else
	echo "fault-matrix: no table written (see the pytest output above)" >&2
fi
exit "$rc"
