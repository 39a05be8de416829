#!/usr/bin/env bash
# Run a command where the SocketCAN interface vcan0 is up:
#   1. natively, if vcan0 exists (it is brought up if needed) or can be created
#      with tools/vcan-up.sh (modprobe vcan works);
#   2. otherwise in a throw-away QEMU VM via tools/vcan-vm/run.sh (this kernel
#      has no CAN support).
# It never skips silently: when neither works it fails and says why.
#
# Usage: tools/with-vcan.sh [--vm | --native] [run.sh options...] -- CMD [ARGS...]
#   --vm      always use the VM       (also: VCAN_MODE=vm)
#   --native  never use the VM        (also: VCAN_MODE=native)
#   run.sh options (--timeout S, --rw DIR, --mem MB, --verbose) apply to the VM only.
# Exit status: CMD's; 124 on VM timeout; 125 (with a message) when no vcan0 could be had.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
mode=${VCAN_MODE:-auto}
vmopts=()
while [ $# -gt 0 ]; do
	case $1 in
	--vm) mode=vm; shift ;;
	--native) mode=native; shift ;;
	--timeout | --rw | --mem | --iface) vmopts+=("$1" "${2:?$1 needs a value}"); shift 2 ;;
	--timeout=* | --rw=* | --mem=* | --iface=* | --verbose | -v) vmopts+=("$1"); shift ;;
	-h | --help) sed -n '2,14p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	--) shift; break ;;
	-*) echo "with-vcan: unknown option $1" >&2; exit 2 ;;
	*) break ;;
	esac
done
[ $# -gt 0 ] || { echo "usage: tools/with-vcan.sh [--vm|--native] -- CMD [ARGS...]" >&2; exit 2; }

if [ "$mode" != vm ]; then
	if native_err=$("$here/vcan-up.sh" vcan0 2>&1); then
		[ -n "${VCAN_VM_GUEST:-}" ] || echo "with-vcan: using native vcan0" >&2
		exec "$@"
	fi
	if [ "$mode" = native ]; then
		echo "with-vcan: ERROR: no native vcan0: $native_err" >&2
		exit 125
	fi
	echo "with-vcan: no native vcan0 (${native_err:-unknown reason}); using a QEMU VM" >&2
fi
exec "$here/vcan-vm/run.sh" "${vmopts[@]}" -- "$@"
