"""Bus logs: write the bench's journal as a `candump -L` log (python-can's CanutilsLogWriter) and read
one back (read_log). Replaying a log into the estimator is caekf_sim.bench.replay.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import List, Sequence, Tuple, Union


from .codec import RECORD, RECORD_SIZE

PathLike = Union[str, Path]


def write_journal(journal: Sequence[Tuple[float, int, bytes]], path: PathLike, channel: str,
                  wall_offset: float) -> int:
    """Journal entries (perf_counter time, 0 sent / 1 received, records) -> candump -L log."""
    import can
    from can.io import CanutilsLogWriter

    n = 0
    writer = CanutilsLogWriter(str(path), channel=channel)
    try:
        for t, direction, blob in journal:
            ts = t + wall_offset
            for off in range(0, len(blob), RECORD_SIZE):
                fid, dlc, data = RECORD.unpack_from(blob, off)
                writer.on_message_received(can.Message(
                    timestamp=ts, arbitration_id=fid, is_extended_id=False, dlc=dlc,
                    data=data[: min(dlc, 8)], is_rx=bool(direction), channel=channel))
                n += 1
    finally:
        writer.stop()
    return n


@dataclass
class LogFrame:
    t: float
    sent_by_bench: bool
    frame_id: int
    dlc: int
    data: bytes

    def record(self) -> bytes:
        return RECORD.pack(self.frame_id, self.dlc, self.data.ljust(8, b"\0")[:8])


def read_log(path: PathLike, estimator_ids: Sequence[int]) -> List[LogFrame]:
    """Frames of a candump -L log (classic CAN data frames; error/remote/extended frames skipped)."""
    from can.io import CanutilsLogReader

    text = Path(path).read_text(encoding="ascii", errors="replace")
    has_markers = any(line.rstrip().endswith(" T") for line in text.splitlines())
    est = set(estimator_ids)
    out: List[LogFrame] = []
    for msg in CanutilsLogReader(str(path)):
        if msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id or msg.is_fd:
            continue
        sent = (not msg.is_rx) if has_markers else msg.arbitration_id not in est
        out.append(LogFrame(float(msg.timestamp), sent, msg.arbitration_id, msg.dlc, bytes(msg.data)))
    return out
