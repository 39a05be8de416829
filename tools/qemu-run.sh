#!/bin/sh
# tools/qemu-run.sh - run one Cortex-M image under QEMU and return the guest's exit status.
#
#   tools/qemu-run.sh --machine mps2-an386|mps2-an500 [--timeout SECONDS] [--plugin SO,ARGS]
#                     [--log FILE] [--] image.elf [guest args...]
#
# It is CMAKE_CROSSCOMPILING_EMULATOR of the cortex-m4f / cortex-m7 builds, so ctest runs every
# target test through it. The image talks to the host by semihosting: its console goes to our
# stdout, and its exit status (SYS_EXIT_EXTENDED) becomes ours. A hung guest never exits by
# itself: after the timeout (default 900 s, or $CAEKF_QEMU_TIMEOUT) QEMU is killed and the status
# is 124, as with timeout(1).
#
# --plugin SO,ARGS  loads a TCG plugin, e.g. build/.../libqemu-icount.so,begin=0x..,end=0x..;
#                   plugin output (qemu_plugin_outs) goes to --log FILE (default: stderr).
# Guest arguments are passed as semihosting argv (SYS_GET_CMDLINE); they must not contain commas.
set -eu

machine=""
timeout_s="${CAEKF_QEMU_TIMEOUT:-900}"
plugin=""
logfile=""
qemu="${CAEKF_QEMU:-qemu-system-arm}"

usage() {
    sed -n '2,17p' "$0" | sed 's/^# \{0,1\}//' >&2
    exit 2
}

while [ $# -gt 0 ]; do
    case "$1" in
        --machine) machine="$2"; shift 2 ;;
        --machine=*) machine="${1#*=}"; shift ;;
        --timeout) timeout_s="$2"; shift 2 ;;
        --timeout=*) timeout_s="${1#*=}"; shift ;;
        --plugin) plugin="$2"; shift 2 ;;
        --plugin=*) plugin="${1#*=}"; shift ;;
        --log) logfile="$2"; shift 2 ;;
        --log=*) logfile="${1#*=}"; shift ;;
        -h|--help) usage ;;
        --) shift; break ;;
        -*) echo "qemu-run.sh: unknown option $1" >&2; usage ;;
        *) break ;;
    esac
done
[ $# -ge 1 ] || usage
[ -n "$machine" ] || { echo "qemu-run.sh: --machine is required" >&2; exit 2; }
image="$1"
shift
[ -f "$image" ] || { echo "qemu-run.sh: no image $image" >&2; exit 2; }

semi="enable=on,target=native,arg=$(basename "$image")"
for a in "$@"; do
    case "$a" in *,*) echo "qemu-run.sh: guest argument with a comma: $a" >&2; exit 2 ;; esac
    semi="$semi,arg=$a"
done

set -- -M "$machine" -nographic -monitor none -serial none \
    -semihosting-config "$semi" -kernel "$image"
if [ -n "$plugin" ]; then
    set -- "$@" -plugin "$plugin" -d plugin
    if [ -n "$logfile" ]; then
        set -- "$@" -D "$logfile"
    fi
fi

# -k: QEMU ignoring SIGTERM still dies 5 s later. </dev/null: QEMU never reads the terminal.
status=0
timeout -k 5 "$timeout_s" "$qemu" "$@" </dev/null || status=$?
if [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then
    echo "qemu-run.sh: $(basename "$image") timed out after ${timeout_s}s on $machine" >&2
fi
exit "$status"
