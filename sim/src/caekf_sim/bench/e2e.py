"""E2E protection of caekf CAN frames (AUTOSAR profile-1 style, see firmware/protocol/README.md).

Byte 0 is a CRC-8/SAE-J1850 (poly 0x1D, init 0xFF, xorout 0xFF) over
[DataID & 0xFF, DataID >> 8, payload bytes 1..7]; bits 8..11 carry a 4-bit alive counter.
Scalar functions for single frames, numpy versions for whole runs (sealing 180,000 input frames
or checking 720,000 estimate frames takes milliseconds instead of seconds).

Also the CTRL_PARAM value encoding: value = mantissa * 10**exp10 in its shortest decimal form.
"""
from __future__ import annotations

from decimal import Decimal
from typing import Optional, Tuple

import numpy as np

CRC8_POLY = 0x1D
CRC8_INIT = 0xFF
CRC8_XOROUT = 0xFF
COUNTER_MASK = 0x0F


def _table() -> Tuple[int, ...]:
    out = []
    for byte in range(256):
        crc = byte
        for _ in range(8):
            crc = ((crc << 1) ^ CRC8_POLY) & 0xFF if crc & 0x80 else (crc << 1) & 0xFF
        out.append(crc)
    return tuple(out)


CRC8_TABLE = _table()
_CRC8_TABLE_NP = np.array(CRC8_TABLE, dtype=np.uint8)


def crc8_sae_j1850(data: bytes, crc: int = CRC8_INIT, final: bool = True) -> int:
    """CRC-8/SAE-J1850 of `data` (check value of b"123456789" is 0x4B)."""
    t = CRC8_TABLE
    for b in data:
        crc = t[crc ^ b]
    return crc ^ CRC8_XOROUT if final else crc


def e2e_crc(data_id: int, payload: bytes) -> int:
    """The CRC byte of an 8-byte payload (byte 0 itself is not covered)."""
    crc = crc8_sae_j1850(bytes((data_id & 0xFF, data_id >> 8)), final=False)
    return crc8_sae_j1850(bytes(payload[1:8]), crc)


def seal(data_id: int, counter: int, payload: bytes) -> bytes:
    """Write the alive counter (bits 8..11) and then the CRC (byte 0) into an 8-byte payload."""
    b = bytearray(payload)
    b[1] = (b[1] & 0xF0) | (counter & COUNTER_MASK)
    b[0] = e2e_crc(data_id, bytes(b))
    return bytes(b)


def counter_of(payload: bytes) -> int:
    return payload[1] & COUNTER_MASK


def crc_ok(data_id: int, payload: bytes) -> bool:
    return len(payload) == 8 and payload[0] == e2e_crc(data_id, payload)


# --- CAN FD frames: CRC-16/CCITT-FALSE in bytes 0..1, counter in bits 16..19 (profile-5 style) ----

CRC16_POLY = 0x1021
CRC16_INIT = 0xFFFF


def _table16() -> np.ndarray:
    out = []
    for byte in range(256):
        crc = byte << 8
        for _ in range(8):
            crc = ((crc << 1) ^ CRC16_POLY) & 0xFFFF if crc & 0x8000 else (crc << 1) & 0xFFFF
        out.append(crc)
    return np.array(out, dtype=np.int64)


_CRC16_TABLE_NP = _table16()
_CRC16_TABLE = tuple(int(x) for x in _CRC16_TABLE_NP)


def crc16_ccitt_false(data: bytes, crc: int = CRC16_INIT) -> int:
    """CRC-16/CCITT-FALSE of `data` (check value of b"123456789" is 0x29B1)."""
    t = _CRC16_TABLE
    for b in data:
        crc = ((crc << 8) & 0xFFFF) ^ t[(crc >> 8) ^ b]
    return crc


def e2e_crc16_np(data_id: int, payloads: np.ndarray) -> np.ndarray:
    """CRC-16 of many CAN FD payloads (n, length) uint8 of one message -> (n,) int64, vectorised."""
    p = np.asarray(payloads, dtype=np.uint8)
    crc = np.full(len(p), crc16_ccitt_false(bytes((data_id & 0xFF, data_id >> 8))), dtype=np.int64)
    t = _CRC16_TABLE_NP
    for j in range(2, p.shape[1]):
        crc = ((crc << 8) & 0xFFFF) ^ t[(crc >> 8) ^ p[:, j]]
    return crc


def seal_fd_np(data_id: int, counters, payloads: np.ndarray) -> np.ndarray:
    """Vectorised seal_fd(): a sealed copy of payloads (n, length)."""
    p = np.array(payloads, dtype=np.uint8, copy=True)
    c = np.broadcast_to(np.asarray(counters, dtype=np.int64) & COUNTER_MASK, (len(p),))
    p[:, 2] = (p[:, 2] & 0xF0) | c.astype(np.uint8)
    crc = e2e_crc16_np(data_id, p)
    p[:, 0] = (crc & 0xFF).astype(np.uint8)
    p[:, 1] = (crc >> 8).astype(np.uint8)
    return p


