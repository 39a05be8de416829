"""The caekf frame codec from firmware/protocol/caekf.dbc (the single source of truth), via cantools.

Two ways to encode and decode, both from cantools' reading of the DBC:
- per frame with cantools itself (`encode`, `decode`): control frames, bad-traffic frames, checks;
- per run with numpy (`pack`, `unpack`): every signal's start bit, length, sign, scale and float-ness
  is taken from cantools' Signal objects and applied to whole columns at once. Encoding a 60 s run
  (180,000 frames) with cantools frame by frame would take minutes in the TCG VM; numpy takes
  milliseconds. `self_check` compares both on sample values, and tests do so on random frames.

A raw frame in this package is a 16-byte Linux `struct can_frame` record
(<u32 can_id, u8 len, 3 pad bytes, 8 data bytes>): what a CAN_RAW socket reads and writes, so
the SocketCAN fast path moves them without conversion; the python-can path converts.
"""
from __future__ import annotations

import functools
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple, Union, cast

import numpy as np

from .. import schema
from ..codegen import named_bits
from . import e2e

PathLike = Union[str, Path]

RECORD = struct.Struct("<IB3x8s")  # struct can_frame (classic CAN)
RECORD_SIZE = RECORD.size  # 16
# struct canfd_frame: the fd profile's bench moves every frame in this 72-byte record (a classic frame with
# flags 0 and len <= 8, whose first 16 bytes are its struct can_frame; a CAN FD frame with FDF | BRS)
RECORD_FD = struct.Struct("<IBB2x64s")
RECORD_FD_SIZE = RECORD_FD.size  # 72
CANFD_BRS = 0x01
CANFD_FDF = 0x04
CAN_SFF_MAX = 0x7FF  # largest 11-bit ID
E2E_SIGNALS = ("E2E_CRC", "E2E_COUNTER")

# The paper's four experiments: presets of the settings schema, sent as ordinary CTRL_PARAMs.
EXPERIMENTS = tuple(schema.preset_names())

# The estimate frames of one step, in the order the estimator sends them (EST_STEP last).
ESTIMATE_MESSAGES = ("EST_GAMMA", "EST_Q1", "EST_Q2", "EST_Q3", "EST_Q4", "EST_V1", "EST_V2",
                     "EST_V3", "EST_V4", "EST_P_NORM", "EST_P_GG", "EST_STEP")
# results column -> (message, signal)
RESULT_SIGNALS = {
    "q1": ("EST_Q1", "Q1"), "q2": ("EST_Q2", "Q2"), "q3": ("EST_Q3", "Q3"), "q4": ("EST_Q4", "Q4"),
    "v1": ("EST_V1", "V1"), "v2": ("EST_V2", "V2"), "v3": ("EST_V3", "V3"), "v4": ("EST_V4", "V4"),
    "gamma": ("EST_GAMMA", "GAMMA"), "p_norm": ("EST_P_NORM", "P_NORM"),
    "p_gg": ("EST_P_GG", "P_GAMMA_GAMMA"), "flags": ("EST_STEP", "FLAGS"),
    "newton_iters": ("EST_STEP", "NEWTON_ITERS"),
}
INPUT_MESSAGES = ("BENCH_U", "BENCH_Y1", "BENCH_Y4")


def default_dbc_path() -> Path:
    """firmware/protocol/caekf.dbc of the source tree this package lives in, else the copy a wheel installs
    (caekf_sim/data/caekf.dbc, sim/CMakeLists.txt)."""
    src = Path(__file__).resolve().parents[4] / "firmware" / "protocol" / "caekf.dbc"
    return src if src.is_file() else Path(__file__).resolve().parents[1] / "data" / "caekf.dbc"


@functools.lru_cache(maxsize=1)
def step_flags() -> Dict[str, int]:
    """EST_STEP.FLAGS' application bits of the default DBC, name -> mask (Codec.step_flags of any DBC)."""
    return dict(Codec().step_flags)


@functools.lru_cache(maxsize=None)
def signal_length(message: str, signal: str) -> int:
    """A signal's width in bits in the default DBC (the profiles' step counters: one source, the DBC)."""
    return int(Codec().messages[message].signals[signal].length)


