#!/usr/bin/env bash
# Run a command where the SocketCAN interface vcan0 is up:
#   1. natively, if vcan0 exists (it is brought up if needed) or can be created
#      with tools/vcan-up.sh (modprobe vcan works);
#   2. otherwise in a throw-away user-mode Linux guest (tools/vcan-uml/run.sh:
#      Debian's user-mode-linux kernel over the host's own root file system).
# It never skips silently: when neither works it fails and says why.
#
# Usage: tools/with-vcan.sh [--uml | --native] [run.sh options...] -- CMD [ARGS...]
#   --uml     always use user-mode Linux (also: VCAN_MODE=uml)
#   --native  never use it                (also: VCAN_MODE=native)
#   run.sh options (--timeout S, --mem MB, --iface NAME, --verbose) apply to user-mode Linux only.
# Exit status: CMD's; 124 on timeout; 125 (with a message) when no vcan0 could be had.
set -uo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
mode=${VCAN_MODE:-auto}
umlopts=()
while [ $# -gt 0 ]; do
	case $1 in
	--uml) mode=uml; shift ;;
	--native) mode=native; shift ;;
	--timeout | --mem | --iface) umlopts+=("$1" "${2:?$1 needs a value}"); shift 2 ;;
	--timeout=* | --mem=* | --iface=* | --verbose | -v) umlopts+=("$1"); shift ;;
	-h | --help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	--) shift; break ;;
	-*) echo "with-vcan: unknown option $1" >&2; exit 2 ;;
	*) break ;;
	esac
done
[ $# -gt 0 ] || { echo "usage: tools/with-vcan.sh [--uml|--native] -- CMD [ARGS...]" >&2; exit 2; }

if [ "$mode" != uml ]; then
	if native_err=$("$here/vcan-up.sh" vcan0 2>&1); then
		[ -n "${CAEKF_UML_GUEST:-}" ] || echo "with-vcan: using native vcan0" >&2
		exec "$@"
	fi
	if [ "$mode" = native ]; then
		echo "with-vcan: ERROR: no native vcan0: $native_err" >&2
		exit 125
	fi
	echo "with-vcan: no native vcan0 (${native_err:-unknown reason}); using user-mode Linux" >&2
fi
exec "$here/vcan-uml/run.sh" "${umlopts[@]}" -- "$@"
