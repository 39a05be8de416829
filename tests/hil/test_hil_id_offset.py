"""Runtime CAN ID base on a bus that already uses the DBC's IDs: a second caekf-host moved by ID_OFFSET
(`--id-offset`) and a bench moved the same way (`Codec(id_offset=...)`, `caekf-sim hil run --id-offset`)
share vcan0 with the session's estimator at the DBC's IDs. The moved pair runs a stretch of the switched
experiment: its estimates equal those of the session's pair bit for bit, and the session's estimator sees
the moved traffic only as foreign IDs (no step of its own, nothing else counted).
"""
from __future__ import annotations

import numpy as np

from conftest import host_process
from hilcfg import PROFILE, report

ID_OFFSET = 0x400  # 0x0C0..0x191 -> 0x4C0..0x591: no ID shared with the DBC's block
ROWS = 3000


def test_moved_id_base_runs_beside_the_dbc_ids(iface, binaries, out_dir, bench, sc, inputs):
    from caekf_sim.bench import Bench
    from caekf_sim.bench.codec import Codec
    from caekf_sim.bench.runner import run_experiment

    codec = Codec(id_offset=ID_OFFSET)
    assert codec.messages["CTRL_RESET"].frame_id == 0x4C0 and codec.messages["EST_PAGE"].frame_id == 0x591
    with host_process(iface, binaries, out_dir / "caekf-host-moved.log", "--id-offset", hex(ID_OFFSET)):
        moved = Bench.open("socketcan", iface, profile=PROFILE, codec=codec)
        try:
            moved.wait_for_estimator(timeout=10.0)
            before = bench.status()
            run = run_experiment(moved, sc, inputs, "switched", ROWS, "lockstep", window=32, timeout=2.0)
            after = bench.status()
        finally:
            moved.close()
    ref = run_experiment(bench, sc, inputs, "switched", ROWS, "lockstep", window=32, timeout=2.0)
    assert run.record.timeouts == 0 and run.decoded.complete.all()
    assert run.health_after["STEPS_DONE"] - run.health_before["STEPS_DONE"] == ROWS
    for col in ("gamma", "flags"):
        a, b = getattr(run.result, col), getattr(ref.result, col)
        assert np.array_equal(a, b), col
    delta = {k: after[k] - before[k] for k in after if not k.startswith("_")}
    foreign = delta.pop("RX_UNKNOWN_ID")
    report(f"[{PROFILE}] ID offset {ID_OFFSET:#x}: {ROWS} steps of switched on the moved IDs equal the DBC-ID "
           f"run's; the DBC-ID estimator counted {foreign} foreign frames meanwhile")
    assert foreign >= ROWS * len(moved.profile.input_messages)
    # the status request of `bench.status()` and its answer are counted (RX_OK, STATUS_REQUESTS, TX_FRAMES:
    # EST_ACK and the EST_HEALTH pages); nothing else moved
    assert {k: v for k, v in delta.items() if v} == {"RX_OK": 1, "STATUS_REQUESTS": 1,
                                                      "TX_FRAMES": 1 + bench.codec.health_pages}
