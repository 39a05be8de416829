# Sourced by the HIL scripts (tools/hil-main.sh, hil-realtime.sh, hil-tests.sh, hil-bench.sh): the part they
# share. Bootstrap only: the bus work itself is Python (`caekf-sim hil run --start-host` starts and stops
# caekf-host, runs the bench, the echo probe, the reports; the HIL suite's fixtures do the same).
#   hil_prepare NAME OUT_DIR    checks the venv, builds host-double, writes OUT_DIR/truth.csv (caekf-truth);
#                               sets out (OUT_DIR, absolute; inside the repository: the guest shares it)
# Sets root, build, scenario (HIL_SCENARIO, default sim/scenarios/paper.toml), py, host_bin.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd -P)
cd "$root"
build=$root/build/host-double
scenario=$(realpath "${HIL_SCENARIO:-$root/sim/scenarios/paper.toml}")
py=$root/.venv/bin/python
host_bin=$build/host/caekf_host/caekf-host

hil_prepare() {
	local name=$1
	out=$(mkdir -p "$2" && cd "$2" && pwd -P)
	case "$out/" in "$root"/*) ;; *) echo "$name: OUT_DIR must be inside the repository (shared with the guest)" >&2; exit 2 ;; esac
	[ -x "$py" ] || { echo "$name: no $py: run tools/bootstrap.sh --hil" >&2; exit 1; }
	local log=$out/build.log
	# under tools/run-tests.sh's lock: its stages that use build/host-double run side by side
	mkdir -p "$root/build"
	flock "$root/build/.host-double.lock" sh -c 'cmake --preset host-double && cmake --build --preset host-double' \
		>"$log" 2>&1 ||
		{ tail -n 30 "$log" >&2; echo "$name: building host-double failed (log: $log)" >&2; exit 1; }
	"$build/host/caekf-truth" --scenario "$scenario" --out "$out/truth.csv" --quiet
}