def e2e_crc16(data_id: int, payload: bytes) -> int:
    """The CRC-16 of a CAN FD payload (bytes 0..1 themselves are not covered)."""
    return crc16_ccitt_false(bytes(payload[2:]), crc16_ccitt_false(bytes((data_id & 0xFF, data_id >> 8))))


def seal_fd(data_id: int, counter: int, payload: bytes) -> bytes:
    """Write the alive counter (bits 16..19) and then the CRC-16 (bytes 0..1, little-endian)."""
    b = bytearray(payload)
    b[2] = (b[2] & 0xF0) | (counter & COUNTER_MASK)
    crc = e2e_crc16(data_id, bytes(b))
    b[0], b[1] = crc & 0xFF, crc >> 8
    return bytes(b)


def crc16_ok(data_id: int, payload: bytes) -> bool:
    return len(payload) >= 3 and int.from_bytes(payload[:2], "little") == e2e_crc16(data_id, payload)


def counter_of_fd(payload: bytes) -> int:
    return payload[2] & COUNTER_MASK


# --- vectorised ------------------------------------------------------------------------------

def e2e_crc_np(data_ids: np.ndarray, payloads: np.ndarray) -> np.ndarray:
    """CRC bytes of many payloads: data_ids (n,) or scalar, payloads (n, 8) uint8 -> (n,) uint8."""
    p = np.asarray(payloads, dtype=np.uint8)
    ids = np.broadcast_to(np.asarray(data_ids, dtype=np.int64), (len(p),))
    t = _CRC8_TABLE_NP
    crc = t[CRC8_INIT ^ (ids & 0xFF)]
    crc = t[crc ^ (ids >> 8).astype(np.uint8)]
    for j in range(1, 8):
        crc = t[crc ^ p[:, j]]
    return crc ^ np.uint8(CRC8_XOROUT)


def seal_np(data_ids, counters, payloads: np.ndarray) -> np.ndarray:
    """Vectorised seal(): returns a sealed copy of payloads (n, 8)."""
    p = np.array(payloads, dtype=np.uint8, copy=True)
    c = np.broadcast_to(np.asarray(counters, dtype=np.int64) & COUNTER_MASK, (len(p),))
    p[:, 1] = (p[:, 1] & 0xF0) | c.astype(np.uint8)
    p[:, 0] = e2e_crc_np(data_ids, p)
    return p


class E2EReceiver:
    """Receiver state of one message, as the estimator keeps it: accept any counter first, then
    reject a repeated counter (duplicate) or a step larger than max_delta (jump; resynchronises)."""

    OK, BAD_DLC, BAD_CRC, DUPLICATE, JUMP = "ok", "bad_dlc", "bad_crc", "duplicate", "jump"

    def __init__(self, data_id: int, max_delta: int = 1) -> None:
        self.data_id = data_id
        self.max_delta = max_delta
        self.last: Optional[int] = None
        self.lost = 0

    def check(self, payload: bytes) -> str:
        if len(payload) != 8:
            return self.BAD_DLC
        if not crc_ok(self.data_id, payload):
            return self.BAD_CRC
        c = counter_of(payload)
        if self.last is None:
            self.last = c
            return self.OK
        delta = (c - self.last) & COUNTER_MASK
        if delta == 0:
            return self.DUPLICATE
        self.last = c
        if delta > self.max_delta:
            return self.JUMP
        self.lost += delta - 1
        return self.OK


def counter_errors_np(counters: np.ndarray) -> Tuple[int, int, int]:
    """(duplicates, jumps, lost) in one message's received counter sequence (max_delta 1)."""
    c = np.asarray(counters, dtype=np.int64)
    if len(c) < 2:
        return 0, 0, 0
    d = np.diff(c) & COUNTER_MASK
    return int(np.sum(d == 0)), int(np.sum(d > 1)), int(np.sum(np.where(d > 1, d - 1, 0)))


# --- CTRL_PARAM value encoding ----------------------------------------------------------------

def to_mantissa_exp10(value: float, max_digits: int = 11) -> Tuple[int, int]:
    """Shortest decimal form of a float as (mantissa, exp10), value = mantissa * 10**exp10.
    Values needing more than max_digits significant digits are rounded to max_digits."""
    d = Decimal(repr(float(value)))
    if d == 0:
        return 0, 0
    d = d.normalize()
    sign, digits, exp = d.as_tuple()
    assert isinstance(exp, int)  # a finite value (repr of a float that is not nan/inf)
    if len(digits) > max_digits:
        d = d.quantize(Decimal(1).scaleb(exp + len(digits) - max_digits)).normalize()
        sign, digits, exp = d.as_tuple()
        assert isinstance(exp, int)
    mant = int("".join(map(str, digits)))
    return (-mant if sign else mant), int(exp)


def from_mantissa_exp10(mantissa: int, exp10: int) -> float:
    """The double the estimator computes from (mantissa, exp10) (correctly rounded)."""
    return float(Decimal(mantissa).scaleb(exp10))
