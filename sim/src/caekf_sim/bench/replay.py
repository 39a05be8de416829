"""Replay a `candump -L` log of the bench into the estimator.

Replay sends the bench's frames of the log byte for byte (their E2E counters and CRCs included,
so recorded bad traffic stays bad) and, after each burst of bench frames, waits for the estimator
frames that closed it in the log (EST_STEP, EST_ACK). At the end every estimate and
acknowledgement frame received is compared with the recorded one, ignoring the E2E byte and
counter (the estimator's transmit counters depend on its history before the log). EST_HEALTH
frames are time-driven and are not compared.

Replay starts at the log's first configuration frame (CTRL_PARAM/CTRL_RESET) when it has one:
answers before it (a status reply, say) depend on the estimator's state before the log.

Direction of a logged frame: the log's R/T marker when present (the bench writes T for what it
sent), otherwise by ID (the DBC's estimator messages are the estimator's).
"""
from __future__ import annotations

import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .. import schema
from . import e2e
from .bench import RunRecord, StepInputs, _progress_bar
from .buslog import LogFrame, read_log
from .codec import RECORD, RECORD_SIZE
from .results import estimate_result

PathLike = Union[str, Path]
E2E_RESYNC_S = 0.6  # the estimator accepts any counter after 0.5 s of silence on a message


def masked(data: bytes) -> bytes:
    """Payload without the E2E CRC and alive counter."""
    b = bytearray(data.ljust(8, b"\0")[:8])
    b[0] = 0
    b[1] &= 0xF0
    return bytes(b)


@dataclass
class Group:
    tx: bytes
    expected: List[Tuple[int, bytes]]  # (id, masked payload) of the estimator's answer, health excluded
    closing: List[Tuple[int, bytes]]  # the EST_STEP / EST_ACK among them
    resets: int = 0  # CTRL_RESET frames in tx


@dataclass
class ReplayReport:
    frames_sent: int = 0
    expected: int = 0
    received: int = 0
    matched: int = 0
    missing: int = 0
    unexpected: int = 0
    waits_timed_out: int = 0
    elapsed: float = 0.0
    segments: List[Tuple[str, bytes, List[int]]] = field(default_factory=list)  # (experiment, rx, steps sent)

    @property
    def ok(self) -> bool:
        return self.expected > 0 and self.missing == 0 and self.unexpected == 0

    def text(self) -> str:
        return (f"replayed {self.frames_sent} bench frames in {self.elapsed:.1f} s; estimator frames "
                f"expected {self.expected}, received {self.received}, matched {self.matched}, "
                f"missing {self.missing}, unexpected {self.unexpected}; waits timed out "
                f"{self.waits_timed_out}")


def from_first_configuration(frames: Sequence[LogFrame], codec) -> List[LogFrame]:
    """The log from the bench's first CTRL_PARAM/CTRL_RESET on (all of it if it has none): what
    came before depends on the estimator's state before the log (e.g. a status reply)."""
    cfg = {codec.messages["CTRL_PARAM"].frame_id, codec.messages["CTRL_RESET"].frame_id}
    for i, f in enumerate(frames):
        if f.sent_by_bench and f.frame_id in cfg:
            return list(frames[i:])
    return list(frames)


def group_frames(frames: Sequence[LogFrame], codec) -> List[Group]:
    health = codec.messages["EST_HEALTH"].frame_id
    closing_ids = {codec.messages["EST_STEP"].frame_id, codec.messages["EST_ACK"].frame_id}
    reset_id = codec.messages["CTRL_RESET"].frame_id
    groups: List[Group] = []
    tx: List[bytes] = []
    resets = 0
    for f in frames:
        if f.sent_by_bench:
            tx.append(f.record())
            resets += f.frame_id == reset_id
            continue
        if f.frame_id == health:
            continue
        if tx:
            groups.append(Group(b"".join(tx), [], [], resets))
            tx, resets = [], 0
        if not groups:
            continue  # answers to frames sent before the log started
        key = (f.frame_id, masked(f.data))
        groups[-1].expected.append(key)
        if f.frame_id in closing_ids:
            groups[-1].closing.append(key)
    if tx:
        groups.append(Group(b"".join(tx), [], [], resets))
    return groups


def preset_of(params: Dict[int, float]) -> str:
    """The preset a configuration's CTRL_PARAM values select (the wire carries no preset): the first
    whose every value is among them, else "custom"."""
    ids = schema.param_ids()
    for p in schema.SCHEMA.presets:
        keys = {schema.SCHEMA.by_name(n).keys[0]: v for n, v in p.values.items()}
        if all(params.get(ids[k]) == v for k, v in keys.items()):
            return p.name
    return "custom"


