#!/usr/bin/env bash
# tools/bootstrap.sh [--hil] [--arm]
#
# Installs everything the build and the tests need, idempotently. A second run with
# everything in place takes well under a second and touches nothing.
#
#   1. apt packages (host toolchain; --arm adds the Cortex-M toolchain and QEMU;
#      --hil adds user-mode Linux, whose kernel brings vcan where this one has none). apt-get update runs only
#      when a package is missing and cannot be installed from the current lists.
#   2. Unity (ThrowTheSwitch), offline: Debian's *source* package `cjson` ships an
#      unmodified Unity under tests/unity/. It is fetched with `apt-get source` (a
#      deb-src entry is added for the running release when none exists) into
#      .cache/downloads and unpacked to .cache/unity (src/unity.c, unity.h,
#      unity_internals.h). cmake/Unity.cmake picks it up from there.
#   3. Python venv at .venv; `pip install -e ./sim[dev]` when sim/pyproject.toml
#      exists, re-run only when that file, the interpreter or the C sources of the
#      estimator binding (core, the settings schema, host/common scenario/truth, sim/src/caekf_sim/_caekf.c) changed.
#   4. CMake 3.25 or newer (CMakePresets.json's workflow presets): where the distribution's is older
#      (Ubuntu 22.04: 3.22), the venv's (PyPI's cmake package) linked in .cache/cmake/bin, which
#      tools/run-tests.sh and tools/run-main.sh then put first on PATH.
#
# Environment knobs:
#   CAEKF_SKIP_APT=1    skip step 1 (e.g. on a machine set up by other means)
#   CAEKF_SKIP_UNITY=1  skip step 2
#   CAEKF_SKIP_VENV=1   skip step 3
#   CAEKF_PYTHON=/path  interpreter used to create the venv
set -euo pipefail

REPO="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
CACHE="$REPO/.cache"
VENV="$REPO/.venv"

WANT_ARM=0
WANT_HIL=0
for arg in "$@"; do
    case "$arg" in
        --arm) WANT_ARM=1 ;;
        --hil) WANT_HIL=1 ;;
        -h|--help) sed -n '2,24p' "${BASH_SOURCE[0]}"; exit 0 ;;
        *) echo "bootstrap: unknown argument '$arg' (use --arm, --hil)" >&2; exit 2 ;;
    esac
done

log()  { printf '[bootstrap] %s\n' "$*"; }
warn() { printf '[bootstrap] WARNING: %s\n' "$*" >&2; }
die()  { printf '[bootstrap] ERROR: %s\n' "$*" >&2; exit 1; }

CLEANUP=()
cleanup() { [ "${#CLEANUP[@]}" -eq 0 ] || rm -rf "${CLEANUP[@]}"; }
trap cleanup EXIT

# --- privileges --------------------------------------------------------------------------
SUDO=()
if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null 2>&1; then
        SUDO=(sudo)
    else
        SUDO=(__no_root__)
    fi
fi
as_root() {
    if [ "${SUDO[0]:-}" = "__no_root__" ]; then
        die "need root for: $* (not root and no sudo)"
    fi
    "${SUDO[@]}" env DEBIAN_FRONTEND=noninteractive "$@"
}
APT_OPTS=(-y -q -o Dpkg::Use-Pty=0 -o APT::Sandbox::User=root -o DPkg::Lock::Timeout=900)

APT_UPDATED=0
apt_update() {
    [ "$APT_UPDATED" -eq 1 ] && return 0
    log "apt-get update"
    as_root apt-get "${APT_OPTS[@]}" update
    APT_UPDATED=1
}

# True when the package is installed (not merely known or half-removed).
pkg_installed() {
    [ "$(dpkg-query -W -f='${db:Status-Status}' "$1" 2>/dev/null || true)" = "installed" ]
}

