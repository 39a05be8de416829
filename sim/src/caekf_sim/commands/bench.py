"""Subcommands of the CAN HIL bench: `hil run`, `hil replay-log`, and the `bench` table.

    caekf-sim hil run --iface vcan0 --scenario F --outdir DIR [--experiments ...]
                      [--mode lockstep|realtime] [--duration S] [--log FILE]
    caekf-sim hil report --outdir DIR [--truth CSV] [--compare-replay [BIN]]   (after hil run --defer-outputs)
    caekf-sim hil replay-log --log FILE [--iface vcan0] [--outdir DIR]
    caekf-sim bench [--steps N] [--iface vcan0] [--no-hil | --hil-only] [--save J] [--merge J...]

`hil` talks to an estimator that is already running on the bus (caekf-host or an MCU);
`bench` starts caekf-host itself for its HIL row when nothing answers on the interface.
"""
from __future__ import annotations

import argparse
import json
import os
import re
import signal
import subprocess
import time
from pathlib import Path
from typing import Dict, List

import numpy as np


from .. import schema
from . import add_scenario_arg, scenario_from_args

REPO = Path(__file__).resolve().parents[4]
BUILD = REPO / "build" / "host-double"
DEFAULT_HOST_BIN = BUILD / "host" / "caekf_host" / "caekf-host"
DEFAULT_REPLAY_BIN = BUILD / "host" / "caekf-replay"
DEFAULT_CBENCH_BIN = BUILD / "host" / "caekf-bench"
EXPERIMENTS = tuple(schema.preset_names())  # the paper's experiments are the schema's presets


def _bus_args(p: argparse.ArgumentParser) -> None:
    p.add_argument("--iface", default="vcan0", help="CAN channel (default vcan0)")
    p.add_argument("--interface", default="socketcan",
                   help="python-can interface (default socketcan; e.g. pcan, kvaser, virtual)")
    p.add_argument("--slow-path", action="store_true",
                   help="use python-can Messages even on SocketCAN (no CAN_RAW/mmsg fast path)")
    p.add_argument("--profile", choices=["diagnostics", "production", "fd"], default="diagnostics",
                   help="protocol profile, as the estimator's (caekf-host --profile; default diagnostics; fd: CAN "
                        "FD frames, the interface must carry them: vcan MTU 72, or a controller with fd on)")
    p.add_argument("--id-offset", type=_id_offset, default=0, metavar="N",
                   help="runtime CAN ID base: every message at its DBC ID + N (decimal or 0x hex, may be "
                        "negative), as the estimator's (caekf-host --id-offset; default 0)")


