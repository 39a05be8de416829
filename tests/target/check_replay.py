#!/usr/bin/env python3
"""Check target_replay's output against the host's caekf-replay (double) trajectory.

    check_replay.py --mode double|float [--float-sigma K] --reference host.csv [--output FILE] -- qemu-run.sh ... image
    check_replay.py --mode ... --reference host.csv --from FILE     (check a saved output)
    check_replay.py --stack-only --from FILE --stack-budget 512     (budget check of a saved output)

The state's columns are the host CSV's between t and p_norm (q1..q4, v1..v4, gamma for the paper; any
mechanism's, the law's and the mechanism's estimated parameters too: a build sized for another scenario);
each "S" line of the image carries as many values.
double (Cortex-M7): every snapshot's state and P_gg must match the host within 1e-9
  relative: |a - b| <= 1e-9 * max(|b|, scale), scale = the largest |b| of that column over the
  whole host trajectory (so components crossing zero are judged against their own size).
float (Cortex-M4F): every contact's final gamma (gamma, gamma2, ...) within 0.5 % of the host's (double), or,
  with --float-sigma K, within K of the host estimate's standard deviations (sqrt of its final p_gg, p_gg2,
  ...): the float and the double run are two realisations of one filter, and where the estimate is uncertain
  (a noisy random walk, the whole contact law estimated) they part by more than 0.5 % and by little of it.
Both: the image must finish ("replay: done") with exit status 0 and print as many steps as the host.
Flag/Newton-iteration mismatches at snapshots are reported (and fail in double mode).
"""
import argparse
import csv
import math
import struct
import subprocess
import sys

TOL_DOUBLE = 1e-9
TOL_FLOAT_GAMMA = 5e-3
def bits_to_double(h):
    return struct.unpack("<d", struct.pack("<Q", int(h, 16)))[0]


def parse_output(text, n=None):
    """The image's output; its "S" lines carry n state values (then P_gg, flags, iterations; n None: not read)."""
    snaps, summary, stack, steps, done = {}, {}, {}, None, False
    for line in text.splitlines():
        if line.startswith("S ") and n is not None:
            p = line.split()
            if len(p) != n + 5:
                raise SystemExit(f"check_replay: a snapshot of {len(p) - 5} values, the host's state has {n}: "
                                 f"{line[:80]}")
            k = int(p[1])
            vals = [bits_to_double(h) for h in p[2:n + 3]]
            snaps[k] = {"x": vals[:n], "p_gg": vals[n], "flags": int(p[n + 3]), "iters": int(p[n + 4])}
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
    """(state column names, rows) of caekf-replay's CSV: the state is every column between t and p_norm; each
    contact's gamma (gamma, gamma2, ...) has its variance in p_gg, p_gg2, ..."""
    rows = []
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        header = list(reader.fieldnames or [])
        cols = header[1:header.index("p_norm")]
        gammas = [c for c in cols if c.startswith("gamma")]
        for r in reader:
            rows.append({"x": [float(r[c]) for c in cols], "p_gg": float(r["p_gg"]),
                         "var": {c: float(r["p_gg" + c[len("gamma"):]]) for c in gammas},
                         "flags": int(r["flags"]), "iters": int(r["newton_iters"])})
    return cols, rows


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
    ap.add_argument("--float-sigma", type=float, default=0.0,
                    help="float: a final gamma may also lie within this many of the host's standard deviations")
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
    if a.stack_only:
        return check_stack(parse_output(text)[2], a.stack_budget)
    cols, ref = load_reference(a.reference)
    n = len(cols)
    snaps, summary, stack, steps, done = parse_output(text, n)

    fails = 0
    if status != 0 or not done:
        print(f"check_replay: FAIL image exit status {status}, finished={done}")
        fails += 1
    if steps != len(ref):
        print(f"check_replay: FAIL image ran {steps} steps, host {len(ref)}")
        return 1
    if not snaps:
        print("check_replay: FAIL no snapshots in the output")
        return 1
    scale = [max(abs(r["x"][i]) for r in ref) for i in range(n)]
    scale_pgg = max(abs(r["p_gg"]) for r in ref)
    worst = [0.0] * (n + 1)
    flag_mismatch = 0
    for k, s in sorted(snaps.items()):
        r = ref[k - 1]
        for i in range(n):
            err = abs(s["x"][i] - r["x"][i]) / max(abs(r["x"][i]), scale[i], 1e-300)
            worst[i] = max(worst[i], err)
        worst[n] = max(worst[n], abs(s["p_gg"] - r["p_gg"]) / max(abs(r["p_gg"]), scale_pgg, 1e-300))
        if s["flags"] != r["flags"] or s["iters"] != r["iters"]:
            flag_mismatch += 1
    names = cols + ["p_gg"]
    print("check_replay: %d snapshots; max scaled error per column: %s" %
          (len(snaps), " ".join(f"{c}={e:.2e}" for c, e in zip(names, worst))))
    print(f"check_replay: snapshots with different flags/newton_iters: {flag_mismatch}")
    float_fails = []
    for c in (c for c in cols if c.startswith("gamma")):  # gamma, gamma2, ...: each contact's
        final_t = snaps[max(snaps)]["x"][cols.index(c)]
        final_h = ref[max(snaps) - 1]["x"][cols.index(c)]
        sigma_h = math.sqrt(max(ref[max(snaps) - 1]["var"][c], 0.0))
        rel = abs(final_t - final_h) / abs(final_h)
        in_sigmas = abs(final_t - final_h) / sigma_h if sigma_h > 0 else math.inf
        print(f"check_replay: final {c} target {final_t:.10g} host {final_h:.10g} rel. diff {rel:.3e} "
              f"({in_sigmas:.3f} of the host's standard deviations)")
        if rel > TOL_FLOAT_GAMMA and in_sigmas > a.float_sigma:
            float_fails.append(f"final {c} differs by {100 * rel:.3f} % (> 0.5 %) and by {in_sigmas:.3f} standard "
                               f"deviations (> {a.float_sigma:g})")
    if a.mode == "double":
        if max(worst) > TOL_DOUBLE:
            print(f"check_replay: FAIL scaled error {max(worst):.3e} > {TOL_DOUBLE}")
            fails += 1
        if flag_mismatch:
            print("check_replay: FAIL flags/iterations differ from the host")
            fails += 1
    else:
        for msg in float_fails:
            print(f"check_replay: FAIL {msg}")
            fails += 1
    if stack:
        print(f"check_replay: stack init={stack.get('init')} B steps={stack.get('steps')} B")
    print("check_replay: " + ("ok" if fails == 0 else "FAILED"))
    return 0 if fails == 0 else 1


if __name__ == "__main__":
    sys.exit(main())