# --- 1. apt packages -----------------------------------------------------------------------
install_apt_packages() {
    # frama-c-base: Frama-C's EVA for tools/eva.py (docs/eva.md)
    local pkgs=(cmake ninja-build gcc g++ make python3-venv python3-dev dpkg-dev clang libclang-rt-dev binutils cppcheck clang-format
                frama-c-base)
    [ "$WANT_ARM" -eq 1 ] && pkgs+=(gcc-arm-none-eabi libnewlib-arm-none-eabi qemu-system-arm)
    # user-mode-linux ships vcan.ko/can.ko/can-raw.ko for its kernel; kmod gives insmod (tools/vcan-uml)
    [ "$WANT_HIL" -eq 1 ] && pkgs+=(user-mode-linux kmod iproute2)

    command -v dpkg-query >/dev/null 2>&1 || die "not a Debian/Ubuntu system (no dpkg-query)"

    local missing=() p
    for p in "${pkgs[@]}"; do
        pkg_installed "$p" || missing+=("$p")
    done
    if [ "${#missing[@]}" -eq 0 ]; then
        log "apt packages: all ${#pkgs[@]} present"
        return 0
    fi
    log "apt packages missing: ${missing[*]}"
    # No package lists at all (fresh container): update first. Otherwise try the
    # current lists and update only if that fails (stale lists -> 404, unknown pkg).
    if ! ls /var/lib/apt/lists/*_Packages* >/dev/null 2>&1; then
        apt_update
    fi
    if ! as_root apt-get "${APT_OPTS[@]}" install --no-install-recommends "${missing[@]}"; then
        [ "$APT_UPDATED" -eq 1 ] && die "apt-get install failed: ${missing[*]}"
        apt_update
        as_root apt-get "${APT_OPTS[@]}" install --no-install-recommends "${missing[@]}" \
            || die "apt-get install failed: ${missing[*]}"
    fi
}

# --- 2. Unity from Debian's cjson source package --------------------------------------------
SRC_LIST_REL="sources.list.d/caekf-src.list"
SRC_LIST="/etc/apt/$SRC_LIST_REL"

os_field() { # os_field KEY -> value from /etc/os-release (empty if absent)
    [ -r /etc/os-release ] || return 0
    ( . /etc/os-release; eval "printf '%s' \"\${$1:-}\"" )
}

# Prints "URI<TAB>SIGNED_BY" for every enabled binary ("deb") source of suite $1,
# reading both the deb822 (*.sources) and the one-line (*.list) formats.
list_binary_sources() {
    local suite="$1" f
    local files=()
    for f in /etc/apt/sources.list /etc/apt/sources.list.d/*.list; do
        [ -r "$f" ] && [ "$f" != "$SRC_LIST" ] && files+=("$f")
    done
    if [ "${#files[@]}" -gt 0 ]; then
        awk -v suite="$suite" '
            /^[[:space:]]*#/ { next }
            $1 == "deb" {
                opts = ""; i = 2
                if ($2 ~ /^\[/) {            # [ key=value ... ] may span several fields
                    while (i <= NF) { opts = opts " " $i; if ($i ~ /\]$/) { i++; break } i++ }
                }
                uri = $i; s = $(i + 1)
                if (s != suite) next
                sb = ""
                if (match(opts, /signed-by=[^] ]+/)) sb = substr(opts, RSTART + 10, RLENGTH - 10)
                print uri "\t" sb
            }' "${files[@]}"
    fi
    for f in /etc/apt/sources.list.d/*.sources; do
        [ -r "$f" ] || continue
        awk -v suite="$suite" '
            function flush() {
                if (types ~ /(^| )deb( |$)/ && enabled != "no") {
                    ns = split(suites, S, " "); nu = split(uris, U, " ")
                    for (a = 1; a <= ns; a++) if (S[a] == suite)
                        for (b = 1; b <= nu; b++) print U[b] "\t" (signed ~ /^\// ? signed : "")
                }
                types = uris = suites = signed = enabled = ""; key = ""
            }
            /^[[:space:]]*#/ { next }
            /^[[:space:]]*$/ { flush(); next }
            /^[[:space:]]/   { next }            # continuation line (e.g. inline key)
            {
                key = tolower($1); sub(/:$/, "", key)
                val = $0; sub(/^[^:]*:[[:space:]]*/, "", val); gsub(/[[:space:]]+/, " ", val)
                sub(/ $/, "", val)
                if (key == "types") types = val
                else if (key == "uris") uris = val
                else if (key == "suites") suites = val
                else if (key == "signed-by") signed = val
                else if (key == "enabled") enabled = tolower(val)
            }
            END { flush() }' "$f"
    done
}

