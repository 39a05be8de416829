#!/usr/bin/env python3
"""Worst-case stack depth of the estimator's entry points, from GCC's -fstack-usage call graph.

    tools/mcu-stack.py --ci-dir build/cortex-m4f/firmware/core [--image x.elf] [--root caekf_step ...]

Reads every *.ci file (-fcallgraph-info=su: per-function frame size plus call edges; the MCU
toolchain file turns it on) under --ci-dir and sums frames along the deepest call path from each
root. Functions without a .ci entry (newlib/libgcc: memcpy, sqrtf, soft-float helpers...) get their
frame from the linked --image instead: the pushes, vpushes and `sub sp` of their disassembly, and
their own `bl` callees, followed the same way. Without --image such a function counts 0 and is
listed as unknown. Dynamic frames and recursion are reported, never hidden. Tail calls are counted
as calls (a safe over-estimate).

Prints one line per root:  <root> worst=<bytes> path=a(f)>b(f)>...  [unknown=..] [dynamic=..]
--json FILE writes the same as JSON.
"""
import argparse
import json
import os
import re
import subprocess
import sys

NODE = re.compile(r'node: \{ title: "([^"]+)" label: "([^"]*)"')
EDGE = re.compile(r'edge: \{ sourcename: "([^"]+)" targetname: "([^"]+)"')
BYTES = re.compile(r"\\n(\d+) bytes \(([^)]*)\)")


def read_ci(ci_dir):
    frames, kinds, edges, aliases = {}, {}, {}, {}
    for dirpath, _, files in os.walk(ci_dir):
        for fn in files:
            if not fn.endswith(".ci"):
                continue
            for line in open(os.path.join(dirpath, fn), errors="replace"):
                m = NODE.search(line)
                if m:
                    title, label = m.groups()
                    b = BYTES.search(label)
                    if b:
                        frames[title] = int(b.group(1))
                        kinds[title] = b.group(2)
                        # a static function's title is "file:name"; callers elsewhere use the title
                        aliases.setdefault(title.rsplit(":", 1)[-1], title)
                    continue
                m = EDGE.search(line)
                if m:
                    edges.setdefault(m.group(1), set()).add(m.group(2))
    return frames, kinds, edges, aliases


def read_image(image, objdump):
    """Frame size and bl/b.w callees per function symbol, from the disassembly."""
    out = subprocess.run([objdump, "-d", "--no-show-raw-insn", image], check=True,
                         capture_output=True, text=True).stdout
    frames, edges = {}, {}
    cur = None
    for line in out.splitlines():
        m = re.match(r"^[0-9a-f]+ <([^>]+)>:$", line)
        if m:
            cur = m.group(1)
            frames[cur] = 0
            edges[cur] = set()
            continue
        if cur is None or "\t" not in line:
            continue
        parts = line.split("\t")
        if len(parts) < 2:
            continue
        ins = parts[1].strip()
        args = parts[2].strip() if len(parts) > 2 else ""
        if ins.startswith("push") or ins.startswith("stmdb") and args.startswith("sp!"):
            frames[cur] += 4 * len(re.findall(r"r\d+|lr|ip|fp|sl", args.split("{", 1)[-1]))
        elif ins.startswith("vpush"):
            regs = args.strip("{}").split(",")
            n = 0
            for r in regs:
                r = r.strip()
                mm = re.match(r"([sd])(\d+)-[sd](\d+)", r)
                if mm:
                    n += (int(mm.group(3)) - int(mm.group(2)) + 1) * (8 if mm.group(1) == "d" else 4)
                elif r:
                    n += 8 if r.startswith("d") else 4
            frames[cur] += n
        elif re.match(r"subw?(\.w)?$", ins) and args.startswith("sp,"):
            mm = re.search(r"#(\d+)", args)
            if mm:
                frames[cur] += int(mm.group(1))
        elif ins.startswith("bl") and not ins.startswith("blx"):
            mm = re.search(r"<([^>+]+)>", args)
            if mm:
                edges[cur].add(mm.group(1))
    return frames, edges


def analyse(root, frames, kinds, edges, aliases, img_frames, img_edges):
    memo, unknown, dynamic, recursive = {}, set(), set(), set()

    def resolve(name):
        if name in frames:
            return name
        return aliases.get(name, name)

    def frame_of(name):
        if name in frames:
            if kinds.get(name, "static") != "static":
                dynamic.add(name)
            return frames[name], edges.get(name, set())
        plain = name.rsplit(":", 1)[-1]
        if plain in img_frames:
            return img_frames[plain], img_edges.get(plain, set())
        unknown.add(plain)
        return 0, set()

    def walk(name, stack):
        name = resolve(name)
        if name in memo:
            return memo[name]
        if name in stack:
            recursive.add(name)
            return 0, []
        f, callees = frame_of(name)
        best, best_path = 0, []
        for c in sorted(callees):
            d, p = walk(c, stack | {name})
            if d > best:
                best, best_path = d, p
        res = (f + best, [(name.rsplit(":", 1)[-1], f)] + best_path)
        memo[name] = res
        return res

    depth, path = walk(root, frozenset())
    return {"root": root, "worst": depth, "path": path, "unknown": sorted(unknown),
            "dynamic": sorted(dynamic), "recursive": sorted(recursive)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--ci-dir", required=True, action="append", help="folder searched for *.ci (repeatable)")
    ap.add_argument("--image", help="linked ELF for library functions without .ci")
    ap.add_argument("--objdump", default="arm-none-eabi-objdump")
    ap.add_argument("--root", action="append", help="entry point (default: caekf_step, caekf_init)")
    ap.add_argument("--json")
    a = ap.parse_args()

    frames, kinds, edges, aliases = {}, {}, {}, {}
    for d in a.ci_dir:
        f, k, e, al = read_ci(d)
        frames.update(f)
        kinds.update(k)
        for s, t in e.items():
            edges.setdefault(s, set()).update(t)
        aliases.update(al)
    if not frames:
        sys.exit(f"mcu-stack.py: no .ci files with frame sizes under {a.ci_dir}")
    img_frames, img_edges = ({}, {})
    if a.image:
        img_frames, img_edges = read_image(a.image, a.objdump)
    results = []
    for root in a.root or ["caekf_step", "caekf_init"]:
        r = analyse(root, frames, kinds, edges, aliases, img_frames, img_edges)
        results.append(r)
        line = f"{root} worst={r['worst']} path=" + ">".join(f"{n}({b})" for n, b in r["path"])
        for key in ("unknown", "dynamic", "recursive"):
            if r[key]:
                line += f" {key}=" + ",".join(r[key])
        print(line)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    return 1 if any(r["recursive"] or r["dynamic"] for r in results) else 0


if __name__ == "__main__":
    sys.exit(main())
