"""The CAN FD profile on the bench: one BENCH_FD (20 bytes) in and one EST_FD (64 bytes) out per step, both
CAN FD frames with bit-rate switch, on a python-can bus opened with `fd=True` (SocketCAN: CAN_RAW_FD_FRAMES),
whose socket then carries prebuilt struct canfd_frame records (a python-can Message per frame costs ~0.8 ms a
step in user-mode Linux). Configuration and status stay on the classic control frames of the `Bench` this
wraps (configure, status: unchanged).

- `FdStepper.run(inputs, rows, window)`: lockstep with `window` steps in flight, or paced at absolute
  deadlines (`dt`, clock_nanosleep TIMER_ABSTIME as `realtime.run_paced`); every EST_FD E2E-checked (CRC-16,
  alive counter) and decoded into a `Decoded` that `results.compare_with_replay` takes with `profiles.FD`;
- the whole bus is recorded (CAN_RAW with CAN_RAW_FD_FRAMES) and written as a candump -L log
  (`ID##<flags><data>` for CAN FD frames), which `caekf-sim busload --log fd=LOG` measures.

The interface must carry CAN FD frames: vcan with `ip link set vcan0 mtu 72` (tools/with-vcan.sh does it),
a real controller with `ip link set can0 type can bitrate 1000000 dbitrate 5000000 fd on`.
"""
from __future__ import annotations

import ctypes
import errno
import os
import socket
import struct
import time
from dataclasses import dataclass
from pathlib import Path
from typing import List, Optional, Tuple, Union

import numpy as np

from . import e2e
from .bench import Bench, BenchError, Decoded, StepInputs
from .profiles import FD
from .realtime import _libc
from .transport import MSG_DONTWAIT, MSG_WAITFORONE, SO_RCVTIMEO, _MMsgBatch, set_rcvbuf

CANFD_FRAME = struct.Struct("<IBBxx64s")  # struct canfd_frame
CAN_FRAME = struct.Struct("<IB3x8s")  # struct can_frame (classic frames on the same socket)
CANFD_BRS = 0x01
CANFD_FDF = 0x04
CAN_RAW_FD_FRAMES = 5
PathLike = Union[str, Path]


class FdRecorder:
    """Every frame on the interface, classic and CAN FD, with the time it was read (drained by the caller)."""

    def __init__(self, channel: str, rcvbuf: int = 32 << 20) -> None:
        self.sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        set_rcvbuf(self.sock, rcvbuf)
        self.sock.setsockopt(socket.SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1)
        self.sock.bind((channel,))
        self.sock.setblocking(False)
        self.frames: List[Tuple[float, int, int, bool, bytes]] = []  # t, id, flags, fd, data

    def drain(self) -> None:
        while True:
            try:
                raw = self.sock.recv(CANFD_FRAME.size)
            except (BlockingIOError, InterruptedError):
                return
            t = time.time()
            if len(raw) == CANFD_FRAME.size:
                fid, n, flags, data = CANFD_FRAME.unpack(raw)
                self.frames.append((t, fid & 0x7FF, flags, True, data[:n]))
            elif len(raw) == CAN_FRAME.size:
                fid, n, data = CAN_FRAME.unpack(raw)
                self.frames.append((t, fid & 0x7FF, 0, False, data[:n]))

    def write_candump(self, path: PathLike, channel: str) -> int:
        """candump -L lines: (SEC.USEC) CHANNEL ID#DATA, or ID##<flags nibble>DATA for a CAN FD frame."""
        with open(path, "w", encoding="ascii") as f:
            for t, fid, flags, fd, data in self.frames:
                sep = f"##{flags & 0xF:X}" if fd else "#"
                f.write(f"({t:.6f}) {channel} {fid:03X}{sep}{data.hex().upper()}\n")
        return len(self.frames)

    def close(self) -> None:
        self.sock.close()


@dataclass
class FdRun:
    rows: int
    elapsed: float
    decoded: Decoded
    timeouts: int
    paced: bool
    late_sends: int = 0
    recorder: Optional[FdRecorder] = None
    log_frames: int = 0

    @property
    def steps_per_second(self) -> float:
        return self.rows / self.elapsed if self.elapsed > 0 else float("nan")


