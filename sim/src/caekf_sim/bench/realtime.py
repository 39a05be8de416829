"""Real-time runs: the bench paced at dt by absolute deadlines, timed by the kernel.

`run_paced` sends step k's input frames at the absolute deadline T0 + k*dt (clock_nanosleep with
TIMER_ABSTIME on CLOCK_REALTIME: no busy wait and no clock read per step, which matters where each
clock read is a trapped system call, as in user-mode Linux) and records the whole bus on a second
CAN_RAW socket, like candump, with kernel receive timestamps (SO_TIMESTAMPNS, the same clock as the
deadlines). Everything is measured from those timestamps after the run:

- frame in: the step's last input frame (BENCH_Y4) on the bus; estimate out: its EST_STEP on the bus;
  latency = out - in;
- a deadline miss: a step whose EST_STEP is not on the bus by its deadline + dt (when the next step's
  inputs are due), or never;
- send lateness: frame in - deadline (the bench's own wake-up and send);
- bus load seen: the recorded frames' worst-case lengths (`busload`) per second of wall time.

The recording is kept as a `candump -L` log. The echo probe (caekf-host --echo) answers each BENCH_Y4
at once with an EST_STEP-ID frame: the same run then shows what the machine and the bus alone cost.
"""
from __future__ import annotations

import ctypes
import ctypes.util
import errno
import os
import socket
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict, List, Optional, Union

import numpy as np

from .busload import fd_time_worst, frame_bits_worst
from .codec import CANFD_FDF, record_size, records_array
from .transport import (CAN_RAW_FD_FRAMES, MSG_DONTWAIT, MSG_WAITFORONE, SO_RCVTIMEO, _IOVec,  # declared once
                        _MMsgHdr, set_rcvbuf)

CLOCK_REALTIME = 0
TIMER_ABSTIME = 1
SO_TIMESTAMPNS = 35
SCM_TIMESTAMPNS = SO_TIMESTAMPNS
CTRL_SIZE = 64  # one cmsghdr (16 bytes) + struct timespec (16), padded
PathLike = Union[str, Path]


class _Timespec(ctypes.Structure):
    _fields_ = [("tv_sec", ctypes.c_long), ("tv_nsec", ctypes.c_long)]


def _libc():
    libc = ctypes.CDLL(ctypes.util.find_library("c") or "libc.so.6", use_errno=True)
    libc.clock_nanosleep.argtypes = [ctypes.c_int, ctypes.c_int, ctypes.POINTER(_Timespec),
                                     ctypes.POINTER(_Timespec)]
    libc.clock_nanosleep.restype = ctypes.c_int
    libc.recvmmsg.restype = ctypes.c_int
    libc.sendmmsg.restype = ctypes.c_int
    return libc


