"""Fault injection on the HIL bus: frames of each fault class, and the fault-matrix table.

Every builder returns sealed records in the bench's format (16-byte struct can_frame, or 72-byte struct
canfd_frame in the fd profile: Bench.record) made with the bench's alive counters, to go in front of one
step's valid input frames (Bench.run_lockstep extra_per_step); what each one must do to the estimator
(caekf_app, EST_HEALTH counters) is said per function. The frames are the profile's: "the step's BENCH_U" is
the input message that carries u (BENCH_FD in the fd profile), "BENCH_Y1/BENCH_Y4" the ones that carry y1/y4.
"""
from __future__ import annotations

import math
from typing import Dict, List, Sequence, Tuple

from .bench import Bench, StepInputs

CAN_EFF_FLAG = 0x80000000
CAN_RTR_FLAG = 0x40000000
NONFINITE = (math.nan, math.inf, -math.inf)


def unchecked_frame(bench: Bench, name: str, values, advance: bool = True) -> bytes:
    """A sealed record of `name` with values outside the DBC's [min|max] (cantools strict=False): for
    values the protocol can carry but must refuse (PARAM_ID beyond the table, |EXP10| > 22)."""
    from . import e2e

    info = bench.codec.messages[name]
    c = bench.tx_counter[name]
    body = bench.codec.db.encode_message(name, {"E2E_CRC": 0, "E2E_COUNTER": c, **values}, strict=False)
    if advance:
        bench.tx_counter[name] = (c + 1) & 15
    return bench.record(name, (e2e.seal_fd if info.is_fd else e2e.seal)(info.data_id, c, body))


def input_message(bench: Bench, col: str) -> str:
    """The profile's input message that carries column `col` ("u", "y1", "y4")."""
    for name, sigs in bench.profile.inputs:
        if any(c == col for _, c in sigs):
            return name
    raise KeyError(f"profile {bench.profile.name} carries no input {col!r}")


def position_frames(bench: Bench) -> Tuple[str, str]:
    """The profile's position frames in the roles of BENCH_Y1 (wrong DLC, duplicate) and BENCH_Y4 (counter
    jump): BENCH_YP for both in production, BENCH_FD in the fd profile."""
    return input_message(bench, "y1"), input_message(bench, "y4")


def step_values(bench: Bench, name: str, inputs: StepInputs, row: int) -> Dict[str, float]:
    """Every signal of input message `name` at `row` (STEP and the inputs it carries), as the run sends it."""
    cols = {"u": float(inputs.u[row]), "y1": float(inputs.y[row, 0]), "y4": float(inputs.y[row, 1])}
    sigs = dict(bench.profile.inputs)[name]
    return {"STEP": int(inputs.wire_steps[row]), **{sig: cols[col] for sig, col in sigs}}


def bad_crc(bench: Bench, inputs: StepInputs, row: int) -> bytes:
    """A copy of the step's BENCH_U with the CRC byte inverted (counter not used up): RX_BAD_CRC +1."""
    name = input_message(bench, "u")
    good = bench.frame(name, step_values(bench, name, inputs, row), advance=False)
    return good[:8] + bytes([good[8] ^ 0xFF]) + good[9:]


def wrong_dlc(bench: Bench, inputs: StepInputs, row: int, name: str = "BENCH_Y1") -> bytes:
    """The step's BENCH_Y1 (or `name`) cut to 6 bytes (DLC 6): RX_BAD_DLC +1."""
    return bench.frame(name, step_values(bench, name, inputs, row), advance=False, dlc=6)


def unknown_ids(bench: Bench, inputs: StepInputs, row: int) -> bytes:
    """Four frames with IDs the estimator does not receive: 0x123, 0x7FF, EST_GAMMA's ID sent by the
    bench, and BENCH_U's number as an extended (29-bit) ID: RX_UNKNOWN_ID +4, no other effect (caekf-host
    without --kernel-filter, its default, hands every frame to the app)."""
    c = bench.codec
    return (bench.record(0x123, bytes(range(8))) + bench.record(0x7FF, bytes(8)) + bench.record("EST_GAMMA", bytes(8))
            + bench.record(c.messages[input_message(bench, "u")].frame_id | CAN_EFF_FLAG, bytes(8), fd=False))


UNKNOWN_IDS_PER_INJECTION = 4


