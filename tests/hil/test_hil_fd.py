"""The CAN FD profile over vcan0 (MTU 72, set up by tools/with-vcan.sh): a second caekf-host with
`--profile fd`, moved by ID_OFFSET (`--id-offset`) so that it shares the bus with the session's estimator,
and the bench's CAN FD stepper (`caekf_sim.bench.fd`, python-can with fd=True): one BENCH_FD (20 bytes) in
and one EST_FD (64 bytes, CRC-16 E2E) out per step, bit-rate switch.

- the switched experiment over the full 60 s in lockstep: every step answered, the bench's E2E check of every
  EST_FD clean, and every value of every step equal to caekf-replay on the inputs the estimator decoded
  (the FD frames carry the diagnostics profile's resolutions); the paper's claim for it holds;
- 5 s paced at 1 kHz with the whole bus recorded: the candump log (out/.../fd-bus.log) holds one BENCH_FD and
  one EST_FD per step, and its bus load (computed from the frames, reported) is measured the way
  `caekf-sim busload --log fd=LOG` does.
"""
from __future__ import annotations

import numpy as np

from conftest import host_process
from hilcfg import report

ID_OFFSET = 0x400
PACED_ROWS = 5000


def test_fd_profile_equals_replay_and_its_log_has_two_frames_per_step(iface, binaries, out_dir, sc, inputs,
                                                                     replay):
    from caekf_sim.bench import Bench
    from caekf_sim.bench.busload import fd_log_seconds, log_load, read_candump, read_candump_fd
    from caekf_sim.bench.codec import Codec
    from caekf_sim.bench.fd import FdStepper
    from caekf_sim.bench.profiles import DATA_BITRATE, FD
    from caekf_sim.bench.results import compare_with_replay

    codec = Codec(id_offset=ID_OFFSET)
    with host_process(iface, binaries, out_dir / "caekf-host-fd.log", "--id-offset", hex(ID_OFFSET), profile="fd"):
        bench = Bench.open("socketcan", iface, codec=codec)
        fd = FdStepper(bench, iface)
        try:
            bench.wait_for_estimator(timeout=10.0)
            bench.configure("switched", bench.params_from_scenario(sc, "switched"))
            run = fd.run(inputs, len(inputs), window=32, timeout=2.0)
            bench.configure("switched", bench.params_from_scenario(sc, "switched"))
            paced = fd.run(inputs, PACED_ROWS, dt=float(sc.dt), timeout=2.0, record=True)
            health = bench.status()
        finally:
            fd.close()
            bench.close()
    dec = run.decoded
    agr = compare_with_replay(dec, replay("switched"), codec, FD)
    err = dec.columns["gamma"][-1] / sc.gamma - 1.0
    report(f"[fd] switched, lockstep (window 32): {run.rows} steps in {run.elapsed:.1f} s = {run.steps_per_second:.0f} "
           f"steps/s; CAN vs caekf-replay: {agr.text()}; final gamma error {100 * err:+.3f} %")
    assert run.timeouts == 0 and dec.complete.all()
    assert (dec.bad_crc, dec.counter_duplicates, dec.counter_jumps) == (0, 0, 0)
    assert agr.ok, agr.text()
    assert abs(err) < 0.005  # the paper's claim for the switched filter, as in the diagnostics profile
    assert health["STEPS_DONE"] >= run.rows + PACED_ROWS * 0.95 and health["RX_BAD_DLC"] == 0

    log = out_dir / "fd-bus.log"
    paced.recorder.write_candump(log, iface)
    t, ids, dlc, data = read_candump(log)
    t_fd, ids_fd, len_fd = read_candump_fd(log)
    n_in = int(np.sum(ids_fd == codec.messages["BENCH_FD"].frame_id))
    n_out = int(np.sum(ids_fd == codec.messages["EST_FD"].frame_id))
    t_all = np.concatenate([t, t_fd])
    seconds = float(t_all.max() - t_all.min())
    classic = log_load(t, ids, dlc, data, 1e6, seconds)
    fd_s = fd_log_seconds(len_fd, 1e6, DATA_BITRATE)
    load = (classic.bits_worst / 1e6 + fd_s) / seconds
    per_step = (classic.bits_worst / 1e6 + fd_s) / PACED_ROWS
    report(f"[fd] paced {PACED_ROWS} steps at 1 kHz: answered {int(paced.decoded.complete.sum())}, bench sends late "
           f"{paced.late_sends}; log {log.name}: {n_in} BENCH_FD + {n_out} EST_FD + {len(t)} classic frames over "
           f"{seconds:.2f} s: {1e6 * per_step:.1f} us/step worst case = {100 * per_step * 1000:.1f} % of 1 Mbit/s "
           f"(5 Mbit/s data) at 1 kHz, {100 * load:.1f} % over the log's duration")
    assert n_in == PACED_ROWS and n_out == int(paced.decoded.complete.sum())
    assert set(len_fd[ids_fd == codec.messages["BENCH_FD"].frame_id].tolist()) == {20}
    assert set(len_fd[ids_fd == codec.messages["EST_FD"].frame_id].tolist()) == {64}
