#!/usr/bin/env bash
# The HIL test suite (tests/hil, pytest), each pass in ONE vcan0 session: native vcan0 if this kernel has it,
# otherwise one user-mode Linux boot (tools/with-vcan.sh). Builds host-double and the truth here first.
#
#   tools/hil-tests.sh [PYTEST ARGS...]     e.g. tools/hil-tests.sh -k bad_traffic
#
# Three passes, one vcan0 session each: the whole suite in the diagnostics profile (test_hil_fd.py aside), then
# test_hil_experiments.py, test_hil_bad_traffic.py and the full fault matrix (all 11 classes) in the production
# profile (CAEKF_HIL_PROFILE=production; out/hil-tests/production/), then test_hil_bad_traffic.py, the full fault
# matrix and test_hil_fd.py in the CAN FD profile (out/hil-tests/fd/). HIL_PROFILES="diagnostics" runs only the first.
#
# Keeps logs and CSVs in out/hil-tests/ (the full runs' CSVs, summary and figures in out/hil-tests/full/).
# Exit status: pytest's (125 if no vcan0 could be had).
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/lib/hil-common.sh"
t0=$SECONDS
hil_prepare hil-tests "$root/out/hil-tests"
color=no
[ -t 1 ] && color=yes
rc=0
profiles=${HIL_PROFILES:-diagnostics production fd}
for profile in $profiles; do
	pout=$out/$profile
	hil=$root/tests/hil
	case $profile in
	diagnostics) pout=$out tests=("$hil" --ignore="$hil/test_hil_fd.py") ;;
	production) tests=("$hil/test_hil_experiments.py" "$hil/test_hil_bad_traffic.py" "$hil/test_hil_fault_matrix.py") ;;
	fd) tests=("$hil/test_hil_bad_traffic.py" "$hil/test_hil_fault_matrix.py" "$hil/test_hil_fd.py") ;;
	*) echo "hil-tests: unknown profile $profile (diagnostics, production, fd)" >&2; exit 2 ;;
	esac
	mkdir -p "$pout"
	prc=0
	CAEKF_HIL_PROFILE=$profile CAEKF_HIL_TRUTH=$out/truth.csv CAEKF_HIL_OUT=$pout CAEKF_BUILD_DIR=$build \
		MPLBACKEND=Agg "$root/tools/with-vcan.sh" -- "$py" -m pytest "${tests[@]}" -p no:cacheprovider -rA \
		--color="$color" "$@" || prc=$?
	if [ "$profile" != diagnostics ] && [ "$prc" = 5 ]; then
		prc=0 # the arguments selected no test of this pass
	fi
	[ "$prc" = 0 ] || rc=$prc
	echo "hil-tests: profile $profile: pytest exit status $prc"
	if [ -s "$pout/full/runs.npz" ]; then # CSVs, summary.txt and figures of the full runs, here (fast)
		MPLBACKEND=Agg "$py" -m caekf_sim.cli hil report --profile "$profile" --outdir "$pout/full" \
			--truth "$out/truth.csv" >/dev/null || echo "hil-tests: (hil report of $pout/full failed)"
	fi
done
echo "hil-tests: exit status $rc after $((SECONDS - t0)) s"
exit "$rc"
