"""Bus load: frame lengths on the wire, computed from the DBC and measured from a recorded log.

Classic CAN, 11-bit identifier, data frame of n bytes (ISO 11898-1), in bit times:
- exact: SOF, ID, RTR, IDE, r0, DLC, data, CRC-15 (the stuffed region, 34 + 8n bits) plus the stuff
  bits the actual contents need, then CRC delimiter, ACK slot and delimiter, EOF (10) and the
  3-bit interframe space;
- worst case: 34 + 8n + floor((34 + 8n - 1) / 4) + 13 (every stuffable position stuffed): 135 bits for
  n = 8, i.e. 135 us at 1 Mbit/s.
CAN FD, 11-bit, bit-rate switch, n bytes (worst case, nominal-rate part and data-rate part):
- nominal: SOF..BRS (17 bits) with worst dynamic stuffing (4), and CRC delimiter..IFS (13): 34 bits;
- data: ESI + DLC (5) + 8n with worst dynamic stuffing, stuff count (4), CRC-17 (n <= 16) or CRC-21,
  and the fixed stuff bits (one per 4 bits of stuff count + CRC).

`dbc_profile_load` sums, for the messages a profile sends per step, their worst-case time per step;
`log_load` sums the recorded frames' exact (and worst-case) lengths over the log's duration.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Dict, List, Optional, Sequence, Union

import numpy as np

PathLike = Union[str, Path]
FD_LENGTHS = (0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64)


def classic_bits_worst(n_bytes) -> np.ndarray:
    """Worst-case bit times of classic 11-bit data frames of n bytes (interframe space included)."""
    n = np.asarray(n_bytes, dtype=np.int64)
    return 34 + 8 * n + (34 + 8 * n - 1) // 4 + 13


def frame_bits_worst(dlc) -> np.ndarray:
    return classic_bits_worst(np.minimum(np.asarray(dlc, dtype=np.int64), 8))


def fd_time_worst(n_bytes: int, nominal: float, data: float) -> float:
    """Worst-case seconds of one CAN FD 11-bit data frame with bit-rate switch."""
    n = min(b for b in FD_LENGTHS if b >= n_bytes)
    crc = 17 if n <= 16 else 21
    nominal_bits = 17 + (17 - 1) // 4 + 13
    dyn = 5 + 8 * n
    data_bits = dyn + (dyn - 1) // 4 + 4 + crc + (4 + crc + 3) // 4
    return nominal_bits / nominal + data_bits / data


def classic_bits_exact(ids: np.ndarray, dlc: np.ndarray, data: np.ndarray) -> np.ndarray:
    """Exact bit times of classic 11-bit data frames (stuff bits from the real contents), vectorised.
    ids (k,), dlc (k,), data (k, 8) uint8."""
    k = len(ids)
    if k == 0:
        return np.zeros(0, dtype=np.int64)
    dlc = np.minimum(dlc.astype(np.int64), 8)
    nbits = 19 + 8 * dlc  # SOF..DLC (19) + data, before the CRC
    maxb = 19 + 64
    bits = np.zeros((k, maxb), dtype=np.uint8)
    idb = ids.astype(np.int64) & 0x7FF
    for j in range(11):  # ID, most significant bit first, after SOF
        bits[:, 1 + j] = (idb >> (10 - j)) & 1
    for j in range(4):
        bits[:, 15 + j] = (dlc >> (3 - j)) & 1
    db = np.unpackbits(data.astype(np.uint8), axis=1)  # MSB first per byte
    bits[:, 19:] = db
    crc = np.zeros(k, dtype=np.int64)
    for j in range(maxb):  # CRC-15 (poly 0x4599) over SOF..data
        live = j < nbits
        nxt = (bits[:, j].astype(np.int64) ^ (crc >> 14)) & 1
        new = (crc << 1) & 0x7FFF
        new = np.where(nxt == 1, new ^ 0x4599, new)
        crc = np.where(live, new, crc)
    total = nbits + 15
    stuff = np.zeros(k, dtype=np.int64)
    last = np.full(k, -1, dtype=np.int64)
    run = np.zeros(k, dtype=np.int64)
    for j in range(maxb + 15):
        # bit j of the stuffed region: frame bits, then the CRC where the data ended
        pos_crc = j - nbits
        in_crc = (pos_crc >= 0) & (pos_crc < 15)
        b = np.where(in_crc, (crc >> np.clip(14 - pos_crc, 0, 14)) & 1, bits[:, min(j, maxb - 1)] if j < maxb else 0)
        live = j < total
        same = b == last
        run = np.where(live, np.where(same, run + 1, 1), run)
        last = np.where(live, b, last)
        hit = live & (run == 5)
        stuff += hit
        last = np.where(hit, 1 - last, last)  # the stuff bit, opposite, starts a new run
        run = np.where(hit, 1, run)
    return total + stuff + 13


@dataclass
class ProfileLoad:
    name: str
    messages: List[str]
    frames_per_step: float
    seconds_per_step: float
    rate_hz: float
    bitrate: float

    @property
    def load(self) -> float:
        return self.seconds_per_step * self.rate_hz


def dbc_profile_load(db, names: Sequence[str], rate_hz: float, bitrate: float = 1e6,
                     data_bitrate: Optional[float] = None, profile: str = "diagnostics",
                     per_step: Optional[Dict[str, float]] = None) -> ProfileLoad:
    """Worst-case load of sending the DBC messages `names` (each `per_step[name]` times a step,
    default once) at `rate_hz` steps/s. FD messages use data_bitrate for their data phase."""
    t = 0.0
    frames = 0.0
    for name in names:
        m = db.get_message_by_name(name)
        times = (per_step or {}).get(name, 1.0)
        if getattr(m, "is_fd", False):
            t += times * fd_time_worst(m.length, bitrate, data_bitrate or bitrate)
        else:
            t += times * float(classic_bits_worst(m.length)) / bitrate
        frames += times
    return ProfileLoad(profile, list(names), frames, t, rate_hz, bitrate)


def step_messages(db) -> List[str]:
    """The classic messages that carry a STEP signal (every profile's step frames but the CAN FD ones)."""
    return [m.name for m in db.messages if any(s.name == "STEP" for s in m.signals) and not m.is_fd]


@dataclass
class LogLoad:
    frames: int
    seconds: float
    bits_exact: int
    bits_worst: int
    bitrate: float

    @property
    def load_exact(self) -> float:
        return self.bits_exact / (self.seconds * self.bitrate) if self.seconds > 0 else float("nan")

    @property
    def load_worst(self) -> float:
        return self.bits_worst / (self.seconds * self.bitrate) if self.seconds > 0 else float("nan")


def log_load(t: np.ndarray, ids: np.ndarray, dlc: np.ndarray, data: np.ndarray, bitrate: float = 1e6,
             seconds: Optional[float] = None) -> LogLoad:
    """Load of recorded classic frames over `seconds` (default: first to last frame + one frame)."""
    if len(t) == 0:
        return LogLoad(0, 0.0, 0, 0, bitrate)
    exact = classic_bits_exact(ids, dlc, data)
    worst = frame_bits_worst(dlc)
    if seconds is None:
        seconds = float(t.max() - t.min()) + float(worst[-1]) / bitrate
    return LogLoad(len(t), seconds, int(exact.sum()), int(worst.sum()), bitrate)


def fd_log_seconds(lengths, nominal: float, data: float) -> float:
    """Worst-case seconds on the bus of recorded CAN FD frames of these lengths (bit-rate switch)."""
    return float(sum(fd_time_worst(int(n), nominal, data) for n in lengths))


def read_candump_fd(path: PathLike):
    """(t [s], ids, lengths) of the CAN FD frames (ID##<flags><data>) of a candump -L log."""
    ts, ids, lens = [], [], []
    with open(path, encoding="ascii", errors="replace") as f:
        for line in f:
            parts = line.split()
            if len(parts) < 3 or "##" not in parts[2]:
                continue
            fid, _, rest = parts[2].partition("##")
            ts.append(float(parts[0].strip("()")))
            ids.append(int(fid, 16))
            lens.append(len(rest[1:]) // 2)  # after the flags nibble
    return np.array(ts), np.array(ids, dtype=np.int64), np.array(lens, dtype=np.int64)


def read_candump(path: PathLike):
    """(t [s], ids, dlc, data (k, 8)) of the classic data frames of a candump -L log."""
    ts, ids, dl, rows = [], [], [], []
    with open(path, encoding="ascii", errors="replace") as f:
        for line in f:
            parts = line.split()
            if len(parts) < 3 or "#" not in parts[2] or "##" in parts[2]:
                continue
            fid, _, payload = parts[2].partition("#")
            if len(fid) != 3 or payload.startswith("R"):
                continue
            b = bytes.fromhex(payload)
            ts.append(float(parts[0].strip("()")))
            ids.append(int(fid, 16))
            dl.append(len(b))
            rows.append(b.ljust(8, b"\0")[:8])
    data = np.frombuffer(b"".join(rows), dtype=np.uint8).reshape(-1, 8) if rows else np.zeros((0, 8), np.uint8)
    return np.array(ts), np.array(ids, dtype=np.int64), np.array(dl, dtype=np.int64), data