class FdStepper:
    """The step frames of the CAN FD profile beside a classic `Bench` (which configures the estimator)."""

    def __init__(self, bench: Bench, channel: str = "vcan0") -> None:
        import can  # python-can

        self.bench = bench
        self.codec = bench.codec
        self.channel = channel
        self.in_info = self.codec.messages["BENCH_FD"]
        self.out_info = self.codec.messages["EST_FD"]
        try:
            self.bus = can.Bus(interface="socketcan", channel=channel, fd=True,
                               can_filters=[{"can_id": self.out_info.frame_id, "can_mask": 0x7FF,
                                             "extended": False}])
        except (OSError, can.CanError) as e:
            raise BenchError(f"cannot open {channel} for CAN FD: {e}") from None
        self.sock: socket.socket = self.bus.socket  # type: ignore[attr-defined]  # SocketcanBus, opened above
        self.fd = self.sock.fileno()
        self.libc = _libc()
        self.tx = _MMsgBatch(256, CANFD_FRAME.size)
        self.rx = _MMsgBatch(256, CANFD_FRAME.size)
        self._timeout = 0.0

    def close(self) -> None:
        self.bus.shutdown()

    def payloads(self, inputs: StepInputs, start: int, stop: int) -> np.ndarray:
        """BENCH_FD payloads of rows [start, stop) with the bench's next alive counters (numpy, CRC-16 sealed)."""
        c0 = self.bench.tx_counter["BENCH_FD"]
        n = stop - start
        p = self.codec.pack("BENCH_FD", {"STEP": inputs.wire_steps[start:stop], "U": inputs.u[start:stop],
                                         "Y1": inputs.y[start:stop, 0], "Y4": inputs.y[start:stop, 1]},
                            counters=(c0 + np.arange(n)) & e2e.COUNTER_MASK)
        self.bench.tx_counter["BENCH_FD"] = (c0 + n) & e2e.COUNTER_MASK
        return p

    def _send(self, frames: List[bytes]) -> None:
        """The frames in sendmmsg batches (retried while the interface queue is full)."""
        done = 0
        while done < len(frames):
            k = min(len(frames) - done, self.tx.n)
            ctypes.memmove(self.tx.buf, b"".join(frames[done:done + k]), k * CANFD_FRAME.size)
            r = self.libc.sendmmsg(self.fd, self.tx.hdr, k, 0)
            if r < 0:
                e = ctypes.get_errno()
                if e not in (errno.ENOBUFS, errno.EAGAIN, errno.EINTR):
                    raise OSError(e, os.strerror(e))
                time.sleep(0.0005)
                continue
            done += r

    def _recv(self, wait: float) -> List[bytes]:
        """EST_FD payloads of one recvmmsg batch: waiting up to `wait` s for the first, 0 = not at all."""
        if wait > 0 and wait != self._timeout:  # a system call saved per batch (trapped in user-mode Linux)
            sec = int(wait)
            self.sock.setsockopt(socket.SOL_SOCKET, SO_RCVTIMEO, struct.pack("@ll", sec, int((wait - sec) * 1e6) or 1))
            self._timeout = wait
        n = self.libc.recvmmsg(self.fd, self.rx.hdr, self.rx.n, MSG_WAITFORONE if wait > 0 else MSG_DONTWAIT, None)
        if n < 0:
            e = ctypes.get_errno()
            if e in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                return []
            raise OSError(e, os.strerror(e))
        out = []
        for i in range(n):
            if self.rx.hdr[i].msg_len == CANFD_FRAME.size:  # a classic frame with the EST_FD ID is not ours
                _, length, _, data = CANFD_FRAME.unpack_from(self.rx.buf, i * CANFD_FRAME.size)
                out.append(data[:length])
        return out

    def frame(self, payload: bytes, frame_id: Optional[int] = None) -> bytes:
        """A struct canfd_frame record (bit-rate switch) of `payload`, BENCH_FD's ID unless given."""
        fid = self.in_info.frame_id if frame_id is None else frame_id
        return CANFD_FRAME.pack(fid, len(payload), CANFD_BRS | CANFD_FDF, bytes(payload))

    def send_records(self, records: List[bytes]) -> None:
        """Raw CAN FD records on the bus (for injected faults), in one sendmmsg batch."""
        self._send(records)

    def run(self, inputs: StepInputs, rows: int, window: int = 32, timeout: float = 2.0,
            dt: Optional[float] = None, record: bool = False, start: int = 0) -> FdRun:
        """Rows [start, rows): lockstep with `window` steps in flight, or paced at dt (absolute deadlines)."""
        from .realtime import CLOCK_REALTIME, TIMER_ABSTIME, _realtime_ns, _Timespec

        frames = [self.frame(p.tobytes()) for p in self.payloads(inputs, start, rows)]
        rows -= start
        rec = FdRecorder(self.channel) if record else None
        got: List[Optional[bytes]] = [None] * rows
        order: List[bytes] = []  # EST_FD payloads in arrival order (E2E continuity)
        wire0 = int(inputs.wire_steps[start])
        sent = done = late = 0
        ts = _Timespec()
        t0_ns = _realtime_ns() + 50_000_000
        t_start = time.perf_counter()

        def take(batch: List[bytes]) -> None:
            nonlocal done
            for data in batch:
                order.append(data)
                row = (int.from_bytes(data[3:5], "little") - wire0) & 0xFFFF  # STEP: bit 24, 16 bits
                if row < rows and got[row] is None:
                    got[row] = data
                    done += 1

        while sent < rows:
            if dt:  # one step at its absolute deadline
                d = t0_ns + int(round(sent * dt * 1e9))
                ts.tv_sec, ts.tv_nsec = d // 1_000_000_000, d % 1_000_000_000
                while self.libc.clock_nanosleep(CLOCK_REALTIME, TIMER_ABSTIME, ctypes.byref(ts), None) == errno.EINTR:
                    pass
                late += _realtime_ns() - d > int(dt * 1e9)
                self._send(frames[sent:sent + 1])
                sent += 1
                take(self._recv(0.0))
                if rec is not None:
                    rec.drain()
                continue
            k = min(window - (sent - done), rows - sent)  # refill the window in one sendmmsg
            if k > 0:
                self._send(frames[sent:sent + k])
                sent += k
            batch = self._recv(timeout)
            if not batch:
                break  # nothing for `timeout`: the run stops, the steps not answered count as timeouts
            take(batch)
        end = time.perf_counter() + timeout
        while done < sent and time.perf_counter() < end:
            take(self._recv(0.05))
        elapsed = time.perf_counter() - t_start
        if rec is not None:
            time.sleep(0.05)
            rec.drain()
            rec.close()
        dec = self.decode(got, order)
        return FdRun(rows, elapsed, dec, int(np.sum(~dec.complete)), bool(dt), late, rec,
                     len(rec.frames) if rec else 0)

    def decode(self, got: List[Optional[bytes]], order: List[bytes]) -> Decoded:
        """Columns of the profile's results per row (NaN where no EST_FD came), with the E2E counts."""
        rows = len(got)
        complete = np.array([g is not None for g in got], dtype=bool)
        blank = bytes(self.out_info.length)
        p = np.frombuffer(b"".join(g if g is not None else blank for g in got), dtype=np.uint8)
        cols = self.codec.unpack("EST_FD", p.reshape(rows, self.out_info.length))
        columns = {}
        for col, src in FD.results.items():
            v = cols[src.signal].astype(float)
            columns[col] = np.where(complete, v, np.nan)
        arrived = np.frombuffer(b"".join(d.ljust(self.out_info.length, b"\0") for d in order), dtype=np.uint8)
        arrived = arrived.reshape(len(order), self.out_info.length)
        sent_crc = arrived[:, 0] | (arrived[:, 1].astype(np.int64) << 8)
        crc_ok = e2e.e2e_crc16_np(self.out_info.data_id, arrived) == sent_crc
        bad_crc = int(np.sum(~crc_ok))
        dup, jumps, _ = e2e.counter_errors_np(arrived[crc_ok, 2] & e2e.COUNTER_MASK)
        status = np.where(complete, cols["STEP_STATUS"], 0).astype(np.int64)
        return Decoded(columns=columns, complete=complete, step_status=status, bad_crc=bad_crc,
                       counter_duplicates=dup, counter_jumps=jumps, frames=len(order))