def _id_offset(text: str) -> int:
    try:
        return int(text, 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not an integer: {text!r} (decimal or 0x hex)") from None


def _codec(args):
    from ..bench.codec import Codec

    try:
        return Codec(id_offset=getattr(args, "id_offset", 0))
    except ValueError as e:
        raise SystemExit(f"caekf-sim hil: --id-offset: {e}") from None


def _progress_args(p: argparse.ArgumentParser) -> None:
    g = p.add_mutually_exclusive_group()
    g.add_argument("--progress", dest="progress", action="store_true", default=None,
                   help="tqdm progress bars (default: only on a terminal)")
    g.add_argument("--no-progress", dest="progress", action="store_false")


def register(sub: argparse._SubParsersAction) -> None:
    hil = sub.add_parser("hil", help="CAN HIL bench: run the experiments over the bus, replay bus logs")
    hsub = hil.add_subparsers(dest="hil_command", metavar="HIL_COMMAND")
    hsub.required = True

    p = hsub.add_parser("run", help="the experiments over CAN against a running estimator")
    _bus_args(p)
    add_scenario_arg(p)
    p.add_argument("--truth", type=Path, default=None,
                   help="truth CSV (t,u,y1,y4,...; e.g. from caekf-truth); default: numpy truth model")
    p.add_argument("--outdir", type=Path, required=True)
    p.add_argument("--experiments", nargs="+", choices=EXPERIMENTS, default=list(EXPERIMENTS))
    p.add_argument("--mode", choices=["lockstep", "realtime"], default="lockstep")
    p.add_argument("--realtime", dest="mode", action="store_const", const="realtime",
                   help="= --mode realtime: pace the bench at dt with absolute deadlines; report per 60 s the "
                        "deadline misses, frame-in -> estimate-out latency p50/p99/max and the bus load seen")
    p.add_argument("--echo-probe", action="store_true",
                   help="with --realtime: the estimator on the bus is caekf-host --echo (no configuration, "
                        "timing only): what the machine and the bus cost without the estimator")
    p.add_argument("--bitrate", type=float, default=1e6, help="bit rate for the bus load (default 1e6)")
    p.add_argument("--duration", type=float, default=None, help="seconds of the scenario to run (default all)")
    p.add_argument("--window", type=int, default=1,
                   help="lockstep: steps in flight (1 = strict lockstep; more overlaps round trips)")
    p.add_argument("--timeout", type=float, default=2.0, help="lockstep: per-step timeout [s]")
    p.add_argument("--log", type=Path, default=None, help="write the bus traffic as a candump -L log")
    p.add_argument("--compare-replay", nargs="?", const=str(DEFAULT_REPLAY_BIN), default=None, metavar="BIN",
                   help="also run caekf-replay on the inputs the estimator saw and compare (default BIN: "
                        "build/host-double/host/caekf-replay)")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--start-host", nargs="?", const=str(DEFAULT_HOST_BIN), default=None, metavar="BIN",
                   help="start caekf-host (default BIN: build/host-double/host/caekf_host/caekf-host) on the interface "
                        "with this --profile and --id-offset for the run and stop it afterwards (its log: "
                        "OUTDIR/caekf-host.log); without it an estimator must already be on the bus")
    p.add_argument("--host-args", default="", metavar="ARGS",
                   help="with --start-host: more caekf-host options, one string "
                        "(e.g. --host-args='--step-timeout-ms 1000')")
    p.add_argument("--then-echo-probe", action="store_true",
                   help="with --realtime --start-host: afterwards the same paced run against caekf-host --echo (the "
                        "estimator replaced by an echo; OUTDIR/realtime-echo.txt, --log's name with -echo)")
    p.add_argument("--defer-outputs", action="store_true",
                   help="only save OUTDIR/runs.npz and print the table; `hil report` writes the rest (use it where "
                        "the bus machine is slow, e.g. the TCG VM)")
    _progress_args(p)
    p.set_defaults(func=cmd_hil_run)

    p = hsub.add_parser("report", help="CSVs, summary, figures and replay comparison from a saved hil run")
    add_scenario_arg(p)
    p.add_argument("--outdir", type=Path, required=True, help="the hil run's OUTDIR (holds runs.npz)")
    p.add_argument("--truth", type=Path, default=None, help="truth CSV, for the figures")
    p.add_argument("--compare-replay", nargs="?", const=str(DEFAULT_REPLAY_BIN), default=None, metavar="BIN")
    p.add_argument("--no-figures", action="store_true")
    p.add_argument("--profile", choices=["diagnostics", "production", "fd"], default="diagnostics",
                   help="the profile the saved run used (default diagnostics)")
    p.set_defaults(func=cmd_hil_report)

    p = hsub.add_parser("replay-log", help="replay a candump -L log into the estimator and compare")
    _bus_args(p)
    add_scenario_arg(p)
    p.add_argument("--log", type=Path, required=True)
    p.add_argument("--outdir", type=Path, default=None, help="write replay-<n>-<experiment>.csv here")
    p.add_argument("--timeout", type=float, default=2.0, help="wait per answer [s]")
    _progress_args(p)
    p.set_defaults(func=cmd_hil_replay_log)

    p = sub.add_parser("busload", help="bus load per step at a rate: worst case from the DBC, and of a recorded log")
    p.add_argument("--dbc", type=Path, default=None, help="DBC (default firmware/protocol/caekf.dbc)")
    p.add_argument("--rate", type=float, default=1000.0, help="steps per second (default 1000)")
    p.add_argument("--bitrate", type=float, default=1e6, help="(nominal) bit rate (default 1e6)")
    p.add_argument("--data-bitrate", type=float, default=5e6,
                   help="CAN FD data-phase bit rate of the fd profile's frames (default 5e6)")
    p.add_argument("--profile", action="append", choices=["diagnostics", "production", "fd"], default=None,
                   help="profile(s) to compute (repeatable; default all)")
    p.add_argument("--page-period", type=int, default=20,
                   help="production: the EST_PAGE period in steps, as caekf-host --page-period (default 20)")
    p.add_argument("--log", action="append", default=None, metavar="[PROFILE=]LOG",
                   help="a candump -L log of a run in PROFILE (default: the first profile): its measured load; "
                        "repeatable")
    p.set_defaults(func=cmd_busload)

    p = sub.add_parser("gen-c", help="the C of the DBC (cantools pack/unpack, message table, wire enumerations) into "
                                     "a folder, as the build generates it")
    p.add_argument("--out", type=Path, required=True, help="the folder (include/ and src/ are made in it)")
    p.set_defaults(func=cmd_gen_c)

    p = sub.add_parser("bench", help="steps/s: C estimator, numpy, FilterPy, and HIL lockstep over CAN")
    add_scenario_arg(p)
    _bus_args(p)
    p.add_argument("--truth", type=Path, default=None, help="truth CSV (default: caekf-truth or numpy)")
    p.add_argument("--steps", type=int, default=None, help="steps for numpy/FilterPy/HIL (default: all)")
    p.add_argument("--hil-steps", type=int, default=10000, help="steps of each HIL run (default 10000)")
    p.add_argument("--windows", default="1,32", help="HIL lockstep windows to measure (default 1,32)")
    p.add_argument("--c-bench", type=Path, default=DEFAULT_CBENCH_BIN)
    p.add_argument("--host-bin", type=Path, default=DEFAULT_HOST_BIN,
                   help="caekf-host to start when no estimator answers on the interface")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--no-hil", action="store_true", help="skip the HIL row")
    g.add_argument("--hil-only", action="store_true", help="only the HIL row")
    p.add_argument("--save", type=Path, default=None, help="also write the rows as JSON")
    p.add_argument("--merge", type=Path, nargs="*", default=[], help="add rows saved by another run")
    p.add_argument("--where", default=None, help="label of this machine in the table")
    p.set_defaults(func=cmd_bench)


