"""Moving 16-byte struct can_frame records between the bench and a python-can bus.

`open_bus(interface, channel)` is `can.Bus(...)`: socketcan/vcan0 by default, any python-can
interface (a USB adapter, `virtual` for tests) works the same. On top of the bus:

- `SocketcanTransport` (interface socketcan): talks to the bus's CAN_RAW socket directly and, on
  Linux, moves many frames per system call with sendmmsg/recvmmsg (ctypes). Per-frame Python
  work is what limits a bench in the TCG VM, so this path avoids python-can's Message objects in
  the hot loop. Falls back to send/recv_into when libc has no *mmsg.
- `PythonCanTransport` (any other interface): bus.send / bus.recv, converted to records.

Both receive only the estimator's frames (kernel or python-can filters from the DBC directions)
and return what they got as one bytes blob of records, so the run loop is the same for both.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
import select
import socket
import struct
import time
from typing import Iterable, List, Optional

from .codec import CANFD_FDF, RECORD, RECORD_FD, RECORD_FD_SIZE, RECORD_SIZE

MSG_WAITFORONE = 0x10000
MSG_DONTWAIT = socket.MSG_DONTWAIT if hasattr(socket, "MSG_DONTWAIT") else 0x40
SO_RCVBUFFORCE = 33
SO_SNDBUFFORCE = 32
SO_RCVTIMEO = 20
CAN_RAW_FD_FRAMES = 5


def open_bus(interface: str = "socketcan", channel: str = "vcan0", **kwargs):
    import can

    return can.Bus(interface=interface, channel=channel, **kwargs)


def set_rcvbuf(sock: socket.socket, size: int) -> None:
    """A deep receive queue (SO_RCVBUFFORCE works as root, else SO_RCVBUF, capped by the kernel)."""
    for opt in (SO_RCVBUFFORCE, socket.SO_RCVBUF):
        try:
            sock.setsockopt(socket.SOL_SOCKET, opt, size)
            return
        except OSError:
            continue


def interface_exists(channel: str) -> bool:
    """True when a network interface of that name exists (Linux); for SocketCAN only."""
    return os.path.exists(f"/sys/class/net/{channel}")


class _IOVec(ctypes.Structure):
    _fields_ = [("iov_base", ctypes.c_void_p), ("iov_len", ctypes.c_size_t)]


class _MsgHdr(ctypes.Structure):
    _fields_ = [("msg_name", ctypes.c_void_p), ("msg_namelen", ctypes.c_uint32),
                ("msg_iov", ctypes.POINTER(_IOVec)), ("msg_iovlen", ctypes.c_size_t),
                ("msg_control", ctypes.c_void_p), ("msg_controllen", ctypes.c_size_t),
                ("msg_flags", ctypes.c_int)]


class _MMsgHdr(ctypes.Structure):
    _fields_ = [("msg_hdr", _MsgHdr), ("msg_len", ctypes.c_uint)]


class _MMsgBatch:
    """A fixed array of mmsghdr, each pointing at one slot of `size` bytes (a struct can_frame, or a
    struct canfd_frame for the CAN FD profile) of one buffer."""

    def __init__(self, n: int, size: int = RECORD_SIZE) -> None:
        self.n = n
        self.size = size
        self.buf = ctypes.create_string_buffer(n * size)
        self.iov = (_IOVec * n)()
        self.hdr = (_MMsgHdr * n)()
        base = ctypes.addressof(self.buf)
        for i in range(n):
            self.iov[i].iov_base = base + i * size
            self.iov[i].iov_len = size
            self.hdr[i].msg_hdr.msg_iov = ctypes.pointer(self.iov[i])
            self.hdr[i].msg_hdr.msg_iovlen = 1


def _libc():
    try:
        libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
        libc.recvmmsg.restype = ctypes.c_int
        libc.sendmmsg.restype = ctypes.c_int
        return libc
    except (OSError, AttributeError):
        return None


class Transport:
    """Interface of a record transport; see the module docstring."""

    name = "?"
    size = RECORD_SIZE  # bytes per record: 16, or 72 (struct canfd_frame) for a CAN FD bench

    def send(self, blob: bytes) -> None:  # blob: k records
        raise NotImplementedError

    def recv(self, timeout: float) -> bytes:
        """Wait up to `timeout` s for at least one frame; return every frame already there."""
        raise NotImplementedError

    def drain(self, settle: float = 0.0) -> int:
        """Drop what is queued (after waiting `settle` s for stragglers); returns frames dropped."""
        n = 0
        end = time.monotonic() + settle
        while True:
            blob = self.recv(max(0.0, end - time.monotonic()) if settle else 0.0)
            if not blob:
                return n
            n += len(blob) // self.size

    def close(self) -> None:
        pass


class SocketcanTransport(Transport):
    """Fast path on a python-can SocketcanBus: its CAN_RAW socket, *mmsg batches of frames."""

    name = "socketcan (CAN_RAW, mmsg)"

    def __init__(self, bus, rx_ids: Iterable[int], batch: int = 256, use_mmsg: bool = True,
                 rcvbuf: int = 8 << 20, wide: bool = False) -> None:
        """wide: CAN FD (CAN_RAW_FD_FRAMES) with 72-byte struct canfd_frame records: a record with CANFD_FDF
        in its flags goes out as a CAN FD frame, any other as a classic one; a classic frame received is
        returned as a record of 72 bytes too (zero-padded)."""
        self.bus = bus
        self.sock: socket.socket = bus.socket
        self.fd = self.sock.fileno()
        self.wide = wide
        self.size = RECORD_FD_SIZE if wide else RECORD_SIZE
        if wide:
            self.sock.setsockopt(socket.SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1)
        self.set_filter(rx_ids)
        set_rcvbuf(self.sock, rcvbuf)
        self.sock.setblocking(True)
        self._timeout: Optional[float] = None  # current SO_RCVTIMEO
        self.libc = _libc() if use_mmsg else None
        self._rx_used = 0
        if self.libc is not None:
            self.name = "socketcan (CAN_RAW, sendmmsg/recvmmsg)" + (", CAN FD" if wide else "")
            self.rx = _MMsgBatch(batch, self.size)
            self.tx = _MMsgBatch(batch, self.size)
            self._rx_mv = memoryview(self.rx.buf).cast("B")
        else:
            self.name = "socketcan (CAN_RAW, send/recv)" + (", CAN FD" if wide else "")
            self._buf = bytearray(self.size)

    def set_filter(self, rx_ids: Iterable[int]) -> None:
        """Kernel acceptance filter: exactly these standard data frames."""
        filt = b"".join(struct.pack("=II", i, 0x7FF | 0x80000000 | 0x40000000) for i in rx_ids)
        self.sock.setsockopt(socket.SOL_CAN_RAW, socket.CAN_RAW_FILTER, filt)

    def _set_timeout(self, timeout: float) -> None:
        if timeout == self._timeout:
            return
        sec = int(timeout)
        usec = int(round((timeout - sec) * 1e6))
        if sec == 0 and usec == 0:
            usec = 1  # 0 would mean "block forever"
        self.sock.setsockopt(socket.SOL_SOCKET, SO_RCVTIMEO, struct.pack("@ll", sec, usec))
        self._timeout = timeout

    def _wire(self, rec: bytes) -> bytes:
        """What goes to the socket for one record: a classic frame of a wide record as its first 16 bytes."""
        return rec if not self.wide or rec[5] & CANFD_FDF else rec[:RECORD_SIZE]

    def send(self, blob: bytes) -> None:
        size = self.size
        n = len(blob) // size
        if self.libc is None or n == 1:
            for i in range(0, len(blob), size):
                self._send_one(self._wire(blob[i:i + size]))
            return
        done = 0
        while done < n:
            k = min(n - done, self.tx.n)
            ctypes.memmove(self.tx.buf, blob[done * size:(done + k) * size], k * size)
            if self.wide:  # each frame's own length: 72 bytes for CAN FD, 16 for classic
                for i in range(k):
                    self.tx.iov[i].iov_len = size if blob[(done + i) * size + 5] & CANFD_FDF else RECORD_SIZE
            r = self.libc.sendmmsg(self.fd, self.tx.hdr, k, 0)
            if r < 0:
                e = ctypes.get_errno()
                if e in (errno.ENOBUFS, errno.EAGAIN, errno.EINTR):
                    time.sleep(0.0005)  # the interface queue is full: let the receivers catch up
                    continue
                raise OSError(e, os.strerror(e))
            if r < k:  # partial: the rest again
                done += r
                continue
            done += k

    def _send_one(self, rec: bytes) -> None:
        while True:
            try:
                self.sock.send(rec)
                return
            except OSError as exc:
                if exc.errno not in (errno.ENOBUFS, errno.EAGAIN, errno.EINTR):
                    raise
                time.sleep(0.0005)

    def recv(self, timeout: float) -> bytes:
        if timeout <= 0:
            return self._recv_nowait()
        if self.libc is None:
            r, _, _ = select.select([self.sock], [], [], timeout)
            return self._recv_nowait() if r else b""
        self._set_timeout(timeout)
        return self._recvmmsg(MSG_WAITFORONE)

    def _recvmmsg(self, flags: int) -> bytes:
        """One recvmmsg() batch as concatenated records; b"" when nothing came (timeout, EINTR)."""
        assert self.libc is not None  # only with use_mmsg
        if self.wide and self._rx_used:  # a classic frame fills 16 bytes of its slot: no stale bytes after it
            ctypes.memset(self.rx.buf, 0, self._rx_used * self.size)
            self._rx_used = 0
        n = self.libc.recvmmsg(self.fd, self.rx.hdr, self.rx.n, flags, None)
        if n < 0:
            e = ctypes.get_errno()
            if e in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                return b""
            raise OSError(e, os.strerror(e))
        self._rx_used = n
        return self._rx_mv[: n * self.size].tobytes()

    def wait_readable(self, timeout: float) -> bool:
        r, _, _ = select.select([self.sock], [], [], max(0.0, timeout))
        return bool(r)

    def _recv_nowait(self) -> bytes:
        if self.libc is not None:
            return self._recvmmsg(MSG_DONTWAIT)
        out = []
        for _ in range(256):
            try:
                n = self.sock.recv_into(self._buf, self.size, MSG_DONTWAIT)
            except (BlockingIOError, InterruptedError):
                break
            if n == self.size:
                out.append(bytes(self._buf))
            elif n == RECORD_SIZE:  # a classic frame on a CAN FD socket
                out.append(bytes(self._buf[:RECORD_SIZE]).ljust(self.size, b"\0"))
        return b"".join(out)


class PythonCanTransport(Transport):
    """Any python-can bus (a real adapter, `virtual`, ...): one Message per frame."""

    def __init__(self, bus, rx_ids: Iterable[int], batch: int = 256, wide: bool = False) -> None:
        import can

        self.can = can
        self.bus = bus
        self.batch = batch
        self.wide = wide
        self.size = RECORD_FD_SIZE if wide else RECORD_SIZE
        self.name = f"python-can ({type(bus).__name__})"
        bus.set_filters([{"can_id": i, "can_mask": 0x7FF, "extended": False} for i in rx_ids])

    def send(self, blob: bytes) -> None:
        for i in range(0, len(blob), self.size):
            if self.wide:
                fid, dlc, flags, data = RECORD_FD.unpack_from(blob, i)
                fd = bool(flags & CANFD_FDF)
                self.bus.send(self.can.Message(arbitration_id=fid, is_extended_id=False, dlc=dlc, is_fd=fd,
                                               bitrate_switch=fd, data=data[: min(dlc, 64 if fd else 8)]))
                continue
            fid, dlc, data = RECORD.unpack_from(blob, i)
            self.bus.send(self.can.Message(arbitration_id=fid, is_extended_id=False, dlc=dlc,
                                           data=data[: min(dlc, 8)]))

    def recv(self, timeout: float) -> bytes:
        out: List[bytes] = []
        msg = self.bus.recv(timeout if timeout > 0 else 0.0)
        while msg is not None:
            if not (msg.is_error_frame or msg.is_remote_frame or msg.is_extended_id):
                data = bytes(msg.data)
                if self.wide:
                    out.append(RECORD_FD.pack(msg.arbitration_id, len(data), 5 if msg.is_fd else 0,
                                              data.ljust(64, b"\0")))
                else:
                    out.append(RECORD.pack(msg.arbitration_id, msg.dlc, data.ljust(8, b"\0")))
            if len(out) >= self.batch:
                break
            msg = self.bus.recv(0.0)
        return b"".join(out)

    def wait_readable(self, timeout: float) -> bool:
        time.sleep(max(0.0, min(timeout, 0.0005)))
        return True


def make_transport(bus, rx_ids: Iterable[int], fast: bool = True, wide: bool = False) -> Transport:
    """The fast path for a SocketCAN bus (unless fast=False), python-can otherwise; wide: CAN FD records."""
    rx_ids = list(rx_ids)
    if fast and hasattr(bus, "socket") and type(bus).__name__ == "SocketcanBus":
        return SocketcanTransport(bus, rx_ids, wide=wide)
    return PythonCanTransport(bus, rx_ids, wide=wide)
