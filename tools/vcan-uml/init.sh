#!/bin/sh
# PID 1 of the user-mode Linux guest started by tools/vcan-uml/run.sh (init=this file).
# The guest's root is the host's own / over hostfs (read-write), so every path, the venv and the
# build tree are where the host has them. This script:
#   1. mounts proc, sys, devtmpfs, devpts and a tmpfs /dev/shm (guest-only mounts),
#   2. loads can, can-raw, can-dev and vcan from the user-mode-linux package (insmod, no modprobe index),
#   3. brings lo and the vcan interfaces up,
#   4. runs JOB/cmd.sh (the caller's environment, cwd and command) with stdout on /dev/tty1
#      (host stdout) and stderr on /dev/tty2 (host stderr),
#   5. writes the exit status to JOB/rc and powers off.
# JOB comes from the kernel command line (caekf_job=DIR); failures go to JOB/error.
export PATH=/usr/sbin:/usr/bin:/sbin:/bin
job=
iflist=vcan0
for w in $(cat /proc/cmdline 2>/dev/null); do
	case $w in caekf_job=*) job=${w#caekf_job=} ;; caekf_ifaces=*) iflist=$(echo "${w#caekf_ifaces=}" | tr , ' ') ;; esac
done
mount -t proc proc /proc 2>/dev/null
[ -n "$job" ] || for w in $(cat /proc/cmdline); do case $w in caekf_job=*) job=${w#caekf_job=} ;; esac; done
die() {
	echo "vcan-uml: ERROR: $*" >&2
	[ -n "$job" ] && echo "$*" >"$job/error"
	poweroff -f
	exit 1
}
[ -n "$job" ] && [ -d "$job" ] || die "no job directory (caekf_job=) on the kernel command line"
mount -t sysfs sysfs /sys || die "mount sysfs"
[ -c /dev/null ] || mount -t devtmpfs devtmpfs /dev || die "mount devtmpfs"
mkdir -p /dev/pts /dev/shm
mount -t devpts devpts /dev/pts
mount -t tmpfs -o mode=1777 tmpfs /dev/shm
ln -sf /proc/self/fd /dev/fd
stty -F /dev/tty2 raw -echo -onlcr 2>/dev/null
stty -F /dev/tty1 raw -echo -onlcr 2>/dev/null
mods=/usr/lib/uml/modules/$(uname -r)/kernel
for m in net/can/can.ko net/can/can-raw.ko drivers/net/can/dev/can-dev.ko drivers/net/can/vcan.ko; do
	insmod "$mods/$m" || die "insmod $mods/$m failed"
done
ip link set lo up
for ifc in $iflist; do
	ip link add dev "$ifc" type vcan || die "cannot create $ifc"
	ip link set "$ifc" mtu 72 || die "cannot set $ifc to CAN FD (mtu 72)" # classic frames pass too
	ip link set "$ifc" up || die "cannot bring $ifc up"
done
cat /proc/uptime >"$job/booted"
/bin/bash "$job/cmd.sh" </dev/null >/dev/tty1 2>/dev/tty2
echo $? >"$job/rc"
kill -KILL -1 2>/dev/null
sync
poweroff -f