# --- hil run ---------------------------------------------------------------------------------

def _open_bench(args, record_log: bool = False):
    from ..bench import Bench
    from ..bench.transport import interface_exists

    if args.interface == "socketcan" and not interface_exists(args.iface):
        raise SystemExit(f"caekf-sim hil: no CAN interface '{args.iface}' here. This kernel may have no "
                         "SocketCAN: run through tools/with-vcan.sh (it boots user-mode Linux with vcan0), or pass "
                         "--iface/--interface for real hardware.")
    return Bench.open(args.interface, args.iface, fast=not args.slow_path, record_log=record_log,
                      profile=getattr(args, "profile", "diagnostics"), codec=_codec(args))


def cmd_hil_echo_probe(args: argparse.Namespace) -> int:
    """--realtime --echo-probe: the paced run against caekf-host --echo; timing report only."""
    from ..bench.realtime import format_paced, paced_stats, write_candump
    from ..bench.runner import load_truth, rows_for

    sc = scenario_from_args(args)
    with _open_bench(args) as bench:
        truth = load_truth(sc, args.truth)
        bench.match_scenario(sc)
        inputs = bench.prepare(truth.t, truth.u, truth.y)
        rows = rows_for(sc, len(inputs), args.duration)
        rec = bench.run_paced(inputs, sc.dt, 0, rows, echo=True)
    p = rec.paced
    text = format_paced(f"ECHO PROBE (caekf-host --echo, no estimator), {rows} steps at {1 / sc.dt:g} Hz",
                        paced_stats(p, args.bitrate), sc.dt, args.bitrate)
    print(text)
    args.outdir.mkdir(parents=True, exist_ok=True)
    (args.outdir / "realtime-echo.txt").write_text(text + "\n", encoding="utf-8")
    if args.log is not None:
        n = write_candump(args.log, args.iface, p.frames_t_ns, p.frames)
        print(f"hil: wrote {n} frames to {args.log} (candump -L, kernel timestamps)")
    return 0


