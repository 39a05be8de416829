#!/usr/bin/env bash
# The HIL test suite (tests/hil, pytest) in ONE vcan0 session: native vcan0 if this kernel has it,
# otherwise one QEMU VM boot (tools/with-vcan.sh). Builds host-double and the truth here first.
#
#   tools/hil-tests.sh [PYTEST ARGS...]     e.g. tools/hil-tests.sh -k bad_traffic
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
CAEKF_HIL_TRUTH=$out/truth.csv CAEKF_HIL_OUT=$out CAEKF_BUILD_DIR=$root/build/host-double MPLBACKEND=Agg \
	"$root/tools/with-vcan.sh" -- "$py" -m pytest "$root/tests/hil" -p no:cacheprovider -rA --color="$color" "$@" || rc=$?
if [ -s "$out/full/runs.npz" ]; then # CSVs, summary.txt and figures of the full runs, here (fast)
	MPLBACKEND=Agg "$py" -m caekf_sim.cli hil report --outdir "$out/full" --truth "$out/truth.csv" >/dev/null ||
		echo "hil-tests: (hil report of $out/full failed)"
fi
echo "hil-tests: exit status $rc after $((SECONDS - t0)) s"
exit "$rc"
