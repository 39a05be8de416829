#!/usr/bin/env bash
# Prepare everything tools/vcan-vm/run.sh needs (idempotent; a fast no-op once done):
#   - qemu-system-x86, xz-utils and busybox-static (apt-get install, root only;
#     busybox-static is only downloaded when the dynamic busybox is installed),
#   - the newest stock Debian kernel linux-image-<ver>-amd64 that apt offers
#     (fetched with `apt-get download`, unpacked with `dpkg-deb -x`, NOT installed),
#   - an uncompressed vmlinux (faster to boot under TCG) and a busybox initramfs
#     holding init.sh and the CAN / vcan / 9p / overlay modules.
# Output goes to <repo>/.cache/vcan-vm/ (or $VCAN_VM_CACHE), which ignores itself in git.
#
# Usage: tools/vcan-vm/setup.sh [--quiet] [--force]
# Env:   VCAN_VM_CACHE       cache dir (default <repo>/.cache/vcan-vm)
#        VCAN_VM_KERNEL_PKG  kernel package to use (default: what linux-image-amd64 depends on)
set -euo pipefail

here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd -P)
repo=$(cd "$here/../.." && pwd -P)
cache=${VCAN_VM_CACHE:-$repo/.cache/vcan-vm}
quiet=0 force=0
for a in "$@"; do
	case $a in
	--quiet | -q) quiet=1 ;;
	--force) force=1 ;;
	-h | --help) sed -n '2,15p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
	*) echo "vcan-vm setup: unknown argument: $a" >&2; exit 2 ;;
	esac
done
log() { [ "$quiet" = 1 ] || echo "vcan-vm setup: $*" >&2; }
die() { echo "vcan-vm setup: ERROR: $*" >&2; exit 1; }

# Modules the guest needs; their dependencies are added automatically.
WANT_MODULES="virtio_pci 9pnet_virtio 9p overlay can can_raw can_bcm can_isotp can_gw can_j1939 vcan"

want_stamp() {
	{
		sha256sum "$here/setup.sh" "$here/init.sh" | cut -d' ' -f1
		echo "${VCAN_VM_KERNEL_PKG:-auto}"
	} | sha256sum | cut -d' ' -f1
}

is_ready() {
	[ -f "$cache/READY" ] && [ "$(cat "$cache/READY")" = "$(want_stamp)" ] &&
		[ -f "$cache/kernel" ] && [ -f "$cache/initrd.cpio" ] &&
		command -v qemu-system-x86_64 >/dev/null 2>&1
}

if [ "$force" = 0 ] && is_ready; then
	exit 0
fi

mkdir -p "$cache"
printf '*\n' >"$cache/.gitignore" # never commit kernels / initramfs
exec 9>"$cache/.lock"
flock 9 # another setup may be running: wait for it, then re-check
if [ "$force" = 0 ] && is_ready; then
	exit 0
fi

# --- host packages ----------------------------------------------------------
apt_updated=0
apt_install() {
	[ "$(id -u)" = 0 ] || die "need root to 'apt-get install $*' (or install them yourself)"
	log "apt-get install $*"
	if ! DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@" >"$cache/apt.log" 2>&1; then
		if [ "$apt_updated" = 0 ]; then
			log "apt-get install failed; running apt-get update and retrying"
			apt-get update >>"$cache/apt.log" 2>&1 || true
			apt_updated=1
			DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends "$@" >>"$cache/apt.log" 2>&1 ||
				die "apt-get install $* failed, see $cache/apt.log"
		else
			die "apt-get install $* failed, see $cache/apt.log"
		fi
	fi
}
pkg_installed() { dpkg-query -W -f='${Status}' "$1" 2>/dev/null | grep -q 'install ok installed'; }

need=()
command -v qemu-system-x86_64 >/dev/null 2>&1 || need+=(qemu-system-x86)
command -v xz >/dev/null 2>&1 || need+=(xz-utils)
if ! pkg_installed busybox-static && ! pkg_installed busybox; then
	need+=(busybox-static)
