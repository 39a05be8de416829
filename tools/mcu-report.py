#!/usr/bin/env python3
"""One command for the MCU numbers: instructions per step, memory, stack.

    tools/mcu-report.py [--no-build] [--no-o2] [--presets cortex-m4f,cortex-m7] [--json FILE]
                        [--breakdown N]

For each preset (default cortex-m4f and cortex-m7; configured/built with `cmake --preset` if needed,
which needs the host-double preset's test data, see tests/target/Replay.cmake):
  * a preset configured with CAEKF_MECHANISM_PRESET (sized for one configuration: cortex-m4f) has no
    default image: the recommended default's figures come from build/<preset>-default, the same
    mechanism sized for the default's configuration (CAEKF_MECHANISM_PRESET=default), and the joint
    four-parameter step's (ln gamma, n, lambda and gap estimated: sim/scenarios/paper-joint.toml, the
    same mechanism and truth) from build/<preset>-joint (configured and built here); each default image
    also runs with the full PSD test of P on every step (target_replay_default_worst): its max is the
    constructed worst case (a contact step with the most Newton iterations and the full test);
  * instructions per estimator step: tests/target/target_replay.elf (the switched-highq-constrained
    experiment of the reference scenario, 60,000 steps) under QEMU with the TCG plugin
    tools/qemu-icount; min / median / max over all steps, and the worst case of the steps with
    contact active + constraint applied + the most Newton iterations seen with both
    (each count includes ~8 instructions of call overhead around caekf_step);
  * text/data/bss (arm-none-eabi-size) of the estimator library, of what the replay image really
    links from it (linker map), of every image; sizeof(caekf_t) (one instance's RAM);
  * stack: worst case from -fstack-usage/-fcallgraph-info (tools/mcu-stack.py) for caekf_step and
    caekf_init, and the measured stack painting of the replay image;
  * with -O2 as well (build/<preset>-o2, library and replay image only) unless --no-o2;
  * with --breakdown N: instructions per function (the N largest) inside the median step, the max
    step and the worst-case step (one more QEMU run each, plugin option profile_interval); for the
    default and the joint step, the median and max steps and the constructed worst case's step (in
    target_replay_default_worst);
  * for a preset sized for one configuration (cortex-m4f), the same figures for an 8-body, 2-contact
    mechanism (tests/target/chain8.toml, its own truth record): the preset's step in build/<preset>-chain8,
    the recommended default's in build/<preset>-chain8-default.
Goals checked (Cortex-M4F, -Os): worst case <= 8000 instructions/step, library text <= 10.5 KB (the
estimator library: the settings' names live in <core>_names), static RAM + one instance <= 2 KB,
stack <= 512 B (the paper's presets); the recommended default's worst case (max, constructed) <= 16000
(issue 14).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
MACHINE = {"cortex-m4f": "mps2-an386", "cortex-m7": "mps2-an500"}
FLAG_CONSTRAINT_APPLIED = 1 << 2
FLAG_CONTACT_ACTIVE = 1 << 3
GOAL_ICOUNT, GOAL_TEXT, GOAL_RAM, GOAL_STACK = 8000, 10752, 2048, 512  # 10.5 KB text, 2 KB RAM
GOAL_ICOUNT_DEFAULT = 16000  # issue 14: the default estimator, < 10 % of 1 ms at 168 MHz


def default_method():
    """The recommended default's method, as the schema's defaults give it (one source: settings.toml)."""
    import tomllib
    with open(os.path.join(ROOT, "sim", "src", "caekf_sim", "schema", "settings.toml"), "rb") as f:
        default = {s["name"]: s.get("default") for s in tomllib.load(f)["setting"]}
    return (f"{default['discretisation']}, {default['contact_substeps']} contact substeps, contact_slr_p "
            f"{default['contact_slr_p']}")


def sh(cmd, **kw):
    return subprocess.run(cmd, check=True, capture_output=True, text=True, **kw).stdout


def cache_value(bdir, key):
    try:
        for line in open(os.path.join(bdir, "CMakeCache.txt")):
            if line.startswith(key + ":"):
                return line.split("=", 1)[1].strip()
    except OSError:
        pass
    return None


def build(preset, bdir, extra=(), targets=()):
    stale = [e for e in extra if e.startswith("-D") and "=" in e
             and cache_value(bdir, e[2:].split("=", 1)[0].split(":", 1)[0]) not in (None, e.split("=", 1)[1])]
    if not os.path.exists(os.path.join(bdir, "CMakeCache.txt")) or stale:
        print(f"mcu-report: configuring {bdir}", file=sys.stderr)
        subprocess.run(["cmake", "--preset", preset, "-B", bdir, "--no-warn-unused-cli", *extra], check=True, cwd=ROOT,
                       stdout=subprocess.DEVNULL)
    cmd = ["cmake", "--build", bdir, "-j", os.environ.get("JOBS", "2")]
    if targets:  # only those the configuration has (a build sized for one configuration has one replay image)
        known = {line.split(":")[0] for line in sh(["ninja", "-C", bdir, "-t", "targets", "all"]).splitlines()}
        targets = [t for t in targets if t in known]
    for t in targets:
        cmd += ["--target", t]
    subprocess.run(cmd, check=True, cwd=ROOT, stdout=subprocess.DEVNULL)


def size_of(path):
    """(text, data, bss) totals of an ELF or an archive."""
    out = sh(["arm-none-eabi-size", "-t", path] if path.endswith(".a") else ["arm-none-eabi-size", path])
    last = out.strip().splitlines()[-1].split()
    return int(last[0]), int(last[1]), int(last[2])


def linked_from_map(mapfile):
    """text/data/bss linked into an image per origin: core library vs toolchain libraries."""
    res = {"core": [0, 0, 0], "toolchain": [0, 0, 0]}
    text = open(mapfile).read()
    i = text.find("Linker script and memory map")
    lines = text[i:].splitlines() if i >= 0 else []
    pending = None
    for line in lines:
        m = re.match(r"^ (\.\S+|COMMON)\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$", line)
        if not m and re.match(r"^ (\.\S+|COMMON)\s*$", line):
            pending = line.strip()
            continue
        if not m and pending:
            m2 = re.match(r"^\s+0x([0-9a-f]+)\s+0x([0-9a-f]+)\s+(\S.*)$", line)
            if m2:
                sec, size, origin = pending, int(m2.group(2), 16), m2.group(3)
            else:
                pending = None
                continue
        elif m:
            sec, size, origin = m.group(1), int(m.group(3), 16), m.group(4)
        else:
            continue
        pending = None
        if size == 0:
            continue
        if "libcaekf_core.a" in origin:
            who = "core"
        elif "/arm-none-eabi/" in origin or "/gcc/arm-none-eabi/" in origin:
            who = "toolchain"
        else:
            continue
        if sec.startswith((".text", ".rodata")):
            res[who][0] += size
        elif sec.startswith(".data"):
            res[who][1] += size
        elif sec.startswith((".bss", "COMMON")):
            res[who][2] += size
    return res


def symbol_size(image, name):
    for line in sh(["arm-none-eabi-nm", "-S", "--defined-only", image]).splitlines():
        p = line.split()
        if len(p) == 4 and p[3] == name:
            return int(p[1], 16)
    return None


def icount(bdir, preset, name="target_replay"):
    image = os.path.join(bdir, "tests", "target", name + ".elf")
    plugin = os.path.join(bdir, "tools", "qemu-icount", "libqemu-icount.so")
    with tempfile.TemporaryDirectory(prefix="mcu-report-") as tmp:
        counts_f, guest_f = os.path.join(tmp, "counts"), os.path.join(tmp, "guest")
        subprocess.run([sys.executable, os.path.join(ROOT, "tools", "qemu-icount", "icount-run.py"),
                        "--machine", MACHINE[preset], "--plugin", plugin, "--quiet",
                        "--counts", counts_f, "--guest-output", guest_f, image],
                       check=True, stdout=subprocess.DEVNULL)
        counts = [int(x) for x in open(counts_f).read().split()]
        guest = open(guest_f).read()
    classes = []
    stack = {}
    summary = ""
    for line in guest.splitlines():
        if line.startswith("C "):
            classes += [int(h, 16) for h in line.split()[1:]]
        elif line.startswith("stack:"):
            stack = {k: int(v) for k, v in (kv.split("=") for kv in line.split()[1:])}
        elif line.startswith("summary:"):
            summary = line
    if len(classes) != len(counts):
        raise SystemExit(f"mcu-report: {len(counts)} counted steps but {len(classes)} step classes")
    s = sorted(counts)
    both = [(c, (cl >> 9) & 31) for c, cl in zip(counts, classes)
            if cl & FLAG_CONTACT_ACTIVE and cl & FLAG_CONSTRAINT_APPLIED]
    r = {"steps": len(counts), "min": s[0], "median": s[(len(s) - 1) // 2], "max": s[-1],
         "max_step": counts.index(s[-1]) + 1, "stack_measured": stack, "summary": summary}
    r["median_step"] = counts.index(r["median"]) + 1
    if both:
        it = max(i for _, i in both)
        r["worst_case"] = max(c for c, i in both if i == it)
        r["worst_case_step"] = 1 + next(k for k, (c, cl) in enumerate(zip(counts, classes))
                                        if c == r["worst_case"] and cl & FLAG_CONTACT_ACTIVE
                                        and cl & FLAG_CONSTRAINT_APPLIED and (cl >> 9) & 31 == it)
        r["worst_case_iters"] = it
        r["worst_case_steps"] = sum(1 for _, i in both if i == it)
        r["contact_constraint_steps"] = len(both)
    iters_all = [(cl >> 9) & 31 for cl in classes]
    r["newton_iters_max"] = max(iters_all)
    # Marginal cost of one Newton iteration: median count per (flags, iterations) group, differences
    # between consecutive iteration counts with the same flags, median of those.
    groups = {}
    for c, cl in zip(counts, classes):
        groups.setdefault((cl & 0x1FF, (cl >> 9) & 31), []).append(c)
    med = {k: sorted(v)[(len(v) - 1) // 2] for k, v in groups.items()}
    deltas = []
    for (fl, it), m in med.items():
        if (fl, it + 1) in med:
            deltas.append(med[(fl, it + 1)] - m)
    if deltas:
        deltas.sort()
        r["per_newton_iteration"] = deltas[(len(deltas) - 1) // 2]
    return r


def breakdown(bdir, preset, steps, top, name="target_replay"):
    """{label: [(function, instructions), ...] + [("total", all)]} for the given 1-based steps (one QEMU
    run each); the list holds the top functions, the total all of them."""
    image = os.path.join(bdir, "tests", "target", name + ".elf")
    plugin = os.path.join(bdir, "tools", "qemu-icount", "libqemu-icount.so")
    res = {}
    for label, step in steps:
        out = sh([sys.executable, os.path.join(ROOT, "tools", "qemu-icount", "icount-run.py"),
                  "--machine", MACHINE[preset], "--plugin", plugin, "--quiet", "--profile", str(top),
                  "--profile-interval", str(step - 1), image])
        rows, total = [], None
        for line in out.splitlines():
            m = re.match(r"profile:\s+(\d+)\s+\S+ %\s+(\S+)$", line)
            if m:
                rows.append((m.group(2), int(m.group(1))))
            m = re.match(r"profile: (\d+) instructions in ", line)
            if m:
                total = int(m.group(1))
        res[f"{label} (step {step})"] = rows + [("total", total)]
    return res


def stack_static(bdir, image="target_replay"):
    out = sh([sys.executable, os.path.join(ROOT, "tools", "mcu-stack.py"),
              "--ci-dir", os.path.join(bdir, "firmware", "core"),
              "--image", os.path.join(bdir, "tests", "target", image + ".elf"),
              "--root", "caekf_step", "--root", "caekf_init"])
    res = {}
    for line in out.splitlines():
        m = re.match(r"(\S+) worst=(\d+) path=(\S+)(.*)", line)
        if m:
            res[m.group(1)] = {"worst": int(m.group(2)), "path": m.group(3), "notes": m.group(4).strip()}
    return res


# An 8-body, 2-contact mechanism (issue 10: the paper's figures for such a build as well): the same
# preset sized for it, its own truth record replayed.
CHAIN8 = os.path.join(ROOT, "tests", "target", "chain8.toml")


# The paper's chain with its 12 masses, springs and dampers declared uncertain (issue 27): the default's step
# estimating them with gamma, the paper's truth replayed.
MECH12 = os.path.join(ROOT, "tests", "target", "paper-mech12.toml")


def sized_for(scenario):
    """CMake options of a build sized for a scenario's mechanism and replaying that scenario's truth."""
    return [f"-DCAEKF_MECHANISM={scenario}", f"-DCAEKF_SCENARIO={scenario}"]


def measure(ddir, preset, image):
    """One replay image's instructions per step, with its build's library text, instance and static stack;
    None when the build has no such image."""
    path = os.path.join(ddir, "tests", "target", image + ".elf")
    if not os.path.exists(path):
        return None
    ic = icount(ddir, preset, image)
    ic["build"] = os.path.relpath(ddir, ROOT)
    ic["lib"] = size_of(os.path.join(ddir, "firmware", "core", "libcaekf_core.a"))
    ic["sizeof_caekf_t"] = symbol_size(path, "est")
    st = stack_static(ddir, image)
    ic["stack_static"] = st.get("caekf_step", {}).get("worst")
    ic["stack_static_init"] = st.get("caekf_init", {}).get("worst")
    return ic


def report_chain8(preset, bdir, args):
    """The paper's presets' figures (their step method and the switched-highq-constrained preset) for a
    build sized for tests/target/chain8.toml, replaying that mechanism's truth (build/<preset>-chain8)."""
    cdir = bdir + "-chain8"
    if not args.no_build:
        build(preset, cdir, sized_for(CHAIN8), ["target_replay", "qemu_icount_plugin"])
    return measure(cdir, preset, "target_replay")


