#!/usr/bin/env python3
"""Run a Cortex-M image under QEMU with the icount plugin and summarise instructions per interval.

    icount-run.py --machine mps2-an386 --plugin build/.../libqemu-icount.so image.elf
                  [--expect-from-output] [--counts FILE] [--guest-output FILE] [--json FILE]
                  [--profile N [--profile-interval K]]

The marker addresses (caekf_mark_begin / caekf_mark_end, or --begin/--end symbols) are read from
the image with arm-none-eabi-nm. The image runs through tools/qemu-run.sh (timeout, exit status).
Prints one line:  intervals=N min=.. median=.. max=.. mean=..
--expect-from-output: the guest prints "expect: c0 c1 ..." and the counts must equal it exactly
(tests/target/icount_calib.c). --max-budget N: every interval must be <= N instructions.
--profile N prints the N functions executing the most instructions, over the whole run or, with
--profile-interval K, inside interval K only (0-based; e.g. the argmax step).
Exit status: the guest's if non-zero, 1 on a mismatch or over budget, else 0.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
QEMU_RUN = os.path.join(HERE, "..", "qemu-run.sh")


def symbol_address(nm, image, name):
    out = subprocess.run([nm, "--defined-only", image], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[2] == name:
            return int(parts[0], 16) & ~1
    raise SystemExit(f"icount-run.py: symbol {name} not found in {image}")


def run(args):
    nm = os.environ.get("CAEKF_ARM_NM", "arm-none-eabi-nm")
    begin = symbol_address(nm, args.image, args.begin)
    end = symbol_address(nm, args.image, args.end)
    with tempfile.TemporaryDirectory(prefix="icount-") as tmp:
        counts_path = args.counts or os.path.join(tmp, "counts.txt")
        log_path = os.path.join(tmp, "plugin.log")
        plugin = f"{args.plugin},begin={begin:#x},end={end:#x},out={counts_path}"
        prof_path = os.path.join(tmp, "profile.txt")
        if args.profile:
            plugin += f",profile={prof_path}"
            if args.profile_interval is not None:
                plugin += f",profile_interval={args.profile_interval}"
        cmd = [QEMU_RUN, "--machine", args.machine, "--timeout", str(args.timeout),
               "--plugin", plugin, "--log", log_path, "--", args.image]
        proc = subprocess.run(cmd, capture_output=True, text=True)
        guest = proc.stdout
        if args.guest_output:
            with open(args.guest_output, "w") as f:
                f.write(guest)
        sys.stderr.write(proc.stderr)
        log = open(log_path).read() if os.path.exists(log_path) else ""
        counts = []
        if os.path.exists(counts_path):
            with open(counts_path) as f:
                counts = [int(x) for x in f.read().split()]
        if args.profile and os.path.exists(prof_path):
            where = "the whole run" if args.profile_interval is None else f"interval {args.profile_interval}"
            print_profile(nm, args.image, prof_path, args.profile, where)
    return proc.returncode, guest, log, counts, begin, end


def profile_by_function(nm, image, path):
    """{function: instructions} from a plugin profile file (blocks attributed to the enclosing symbol)."""
    syms = []
    out = subprocess.run([nm, "--defined-only", "-n", "-S", image], check=True, capture_output=True, text=True).stdout
    for line in out.splitlines():
        p = line.split()
        if len(p) == 4 and p[2] in "tTwW":
            syms.append((int(p[0], 16) & ~1, int(p[1], 16), p[3]))
    syms.sort()
    per = {}
    import bisect
    starts = [s[0] for s in syms]
    for line in open(path):
        va, n, ex = line.split()
        va, insns = int(va, 16), int(n) * int(ex)
        i = bisect.bisect_right(starts, va) - 1
        name = syms[i][2] if i >= 0 and va < syms[i][0] + max(syms[i][1], 2) else f"?{va:#x}"
        per[name] = per.get(name, 0) + insns
    return per


def print_profile(nm, image, path, top, where="the whole run"):
    per = profile_by_function(nm, image, path)
    total = sum(per.values())
    print(f"profile: {total} instructions in {where}, top {top} functions:")
    for name, v in sorted(per.items(), key=lambda kv: -kv[1])[:top]:
        print(f"profile: {v:12d} {100.0 * v / total:6.2f} %  {name}")


def summary(counts):
    if not counts:
        return {"intervals": 0}
    s = sorted(counts)
    return {
        "intervals": len(counts),
        "min": s[0],
        "median": s[(len(s) - 1) // 2],
        "max": s[-1],
        "mean": round(statistics.fmean(counts), 1),
        "argmax": counts.index(s[-1]),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("image")
    ap.add_argument("--machine", required=True)
    ap.add_argument("--plugin", required=True, help="path of libqemu-icount.so")
    ap.add_argument("--begin", default="caekf_mark_begin")
    ap.add_argument("--end", default="caekf_mark_end")
    ap.add_argument("--timeout", type=int, default=600)
    ap.add_argument("--counts", help="write the per-interval counts here (one per line)")
    ap.add_argument("--guest-output", help="write the guest's console output here")
    ap.add_argument("--json", help="write the summary as JSON here")
    ap.add_argument("--expect-from-output", action="store_true")
    ap.add_argument("--max-budget", type=int, help="fail if any interval exceeds this many instructions")
    ap.add_argument("--quiet", action="store_true", help="do not echo the guest output")
    ap.add_argument("--profile", type=int, default=0, metavar="N",
                    help="also print the N functions executing the most instructions (whole run)")
    ap.add_argument("--profile-interval", type=int, metavar="K",
                    help="with --profile: profile interval K only (0-based)")
    args = ap.parse_args()

    status, guest, log, counts, begin, end = run(args)
    if not args.quiet:
        sys.stdout.write(guest)
    for line in log.splitlines():
        if line.startswith("icount: intervals="):
            print(f"plugin: {line[len('icount: '):]}")
    summ = summary(counts)
    summ.update({"image": os.path.basename(args.image), "machine": args.machine,
                 "begin": hex(begin), "end": hex(end), "guest_status": status})
    print("icount-run: " + " ".join(f"{k}={v}" for k, v in summ.items()))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(summ, f, indent=1)
    if status != 0:
        print(f"icount-run: guest exit status {status}", file=sys.stderr)
        return status
    if args.expect_from_output:
        exp = None
        for line in guest.splitlines():
            if line.startswith("expect:"):
                exp = [int(x) for x in line.split()[1:]]
        if exp is None:
            print("icount-run: no 'expect:' line in the guest output", file=sys.stderr)
            return 1
        if exp != counts:
            print(f"icount-run: MISMATCH expected {exp} got {counts}", file=sys.stderr)
            return 1
        print(f"icount-run: counts match the expected {exp}")
    if args.max_budget is not None:
        if not counts or max(counts) > args.max_budget:
            print(f"icount-run: FAIL max {summ.get('max')} instructions per interval > budget {args.max_budget}",
                  file=sys.stderr)
            return 1
        print(f"icount-run: max {summ['max']} <= budget {args.max_budget}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