fi
[ ${#need[@]} -eq 0 ] || apt_install "${need[@]}"

tmp=$(mktemp -d "$cache/tmp.XXXXXX")
trap 'rm -rf "$tmp"' EXIT

apt_download() { # pkg -> prints path of the .deb
	local d="$tmp/dl-$1"
	mkdir -p "$d"
	if ! (cd "$d" && apt-get -o APT::Sandbox::User=root download "$1") >>"$cache/apt.log" 2>&1; then
		if [ "$apt_updated" = 0 ] && [ "$(id -u)" = 0 ]; then
			log "apt-get download $1 failed; running apt-get update and retrying"
			apt-get update >>"$cache/apt.log" 2>&1 || true
			apt_updated=1
			(cd "$d" && apt-get -o APT::Sandbox::User=root download "$1") >>"$cache/apt.log" 2>&1 ||
				return 1
		else
			return 1
		fi
	fi
	ls "$d"/*.deb
}

# --- static busybox -----------------------------------------------------------
if pkg_installed busybox-static; then
	busybox=$(command -v busybox || echo /bin/busybox)
else
	# Only the dynamic busybox is installed (it conflicts with busybox-static):
	# take the static binary from the package without installing it.
	log "downloading busybox-static (not installing it: the dynamic busybox is installed)"
	deb=$(apt_download busybox-static) || die "apt-get download busybox-static failed, see $cache/apt.log"
	dpkg-deb -x "$deb" "$tmp/bb"
	busybox=$tmp/bb/bin/busybox
fi
[ -x "$busybox" ] || die "no static busybox found at $busybox"

# --- kernel -------------------------------------------------------------------
pick_kernel() {
	if [ -n "${VCAN_VM_KERNEL_PKG:-}" ]; then
		echo "$VCAN_VM_KERNEL_PKG"
		return
	fi
	local k
	k=$(apt-cache depends linux-image-amd64 2>/dev/null |
		awk '$1 == "Depends:" && $2 ~ /^linux-image-[0-9].*-amd64(-unsigned)?$/ {print $2; exit}')
	if [ -z "$k" ]; then
		k=$(apt-cache pkgnames linux-image- 2>/dev/null |
			grep -E '^linux-image-[0-9]+\.[0-9]+\.[0-9]+(\+[a-z0-9.]+)?-[0-9]+-amd64$' | sort -V | tail -n1 || true)
	fi
	echo "$k"
}
kpkg=$(pick_kernel)
if [ -z "$kpkg" ] && [ "$apt_updated" = 0 ] && [ "$(id -u)" = 0 ]; then
	log "no linux-image-*-amd64 known to apt; running apt-get update"
	apt-get update >>"$cache/apt.log" 2>&1 || true
	apt_updated=1
	kpkg=$(pick_kernel)
fi
[ -n "$kpkg" ] || die "apt offers no linux-image-<version>-amd64 package (is apt-get update done?)"
case $kpkg in *cloud* | *-rt-* | *-dbg) die "refusing kernel package $kpkg (cloud/rt/dbg flavours lack modules we need)" ;; esac

kernel_stamp() { sha256sum "$here/setup.sh" | cut -d' ' -f1; }

# Reuse the unpacked kernel if it is the one apt offers and this script has not changed.
kdir=
if [ -f "$cache/kernel-package" ] && [ "$(cat "$cache/kernel-package")" = "$kpkg" ] &&
	[ -f "$cache/kernel-version" ]; then
	kver=$(cat "$cache/kernel-version")
	d="$cache/kernel-$kver"
	if [ -f "$d/.done" ] && [ "$(cat "$d/.done")" = "$(kernel_stamp)" ]; then
		kdir=$d
		kimage=$(ls "$kdir/vmlinux" 2>/dev/null || echo "$kdir/vmlinuz")
		log "reusing $kpkg"
	fi
fi
fetch_kernel() {
	log "downloading $kpkg"
	if ! deb=$(apt_download "$kpkg"); then
		case $kpkg in
		*-unsigned) die "apt-get download $kpkg failed, see $cache/apt.log" ;;
		*) log "trying $kpkg-unsigned"
			deb=$(apt_download "$kpkg-unsigned") || die "apt-get download $kpkg failed, see $cache/apt.log" ;;
		esac
	fi
	log "unpacking $(basename "$deb")"
	dpkg-deb -x "$deb" "$tmp/k"
	rm -f "$deb"

	vmlinuz=$(ls "$tmp"/k/boot/vmlinuz-* 2>/dev/null | head -n1)
	[ -n "$vmlinuz" ] || die "$kpkg has no /boot/vmlinuz-*"
	kver=${vmlinuz##*/vmlinuz-}
	moddir=
	for d in "$tmp/k/lib/modules/$kver" "$tmp/k/usr/lib/modules/$kver"; do
		[ -d "$d" ] && moddir=$d && break
	done
	[ -n "$moddir" ] || die "$kpkg has no modules directory for $kver"
	kconfig="$tmp/k/boot/config-$kver"

	# --- module dependency resolution ---------------------------------------------
	declare -A modpath=()
	while IFS= read -r f; do
		b=${f##*/}
		b=${b%%.ko*}
		modpath[${b//-/_}]=$f
	done < <(find "$moddir" -name '*.ko' -o -name '*.ko.xz' -o -name '*.ko.zst' -o -name '*.ko.gz')

	builtin_has() { # name (with _)
		[ -f "$moddir/modules.builtin" ] && sed 's/-/_/g' "$moddir/modules.builtin" | grep -q "/$1\.ko\$"
	}

	mkdir -p "$tmp/rd/lib/modules"
	: >"$tmp/rd/lib/modules/load.order"
	declare -A done_mod=()
	add_module() { # name
		local n=${1//-/_} f out deps d
		[ -n "${done_mod[$n]:-}" ] && return 0
		done_mod[$n]=1
		f=${modpath[$n]:-}
		if [ -z "$f" ]; then
			builtin_has "$n" && return 0
			die "module $n is neither in $kpkg nor built in"
		fi
		out="$tmp/rd/lib/modules/$n.ko"
		case $f in
		*.ko) cp "$f" "$out" ;;
		*.ko.xz) xz -dc "$f" >"$out" ;;
		*.ko.gz) gzip -dc "$f" >"$out" ;;
		*.ko.zst)
			command -v zstd >/dev/null 2>&1 || apt_install zstd
			zstd -qdc "$f" >"$out" ;;
		esac
		deps=$(tr '\0' '\n' <"$out" | grep -a '^depends=' | head -n1 | cut -d= -f2 | tr ',' ' ')
		for d in $deps; do add_module "$d"; done
		echo "$n" >>"$tmp/rd/lib/modules/load.order" # after its dependencies
	}
	for m in $WANT_MODULES; do add_module "$m"; done

	# --- kernel image: uncompressed vmlinux if possible (saves ~3 s of TCG decompression)
	extract_vmlinux() { # bzImage out
		local img=$1 out=$2 sig tool off
		for sig in 'xz:\xfd7zXZ\x00' 'gzip:\x1f\x8b\x08' 'zstd:\x28\xb5\x2f\xfd'; do
			tool=${sig%%:*}
			command -v "$tool" >/dev/null 2>&1 || continue
			for off in $(LC_ALL=C grep -obUaP "${sig#*:}" "$img" 2>/dev/null | cut -d: -f1 | head -n 5); do
				case $tool in
				xz) tail -c +$((off + 1)) "$img" | xz -dc --single-stream >"$out" 2>/dev/null || true ;;
				gzip) tail -c +$((off + 1)) "$img" | gzip -dc >"$out" 2>/dev/null || true ;;
				zstd) tail -c +$((off + 1)) "$img" | zstd -qdc >"$out" 2>/dev/null || true ;;
				esac
				if [ "$(head -c 4 "$out" | od -An -tx1 | tr -d ' ')" = 7f454c46 ]; then
					return 0
				fi
			done
		done
		rm -f "$out"
		return 1
	}
	kdir="$cache/kernel-$kver"
	rm -rf "$kdir"
	mkdir -p "$kdir"
	cp "$vmlinuz" "$kdir/vmlinuz"
	cp "$kconfig" "$kdir/config" 2>/dev/null || true
	kimage=$kdir/vmlinuz
	if grep -q '^CONFIG_PVH=y' "$kdir/config" 2>/dev/null && extract_vmlinux "$vmlinuz" "$kdir/vmlinux"; then
		kimage=$kdir/vmlinux
		log "extracted uncompressed vmlinux"
	else
		log "booting the compressed bzImage (could not extract a PVH-bootable vmlinux)"
	fi
	cp -r "$tmp/rd/lib/modules" "$kdir/modules"

	kernel_stamp >"$kdir/.done"
}
[ -n "$kdir" ] || fetch_kernel