ensure_deb_src() {
    # Already resolvable (existing deb-src, or our list from an earlier run)?
    if [ -n "$(apt-cache showsrc --only-source cjson 2>/dev/null | head -n1)" ]; then
        return 0
    fi
    local id codename comps
    id="$(os_field ID)"
    codename="$(os_field VERSION_CODENAME)"
    [ -n "$codename" ] || codename="$(os_field UBUNTU_CODENAME)"
    [ -n "$codename" ] || codename="$(lsb_release -sc 2>/dev/null || true)"
    [ -n "$codename" ] || { warn "cannot tell the release codename; no deb-src added"; return 1; }
    comps="main"
    [ "$id" = "ubuntu" ] && comps="main universe"   # cjson is in universe on Ubuntu

    if [ ! -f "$SRC_LIST" ]; then
        local lines entries=""
        lines="$(list_binary_sources "$codename" | awk '!seen[$1]++')"
        if [ -z "$lines" ]; then
            case "$id" in
                ubuntu)
                    case "$(dpkg --print-architecture)" in
                        amd64|i386) lines="http://archive.ubuntu.com/ubuntu/	" ;;
                        *)          lines="http://ports.ubuntu.com/ubuntu-ports/	" ;;
                    esac ;;
                *) lines="http://deb.debian.org/debian	" ;;
            esac
            warn "no binary source for '$codename' found; using default mirror ${lines%%	*}"
        fi
        local uri sb
        while IFS=$'\t' read -r uri sb; do
            [ -n "$uri" ] || continue
            if [ -n "$sb" ]; then
                entries+="deb-src [signed-by=$sb] $uri $codename $comps"$'\n'
            else
                entries+="deb-src $uri $codename $comps"$'\n'
            fi
        done <<<"$lines"
        log "adding $SRC_LIST:"
        printf '%s' "$entries" | sed 's/^/    /'
        printf '# Added by caekf tools/bootstrap.sh: source packages (Unity comes from cjson'"'"'s source).\n%s' \
            "$entries" | as_root tee "$SRC_LIST" >/dev/null
    fi
    # Refresh only our list: fast, and leaves the other lists as they are.
    log "apt-get update (deb-src only)"
    as_root apt-get "${APT_OPTS[@]}" update \
        -o Dir::Etc::sourcelist="$SRC_LIST_REL" -o Dir::Etc::sourceparts=- \
        -o APT::Get::List-Cleanup=0
    [ -n "$(apt-cache showsrc --only-source cjson 2>/dev/null | head -n1)" ]
}