def _realtime_report(runs, args, dt: float) -> str:
    from ..bench.realtime import format_paced, paced_stats, write_candump

    blocks = []
    for i, r in enumerate(runs):
        p = r.record.paced
        if p is None:
            continue
        blocks.append(format_paced(f"realtime {r.experiment}, {r.record.n} steps at {1 / dt:g} Hz",
                                   paced_stats(p, args.bitrate), dt, args.bitrate))
        if args.log is not None:
            path = args.log if len(runs) == 1 else \
                args.log.with_name(f"{args.log.stem}-{r.experiment}{args.log.suffix}")
            n = write_candump(path, args.iface, p.frames_t_ns, p.frames)
            blocks.append(f"hil: wrote {n} frames to {path} (candump -L, kernel timestamps)")
    return "\n".join(blocks)


def _with_host(args, func, echo: bool = False, append: bool = False) -> int:
    """func() with caekf-host started for it when --start-host asks (its non-zero counters printed after)."""
    if args.start_host is None:
        return func()
    import shlex

    from ..bench.hostproc import HostError, counters, running_host

    args.outdir.mkdir(parents=True, exist_ok=True)
    log = args.outdir / "caekf-host.log"
    extra = shlex.split(args.host_args) + (["--echo"] if echo else [])
    try:
        with running_host(args.start_host, args.iface, log, args.profile, args.id_offset, extra, append=append):
            rc = func()
    except HostError as e:
        raise SystemExit(f"caekf-sim hil run: {e}") from None
    print(f"== caekf-host{' --echo' if echo else ''} (stopped):\n{counters(log)}", flush=True)
    return rc


def cmd_hil_run(args: argparse.Namespace) -> int:
    if args.mode != "realtime" and (args.echo_probe or args.then_echo_probe):
        raise SystemExit("caekf-sim hil run: --echo-probe and --then-echo-probe need --realtime")
    if args.then_echo_probe and args.start_host is None:
        raise SystemExit("caekf-sim hil run: --then-echo-probe needs --start-host (it restarts caekf-host with --echo)")
    if args.echo_probe:
        return _with_host(args, lambda: cmd_hil_echo_probe(args), echo=True)
    rc = _with_host(args, lambda: _hil_run(args))
    if args.then_echo_probe:
        echo = argparse.Namespace(**vars(args))
        echo.log = args.log.with_name(f"{args.log.stem}-echo{args.log.suffix}") if args.log else None
        rc_echo = _with_host(echo, lambda: cmd_hil_echo_probe(echo), echo=True, append=True)
        rc = rc or rc_echo
    return rc


def _hil_run(args: argparse.Namespace) -> int:
    from ..bench.results import RUNS_FILE, format_summary, save_runs
    from ..bench.runner import load_truth, run_experiments

    sc = scenario_from_args(args)
    scenario_path = args.scenario or _default_scenario()
    t_start = time.perf_counter()
    paced_log = args.mode == "realtime" and args.interface == "socketcan"  # the recorder keeps the log
    with _open_bench(args, record_log=args.log is not None and not paced_log) as bench:
        truth = load_truth(sc, args.truth)
        print(f"hil: truth loaded ({len(truth.t)} samples) after {time.perf_counter() - t_start:.1f} s", flush=True)
        st = bench.wait_for_estimator()
        print(f"hil: estimator answers on {args.iface} (configured: {bool(st['_state'] & 1)}, steps done so far "
              f"{st.get('STEPS_DONE', 0)})", flush=True)
        runs = run_experiments(bench, sc, truth, args.experiments, args.duration, args.mode, args.window,
                               args.timeout, args.progress, log=lambda s: print(s, flush=True))
        if args.log is not None and not paced_log:
            n = bench.write_log(args.log)
            print(f"hil: wrote {n} frames to {args.log} (candump -L)")
    args.outdir.mkdir(parents=True, exist_ok=True)
    if args.mode == "realtime":
        rt = _realtime_report(runs, args, sc.dt)
        if rt:
            print(rt)
            (args.outdir / "realtime.txt").write_text(rt + "\n", encoding="utf-8")
    header = (f"caekf HIL over CAN ({args.interface} {args.iface}), {args.mode}"
              + (f" window {args.window}" if args.mode == "lockstep" else "")
              + f", scenario {scenario_path}, {runs[0].record.n if runs else 0} steps per experiment")
    saved = save_runs(runs, args.outdir / RUNS_FILE, header)
    rc = 2 if any(r.record.timeouts for r in runs) else 0
    if args.defer_outputs:
        print(header + "\n" + format_summary(runs, sc.gamma))
        print(f"hil: runs saved to {saved} after {time.perf_counter() - t_start:.1f} s; CSVs, summary.txt, "
              f"figures and the replay comparison: caekf-sim hil report --outdir {args.outdir}")
        return rc
    rc |= _report(runs, header, args.outdir, sc, scenario_path, truth, args.compare_replay, not args.no_figures,
                  args.profile)
    print(f"hil: total {time.perf_counter() - t_start:.1f} s; results in {args.outdir}")
    return rc