# --- initramfs ------------------------------------------------------------------
rd=$tmp/rd
rm -rf "$rd"
mkdir -p "$rd/lib"
cp -r "$kdir/modules" "$rd/lib/modules"
mkdir -p "$rd/bin" "$rd/dev" "$rd/proc" "$rd/sys" "$rd/job" "$rd/lower" "$rd/rw" "$rd/newroot"
cp "$busybox" "$rd/bin/busybox"
ln -s busybox "$rd/bin/sh"
install -m 0755 "$here/init.sh" "$rd/init"
(cd "$rd" && find . | LC_ALL=C sort | "$busybox" cpio -o -H newc -R 0:0 2>/dev/null) >"$tmp/initrd.cpio"
[ -s "$tmp/initrd.cpio" ] || die "building the initramfs failed"
mv "$tmp/initrd.cpio" "$cache/initrd.cpio"
ln -sfn "${kimage#"$cache"/}" "$cache/kernel"
echo "$kpkg" >"$cache/kernel-package"
echo "$kver" >"$cache/kernel-version"
# drop kernels of older runs
for d in "$cache"/kernel-*/; do
	[ "${d%/}" = "$kdir" ] || rm -rf "${d%/}"
done
want_stamp >"$cache/READY"
log "ready: $kpkg ($kver), modules: $(tr '\n' ' ' <"$kdir/modules/load.order")"