class BusRecorder:
    """A CAN_RAW socket that receives every frame on the interface with its kernel timestamp (wide: CAN FD
    frames too, every frame as a 72-byte struct canfd_frame record)."""

    def __init__(self, channel: str, batch: int = 512, rcvbuf: int = 32 << 20, wide: bool = False) -> None:
        self.sock = socket.socket(socket.AF_CAN, socket.SOCK_RAW, socket.CAN_RAW)
        set_rcvbuf(self.sock, rcvbuf)
        self.sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)
        self.wide = wide
        self.size = size = record_size(wide)
        if wide:
            self.sock.setsockopt(socket.SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1)
        self.sock.bind((channel,))
        self.fd = self.sock.fileno()
        self.libc = _libc()
        self.n = batch
        self.buf = ctypes.create_string_buffer(batch * size)
        self.ctrl = ctypes.create_string_buffer(batch * CTRL_SIZE)
        self.iov = (_IOVec * batch)()
        self.hdr = (_MMsgHdr * batch)()
        base, cbase = ctypes.addressof(self.buf), ctypes.addressof(self.ctrl)
        for i in range(batch):
            self.iov[i].iov_base = base + i * size
            self.iov[i].iov_len = size
            self.hdr[i].msg_hdr.msg_iov = ctypes.pointer(self.iov[i])
            self.hdr[i].msg_hdr.msg_iovlen = 1
            self.hdr[i].msg_hdr.msg_control = cbase + i * CTRL_SIZE
        # a ctypes array is a buffer, which numpy's stubs do not list among frombuffer's arguments
        self._ctrl_np = np.frombuffer(self.ctrl, dtype=np.int64).reshape(  # type: ignore[call-overload]
            batch, CTRL_SIZE // 8)
        self.records: List[bytes] = []
        self.stamps: List[np.ndarray] = []
        self._timeout: Optional[float] = None
        self._base = ctypes.addressof(self.buf)
        for i in range(batch):
            self.hdr[i].msg_hdr.msg_controllen = CTRL_SIZE
        self._used = 0  # headers the last call filled: only those need msg_controllen set again

    def _set_timeout(self, timeout: float) -> None:
        if timeout != self._timeout:
            sec = int(timeout)
            usec = max(1, int(round((timeout - sec) * 1e6))) if sec == 0 else int(round((timeout - sec) * 1e6))
            self.sock.setsockopt(socket.SOL_SOCKET, SO_RCVTIMEO, struct.pack("@ll", sec, usec))
            self._timeout = timeout

    def poll(self, timeout: float = 0.0) -> int:
        """Take what is queued (waiting up to `timeout` s for the first frame); frames taken."""
        hdr = self.hdr
        for i in range(self._used):
            hdr[i].msg_hdr.msg_controllen = CTRL_SIZE
        if self.wide and self._used:  # a classic frame fills 16 bytes of its slot: no stale bytes after it
            ctypes.memset(self.buf, 0, self._used * self.size)
        self._used = 0
        if timeout > 0:
            self._set_timeout(timeout)
            k = self.libc.recvmmsg(self.fd, self.hdr, self.n, MSG_WAITFORONE, None)
        else:
            k = self.libc.recvmmsg(self.fd, self.hdr, self.n, MSG_DONTWAIT, None)
        if k < 0:
            e = ctypes.get_errno()
            if e in (errno.EAGAIN, errno.EWOULDBLOCK, errno.EINTR):
                return 0
            raise OSError(e, os.strerror(e))
        if k == 0:
            return 0
        self._used = k
        # cmsghdr: len (8), level (4), type (4); then struct timespec
        c = self._ctrl_np[:k]
        self.stamps.append(c[:, 2] * 1_000_000_000 + c[:, 3])
        self.records.append(ctypes.string_at(self._base, k * self.size))
        return k

    def drain(self, quiet: float) -> None:
        """Take frames until none came for `quiet` seconds."""
        while self.poll(quiet):
            pass

    def frames(self):
        """(timestamps in ns, record array) of everything recorded."""
        if not self.records:
            return np.zeros(0, np.int64), records_array(b"", self.wide)
        return np.concatenate(self.stamps), records_array(b"".join(self.records), self.wide)

    def close(self) -> None:
        self.sock.close()


def write_candump(path: PathLike, channel: str, t_ns: np.ndarray, recs) -> int:
    """candump -L lines: (SEC.USEC) CHANNEL ID#DATA, or ID##<flags nibble>DATA for a CAN FD frame."""
    flags = recs["flags"].tolist() if "flags" in (recs.dtype.names or ()) else [0] * len(recs)
    with open(path, "w", encoding="ascii") as f:
        for t, fid, dlc, fl, data in zip(t_ns.tolist(), recs["id"].tolist(), recs["dlc"].tolist(), flags,
                                         recs["data"]):
            sep = f"##{fl & 0xF:X}" if fl & CANFD_FDF else "#"
            f.write(f"({t // 1_000_000_000}.{(t // 1000) % 1_000_000:06d}) {channel} {fid:03X}{sep}"
                    f"{bytes(data[:dlc]).hex().upper()}\n")
    return len(t_ns)


@dataclass
class PacedRun:
    n: int
    dt: float
    deadlines_ns: np.ndarray
    t_in_ns: np.ndarray  # per row: its last input frame on the bus (NaN-free: -1 if never seen)
    t_out_ns: np.ndarray  # per row: its EST_STEP on the bus, -1 if never
    frames_t_ns: np.ndarray
    frames: np.ndarray  # record array of every frame on the bus
    echo: bool = False
    windows: List[Dict[str, float]] = field(default_factory=list)


def run_paced(transport, blobs: List[bytes], wire: List[int], dt: float, channel: str, in_id: int, out_id: int,
              grace: float = 0.5, start_delay: float = 0.05, out_step_bits: int = 16,
              in_step_bits: int = 16, in_step_start: int = 12, out_step_start: int = 12,
              wide: bool = False) -> PacedRun:
    """Send blobs[k] at T0 + k*dt (absolute, CLOCK_REALTIME); record the bus; match by STEP (its start bit
    and width in the input and output messages; wide: CAN FD records, as the transport's)."""
    libc = _libc()
    rec = BusRecorder(channel, wide=wide)
    send = transport.send
    poll = rec.poll
    n = len(blobs)
    dt_ns = int(round(dt * 1e9))
    t0 = _realtime_ns() + int(start_delay * 1e9)
    ts = _Timespec()
    tsp = ctypes.byref(ts)
    sleep = libc.clock_nanosleep
    try:
        for k in range(n):
            d = t0 + k * dt_ns
            ts.tv_sec = d // 1_000_000_000
            ts.tv_nsec = d % 1_000_000_000
            while sleep(CLOCK_REALTIME, TIMER_ABSTIME, tsp, None) == errno.EINTR:
                pass
            send(blobs[k])
            poll(0.0)
        rec.drain(grace)
    finally:
        rec.close()
    t_ns, frames = rec.frames()
    deadlines = t0 + dt_ns * np.arange(n, dtype=np.int64)
    t_in = _first_by_step(t_ns, frames, in_id, wire, in_step_bits, in_step_start)
    t_out = _first_by_step(t_ns, frames, out_id, wire, out_step_bits, out_step_start)
    return PacedRun(n, dt, deadlines, t_in, t_out, t_ns, frames)


def _realtime_ns() -> int:
    import time

    return time.clock_gettime_ns(time.CLOCK_REALTIME)


def _first_by_step(t_ns: np.ndarray, frames, fid: int, wire: List[int], step_bits: int = 16,
                   step_start: int = 12) -> np.ndarray:
    """Per row: the timestamp of the first frame `fid` whose STEP (bits step_start.., step_bits wide: 16, or 8
    for the production profile's BENCH_YP and EST_PROD, unwrapped in bus order) is that row's."""
    n = len(wire)
    out = np.full(n, -1, dtype=np.int64)
    if n == 0 or len(frames) == 0:
        return out
    sel = frames["id"] == fid
    d = frames["data"][sel]
    first = step_start // 8
    st = np.zeros(len(d), dtype=np.int64)
    for k in range((step_start % 8 + step_bits + 7) // 8):
        st |= d[:, first + k].astype(np.int64) << (8 * k)
    st >>= step_start % 8
    mod = 1 << step_bits
    st &= mod - 1
    if step_bits >= 16:
        row = (st - int(wire[0])) & 0xFFFF
    else:  # unwrap in bus order, relative to the run's first step
        row = np.empty(len(st), dtype=np.int64)
        if len(st):
            row[0] = (st[0] - int(wire[0])) % mod
            row[1:] = row[0] + np.cumsum((np.diff(st) + mod // 2) % mod - mod // 2)
    ok = (row >= 0) & (row < n)
    row, tt = row[ok], t_ns[sel][ok]
    order = np.argsort(tt, kind="stable")[::-1]  # later first, so the first one per row wins below
    out[row[order]] = tt[order]
    return out


def frame_times_worst(frames, bitrate: float, data_bitrate: float = 5e6) -> np.ndarray:
    """Worst-case bus time of each recorded frame, in bit times at `bitrate` (CAN FD frames with bit-rate
    switch to `data_bitrate`, busload.fd_time_worst)."""
    if not len(frames):
        return np.zeros(0)
    bits = frame_bits_worst(frames["dlc"]).astype(float)
    if "flags" in (frames.dtype.names or ()):
        fd = (frames["flags"] & CANFD_FDF) != 0
        bits[fd] = [fd_time_worst(int(n), bitrate, data_bitrate) * bitrate for n in frames["dlc"][fd]]
    return bits


def paced_stats(run: PacedRun, bitrate: float, window_s: float = 60.0, est_ids=None,
                data_bitrate: float = 5e6) -> List[Dict[str, float]]:
    """Per window of `window_s` seconds of steps (and 'all'): deadline misses, latency p50/p99/max,
    send lateness p99, bus load seen (worst-case frame lengths of the recorded frames; CAN FD frames with
    their data phase at data_bitrate)."""
    per = max(1, int(round(window_s / run.dt)))
    bits = frame_times_worst(run.frames, bitrate, data_bitrate)
    out = []
    bounds = [(a, min(run.n, a + per)) for a in range(0, run.n, per)]
    if len(bounds) > 1:
        bounds.append((0, run.n))
    for a, b in bounds:
        dl = run.deadlines_ns[a:b]
        tin, tout = run.t_in_ns[a:b], run.t_out_ns[a:b]
        got = (tout >= 0) & (tin >= 0)
        lat = (tout[got] - tin[got]) / 1e9
        late = (tin[tin >= 0] - dl[tin >= 0]) / 1e9
        miss = int(np.sum(tout < 0) + np.sum(tout[tout >= 0] > dl[tout >= 0] + int(run.dt * 1e9)))
        t_lo, t_hi = dl[0], dl[-1] + int(run.dt * 1e9)
        in_win = (run.frames_t_ns >= t_lo) & (run.frames_t_ns < t_hi)
        dur = (t_hi - t_lo) / 1e9
        row = {"from_s": a * run.dt, "to_s": b * run.dt, "steps": float(b - a), "answered": float(got.sum()),
               "misses": float(miss), "frames": float(in_win.sum()),
               "bus_load": float(bits[in_win].sum() / (dur * bitrate)) if dur > 0 else float("nan"),
               "all": float(a == 0 and b == run.n and len(bounds) > 1)}
        if len(lat):
            row.update(p50=float(np.percentile(lat, 50)), p99=float(np.percentile(lat, 99)), max=float(lat.max()))
        if len(late):
            row.update(send_late_p99=float(np.percentile(late, 99)), send_late_max=float(late.max()))
        out.append(row)
    run.windows = out
    return out


def format_paced(name: str, rows: List[Dict[str, float]], dt: float, bitrate: float) -> str:
    lines = [f"{name}: deadline = inputs due + dt ({1e3 * dt:g} ms); latency = last input frame -> the frame that "
             f"closes the step (EST_STEP, EST_PROD, EST_FD), both kernel-timestamped on the bus; bus load = worst-case "
             f"bits at {bitrate / 1e6:g} Mbit/s (CAN FD frames: data phase at 5 Mbit/s)"]
    lines.append(f"  {'window':>14}  {'steps':>7}  {'answered':>8}  {'misses':>7}  {'p50 us':>7}  {'p99 us':>7}  "
                 f"{'max us':>8}  {'send late p99 us':>16}  {'bus load':>8}")
    for r in rows:
        w = "all" if r.get("all") else f"{r['from_s']:.0f}-{r['to_s']:.0f} s"
        f = lambda k, s=1e6: f"{s * r[k]:.0f}" if k in r else "-"  # noqa: E731
        lines.append(f"  {w:>14}  {int(r['steps']):>7}  {int(r['answered']):>8}  {int(r['misses']):>7}  "
                     f"{f('p50'):>7}  {f('p99'):>7}  {f('max'):>8}  {f('send_late_p99'):>16}  "
                     f"{100 * r['bus_load']:>7.1f}%")
    return "\n".join(lines)
