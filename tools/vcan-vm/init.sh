#!/bin/busybox sh
# /init (PID 1) of the vcan-vm initramfs. Copied in by tools/vcan-vm/setup.sh.
#
# 1. loads the kernel modules listed in /lib/modules/load.order,
# 2. mounts the job dir (9p tag "vcanjob") at /job and sources /job/conf.sh,
# 3. builds the guest root: host / over 9p (read-only, cache=loose) under a
#    tmpfs overlay, plus the read-write shares (tags share0..N) at their host
#    paths,
# 4. brings up lo and the vcan interfaces,
# 5. runs /job/cmd.sh with the host's bash chrooted into that root,
# 6. writes the exit status to /job/rc and powers off.
# Failures are written to /job/error; the host wrapper (run.sh) reports them.

/bin/busybox mount -t devtmpfs devtmpfs /dev 2>/dev/null
# ttyS0 is the host's stdout (about 0.5-0.7 MB/s under TCG).
exec </dev/null >/dev/ttyS0 2>&1
/bin/busybox --install -s /bin
export PATH=/bin
mount -t proc proc /proc
mount -t sysfs sysfs /sys
# Kernel messages go to ttyS1 (a log file on the host) unless verbose.
# No \n -> \r\n translation, so the host sees the command's output unchanged.
stty -F /dev/ttyS0 -onlcr 2>/dev/null

say() { echo "vcan-vm: $*"; }
halt() { sync; poweroff -f; sleep 10; }
die() {
	say "ERROR: $*"
	[ -f /job/.vcanjob ] && echo "$*" >/job/error
	halt
}

case " $(cat /proc/cmdline) " in *" vcanvm.verbose "*) verbose=1 ;; *) verbose=0 ;; esac
vsay() { [ "$verbose" = 1 ] && say "$*"; return 0; }

while read -r m; do
	[ -n "$m" ] || continue
	insmod "/lib/modules/$m.ko" || die "insmod $m failed"
done </lib/modules/load.order
vsay "modules loaded"

opts9p="trans=virtio,version=9p2000.L,msize=262144"
mount9p() { # tag dir extra-opts: retried briefly in case the device is still being probed
	n=0
	until mount -t 9p -o "$opts9p$3" "$1" "$2" 2>/dev/null; do
		n=$((n + 1))
		[ $n -ge 50 ] && { mount -t 9p -o "$opts9p$3" "$1" "$2"; return; }
		sleep 0.1
	done
}

mkdir -p /job /lower /rw /newroot
mount9p vcanjob /job "" || die "cannot mount the job dir (9p tag vcanjob)"
[ -f /job/conf.sh ] || die "/job/conf.sh missing"
: >/job/.vcanjob 2>/dev/null || die "job dir is not writable"
. /job/conf.sh

mount9p hostroot /lower ",ro,cache=loose" || die "cannot mount the host root (9p tag hostroot)"
mount -t tmpfs -o mode=0755 tmpfs /rw || die "cannot mount tmpfs"
mkdir -p /rw/upper /rw/work
mount -t overlay overlay -o lowerdir=/lower,upperdir=/rw/upper,workdir=/rw/work /newroot ||
	die "cannot mount the overlay root"
R=/newroot
mount -t proc proc $R/proc || die "mount proc"
mount -t sysfs sysfs $R/sys || die "mount sysfs"
mount -t devtmpfs devtmpfs $R/dev || die "mount devtmpfs"
mkdir -p $R/dev/pts $R/dev/shm
mount -t devpts -o gid=5,mode=620,ptmxmode=666 devpts $R/dev/pts
mount -t tmpfs -o mode=1777 tmpfs $R/dev/shm
ln -sf /proc/self/fd $R/dev/fd
ln -sf /proc/self/fd/0 $R/dev/stdin
ln -sf /proc/self/fd/1 $R/dev/stdout
ln -sf /proc/self/fd/2 $R/dev/stderr
mount -t tmpfs -o mode=0755 tmpfs $R/run || die "mount /run"
mkdir -p $R/run/vcan-job
mount -o bind /job $R/run/vcan-job || die "bind-mount the job dir"

i=0
while [ "$i" -lt "${VM_NSHARES:-0}" ]; do
	eval "p=\$VM_SHARE_$i"
	mkdir -p "$R$p" 2>/dev/null
	mount9p "share$i" "$R$p" ",cache=loose" || die "cannot mount share$i at $p"
	vsay "mounted $p read-write"
	i=$((i + 1))
done

hostname vcan-vm
ip link set lo up
for ifc in ${VM_IFACES:-vcan0}; do
	if ! ip link add dev "$ifc" type vcan 2>/dev/null; then
		# busybox ip may not know "type vcan": use the host's iproute2.
		vsay "busybox ip could not create $ifc, trying the host's ip"
		chroot $R ip link add dev "$ifc" type vcan ||
			die "cannot create $ifc (neither busybox ip nor the host's ip could)"
	fi
	ip link set "$ifc" up || die "cannot bring $ifc up"
	vsay "$ifc up"
done

cat /proc/uptime >/job/booted
vsay "booted (guest uptime $(cut -d' ' -f1 /proc/uptime) s), running the command"

chroot $R /bin/bash /run/vcan-job/cmd.sh </dev/null
rc=$?
echo "$rc" >/job/rc
# Leftover background processes would keep files busy; the VM is going away.
kill -KILL -1 2>/dev/null
sync
i=$((${VM_NSHARES:-0} - 1))
while [ "$i" -ge 0 ]; do
	eval "p=\$VM_SHARE_$i"
	umount "$R$p" 2>/dev/null
	i=$((i - 1))
done
sync
halt