def report_preset(preset, args, o2):
    bdir = os.path.join(ROOT, "build", preset + ("-o2" if o2 else ""))
    if not args.no_build:
        extra = []
        if o2:
            # same host data as the -Os build; only the library and the replay images are built (the tests
            # stay configured: the replay images take their settings from the tests' fixture)
            extra = ["-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS_RELEASE=-O2 -g -DNDEBUG"]
            for key in ("CAEKF_HOST_BUILD_DIR", "CAEKF_TESTDATA_DIR"):
                v = cache_value(os.path.join(ROOT, "build", preset), key)
                if v:
                    extra.append(f"-D{key}={v}")
        targets = ["target_replay", "target_replay_default", "qemu_icount_plugin"] if o2 else []
        build(preset, bdir, extra, targets)
    lib = os.path.join(bdir, "firmware", "core", "libcaekf_core.a")
    replay = os.path.join(bdir, "tests", "target", "target_replay.elf")
    if not (os.path.exists(lib) and os.path.exists(replay)):
        print(f"mcu-report: {bdir} has no library or replay image; skipped", file=sys.stderr)
        return None
    r = {"preset": preset, "opt": "-O2" if o2 else "-Os", "lib": size_of(lib)}
    r["linked"] = linked_from_map(replay + ".map")
    r["sizeof_caekf_t"] = symbol_size(replay, "est")
    r["icount"] = icount(bdir, preset)
    if os.path.exists(os.path.join(bdir, "tests", "target", "target_replay_default.elf")):
        r["icount_default"] = icount(bdir, preset, "target_replay_default")
        if os.path.exists(os.path.join(bdir, "tests", "target", "target_replay_default_worst.elf")):
            r["icount_default"]["constructed"] = icount(bdir, preset, "target_replay_default_worst")
    elif cache_value(bdir, "CAEKF_MECHANISM_PRESET"):
        # Sized for one configuration (a preset's step method): no default image. The default's numbers
        # come from the same mechanism's build sized for the default's configuration
        # (CAEKF_MECHANISM_PRESET=default, build/<preset>[-o2]-default), and the joint four-parameter
        # step's from the same mechanism estimating its whole contact law (sim/scenarios/paper-joint.toml,
        # build/<preset>[-o2]-joint; -Os only).
        # (label, build folder suffix, CMake options, whether the paper's truth is its truth: a variant with
        # its own mechanism must not take the host test data of the preset's build)
        variants = [("default", "-default", [], True)]
        if not o2:
            variants.append(("joint", "-joint", sized_for(os.path.join(ROOT, "sim", "scenarios", "paper-joint.toml")),
                             True))
            variants.append(("chain8", "-chain8-default", sized_for(CHAIN8), False))
            variants.append(("mech12", "-mech12", sized_for(MECH12), True))
        for label, suffix, vextra, paper_truth in variants:
            ddir = bdir + suffix
            if not args.no_build:
                extra = ["-DCAEKF_MECHANISM_PRESET=default", *vextra]
                if o2:
                    extra += ["-DCMAKE_BUILD_TYPE=Release", "-DCMAKE_C_FLAGS_RELEASE=-O2 -g -DNDEBUG"]
                for key in ("CAEKF_HOST_BUILD_DIR", "CAEKF_TESTDATA_DIR") if paper_truth else ():
                    v = cache_value(os.path.join(ROOT, "build", preset), key)
                    if v:
                        extra.append(f"-D{key}={v}")
                build(preset, ddir, extra, ["target_replay_default", "target_replay_default_worst",
                                            "qemu_icount_plugin"])
            ic = measure(ddir, preset, "target_replay_default")
            if ic is None:
                continue
            if os.path.exists(os.path.join(ddir, "tests", "target", "target_replay_default_worst.elf")):
                ic["constructed"] = icount(ddir, preset, "target_replay_default_worst")
            r["icount_" + label] = ic
            if args.breakdown:
                r["breakdown_" + label] = breakdown(ddir, preset, [("median", ic["median_step"]),
                                                                   ("max", ic["max_step"])],
                                                    args.breakdown, "target_replay_default")
                if "constructed" in ic:  # the constructed worst case's own step, in its own image
                    r["breakdown_" + label].update(breakdown(
                        ddir, preset, [("constructed worst", ic["constructed"]["max_step"])], args.breakdown,
                        "target_replay_default_worst"))
            if label == "default":
                r["lib_default"] = ic["lib"]
        if not o2:
            r["chain8"] = report_chain8(preset, bdir, args)
    r["stack_static"] = stack_static(bdir)
    if args.breakdown:
        ic = r["icount"]
        steps = [("median", ic["median_step"]), ("max", ic["max_step"])]
        if "worst_case_step" in ic:
            steps.append(("worst case", ic["worst_case_step"]))
        r["breakdown"] = breakdown(bdir, preset, steps, args.breakdown)
    if not o2:
        images = []
        for dirpath, _, files in os.walk(os.path.join(bdir, "tests")):
            for f in sorted(files):
                if f.endswith(".elf"):
                    images.append((f[:-4], size_of(os.path.join(dirpath, f))))
        r["images"] = sorted(images)
    return r