fetch_unity() {
    local dest="$CACHE/unity"
    if [ -f "$dest/src/unity.c" ] && [ -f "$dest/src/unity.h" ] && [ -f "$dest/src/unity_internals.h" ]; then
        log "Unity: present in .cache/unity ($(head -n1 "$dest/SOURCE" 2>/dev/null || echo 'origin unknown'))"
        return 0
    fi
    local dl="$CACHE/downloads"
    mkdir -p "$dl"
    local dsc
    dsc="$(ls -1 "$dl"/cjson_*.dsc 2>/dev/null | sort -V | tail -n1 || true)"
    if [ -z "$dsc" ]; then
        ensure_deb_src || { warn "no deb-src for cjson; Unity not fetched (CMake will try its pinned download)"; return 0; }
        log "apt-get source --download-only cjson -> .cache/downloads"
        # apt-get source needs no root: it only downloads into the current directory.
        ( cd "$dl" && apt-get -q -o APT::Sandbox::User="$(id -un)" source --download-only cjson ) \
            || { warn "apt-get source cjson failed; Unity not fetched"; return 0; }
        dsc="$(ls -1 "$dl"/cjson_*.dsc 2>/dev/null | sort -V | tail -n1 || true)"
        [ -n "$dsc" ] || { warn "no cjson .dsc after download"; return 0; }
    fi
    local tmp
    tmp="$(mktemp -d "$CACHE/unpack.XXXXXX")"
    CLEANUP+=("$tmp")
    if command -v dpkg-source >/dev/null 2>&1; then
        # --no-check: the .dsc signature cannot be checked without debian-keyring; the
        # files themselves were verified by apt against the signed Sources index.
        dpkg-source --no-check -x "$dsc" "$tmp/cjson" >/dev/null
    else
        local orig
        orig="$(ls -1 "$dl"/cjson_*.orig.tar.* | sort -V | tail -n1)"
        mkdir -p "$tmp/cjson"
        tar -xf "$orig" -C "$tmp/cjson" --strip-components=1
    fi
    local usrc="$tmp/cjson/tests/unity"
    [ -f "$usrc/src/unity.c" ] || die "cjson source has no tests/unity/src/unity.c ($dsc)"
    local ver
    ver="$(awk '/#define UNITY_VERSION_(MAJOR|MINOR|BUILD)[ \t]/ {v = v (v ? "." : "") $3} END {print v}' "$usrc/src/unity.h")"
    [ -n "$ver" ] || ver="$(tr -d '[:space:]' <"$usrc/release/version.info" 2>/dev/null || true)"
    rm -rf "$dest.new"
    cp -a "$usrc" "$dest.new"
    # cJSON's copy differs from upstream Unity in one line: unity_internals.h always
    # includes ../examples/unity_config.h (which only defines UNITY_INCLUDE_DOUBLE).
    # Restore upstream's opt-in form so the copy is upstream Unity again and configured
    # only by the compile definitions cmake/Unity.cmake sets.
    local note="unmodified"
    if grep -q '^#include "../examples/unity_config.h"$' "$dest.new/src/unity_internals.h"; then
        sed -i 's|^#include "../examples/unity_config.h"$|#ifdef UNITY_INCLUDE_CONFIG_H\n#include "unity_config.h"\n#endif|' \
            "$dest.new/src/unity_internals.h"
        note="cJSON's forced '#include \"../examples/unity_config.h\"' reverted to upstream's #ifdef UNITY_INCLUDE_CONFIG_H form"
    fi
    {
        echo "Unity $ver from Debian source package $(basename "$dsc" .dsc) (tests/unity/)"
        echo "Changes: $note."
        echo "Unpacked by tools/bootstrap.sh on $(date -u +%Y-%m-%dT%H:%M:%SZ). Not part of the repository."
    } >"$dest.new/SOURCE"
    rm -rf "$dest"
    mv "$dest.new" "$dest"
    rm -rf "$tmp"
    log "Unity $ver unpacked to .cache/unity"
}

# --- 3. Python venv ------------------------------------------------------------------------
pick_python() {
    if [ -n "${CAEKF_PYTHON:-}" ]; then echo "$CAEKF_PYTHON"; return; fi
    # Prefer the distribution interpreter (python3-venv provides ensurepip for it).
    if [ -x /usr/bin/python3 ] && /usr/bin/python3 -c 'import venv, ensurepip' >/dev/null 2>&1; then
        echo /usr/bin/python3; return
    fi
    command -v python3 || die "no python3 found"
}