@dataclass(frozen=True)
class SignalLayout:
    name: str
    start: int
    length: int
    signed: bool
    is_float: bool
    scale: float
    offset: float
    minimum: Optional[float]
    maximum: Optional[float]

    @property
    def mask(self) -> int:
        return (1 << self.length) - 1

    def resolution(self, value: np.ndarray) -> np.ndarray:
        """Largest |decoded - value| of a correct encoding: half an LSB for scaled integers,
        half a float32 ULP (2^-24 relative) for float signals."""
        v = np.abs(np.asarray(value, dtype=float))
        if self.is_float:
            return np.maximum(v * 2.0**-24, 2.0**-150)
        return 0.5 * self.scale + 4 * np.finfo(float).eps * v


@dataclass(frozen=True)
class MessageInfo:
    name: str
    frame_id: int
    data_id: int
    to_estimator: bool
    signals: Dict[str, SignalLayout]
    length: int = 8  # payload bytes: 8, or a CAN FD frame's length (E2E with CRC-16, e2e.seal_fd)
    is_fd: bool = False


class Codec:
    """cantools' database of caekf.dbc plus the numpy packers built from it.

    id_offset is the runtime CAN ID base (caekf-host --id-offset): every message travels at its DBC ID +
    id_offset (`MessageInfo.frame_id` is that bus ID); E2E data IDs stay the DBC's."""

    def __init__(self, dbc_path: Optional[PathLike] = None, id_offset: int = 0) -> None:
        import cantools  # a [dev] dependency of caekf-sim

        self.path = Path(dbc_path) if dbc_path else default_dbc_path()
        db = cantools.database.load_file(str(self.path))
        if not isinstance(db, cantools.database.can.Database):
            raise ValueError(f"{self.path}: not a CAN database (DBC)")
        self.db: cantools.database.can.Database = db
        ids = [m.frame_id for m in self.db.messages]
        if ids and not (0 <= min(ids) + id_offset and max(ids) + id_offset <= CAN_SFF_MAX):
            raise ValueError(f"CAN ID offset {id_offset:#x} moves the IDs 0x{min(ids):03X}..0x{max(ids):03X} out of "
                             f"0..0x{CAN_SFF_MAX:03X} (valid: {-min(ids):#x}..{CAN_SFF_MAX - max(ids):#x})")
        self.id_offset = int(id_offset)
        self.messages: Dict[str, MessageInfo] = {}
        self.by_id: Dict[int, MessageInfo] = {}
        for m in self.db.messages:
            if m.is_extended_frame or not (m.length == 8 or (m.is_fd and 8 < m.length <= 64)):
                raise ValueError(f"{m.name}: the bench expects 11-bit IDs and classic 8-byte or CAN FD frames")
            sigs = {}
            for s in m.signals:
                if s.byte_order != "little_endian":
                    raise ValueError(f"{m.name}.{s.name}: only little-endian signals are supported")
                sigs[s.name] = SignalLayout(s.name, s.start, s.length, s.is_signed, s.is_float,
                                            float(s.scale), float(s.offset), s.minimum, s.maximum)
            if m.dbc is None:
                raise ValueError(f"{m.name}: no DBC attributes (E2E_DataID)")
            info = MessageInfo(m.name, m.frame_id + self.id_offset, int(m.dbc.attributes["E2E_DataID"].value),
                               m.senders == ["BENCH"], sigs, m.length, bool(m.is_fd))
            self.messages[m.name] = info
            self.by_id[info.frame_id] = info
        self.to_estimator_ids = sorted(i.frame_id for i in self.messages.values() if i.to_estimator)
        self.from_estimator_ids = sorted(i.frame_id for i in self.messages.values() if not i.to_estimator)
        self.param_ids = self._choices("CTRL_PARAM", "PARAM_ID")
        self.ack_status_names = {v: k for k, v in self._choices("EST_ACK", "ACK_STATUS").items()}
        self.step_status_names = {v: k for k, v in self._choices("EST_STEP", "STEP_STATUS").items()}
        # EST_STEP.FLAGS' application bits (the DBC's CaekfBits attribute) as name -> mask
        self.step_flags = {n: 1 << b for n, b in
                           named_bits(self.db.get_message_by_name("EST_STEP").get_signal_by_name("FLAGS")).items()}
        health = self.db.get_message_by_name("EST_HEALTH")
        pages = sorted((s.multiplexer_ids[0], s.start, s.name) for s in health.signals if s.multiplexer_ids)
        self.counter_names: List[str] = [name for _, _, name in pages]
        self.health_pages = len(pages) // 2

    def _choices(self, message: str, signal: str) -> Dict[str, int]:
        sig = self.db.get_message_by_name(message).get_signal_by_name(signal)
        return {str(name): int(value) for value, name in (sig.choices or {}).items()}

    # --- one frame, through cantools ---------------------------------------------------------

    def encode(self, name: str, values: Mapping[str, float], counter: int) -> bytes:
        """cantools encode with E2E_CRC = 0 and the counter, then the CRC inserted. STEP is taken
        modulo its signal's width (16 bits, 8 in BENCH_YP and EST_PROD), as `pack` does."""
        info = self.messages[name]
        if "STEP" in values and "STEP" in info.signals:
            values = {**values, "STEP": int(values["STEP"]) & info.signals["STEP"].mask}
        body = self.db.encode_message(name, {"E2E_CRC": 0, "E2E_COUNTER": counter & 15, **values},
                                      strict=True)
        return (e2e.seal_fd if info.is_fd else e2e.seal)(info.data_id, counter, body)

    def decode(self, frame_id: int, data: bytes) -> Dict[str, float]:
        """Decode a frame seen on the bus (frame_id: the bus ID, DBC ID + id_offset)."""
        decoded = self.db.decode_message(frame_id - self.id_offset, bytes(data), decode_choices=False)
        assert isinstance(decoded, dict)  # a plain message, not a container frame
        return cast(Dict[str, float], dict(decoded))  # numbers only: decode_choices=False

    def record(self, name_or_id: Union[str, int], data: bytes, dlc: Optional[int] = None, wide: bool = False,
               fd: Optional[bool] = None) -> bytes:
        """A 16-byte struct can_frame; dlc other than len(data) makes a deliberately wrong frame. wide: a
        72-byte struct canfd_frame record instead (the fd profile's bench), a CAN FD frame (FDF | BRS) when
        `fd` or, by default, when the message is a CAN FD one or the data is longer than 8 bytes."""
        fid = self.messages[name_or_id].frame_id if isinstance(name_or_id, str) else int(name_or_id)
        data = bytes(data)
        n = len(data) if dlc is None else dlc
        if not wide:
            return RECORD.pack(fid, n, data.ljust(8, b"\0")[:8])
        if fd is None:
            fd = (isinstance(name_or_id, str) and self.messages[name_or_id].is_fd) or len(data) > 8
        return RECORD_FD.pack(fid, n, (CANFD_FDF | CANFD_BRS) if fd else 0, data.ljust(64, b"\0")[:64])

    # --- whole columns, through numpy ---------------------------------------------------------

    def pack(self, name: str, columns: Mapping[str, np.ndarray], counters=0) -> np.ndarray:
        """Payloads (n, 8) uint8 of message `name`, signals from columns (physical values; scaled
        integers rounded half-even like cantools and clipped to the signal range), sealed with
        `counters` (scalar or (n,)). Missing signals are 0."""
        info = self.messages[name]
        n = len(next(iter(columns.values())))
        if info.is_fd:
            return self._pack_fd(info, columns, n, counters)
        word = np.zeros(n, dtype=np.uint64)
        for sname, values in columns.items():
            sig = info.signals[sname]
            raw = self.raw_values(sig, values)
            word |= (raw & np.uint64(sig.mask)) << np.uint64(sig.start)
        payloads = word.astype("<u8").view(np.uint8).reshape(n, 8)
        return e2e.seal_np(info.data_id, counters, payloads)

    def _pack_fd(self, info: MessageInfo, columns: Mapping[str, np.ndarray], n: int, counters) -> np.ndarray:
        """pack() of a CAN FD message (any length): each signal shifted into the bytes it spans (<= 56 bits
        wide, so at most 8 bytes); sealed with CRC-16."""
        payloads = np.zeros((n, info.length), dtype=np.uint8)
        for sname, values in columns.items():
            sig = info.signals[sname]
            v = (self.raw_values(sig, values) & np.uint64(sig.mask)) << np.uint64(sig.start % 8)
            first = sig.start // 8
            for k in range((sig.start % 8 + sig.length + 7) // 8):
                payloads[:, first + k] |= ((v >> np.uint64(8 * k)) & np.uint64(0xFF)).astype(np.uint8)
        return e2e.seal_fd_np(info.data_id, counters, payloads)

    @staticmethod
    def raw_values(sig: SignalLayout, values) -> np.ndarray:
        """Physical values -> raw unsigned field values (uint64, two's complement if signed)."""
        v = np.asarray(values)
        if sig.is_float:
            if sig.length != 32:
                raise ValueError(f"{sig.name}: only float32 signals are supported")
            return v.astype("<f4").view("<u4").astype(np.uint64)
        if sig.scale == 1.0 and sig.offset == 0.0 and np.issubdtype(v.dtype, np.integer):
            raw = v.astype(np.int64)
        else:
            raw = np.rint((v.astype(float) - sig.offset) / sig.scale)
            lo = -(1 << (sig.length - 1)) if sig.signed else 0
            hi = (1 << (sig.length - 1)) - 1 if sig.signed else (1 << sig.length) - 1
            raw = np.clip(raw, lo, hi).astype(np.int64)
        return raw.astype(np.uint64)  # negative values wrap to two's complement

    def unpack(self, name: str, payloads: np.ndarray, signals: Optional[Iterable[str]] = None,
               scaled: bool = True) -> Dict[str, np.ndarray]:
        """Decode columns of payloads (n, 8) like cantools' decode_message (raw * scale + offset)."""
        info = self.messages[name]
        p = np.ascontiguousarray(np.asarray(payloads, dtype=np.uint8).reshape(-1, info.length))
        if not info.is_fd:
            word = p.view("<u8").reshape(-1)
        out = {}
        for sname in signals or info.signals:
            sig = info.signals[sname]
            if info.is_fd:  # the <= 8 bytes the signal spans, as one little-endian word
                first = sig.start // 8
                raw = np.zeros(len(p), dtype=np.uint64)
                for k in range((sig.start % 8 + sig.length + 7) // 8):
                    raw |= p[:, first + k].astype(np.uint64) << np.uint64(8 * k)
                raw = (raw >> np.uint64(sig.start % 8)) & np.uint64(sig.mask)
            else:
                raw = (word >> np.uint64(sig.start)) & np.uint64(sig.mask)
            if sig.is_float:
                out[sname] = raw.astype("<u4").view("<f4").astype(float)
                continue
            r = raw.astype(np.int64)
            if sig.signed:
                r = np.where(r >= (1 << (sig.length - 1)), r - (1 << sig.length), r)
            if not scaled or (sig.scale == 1.0 and sig.offset == 0.0):
                out[sname] = r
            else:
                out[sname] = r * sig.scale + sig.offset
        return out

    def quantize(self, name: str, signal: str, values) -> np.ndarray:
        """What the receiver decodes after this value went over the bus (e.g. y rounded to the
        1e-12 m LSB, u rounded to float32)."""
        p = self.pack(name, {signal: np.atleast_1d(np.asarray(values, dtype=float))})
        return self.unpack(name, p, [signal])[signal]

    def self_check(self, samples: Sequence[Tuple[str, Mapping[str, float]]]) -> None:
        """Raise if numpy packing differs from cantools on these (message, values) samples."""
        for name, values in samples:
            want = self.encode(name, values, 5)
            got = self.pack(name, {k: np.array([v]) for k, v in values.items()}, 5)[0].tobytes()
            if want != got:
                raise AssertionError(f"numpy codec differs from cantools for {name} {dict(values)}: "
                                     f"{got.hex()} != {want.hex()}")


_RECORD_DTYPE = np.dtype([("id", "<u4"), ("dlc", "u1"), ("pad", "u1", (3,)), ("data", "u1", (8,))])
_RECORD_FD_DTYPE = np.dtype([("id", "<u4"), ("dlc", "u1"), ("flags", "u1"), ("pad", "u1", (2,)),
                             ("data", "u1", (64,))])


def records_array(blob: Union[bytes, bytearray, memoryview], wide: bool = False) -> np.ndarray:
    """View a blob of 16-byte records (wide: 72-byte struct canfd_frame records) as a structured array
    (id, dlc, data; wide: flags too, dlc is the payload length)."""
    return np.frombuffer(bytes(blob), dtype=_RECORD_FD_DTYPE if wide else _RECORD_DTYPE)


def record_size(wide: bool) -> int:
    return RECORD_FD_SIZE if wide else RECORD_SIZE


def make_records(frame_ids: np.ndarray, payloads: np.ndarray) -> np.ndarray:
    """(n, 16) uint8 struct can_frame records from ids (n,) and payloads (n, 8)."""
    n = len(payloads)
    rec = np.zeros((n, RECORD_SIZE), dtype=np.uint8)
    rec[:, 0:4] = np.asarray(frame_ids, dtype="<u4").reshape(-1, 1).view(np.uint8).reshape(n, 4) \
        if np.ndim(frame_ids) else np.frombuffer(struct.pack("<I", int(frame_ids)), np.uint8)
    rec[:, 4] = 8
    rec[:, 8:16] = payloads
    return rec