def replay_log(bench, path: PathLike, timeout: float = 2.0, progress: Optional[bool] = None,
               resync: float = E2E_RESYNC_S) -> ReplayReport:
    """Replay a candump -L log's bench frames into the estimator (see the module docstring)."""
    codec = bench.codec
    frames = from_first_configuration(read_log(path, codec.from_estimator_ids), codec)
    groups = group_frames(frames, codec)
    rep = ReplayReport()
    health = codec.messages["EST_HEALTH"].frame_id
    closing_ids = {codec.messages["EST_STEP"].frame_id, codec.messages["EST_ACK"].frame_id}
    u_id = codec.messages["BENCH_U"].frame_id
    u_did = codec.messages["BENCH_U"].data_id
    reset_id = codec.messages["CTRL_RESET"].frame_id
    param_id = codec.messages["CTRL_PARAM"].frame_id
    segment_params: Dict[int, float] = {}
    bench.drain()
    time.sleep(resync)  # let the estimator's E2E receivers accept the log's counters
    bench.drain()
    expected_all: Counter = Counter()
    received_all: Counter = Counter()
    bar = _progress_bar(len(groups), "replay", progress)
    seg_name = "none"
    seg_rx: List[bytes] = []
    seg_steps: List[int] = []
    t0 = time.perf_counter()
    for gi, g in enumerate(groups):
        for off in range(0, len(g.tx), RECORD_SIZE):
            fid, dlc, data = RECORD.unpack_from(g.tx, off)
            if fid == param_id and dlc == 8:
                d = codec.decode(fid, data)
                segment_params[int(d["PARAM_ID"])] = float(d["PARAM_MANTISSA"]) * 10.0 ** int(d["PARAM_EXP10"])
            elif fid == reset_id and dlc == 8:
                if seg_rx or seg_steps:
                    rep.segments.append((seg_name, b"".join(seg_rx), seg_steps))
                seg_name = preset_of(segment_params)
                segment_params = {}
                seg_rx, seg_steps = [], []
            elif fid == u_id and dlc == 8 and e2e.crc_ok(u_did, data):
                seg_steps.append((data[1] >> 4) | (data[2] << 4) | ((data[3] & 0x0F) << 12))
        bench.send(g.tx)
        rep.frames_sent += len(g.tx) // RECORD_SIZE
        expected_all.update(g.expected)
        pending = Counter(g.closing)
        end = time.perf_counter() + timeout
        while +pending:
            left = end - time.perf_counter()
            if left <= 0:
                rep.waits_timed_out += 1
                break
            blob = bench.recv(left)
            if not blob:
                continue
            seg_rx.append(blob)
            for off in range(0, len(blob), RECORD_SIZE):
                fid, dlc, data = RECORD.unpack_from(blob, off)
                if fid == health:
                    continue
                key = (fid, masked(data))
                received_all[key] += 1
                if fid in closing_ids and pending[key] > 0:
                    pending[key] -= 1
        if bar is not None and gi % 200 == 0:
            bar.update(min(200, len(groups) - bar.n))
    # anything still arriving
    time.sleep(0.05)
    blob = bench.recv(0.0)
    while blob:
        seg_rx.append(blob)
        for off in range(0, len(blob), RECORD_SIZE):
            fid, dlc, data = RECORD.unpack_from(blob, off)
            if fid != health:
                received_all[(fid, masked(data))] += 1
        blob = bench.recv(0.0)
    if seg_rx or seg_steps:
        rep.segments.append((seg_name, b"".join(seg_rx), seg_steps))
    if bar is not None:
        bar.close()
    rep.elapsed = time.perf_counter() - t0
    rep.expected = sum(expected_all.values())
    rep.received = sum(received_all.values())
    rep.matched = sum((expected_all & received_all).values())
    rep.missing = rep.expected - rep.matched
    rep.unexpected = rep.received - rep.matched
    _continue_counters(bench, frames)
    return rep


def _continue_counters(bench, frames: Sequence[LogFrame]) -> None:
    """After a replay the estimator expects the log's counters to go on: so does the bench. Only frames
    the estimator accepted count: a frame with a bad CRC (recorded on purpose, say) moved no counter."""
    by_id = {m.frame_id: m for m in bench.codec.messages.values() if m.to_estimator}
    for f in frames:
        m = by_id.get(f.frame_id)
        if f.sent_by_bench and m is not None and f.dlc == 8 and e2e.crc_ok(m.data_id, f.data):
            bench.tx_counter[m.name] = ((f.data[1] & 0x0F) + 1) & 0x0F


def segment_results(bench, rep: ReplayReport, dt: float):
    """Per configuration segment of a replay: (experiment, EstimateResult of its complete steps)."""

    out = []
    for name, rx, steps in rep.segments:
        if not steps:
            continue
        s = np.asarray(steps, dtype=np.int64)
        k = np.concatenate([[s[0]], s[0] + np.cumsum((np.diff(s) + 0x8000) % 0x10000 - 0x8000)])
        first, n = int(k.min()), int(k.max() - k.min() + 1)
        wire = (first + np.arange(n)) & 0xFFFF
        t = (first + np.arange(n)) * dt
        inputs = StepInputs(t, np.zeros(n), np.zeros((n, 2)), wire, {}, np.zeros(n), np.zeros((n, 2)))
        rec = RunRecord(0, n, "replay", 1, chunks=[rx])
        dec = bench.decode_run(rec, inputs)
        out.append((name, estimate_result(dec, t)))
    return out