def counter_jump(bench: Bench, inputs: StepInputs, row: int, name: str = "BENCH_Y4") -> bytes:
    """The step's BENCH_Y4 (or `name`) with its counter +5 (valid CRC): rejected, the receiver resynchronises
    on it and the bench goes on from there (the valid frame follows with the next counter): RX_COUNTER_JUMP +1."""
    jumped = (bench.tx_counter[name] + 5) & 15
    return bench.frame(name, step_values(bench, name, inputs, row), counter=jumped)


def duplicate(bench: Bench, inputs: StepInputs, row: int, name: str = "BENCH_Y1") -> bytes:
    """A valid BENCH_Y1 (or `name`) of the step twice with the same counter (the first copy opens the step),
    then the step's own frame with the next counter: RX_DUPLICATE +1 and RX_REPEATED +1 (first value kept).
    With BENCH_YP (production) the first copy brings y1 and y4, the step's BENCH_U completes it and its own
    BENCH_YP, sent after BENCH_U, is late: RX_DUPLICATE +1, RX_LATE +1; so with BENCH_FD (fd), whose first
    copy completes the step by itself."""
    f = bench.frame(name, step_values(bench, name, inputs, row))
    return f + f


def duplicate_completes_step(bench: Bench) -> bool:
    """Whether a duplicate() copy completes its step, making the step's own frame late (RX_LATE) rather than
    a repeated signal (RX_REPEATED): when one frame carries both positions (BENCH_YP, BENCH_FD)."""
    y_a, y_b = position_frames(bench)
    return y_a == y_b


def nonfinite_u(bench: Bench, inputs: StepInputs, row: int, i: int) -> bytes:
    """BENCH_U of the step with U = NaN, +Inf or -Inf (valid E2E): RX_BAD_VALUE +1; the valid one follows."""
    name = input_message(bench, "u")
    return unchecked_frame(bench, name, {**step_values(bench, name, inputs, row), "U": NONFINITE[i % 3]})


def out_of_range_param(bench: Bench, i: int) -> bytes:
    """A configuration with a value outside its parameter's range, committed by CTRL_RESET(N_PARAMS=1):
    even i: PARAM_ID beyond the table (len(param_ids)..255, RX_BAD_VALUE +1); odd i: newton_max_iter = 2.5 (an integer
    parameter).
    Refused with EST_ACK REFUSED_PARAM: CFG_REFUSED +1, the running estimator untouched."""
    n_ids = len(bench.codec.param_ids)
    if i % 2 == 0:
        pid = n_ids + (i // 2) % (256 - n_ids)
        p = unchecked_frame(bench, "CTRL_PARAM", {"PARAM_ID": pid, "PARAM_EXP10": 0, "PARAM_MANTISSA": 1})
    else:
        p = bench.param_frame("newton_max_iter", 2.5)
    token = bench._next_token()
    return p + bench.frame("CTRL_RESET", {"N_PARAMS": 1, "TOKEN": token})


def flood(bench: Bench, per_step: int = 10) -> bytes:
    """per_step unrelated frames (IDs 0x200.., not the estimator's): RX_UNKNOWN_ID +per_step, no other effect."""
    return b"".join(bench.record(0x200 + j, bytes([j & 0xFF] * 8)) for j in range(per_step))


def reset_storm(bench: Bench, n: int) -> List[int]:
    """n CTRL_RESET(N_PARAMS=0) in one burst, each re-initialising the estimator with its running
    settings (CFG_ACCEPTED +n, n EST_ACK); returns their tokens."""
    tokens = []
    blob = b""
    for _ in range(n):
        t = bench._next_token()
        tokens.append(t)
        blob += bench.frame("CTRL_RESET", {"N_PARAMS": 0, "TOKEN": t})
    bench.send(blob)
    return tokens


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    w = [max(len(str(r[i])) for r in [header, *rows]) for i in range(len(header))]
    line = lambda r: "| " + " | ".join(str(c).ljust(w[i]) for i, c in enumerate(r)) + " |"  # noqa: E731
    return "\n".join([line(header), "|" + "|".join("-" * (x + 2) for x in w) + "|", *map(line, rows)])


def count_acks(bench: Bench, chunks: Sequence[bytes]) -> Dict[str, int]:
    """EST_ACK frames in received chunks, by ACK_STATUS name."""
    out: Dict[str, int] = {}
    if not chunks:
        return out
    recs = bench.records(b"".join(chunks))
    ack_id = bench.codec.messages["EST_ACK"].frame_id
    for r in recs[recs["id"] == ack_id]:
        a = bench._decode_ack(bytes(r["data"][:8]))
        out[a.status_name] = out.get(a.status_name, 0) + 1
    return out
