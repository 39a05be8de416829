#!/usr/bin/env bash
# Create and bring up a virtual SocketCAN interface on this kernel (idempotent).
# Needs a kernel with CAN support (modprobe vcan) and root (or password-less sudo).
#
# Usage: tools/vcan-up.sh [IFACE...]     (default: vcan0)
# Exit status 0 when every interface is up; non-zero with a message otherwise.
set -euo pipefail

[ $# -gt 0 ] || set -- vcan0

as_root() {
	if [ "$(id -u)" = 0 ]; then
		"$@"
	elif command -v sudo >/dev/null 2>&1 && sudo -n true 2>/dev/null; then
		sudo -n "$@"
	else
		echo "vcan-up: need root (or password-less sudo) for: $*" >&2
		return 1
	fi
}
die() { echo "vcan-up: $*" >&2; exit 1; }

PATH=$PATH:/usr/sbin:/sbin
exists() { [ -e "/sys/class/net/$1" ]; }
is_up() { [ $(($(cat "/sys/class/net/$1/flags" 2>/dev/null || echo 0) & 1)) = 1 ]; }
need_ip() { command -v ip >/dev/null 2>&1 || die "the 'ip' command (iproute2) is missing, cannot $*"; }

for ifc in "$@"; do
	if exists "$ifc" && is_up "$ifc"; then
		continue
	fi
	if ! exists "$ifc"; then
		if [ ! -d /sys/module/vcan ]; then
			if ! command -v modprobe >/dev/null 2>&1; then
				if ls /lib/modules/"$(uname -r)"/kernel/drivers/net/can/vcan.ko* >/dev/null 2>&1; then
					die "modprobe (kmod) is missing, cannot load vcan"
				fi
				die "this kernel ($(uname -r)) has no vcan support (no vcan module, no modprobe)"
			fi
			as_root modprobe vcan 2>/dev/null ||
				die "modprobe vcan failed: this kernel ($(uname -r)) has no vcan module (CONFIG_CAN_VCAN)"
		fi
		as_root modprobe can_raw 2>/dev/null || true
		need_ip "create $ifc"
		as_root ip link add dev "$ifc" type vcan ||
			exists "$ifc" || # lost a race with another caller
			die "cannot create $ifc"
	fi
	if ! is_up "$ifc"; then
		need_ip "bring $ifc up"
		as_root ip link set dev "$ifc" mtu 72 || true # CAN FD frames (the fd profile); only while down
		as_root ip link set up dev "$ifc" || die "cannot bring $ifc up"
	fi
done