setup_venv() {
    local py="$VENV/bin/python"
    if ! [ -x "$py" ] || ! "$py" -c 'import sys' >/dev/null 2>&1; then
        local base
        base="$(pick_python)"
        log "creating venv .venv with $base ($("$base" -V 2>&1))"
        rm -rf "$VENV"
        "$base" -m venv "$VENV"
    fi
    local pyproject="$REPO/sim/pyproject.toml"
    if ! [ -f "$pyproject" ]; then
        log "venv: ready (no sim/pyproject.toml yet, nothing to install)"
        return 0
    fi
    local stamp="$VENV/.caekf-sim.stamp" want
    # The package builds the C estimator binding (sim/CMakeLists.txt) from the core, host/common and
    # its own C file: a change to any of them re-installs (and so rebuilds) it as well.
    want="$( { sha256sum "$pyproject" "$REPO/sim/CMakeLists.txt" "$REPO"/sim/src/caekf_sim/*.c \
                 "$REPO"/firmware/core/*.[ch] "$REPO"/firmware/core/sources.cmake "$REPO"/firmware/include/caekf/*.h \
                 "$REPO"/host/common/scenario.[ch] "$REPO"/host/common/truth.[ch] "$REPO"/cmake/CaekfCodegen.cmake \
                 "$REPO"/sim/src/caekf_sim/schema/settings.toml "$REPO"/sim/src/caekf_sim/schema/codegen.py 2>/dev/null \
                 | sha256sum | cut -d' ' -f1; "$py" -V 2>&1; } | tr '\n' ' ')"
    if [ -f "$stamp" ] && [ "$(cat "$stamp")" = "$want" ]; then
        log "venv: sim[dev] up to date"
        return 0
    fi
    log "venv: pip install -e ./sim[dev]"
    export PIP_DISABLE_PIP_VERSION_CHECK=1 PIP_NO_INPUT=1
    ( cd "$REPO" && "$py" -m pip install -q -e "./sim[dev]" )
    printf '%s' "$want" >"$stamp"
}

# --- 4. CMake >= 3.25 ----------------------------------------------------------------------
# Where the distribution's cmake is older, .cache/cmake/bin links the venv's (PyPI's cmake package, which FMPy
# already brings; installed here if not) and tools/run-tests.sh and tools/run-main.sh put it first on PATH.
CMAKE_MIN=3.25
cmake_version() { "$1" --version 2>/dev/null | awk 'NR == 1 { print $3 }'; }
version_ok() { [ -n "$1" ] && [ "$(printf '%s\n%s\n' "$CMAKE_MIN" "$1" | sort -V | head -n 1)" = "$CMAKE_MIN" ]; }
setup_cmake() {
    local v vv
    v="$(cmake_version cmake)"
    if version_ok "$v"; then
        rm -rf "$CACHE/cmake"
        log "cmake $v (>= $CMAKE_MIN)"
        return 0
    fi
    [ -x "$VENV/bin/python" ] || die "cmake ${v:-none} is older than $CMAKE_MIN and there is no venv to install one into"
    vv="$(cmake_version "$VENV/bin/cmake")"
    if ! version_ok "$vv"; then
        log "cmake ${v:-none} < $CMAKE_MIN: pip install cmake into .venv"
        "$VENV/bin/python" -m pip install -q "cmake>=$CMAKE_MIN"
        vv="$(cmake_version "$VENV/bin/cmake")"
    fi
    mkdir -p "$CACHE/cmake/bin"
    ln -sf "$VENV/bin/cmake" "$VENV/bin/ctest" "$VENV/bin/cpack" "$CACHE/cmake/bin/"
    log "cmake ${v:-none} < $CMAKE_MIN: .cache/cmake/bin has the venv's $vv"
}

# -------------------------------------------------------------------------------------------
t0=$SECONDS
[ "${CAEKF_SKIP_APT:-0}" = 1 ]   || install_apt_packages
mkdir -p "$CACHE"
[ "${CAEKF_SKIP_UNITY:-0}" = 1 ] || fetch_unity
[ "${CAEKF_SKIP_VENV:-0}" = 1 ]  || setup_venv
setup_cmake
log "done in $((SECONDS - t0)) s"