def _report(runs, header, outdir: Path, sc, scenario_path, truth, compare_bin, figures: bool,
            profile: str = "diagnostics") -> int:
    """CSVs, summary.txt (+ the caekf-replay comparison), figures; prints the summary. 1 if CAN != replay."""
    from ..bench.codec import Codec
    from ..bench.results import compare_runs_with_replay, write_outputs

    t0 = time.perf_counter()
    text, pngs = write_outputs(runs, outdir, sc.gamma, sc.gamma_min, truth, header, figures=figures)
    print(f"hil: results written in {time.perf_counter() - t0:.1f} s", flush=True)
    rc = 0
    if compare_bin:
        t0 = time.perf_counter()
        from ..bench.profiles import get_profile

        block, ok = compare_runs_with_replay(runs, compare_bin, scenario_path, outdir, Codec(), get_profile(profile))
        with open(outdir / "summary.txt", "a", encoding="utf-8") as f:
            f.write(block + "\n")
        text += "\n" + block
        rc = 0 if ok else 1
        print(f"hil: caekf-replay comparison in {time.perf_counter() - t0:.1f} s", flush=True)
    print(text)
    for p in pngs:
        print(f"wrote {p}")
    return rc


def cmd_hil_report(args: argparse.Namespace) -> int:
    from ..bench.results import RUNS_FILE, load_runs
    from ..truth import read_truth_csv

    sc = scenario_from_args(args)
    path = args.outdir / RUNS_FILE
    if not path.exists():
        raise SystemExit(f"caekf-sim hil report: {path} not found (written by caekf-sim hil run)")
    runs, header = load_runs(path)
    truth = read_truth_csv(args.truth) if args.truth else None
    if truth is None and not args.no_figures:
        print("hil report: no --truth: no figures")
    rc = _report(runs, header, args.outdir, sc, args.scenario or _default_scenario(), truth, args.compare_replay,
                 not args.no_figures and truth is not None, args.profile)
    return rc | (2 if any(r.record.timeouts for r in runs) else 0)


def cmd_hil_replay_log(args: argparse.Namespace) -> int:
    from ..bench.replay import replay_log, segment_results
    from ..results import write_result_csv

    sc = scenario_from_args(args)
    with _open_bench(args) as bench:
        bench.wait_for_estimator()
        rep = replay_log(bench, args.log, timeout=args.timeout, progress=args.progress)
        print(rep.text())
        if args.outdir is not None:
            args.outdir.mkdir(parents=True, exist_ok=True)
            for i, (name, res) in enumerate(segment_results(bench, rep, sc.dt)):
                path = args.outdir / f"replay-{i}-{name}.csv"
                write_result_csv(res, path)
                print(f"wrote {path} ({len(res.t)} steps)")
    return 0 if rep.ok else 1


# --- gen-c -----------------------------------------------------------------------------------

def cmd_gen_c(args: argparse.Namespace) -> int:
    from .. import codegen

    for p in codegen.write(args.out):
        print(f"wrote {p}")
    return 0


# --- busload ---------------------------------------------------------------------------------