def fmt_row(cols, widths):
    return "| " + " | ".join(str(c).ljust(w) for c, w in zip(cols, widths)) + " |"


def table(title, header, rows):
    widths = [max(len(str(x)) for x in col) for col in zip(header, *rows)]
    print(f"\n{title}")
    print(fmt_row(header, widths))
    print("|" + "|".join("-" * (w + 2) for w in widths) + "|")
    for row in rows:
        print(fmt_row(row, widths))


def ok(v, goal):
    return "yes" if v <= goal else "NO"


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--presets", default="cortex-m4f,cortex-m7")
    ap.add_argument("--no-build", action="store_true", help="use the existing builds as they are")
    ap.add_argument("--no-o2", action="store_true", help="skip the -O2 builds")
    ap.add_argument("--json", help="also write all numbers as JSON")
    ap.add_argument("--breakdown", type=int, default=0, metavar="N",
                    help="per-function instructions (top N) of the median, max and worst-case steps")
    a = ap.parse_args()

    results = []
    for p in a.presets.split(","):
        results.append(report_preset(p, a, False))
        if not a.no_o2:
            results.append(report_preset(p, a, True))
    results = [r for r in results if r is not None]
    if not results:
        return 1

    rows = []
    for r in results:
        ic = r["icount"]
        wc = ic.get("worst_case")
        wc_s = f"{wc} ({ic['worst_case_iters']} it, {ic['worst_case_steps']} steps)" if wc else "n/a"
        goal = ok(wc if wc else ic["max"], GOAL_ICOUNT) if r["preset"] == "cortex-m4f" else "-"
        rows.append([r["preset"], r["opt"], ic["min"], ic["median"], f"{ic['max']} (step {ic['max_step']})",
                     wc_s, goal])
    notes = []
    for r in results:
        ic = r["icount"]
        if "per_newton_iteration" in ic and "worst_case" in ic:
            bound = ic["worst_case"] + (20 - ic["worst_case_iters"]) * ic["per_newton_iteration"]
            notes.append(f"  {r['preset']} {r['opt']}: one more Newton iteration costs ~{ic['per_newton_iteration']} "
                         f"instructions; a contact+constraint step at the bound of 20 iterations would be ~{bound}")
    table("Instructions per caekf_step (QEMU TCG count, reference scenario switched-highq-constrained, "
          "60,000 steps)", ["target", "opt", "min", "median", "max", "worst case: contact+constraint, "
          "max Newton", f"<= {GOAL_ICOUNT}"], rows)
    print("\n".join(notes))
    rows = []
    for r in results:
        for label in ("default", "joint", "chain8", "mech12"):
            ic = r.get("icount_" + label)
            if not ic:
                continue
            worst = max(ic["max"], ic["constructed"]["max"]) if "constructed" in ic else ic["max"]
            goal = ok(worst, GOAL_ICOUNT_DEFAULT) if r["preset"] == "cortex-m4f" and label == "default" else "-"
            cons = ic.get("constructed")
            rows.append([r["preset"], r["opt"], label, ic.get("build", "same"), ic["min"], ic["median"],
                         f"{ic['max']} (step {ic['max_step']})",
                         f"{cons['max']} (step {cons['max_step']})" if cons else "n/a", ic["newton_iters_max"],
                         f"{ic.get('stack_static', '-')} / {ic['stack_measured'].get('steps')}",
                         ic["lib"][0] if "lib" in ic else "same",
                         ic.get("sizeof_caekf_t") or "same", goal])
    if rows:
        table(f"Instructions per caekf_step, the recommended default ({default_method()}), the joint "
              "four-parameter step (ln gamma, n, lambda, gap: sim/scenarios/paper-joint.toml) and the default on the "
              "8-body, 2-contact chain (tests/target/chain8.toml, its own truth), the default with the chain's "
              "12 masses, springs and dampers estimated (mech12: tests/target/paper-mech12.toml); 60,000 steps; "
              "constructed worst case: the full PSD test of P on every step",
              ["target", "opt", "estimator", "build", "min", "median", "max", "constructed worst case",
               "Newton iterations max", "caekf_step stack static / painted", "lib text", "sizeof(caekf_t)",
               f"worst <= {GOAL_ICOUNT_DEFAULT}"], rows)
    rows = []
    for r in results:
        ic = r.get("chain8")
        if ic:
            wc = ic.get("worst_case")
            rows.append([r["preset"], ic["build"], ic["min"], ic["median"], f"{ic['max']} (step {ic['max_step']})",
                         f"{wc} ({ic['worst_case_iters']} it, {ic['worst_case_steps']} steps)" if wc else "n/a",
                         ic["lib"][0], ic["sizeof_caekf_t"],
                         f"{ic['stack_static']} / {ic['stack_measured'].get('steps')}",
                         f"{ic['stack_static_init']} / {ic['stack_measured'].get('init')}"])
    if rows:
        table("The paper's presets' figures for an 8-body, 2-contact build (tests/target/chain8.toml, its own "
              "truth, switched-highq-constrained, 60,000 steps)",
              ["target", "build", "min", "median", "max", "worst case: contact+constraint, max Newton", "lib text",
               "sizeof(caekf_t)", "caekf_step stack static / painted", "caekf_init stack static / painted"], rows)
    for r, key, what in [(r, key, what) for r in results for key, what in
                         (("breakdown", ""), ("breakdown_default", " (the default)"), ("breakdown_joint", " (joint)"))]:
        bd = r.get(key)
        if not bd:
            continue
        names = []
        for rows in bd.values():
            names += [n for n, _ in rows if n not in names and n != "total"]
        labels = list(bd)
        per = {lab: dict(bd[lab]) for lab in labels}
        table(f"Instructions per function, {r['preset']} {r['opt']}{what} (the largest; total: all functions)",
              ["function", *labels],
              [[n, *(per[lab].get(n, "-") for lab in labels)] for n in names + ["total"]])

    rows = []
    for r in results:
        t, d, b = r["lib"]
        lt, ld, lb = r["linked"]["core"]
        tt, td, tb = r["linked"]["toolchain"]
        inst = r["sizeof_caekf_t"] or 0
        goal = (f"{ok(t, GOAL_TEXT)} / {ok(d + b + inst, GOAL_RAM)}"
                if r["preset"] == "cortex-m4f" and r["opt"] == "-Os" else "-")
        rows.append([r["preset"], r["opt"], t, d, b, f"{lt}/{ld}/{lb}", f"{tt}/{td}/{tb}",
                     r["sizeof_caekf_t"], goal])
    table("Estimator memory (bytes; text includes rodata)",
          ["target", "opt", "lib text", "lib data", "lib bss", "core linked in replay t/d/b",
           "libc+libm+libgcc in replay t/d/b", "sizeof(caekf_t)", "text<=10.5K / lib data+bss+instance<=2K"], rows)

    rows = []
    for r in results:
        st = r["stack_static"]
        ms = r["icount"]["stack_measured"]
        worst = max(st.get("caekf_step", {}).get("worst", 0), st.get("caekf_init", {}).get("worst", 0))
        goal = ok(max(worst, ms.get("steps", 0), ms.get("init", 0)), GOAL_STACK) if r["preset"] == "cortex-m4f" else "-"
        rows.append([r["preset"], r["opt"], st.get("caekf_step", {}).get("worst"),
                     st.get("caekf_init", {}).get("worst"), ms.get("steps"), ms.get("init"), goal])
    table("Stack (bytes)", ["target", "opt", "caekf_step -fstack-usage worst", "caekf_init -fstack-usage worst",
                            "caekf_step measured (painting)", "caekf_init measured", f"<= {GOAL_STACK}"], rows)
    for r in results:
        st = r["stack_static"].get("caekf_step")
        if st:
            print(f"  {r['preset']} {r['opt']} deepest path: {st['path']} {st['notes']}")

    rows = []
    for r in results:
        for name, (t, d, b) in r.get("images", []):
            rows.append([r["preset"], name, t, d, b])
    if rows:
        table("Images (-Os; arm-none-eabi-size)", ["target", "image", "text", "data", "bss"], rows)
    for r in results:
        print(f"  {r['preset']} {r['opt']} replay {r['icount']['summary']}")
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    return 0


if __name__ == "__main__":
    sys.exit(main())
