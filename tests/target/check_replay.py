#!/usr/bin/env python3
"""Check target_replay's output against the host's caekf-replay (double) trajectory.

    check_replay.py --mode double|float --reference host.csv [--output FILE] -- qemu-run.sh ... image
    check_replay.py --mode ... --reference host.csv --from FILE     (check a saved output)
    check_replay.py --stack-only --from FILE --stack-budget 512     (budget check of a saved output)

double (Cortex-M7): every snapshot's state x0..x8 and P_gg must match the host within 1e-9
  relative: |a - b| <= 1e-9 * max(|b|, scale), scale = the largest |b| of that column over the
  whole host trajectory (so components crossing zero are judged against their own size).
float (Cortex-M4F): the final gamma within 0.5 % of the host's (double) final gamma.
Both: the image must finish ("replay: done") with exit status 0 and print as many steps as the host.
Flag/Newton-iteration mismatches at snapshots are reported (and fail in double mode).
"""
import argparse
import csv
import struct
import subprocess
import sys

TOL_DOUBLE = 1e-9
TOL_FLOAT_GAMMA = 5e-3
COLS = ["q1", "q2", "q3", "q4", "v1", "v2", "v3", "v4", "gamma"]


def bits_to_double(h):
    return struct.unpack("<d", struct.pack("<Q", int(h, 16)))[0]


def parse_output(text):
    snaps, summary, stack, steps, done = {}, {}, {}, None, False
    for line in text.splitlines():
        if line.startswith("S "):
            p = line.split()
            k = int(p[1])
            vals = [bits_to_double(h) for h in p[2:12]]
            snaps[k] = {"x": vals[:9], "p_gg": vals[9], "flags": int(p[12]), "iters": int(p[13])}
        elif line.startswith("summary:"):
            summary = dict(kv.split("=", 1) for kv in line.split()[1:])
        elif line.startswith("stack:"):
            stack = {k: int(v) for k, v in (kv.split("=", 1) for kv in line.split()[1:])}
        elif line.startswith("replay: mcu="):
            for kv in line.split()[1:]:
                if kv.startswith("steps="):
                    steps = int(kv[6:])
        elif line.strip() == "replay: done":
            done = True
    return snaps, summary, stack, steps, done


def load_reference(path):
    rows = []
    with open(path, newline="") as f:
        for r in csv.DictReader(f):
            rows.append({"x": [float(r[c]) for c in COLS], "p_gg": float(r["p_gg"]),
                         "flags": int(r["flags"]), "iters": int(r["newton_iters"])})
    return rows


def check_stack(stack, budget):
    if not stack:
        print("check_replay: no 'stack:' line")
        return 1
    print(f"check_replay: stack init={stack.get('init')} B, steps={stack.get('steps')} B "
          f"(reserved {stack.get('reserved')} B, budget {budget} B)")
    worst = max(stack.get("init", 0), stack.get("steps", 0))
    if worst > budget:
        print(f"check_replay: FAIL measured stack {worst} B exceeds the budget {budget} B")
        return 1
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mode", choices=("double", "float"))
    ap.add_argument("--reference")
    ap.add_argument("--output", help="save the image's output here")
    ap.add_argument("--from", dest="from_file", help="check a saved output instead of running")
    ap.add_argument("--stack-only", action="store_true")
    ap.add_argument("--stack-budget", type=int, default=512)
    ap.add_argument("cmd", nargs="*")
    a = ap.parse_args()

    status = 0
    if a.from_file:
        text = open(a.from_file).read()
    else:
        if not a.cmd:
            ap.error("a command to run the image (or --from FILE) is required")
        proc = subprocess.run(a.cmd, capture_output=True, text=True)
        text, status = proc.stdout, proc.returncode
        sys.stderr.write(proc.stderr)
        if a.output:
            with open(a.output, "w") as f:
                f.write(text)
    snaps, summary, stack, steps, done = parse_output(text)
    if a.stack_only:
        return check_stack(stack, a.stack_budget)

    fails = 0
    if status != 0 or not done:
        print(f"check_replay: FAIL image exit status {status}, finished={done}")
        fails += 1
    ref = load_reference(a.reference)
    if steps != len(ref):
        print(f"check_replay: FAIL image ran {steps} steps, host {len(ref)}")
        return 1
    if not snaps:
        print("check_replay: FAIL no snapshots in the output")
        return 1
    scale = [max(abs(r["x"][i]) for r in ref) for i in range(9)]
    scale_pgg = max(abs(r["p_gg"]) for r in ref)
    worst = [0.0] * 10
    flag_mismatch = 0
    for k, s in sorted(snaps.items()):
        r = ref[k - 1]
        for i in range(9):
            err = abs(s["x"][i] - r["x"][i]) / max(abs(r["x"][i]), scale[i], 1e-300)
            worst[i] = max(worst[i], err)
        worst[9] = max(worst[9], abs(s["p_gg"] - r["p_gg"]) / max(abs(r["p_gg"]), scale_pgg, 1e-300))
        if s["flags"] != r["flags"] or s["iters"] != r["iters"]:
            flag_mismatch += 1
    names = COLS + ["p_gg"]
    print("check_replay: %d snapshots; max scaled error per column: %s" %
          (len(snaps), " ".join(f"{n}={e:.2e}" for n, e in zip(names, worst))))
    print(f"check_replay: snapshots with different flags/newton_iters: {flag_mismatch}")
    final_t = snaps[max(snaps)]["x"][8]
    final_h = ref[max(snaps) - 1]["x"][8]
    rel = abs(final_t - final_h) / abs(final_h)
    print(f"check_replay: final gamma target {final_t:.10g} host {final_h:.10g} rel. diff {rel:.3e}")
    if a.mode == "double":
        if max(worst) > TOL_DOUBLE:
            print(f"check_replay: FAIL scaled error {max(worst):.3e} > {TOL_DOUBLE}")
            fails += 1
        if flag_mismatch:
            print("check_replay: FAIL flags/iterations differ from the host")
            fails += 1
    else:
        if rel > TOL_FLOAT_GAMMA:
            print(f"check_replay: FAIL final gamma differs by {100 * rel:.3f} % (> 0.5 %)")
            fails += 1
    if stack:
        print(f"check_replay: stack init={stack.get('init')} B steps={stack.get('steps')} B")
    print("check_replay: " + ("ok" if fails == 0 else "FAILED"))
    return 0 if fails == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