def cmd_busload(args: argparse.Namespace) -> int:
    import cantools

    from ..bench.busload import dbc_profile_load, fd_log_seconds, log_load, read_candump, read_candump_fd
    from ..bench.codec import default_dbc_path
    from ..bench.profiles import PROFILES, production

    dbc = args.dbc or default_dbc_path()
    db = cantools.database.load_file(str(dbc))
    names = args.profile or list(PROFILES)
    logs: Dict[str, List[Path]] = {}
    for item in args.log or []:
        prof, sep, path = item.partition("=")
        if not sep:
            prof, path = names[0], item
        if prof not in PROFILES:
            raise SystemExit(f"caekf-sim busload: --log {item}: unknown profile {prof!r}")
        logs.setdefault(prof, []).append(Path(path))
    print(f"bus load at {args.rate:g} steps/s, {args.bitrate / 1e6:g} Mbit/s, 11-bit IDs, worst-case bit stuffing "
          f"(CAN FD frames: {args.data_bitrate / 1e6:g} Mbit/s data phase, bit-rate switch)")
    print(f"{'profile':<12}  {'source':<40}  {'frames/step':>11}  {'us/step':>8}  {'load':>7}")
    for name in names:
        prof = production(args.page_period, args.rate) if name == "production" else PROFILES[name]
        msgs = list(prof.per_step)
        pl = dbc_profile_load(db, msgs, args.rate, args.bitrate, args.data_bitrate, name, prof.per_step)
        print(f"{name:<12}  {'computed from ' + dbc.name:<40}  {pl.frames_per_step:>11.2f}  "
              f"{1e6 * pl.seconds_per_step:>8.1f}  {100 * pl.load:>6.1f}%")
        for path in logs.get(name, []):
            if not path.is_file():
                raise SystemExit(f"caekf-sim busload: {path}: no such log")
            t, ids, dlc, data = read_candump(path)
            t_fd, _, len_fd = read_candump_fd(path)
            t_all = np.concatenate([t, t_fd])
            seconds = float(t_all.max() - t_all.min()) + 135e-6 if len(t_all) else 0.0
            ll = log_load(t, ids, dlc, data, args.bitrate, seconds)
            fd_s = fd_log_seconds(len_fd, args.bitrate, args.data_bitrate)  # CAN FD frames: worst case
            steps = max(1.0, seconds * args.rate)
            frames = ll.frames + len(len_fd)
            for kind, bits in (("worst", ll.bits_worst), ("exact", ll.bits_exact)):
                s = bits / args.bitrate + fd_s
                print(f"{name:<12}  {'measured, ' + path.name + f' ({kind})':<40}  {frames / steps:>11.2f}  "
                      f"{1e6 * s / steps:>8.1f}  {100 * s / seconds if seconds else float('nan'):>6.1f}%")
            print(f"{'':<12}  (log: {frames} frames ({len(len_fd)} CAN FD) over {seconds:.3f} s; exact = the "
                  "stuff bits of the recorded classic contents, CAN FD frames at their worst case)")
    return 0


# --- bench -----------------------------------------------------------------------------------

def _c_bench(bin_path: Path, scenario: Path, truth_csv: Path) -> List[Dict]:
    if not bin_path.exists():
        return [{"implementation": "C estimator (caekf-bench)", "experiment": "-", "steps_per_s": None,
                 "note": f"{bin_path} not built"}]
    out = subprocess.run([str(bin_path), str(scenario), str(truth_csv), "3"], check=True,
                         capture_output=True, text=True).stdout
    rows = []
    for line in out.splitlines():
        m = re.match(r"(\S+)\s+(\S+)\s+(\d+)\s+(\d+)\s+([\d.]+)", line)
        if m:
            rows.append({"implementation": f"C estimator ({m.group(2)}, caekf-bench)", "experiment": m.group(1),
                         "steps_per_s": float(m.group(4)), "steps": int(m.group(3)), "note": "best of 3"})
    return rows


