#!/usr/bin/env bash
# The HIL test suite (tests/hil, pytest) in ONE vcan0 session: native vcan0 if this kernel has it,
# otherwise one QEMU VM boot (tools/with-vcan.sh). Builds host-double and the truth here first.
#
#   tools/hil-tests.sh [PYTEST ARGS...]     e.g. tools/hil-tests.sh -k bad_traffic
#
# Two passes: the whole suite in the diagnostics profile (test_hil_fd.py runs the CAN FD profile there, with a
# caekf-host of its own), then test_hil_experiments.py, test_hil_bad_traffic.py and the full fault matrix (all 11
# classes) in the production profile (CAEKF_HIL_PROFILE=production; out/hil-tests/production/).
# HIL_PROFILES="diagnostics" runs only the first.
#
# Keeps logs and CSVs in out/hil-tests/ (the full runs' CSVs, summary and figures in out/hil-tests/full/).
# Exit status: pytest's (125 if no vcan0 could be had).
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd -P)
cd "$root"
out=$root/out/hil-tests
py=$root/.venv/bin/python
[ -x "$py" ] || { echo "hil-tests: no $py: run tools/bootstrap.sh" >&2; exit 1; }
t0=$SECONDS
cmake --preset host-double >/dev/null
cmake --build --preset host-double
mkdir -p "$out"
"$root/build/host-double/host/caekf-truth" --scenario "$root/sim/scenarios/paper.toml" --out "$out/truth.csv" --quiet
color=no
[ -t 1 ] && color=yes
rc=0
profiles=${HIL_PROFILES:-diagnostics production}
for profile in $profiles; do
	pout=$out
	tests=("$root/tests/hil")
	if [ "$profile" != diagnostics ]; then
		pout=$out/$profile
		tests=("$root/tests/hil/test_hil_experiments.py" "$root/tests/hil/test_hil_bad_traffic.py"
			"$root/tests/hil/test_hil_fault_matrix.py")
		mkdir -p "$pout"
	fi
	prc=0
	CAEKF_HIL_PROFILE=$profile CAEKF_HIL_TRUTH=$out/truth.csv CAEKF_HIL_OUT=$pout CAEKF_BUILD_DIR=$root/build/host-double \
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