def _truth_csv(args, sc, tmpdir: Path) -> Path:
    if args.truth is not None:
        return args.truth
    tool = BUILD / "host" / "caekf-truth"
    path = tmpdir / "bench-truth.csv"
    if tool.exists():
        subprocess.run([str(tool), "--scenario", str(args.scenario or _default_scenario()), "--out", str(path),
                        "--quiet"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    else:
        from ..truth import simulate, write_truth_csv

        write_truth_csv(simulate(sc), path)
    return path


def _default_scenario() -> Path:
    from ..scenario import default_scenario_path

    return default_scenario_path()


def _hil_rows(args, sc, truth) -> List[Dict]:
    from ..bench import Bench, BenchError
    from ..bench.transport import interface_exists

    label = "HIL lockstep over CAN (caekf-host)"
    if args.interface == "socketcan" and not interface_exists(args.iface):
        return [{"implementation": label, "experiment": "switched", "steps_per_s": None,
                 "note": f"not measured: no CAN interface {args.iface} here (tools/hil-bench.sh runs it in a VM)"}]
    host = None
    rows = []
    bench = Bench.open(args.interface, args.iface, fast=not args.slow_path)
    try:
        try:
            bench.status(timeout=0.3, retries=1)
        except BenchError:
            if not args.host_bin.exists():
                return [{"implementation": label, "experiment": "switched", "steps_per_s": None,
                         "note": f"no estimator answers and {args.host_bin} is not built"}]
            host = subprocess.Popen([str(args.host_bin), "--iface", args.iface, "--quiet", "--status-period-ms", "0",
                                     "--step-timeout-ms", "1000"],
                                    stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
            bench.wait_for_estimator()
        inputs = bench.prepare(truth.t, truth.u, truth.y)
        n = min(args.hil_steps, len(inputs))
        for w in [int(x) for x in args.windows.split(",") if x]:
            bench.configure("switched", bench.params_from_scenario(sc, "switched"))
            rec = bench.run_lockstep(inputs, 0, n, window=w, timeout=1.0, progress=False)
            dec = bench.decode_run(rec, inputs)
            rows.append({"implementation": f"HIL lockstep over CAN, window {w}", "experiment": "switched",
                         "steps_per_s": n / rec.elapsed, "steps": n,
                         "note": f"{bench.transport.name}; {int(dec.complete.sum())}/{n} complete, "
                                 f"timeouts {rec.timeouts}"})
    finally:
        bench.close()
        if host is not None:
            host.send_signal(signal.SIGTERM)
            try:
                host.wait(5)
            except subprocess.TimeoutExpired:
                host.kill()
    return rows


def cmd_bench(args: argparse.Namespace) -> int:
    import tempfile

    from ..experiments import experiment_config, run_experiment
    from ..truth import Truth, read_truth_csv

    sc = scenario_from_args(args)
    where = args.where or ("user-mode Linux (1 CPU)" if os.environ.get("CAEKF_UML_GUEST") else "host")
    rows: List[Dict] = []
    with tempfile.TemporaryDirectory() as td:
        truth_csv = _truth_csv(args, sc, Path(td))
        full = read_truth_csv(truth_csv)
        n = min(args.steps or len(full), len(full))
        truth = Truth(full.t[:n], full.u[:n], full.y[:n], full.q[:n], full.v[:n], full.delta[:n])
        if not args.hil_only:
            rows += _c_bench(args.c_bench, args.scenario or _default_scenario(), truth_csv)
            res = run_experiment(sc, truth, "switched", keep_P=False)
            rows.append({"implementation": "numpy AEKF (caekf_sim.estimator)", "experiment": "switched",
                         "steps_per_s": res.steps_per_second, "steps": n, "note": ""})
            try:
                from ..filterpy_check import _filterpy_ekf_class, run_filterpy

                _filterpy_ekf_class()  # imports filterpy (and scipy) before the clock starts
                t0 = time.perf_counter()
                run_filterpy(sc, truth, experiment_config("canonical"))
                rows.append({"implementation": "FilterPy EKF (caekf_sim.filterpy_check)", "experiment": "canonical",
                             "steps_per_s": n / (time.perf_counter() - t0), "steps": n, "note": ""})
            except ImportError as exc:
                rows.append({"implementation": "FilterPy EKF", "experiment": "canonical", "steps_per_s": None,
                             "note": f"filterpy missing: {exc}"})
        if not args.no_hil:
            rows += _hil_rows(args, sc, truth)
    for r in rows:
        r.setdefault("where", where)
    if args.save:
        args.save.parent.mkdir(parents=True, exist_ok=True)
        args.save.write_text(json.dumps(rows, indent=1), encoding="utf-8")
    for m in args.merge:
        rows += json.loads(Path(m).read_text(encoding="utf-8"))
    from ..bench.results import format_table

    table = [[r["implementation"], r["experiment"], r.get("where", "?"),
              f"{r['steps_per_s']:,.0f}" if r.get("steps_per_s") else "-", r.get("note", "")] for r in rows]
    print(f"steps per second on {Path(args.scenario or _default_scenario()).name}, "
          f"{n} steps for numpy/FilterPy (dt = {sc.dt:g} s: real time is {1 / sc.dt:,.0f} steps/s)")
    print(format_table(["implementation", "experiment", "where", "steps/s", "note"], table))
    return 0
