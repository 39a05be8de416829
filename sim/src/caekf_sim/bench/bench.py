"""The HIL bench: configures the estimator over CAN and drives it with a recorded truth.

One `Bench` per bus and process: it owns the bench's E2E alive counters (continuous over every
experiment, so the four experiments run back to back without restarting caekf-host), the request
tokens, and an optional journal of every frame sent and received (written as a `candump -L` log).

Runs:
- `run_lockstep`: send step k's three input frames, wait for its EST_STEP (the last estimate frame)
  with a timeout, go on. `window` > 1 keeps up to that many steps in flight (pipelined lockstep:
  the estimator handles frames in order, so the estimates are the same; only the bus round trips
  overlap). A step whose EST_STEP does not come within `timeout` is counted and given up: the loop
  never hangs.
- `run_realtime`: send step k at t0 + k*dt whatever the estimator does (with flow control: at most
  `max_in_flight` steps unanswered), record when each EST_STEP comes back, and report latency
  percentiles and deadline misses (`latency_stats`).

The hot loops touch only bytes: input frames are encoded and sealed for the whole run with numpy
before it starts (`prepare`, `seal_steps`), received frames are appended as raw records and decoded
after the run (`decode_run`), which also checks their E2E protection.
"""
from __future__ import annotations

import os
import struct
import sys
import time
from array import array
from dataclasses import dataclass, field
from typing import Dict, Iterable, List, Mapping, Optional, Sequence, Tuple

import numpy as np

from .. import schema
from . import e2e
from .buslog import write_journal
from .codec import RECORD, RECORD_FD, Codec, record_size, records_array
from .profiles import INPUT_KEYS, SENSOR_KEYS, Profile, get_profile, mechanism_profile
from .transport import Transport, make_transport, open_bus

STEP_MOD = 1 << 16
E2E_FIELDS = ("E2E_CRC", "E2E_COUNTER")


class BenchError(RuntimeError):
    pass


class ConfigRefused(BenchError):
    def __init__(self, status: int, status_name: str, bad_param: str) -> None:
        super().__init__(f"configuration refused: {status_name} ({status}), parameter {bad_param}")
        self.status, self.status_name, self.bad_param = status, status_name, bad_param


@dataclass
class Ack:
    token: int
    status: int
    status_name: str
    bad_param: int
    n_params_rx: int
    state: int


@dataclass
class StepInputs:
    """A run's inputs: t, u, y as given, their frames' payloads (unsealed) and what the
    estimator decodes from them (u_seen: float32(u); y_seen: y rounded to the 1e-12 m LSB)."""

    t: np.ndarray
    u: np.ndarray
    y: np.ndarray
    wire_steps: np.ndarray  # STEP field per row: sample number k = row + 1, modulo 2^16
    payloads: Dict[str, np.ndarray]  # input message of the profile -> (n, 8) uint8, E2E fields zero
    u_seen: np.ndarray  # (n,) for one input, (n, inputs) for more
    y_seen: np.ndarray  # (n, sensors)
    names: Tuple[str, ...] = ("u", "y1", "y4")  # measurement CSV columns after t: the inputs, then the sensors

    def __len__(self) -> int:
        return len(self.t)


@dataclass
class RunRecord:
    """What one run sent and received (raw), decoded later by `decode_run`."""

    start: int
    stop: int
    mode: str = "lockstep"
    window: int = 1
    chunks: List[bytes] = field(default_factory=list)
    timeouts: int = 0
    elapsed: float = 0.0
    t_sent: Optional[np.ndarray] = None  # realtime: perf_counter after the step's frames went out
    t_rx: Optional[np.ndarray] = None  # realtime: perf_counter when its EST_STEP was read
    late_sends: int = 0  # realtime: steps the bench itself sent more than dt late
    held: int = 0  # realtime: steps held back because max_in_flight were unanswered
    aborted: bool = False  # lockstep: gave up after too many timeouts in a row
    dt: float = float("nan")
    deadlines: Optional[np.ndarray] = None  # paced realtime: each step's absolute deadline (same clock as t_*)
    paced: Optional[object] = None  # paced realtime: the realtime.PacedRun (whole-bus recording)

    @property
    def n(self) -> int:
        return self.stop - self.start


@dataclass
class Decoded:
    """Estimates of rows [start, stop) as decoded from CAN; NaN where a frame never came."""

    columns: Dict[str, np.ndarray]
    complete: np.ndarray  # bool per row: every estimate frame the profile sends each step received
    step_status: np.ndarray
    bad_crc: int = 0
    bad_dlc: int = 0
    counter_duplicates: int = 0
    counter_jumps: int = 0
    counter_lost: int = 0
    duplicated_steps: int = 0
    foreign_steps: int = 0  # estimate frames whose STEP maps outside the run
    frames: int = 0
    carried: Dict[str, np.ndarray] = field(default_factory=dict)  # column -> rows whose value came over CAN


def profile_is_fd(profile: Profile, codec: Codec) -> bool:
    """Whether a profile's step frames are CAN FD ones (the DBC says so: VFrameFormat StandardCAN_FD)."""
    return any(codec.messages[m].is_fd for m in (*profile.input_messages, profile.closing))


def _now() -> float:
    return time.perf_counter()


class Bench:
    """Bench side of the caekf CAN protocol over one python-can bus."""

    def __init__(self, transport: Transport, codec: Optional[Codec] = None, record_log: bool = False,
                 channel: str = "vcan0", profile: str = "diagnostics") -> None:
        self.codec = codec or Codec()
        self.profile: Profile = get_profile(profile)
        # the fd profile's bench moves every frame as a 72-byte struct canfd_frame record (classic ones too)
        self.wide = profile_is_fd(self.profile, self.codec)
        self.rsize = record_size(self.wide)
        if getattr(transport, "size", self.rsize) != self.rsize:
            raise BenchError(f"profile {self.profile.name} needs a {'CAN FD' if self.wide else 'classic'} transport")
        self.transport = transport
        self.channel = channel
        self.tx_counter: Dict[str, int] = {m.name: 0 for m in self.codec.messages.values() if m.to_estimator}
        self.token = (os.getpid() * 7) & 0xFF
        self.journal: Optional[List[Tuple[float, int, bytes]]] = [] if record_log else None
        self.wall_offset = time.time() - _now()
        self.rx_bad_crc = 0  # control frames from the estimator that failed the CRC
        closing = self.codec.messages[self.profile.closing]
        self._est_step_pat = struct.pack("<IB", closing.frame_id, closing.length)  # id and length of its records
        step = closing.signals["STEP"]
        self._step_at = (8 + step.start // 8, 8 + (step.start + step.length + 7) // 8, step.start % 8)
        self._step_mask = self.profile.step_mask
        self._ack_id = self.codec.messages["EST_ACK"].frame_id
        self._health_id = self.codec.messages["EST_HEALTH"].frame_id
        self.names: Tuple[str, ...] = ("u", "y1", "y4")  # the paper's measurement columns (use_mechanism)

    def use_mechanism(self, sc) -> Profile:
        """Drive a scenario's mechanism (diagnostics profile only): its inputs and sensors in, every body's and
        contact's estimate out (profiles.mechanism_profile; the paper's mechanism keeps the paper's frames).
        `prepare` then takes its truth's u and y and names the seen inputs' columns as caekf-replay reads them."""
        from ..mechanism import Mechanism

        if self.profile.name != "diagnostics":
            raise BenchError(f"profile {self.profile.name} carries the paper's frames only (input 1, sensors 1 and "
                             "2 as positions, bodies 1..4, contact 1): run a mechanism in the diagnostics profile")
        mech = Mechanism.from_scenario(sc)
        self.profile = mechanism_profile(mech)
        self.names = tuple(mech.input_names()) + tuple(mech.sensor_names())
        return self.profile

    def match_scenario(self, sc) -> Profile:
        """The profile for a scenario's mechanism: diagnostics -> use_mechanism; production and fd carry the
        paper's inputs only (input 1, sensors 1 and 2 as positions): another mechanism is refused there, rather
        than its sensors sent on frames of another kind."""
        from ..mechanism import POSITION, Mechanism

        if self.profile.name == "diagnostics":
            return self.use_mechanism(sc)
        mech = Mechanism.from_scenario(sc)
        if mech.n_inputs != 1 or mech.sensor_kind.tolist() != [POSITION, POSITION]:
            raise BenchError(f"profile {self.profile.name} carries one input and two position sensors; this mechanism "
                             f"has {mech.n_inputs} input(s) and sensors {', '.join(mech.sensor_names())}: run it in "
                             "the diagnostics profile")
        return self.profile

    @classmethod
    def open(cls, interface: str = "socketcan", channel: str = "vcan0", fast: bool = True,
             record_log: bool = False, codec: Optional[Codec] = None, profile: str = "diagnostics",
             **bus_kwargs) -> "Bench":
        codec = codec or Codec()
        wide = profile_is_fd(get_profile(profile), codec)
        if wide:
            bus_kwargs.setdefault("fd", True)
        bus = open_bus(interface, channel, **bus_kwargs)
        return cls(make_transport(bus, codec.from_estimator_ids, fast=fast, wide=wide), codec, record_log, channel,
                   profile)

    def close(self) -> None:
        self.transport.close()
        bus = getattr(self.transport, "bus", None)
        if bus is not None:
            bus.shutdown()

    def __enter__(self) -> "Bench":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    # --- frames ---------------------------------------------------------------------------

    def frame(self, name: str, values: Mapping[str, float], counter: Optional[int] = None,
              advance: bool = True, dlc: Optional[int] = None) -> bytes:
        """One sealed record of `name` encoded by cantools. The counter is the message's next one
        unless given; `advance` moves the message's counter past the one used."""
        c = self.tx_counter[name] if counter is None else counter
        data = self.codec.encode(name, values, c)
        if advance:
            self.tx_counter[name] = (c + 1) & 15
        if dlc is not None:
            return self.record(name, data[:dlc], dlc)
        return self.record(name, data)

    def record(self, name_or_id, data: bytes, dlc: Optional[int] = None, fd: Optional[bool] = None) -> bytes:
        """One raw record in this bench's format (Codec.record; 72-byte canfd_frame records in the fd profile,
        a CAN FD frame there when `fd` or, by default, for a CAN FD message or more than 8 bytes)."""
        return self.codec.record(name_or_id, data, dlc, wide=self.wide, fd=fd)

    def records(self, blob: bytes) -> np.ndarray:
        """A blob of this bench's records as a structured array (codec.records_array)."""
        return records_array(blob, self.wide)

    def unpack_record(self, blob: bytes, off: int) -> Tuple[int, int, bytes]:
        """(id, dlc or length, data) of the record at `off`."""
        if self.wide:
            fid, dlc, _, data = RECORD_FD.unpack_from(blob, off)
            return fid, dlc, data
        return RECORD.unpack_from(blob, off)

    def send(self, blob: bytes) -> None:
        self.transport.send(blob)
        if self.journal is not None:
            self.journal.append((_now(), 0, blob))

    def recv(self, timeout: float) -> bytes:
        blob = self.transport.recv(timeout)
        if blob and self.journal is not None:
            self.journal.append((_now(), 1, blob))
        return blob

    def drain(self) -> int:
        n = 0
        while True:
            blob = self.recv(0.0)
            if not blob:
                return n
            n += len(blob) // self.rsize

    def _next_token(self) -> int:
        self.token = (self.token + 1) & 0xFF
        return self.token

    def _control_frames(self, blob: bytes) -> Iterable[Tuple[int, bytes]]:
        for off in range(0, len(blob), self.rsize):
            fid, dlc, data = self.unpack_record(blob, off)
            if fid in (self._ack_id, self._health_id):
                data = data[:8]
                info = self.codec.by_id[fid]
                if dlc != 8 or not e2e.crc_ok(info.data_id, data):
                    self.rx_bad_crc += 1
                    continue
                yield fid, data

    def _decode_ack(self, data: bytes) -> Ack:
        d = self.codec.decode(self._ack_id, data)
        st = int(d["ACK_STATUS"])
        return Ack(int(d["TOKEN"]), st, self.codec.ack_status_names.get(st, str(st)), int(d["BAD_PARAM"]),
                   int(d["N_PARAMS_RX"]), int(d["STATE"]))

    def _await_ack(self, token: int, timeout: float, health: bool = False):
        """Wait for EST_ACK with this token (and, with health, the EST_HEALTH pages after it)."""
        end = _now() + timeout
        ack = None
        pages: Dict[int, Dict[str, int]] = {}
        while _now() < end:
            blob = self.recv(max(0.001, end - _now()))
            for fid, data in self._control_frames(blob):
                if fid == self._ack_id and ack is None:
                    a = self._decode_ack(data)
                    if a.token == token:
                        ack = a
                elif fid == self._health_id and ack is not None and health:
                    d = self.codec.decode(fid, data)
                    page = int(d.pop("PAGE"))
                    pages.setdefault(page, {k: int(v) for k, v in d.items() if k not in E2E_FIELDS})
            if ack is not None and (not health or len(pages) >= self.codec.health_pages):
                break
        return ack, pages

    # --- control ----------------------------------------------------------------------------

    def status(self, timeout: float = 2.0, retries: int = 3) -> Dict[str, int]:
        """CTRL_STATUS_REQ -> EST_ACK + every EST_HEALTH page: the estimator's counters."""
        for _ in range(retries):
            token = self._next_token()
            self.send(self.frame("CTRL_STATUS_REQ", {"TOKEN": token}))
            ack, pages = self._await_ack(token, timeout, health=True)
            if ack is not None and len(pages) >= self.codec.health_pages:
                out: Dict[str, int] = {}
                for p in sorted(pages):
                    out.update(pages[p])
                out["_state"] = ack.state
                return out
        raise BenchError(f"no status reply from the estimator after {retries} requests "
                         f"({timeout:g} s each): is caekf-host running on {self.channel}?")

    def wait_for_estimator(self, timeout: float = 10.0) -> Dict[str, int]:
        """Status requests until the estimator answers (it may still be starting)."""
        end = _now() + timeout
        while True:
            try:
                return self.status(timeout=0.5, retries=1)
            except BenchError:
                if _now() > end:
                    raise BenchError(f"the estimator did not answer on {self.channel} within {timeout:g} s "
                                     "(is caekf-host running on this interface?)") from None

    def params_from_scenario(self, sc, preset: Optional[str] = None) -> List[Tuple[str, float]]:
        """Every CTRL_PARAM setting of the scenario (its values over the schema's defaults) with the
        named preset's values over them, in PARAM_ID order: a complete configuration, so nothing of an
        earlier one carries over. The estimator knows no presets: they travel as ordinary settings."""
        params = schema.wire_values(sc.values(), preset, complete=True)
        unknown = [k for k, _ in params if k not in self.codec.param_ids]
        if unknown:
            raise BenchError(f"the DBC has no PARAM_ID for {unknown[0]!r} (is it stale? run codegen.py dbc)")
        return params

    def param_frame(self, name: str, value: float) -> bytes:
        mant, exp10 = e2e.to_mantissa_exp10(value)
        return self.frame("CTRL_PARAM", {"PARAM_ID": self.codec.param_ids[schema.canonical(name)], "PARAM_EXP10": exp10,
                                         "PARAM_MANTISSA": mant})

    def configure(self, label: str, params: Sequence[Tuple[str, float]] = (), timeout: float = 2.0,
                  retries: int = 4) -> Ack:
        """CTRL_PARAM x len(params), CTRL_RESET(N_PARAMS), EST_ACK; retried when the answer is missing
        or INCOMPLETE (a parameter frame lost or rejected), raises on refusal. `label` (a preset's name,
        say) only names the configuration in messages."""
        last = "no answer"
        for _ in range(retries):
            self.drain()
            blob = b"".join(self.param_frame(n, v) for n, v in params)
            token = self._next_token()
            blob += self.frame("CTRL_RESET", {"N_PARAMS": len(params), "TOKEN": token})
            self.send(blob)
            ack, _ = self._await_ack(token, timeout)
            if ack is None:
                last = f"no EST_ACK within {timeout:g} s"
                continue
            if ack.status == 0:
                return ack
            last = f"{ack.status_name} (n_params_rx {ack.n_params_rx} of {len(params)})"
            if ack.status_name != "REFUSED_INCOMPLETE":
                bad = {v: k for k, v in self.codec.param_ids.items()}.get(ack.bad_param, str(ack.bad_param))
                raise ConfigRefused(ack.status, ack.status_name, bad)
        raise BenchError(f"configuring {label} failed after {retries} attempts: {last}")

    # --- inputs ---------------------------------------------------------------------------

    def prepare(self, t, u, y, check: bool = True) -> StepInputs:
        """Encode every step's input frames once (numpy, from the DBC); checked against cantools. u: (n,) or
        (n, inputs), y: (n, sensors) in the mechanism's order (use_mechanism; the paper: y1, y4)."""
        t = np.asarray(t, dtype=float)
        n = len(t)
        u2 = np.asarray(u, dtype=float).reshape(n, -1)
        y2 = np.asarray(y, dtype=float).reshape(n, -1)
        steps = (np.arange(1, n + 1) % STEP_MOD).astype(np.int64)
        values = {**{INPUT_KEYS[i]: u2[:, i] for i in range(min(u2.shape[1], len(INPUT_KEYS)))},
                  **{SENSOR_KEYS[s]: y2[:, s] for s in range(min(y2.shape[1], len(SENSOR_KEYS)))}}
        missing = [col for _, sigs in self.profile.inputs for _, col in sigs if col not in values]
        if missing:
            raise BenchError(f"profile {self.profile.name} sends {', '.join(missing)}: the inputs have "
                             f"{u2.shape[1]} input(s) and {y2.shape[1]} sensor(s)")
        payloads = {}
        seen = {}
        for name, sigs in self.profile.inputs:
            payloads[name] = self.codec.pack(name, {"STEP": steps, **{sig: values[col] for sig, col in sigs}},
                                             counters=0)
            payloads[name][:, 0] = 0
            dec = self.codec.unpack(name, payloads[name], [sig for sig, _ in sigs])
            for sig, col in sigs:
                seen[col] = dec[sig]
        if check and n:
            rows = sorted({0, n // 2, n - 1})
            self.codec.self_check([(name, {"STEP": int(steps[r]), **{sig: float(values[col][r]) for sig, col in sigs}})
                                   for r in rows for name, sigs in self.profile.inputs])
        u_keys = [k for k in INPUT_KEYS if k in seen]
        y_keys = [k for k in SENSOR_KEYS if k in seen]
        u_seen = seen[u_keys[0]] if len(u_keys) == 1 else np.column_stack([seen[k] for k in u_keys])
        y_seen = np.column_stack([seen[k] for k in y_keys])
        return StepInputs(t, u2[:, 0] if u2.shape[1] == 1 else u2, y2, steps, payloads, u_seen, y_seen, self.names)

    def seal_steps(self, inputs: StepInputs, start: int, stop: int, order: Optional[Sequence[str]] = None,
                   extra: bytes = b"") -> List[bytes]:
        """Sealed records of rows [start, stop), one bytes blob per step (its input frames in the
        profile's order, after `extra`), with the bench's counters, which move on past them."""
        order = tuple(order or self.profile.input_messages)
        n = stop - start
        if n <= 0:
            return []
        recs = np.zeros((n, len(order), self.rsize), dtype=np.uint8)
        for j, name in enumerate(order):
            info = self.codec.messages[name]
            c0 = self.tx_counter[name]
            counters = (c0 + np.arange(n)) & 15
            seal = e2e.seal_fd_np if info.is_fd else e2e.seal_np
            sealed = seal(info.data_id, counters, inputs.payloads[name][start:stop])
            recs[:, j, :8] = np.frombuffer(self.record(name, bytes(info.length))[:8], np.uint8)
            recs[:, j, 8:8 + info.length] = sealed
            self.tx_counter[name] = int((c0 + n) & 15)
        flat = recs.tobytes()
        size = len(order) * self.rsize
        if extra:
            return [extra + flat[i:i + size] for i in range(0, len(flat), size)]
        return [flat[i:i + size] for i in range(0, len(flat), size)]

    # --- runs -----------------------------------------------------------------------------

    def _step_of(self, chunk: bytes, p: int) -> int:
        """STEP (its DBC start bit and width in the profile's closing message) of the record at offset p."""
        a, b, shift = self._step_at
        return (int.from_bytes(chunk[p + a:p + b], "little") >> shift) & self._step_mask

    def _last_est_step(self, chunk: bytes) -> int:
        """STEP of the last closing record (EST_STEP, EST_PROD) in a chunk, -1 if none."""
        pat = self._est_step_pat
        p = chunk.rfind(pat)
        while p >= 0 and p % self.rsize:
            p = chunk.rfind(pat, 0, p + len(pat) - 1)  # a match inside data bytes: look further back
        return self._step_of(chunk, p) if p >= 0 else -1

    def run_lockstep(self, inputs: StepInputs, start: int = 0, stop: Optional[int] = None, window: int = 1,
                     timeout: float = 1.0, progress: Optional[bool] = None, extra_per_step: bytes = b"",
                     record: Optional[RunRecord] = None, desc: str = "lockstep", batch_sched: bool = True,
                     max_timeouts_in_a_row: int = 20) -> RunRecord:
        """Send rows [start, stop) in lockstep (see the module docstring).

        batch_sched: run the loop as SCHED_BATCH (Linux), so that each estimate frame arriving
        does not preempt the estimator to wake the bench (on one CPU, e.g. the TCG VM, that
        would cost a context switch per frame); the bench then reads a step's frames at once.
        After max_timeouts_in_a_row timeouts in a row the estimator is taken to be gone: the rest
        of the run is counted as timed out (rec.aborted) instead of waiting `timeout` per step."""
        with _batch_scheduling(batch_sched):
            return self._run_lockstep(inputs, start, stop, window, timeout, progress, extra_per_step, record, desc,
                                      max_timeouts_in_a_row)

    def _run_lockstep(self, inputs, start, stop, window, timeout, progress, extra_per_step, record, desc,
                      max_timeouts_in_a_row):
        stop = len(inputs) if stop is None else stop
        rec = record or RunRecord(start, stop, "lockstep", window)
        blobs = self.seal_steps(inputs, start, stop, extra=extra_per_step)
        wire = inputs.wire_steps[start:stop].tolist()
        n = len(blobs)
        send, recv = self.transport.send, self.transport.recv
        journal = self.journal
        last_est_step = self._last_est_step
        mask = self._step_mask
        chunks = rec.chunks
        window = max(1, int(window))
        bar = _progress_bar(n, desc, progress)
        done = sent = timeouts = streak = 0
        max_streak = max(1, int(max_timeouts_in_a_row))
        shown = 0
        t0 = _now()
        progress_at = t0
        while done < n:
            if sent < n and sent - done < window:  # refill the window in one send (one sendmmsg)
                k = min(n, done + window)
                blob = blobs[sent] if k == sent + 1 else b"".join(blobs[sent:k])
                send(blob)
                if journal is not None:
                    journal.append((_now(), 0, blob))
                sent = k
            chunk = recv(timeout)
            if chunk:
                chunks.append(chunk)
                if journal is not None:
                    journal.append((_now(), 1, chunk))
                s = last_est_step(chunk)
                if s >= 0:
                    d = (wire[sent - 1] - s) & mask  # steps between the newest sent and this one
                    if d < sent - done:
                        done = sent - d
                        streak = 0
                        progress_at = _now()
                        if bar is not None and done - shown >= 250:
                            bar.update(done - shown)
                            shown = done
                        continue
            if _now() - progress_at >= timeout:  # the oldest step in flight never came back
                timeouts += 1
                streak += 1
                done += 1
                progress_at = _now()
                if streak >= max_streak:  # the estimator is gone: give up the rest, do not wait on
                    rec.aborted = True
                    timeouts += n - done
                    done = n
        rec.elapsed += _now() - t0
        rec.timeouts += timeouts
        # estimates still on their way (a timed-out step answered late): collect briefly
        tail = recv(0.0)
        if tail:
            chunks.append(tail)
            if journal is not None:
                journal.append((_now(), 1, tail))
        if bar is not None:
            bar.update(n - shown)
            bar.close()
        return rec

    def run_realtime(self, inputs: StepInputs, dt: float, start: int = 0, stop: Optional[int] = None,
                     grace: float = 1.0, progress: Optional[bool] = None, desc: str = "realtime",
                     batch_sched: bool = True, max_in_flight: int = 32) -> RunRecord:
        """Send row k at t0 + k*dt and time each step's EST_STEP.

        If the bench falls behind it sends the overdue steps at once, but never has more than
        `max_in_flight` steps unanswered (an answer older than `grace` counts as lost): an
        overloaded machine (the TCG VM at 1 kHz) then shows up as late sends, latency and deadline
        misses, not as frames dropped by the estimator's full receive queue, which would make it
        skip steps and leave the truth for the rest of the run. Sends held back are counted (held).
        batch_sched as in run_lockstep: the bench does not preempt the estimator at each of its
        frames, and EST_STEP is its last frame, so the latency measured to it does not suffer."""
        with _batch_scheduling(batch_sched):
            return self._run_realtime(inputs, dt, start, stop, grace, progress, desc, max(1, int(max_in_flight)))

    def _run_realtime(self, inputs, dt, start, stop, grace, progress, desc, max_in_flight):
        stop = len(inputs) if stop is None else stop
        rec = RunRecord(start, stop, "realtime", 0, dt=dt)
        blobs = self.seal_steps(inputs, start, stop)
        wire = inputs.wire_steps[start:stop].tolist()
        n = len(blobs)
        t_sent = array("d", bytes(8 * n))
        t_rx = array("d", bytes(8 * n))
        send, recv, wait = self.transport.send, self.transport.recv, self.transport.wait_readable
        journal = self.journal
        pat = self._est_step_pat
        chunks = rec.chunks
        bar = _progress_bar(n, desc, progress)
        shown = 0
        sent = answered = late = held = oldest = 0
        held_step = -1
        t0 = _now() + 0.01
        end = None
        while True:
            now = _now()
            if sent < n:
                due = t0 + sent * dt
                while oldest < sent and (t_rx[oldest] != 0.0 or now - t_sent[oldest] > grace):
                    oldest += 1  # answered, or given up on
                if now >= due and sent - oldest >= max_in_flight:
                    if held_step != sent:  # flow control: wait for answers instead of piling up
                        held += 1
                        held_step = sent
                    wait_s = min(dt, 0.001)
                elif now >= due:
                    send(blobs[sent])
                    ts = _now()
                    t_sent[sent] = ts
                    if journal is not None:
                        journal.append((ts, 0, blobs[sent]))
                    if ts - due > dt:
                        late += 1
                    sent += 1
                    if bar is not None and sent - shown >= 250:
                        bar.update(sent - shown)
                        shown = sent
                    continue
                else:
                    wait_s = due - now
            else:
                if end is None:
                    end = now + grace
                if answered >= n or now >= end:
                    break
                wait_s = end - now
            if not wait(wait_s):
                continue
            chunk = recv(0.0)
            if not chunk:
                continue
            tr = _now()
            chunks.append(chunk)
            if journal is not None:
                journal.append((tr, 1, chunk))
            p = chunk.find(pat) if sent else -1
            while p >= 0:
                if p % self.rsize == 0:
                    s = self._step_of(chunk, p)
                    i = sent - 1 - ((wire[sent - 1] - s) & self._step_mask)
                    if 0 <= i < n and t_rx[i] == 0.0:
                        t_rx[i] = tr
                        answered += 1
                p = chunk.find(pat, p + 1)
        rec.elapsed = _now() - t0
        ts_arr = np.frombuffer(t_sent, dtype=float).copy()
        tr_arr = np.frombuffer(t_rx, dtype=float).copy()
        tr_arr[tr_arr == 0.0] = np.nan
        rec.t_sent, rec.t_rx = ts_arr, tr_arr
        rec.late_sends = late
        rec.held = held
        rec.timeouts = int(np.sum(np.isnan(tr_arr)))
        if bar is not None:
            bar.update(n - shown)
            bar.close()
        return rec

    def run_paced(self, inputs: StepInputs, dt: float, start: int = 0, stop: Optional[int] = None,
                  echo: bool = False, grace: float = 0.5):
        """Real time on SocketCAN (`realtime.run_paced`): step k's frames at the absolute deadline
        T0 + k*dt, the whole bus recorded with kernel timestamps. The RunRecord holds the estimate
        frames (for decode_run), per-step in/out times and the recording (rec.paced); with echo (the
        estimator replaced by caekf-host --echo) only the timing means anything."""
        from .realtime import run_paced
        from .transport import SocketcanTransport

        if not isinstance(self.transport, SocketcanTransport):
            raise BenchError("paced real-time runs need SocketCAN (kernel timestamps of the whole bus)")
        stop = len(inputs) if stop is None else stop
        rec = RunRecord(start, stop, "realtime", 0, dt=dt)
        blobs = self.seal_steps(inputs, start, stop)
        wire = inputs.wire_steps[start:stop].tolist()
        sock = self.transport.sock
        import socket as _socket

        sock.setsockopt(_socket.SOL_CAN_RAW, _socket.CAN_RAW_FILTER, b"")  # the recorder sees the bus
        last_in = self.codec.messages[self.profile.input_messages[-1]]
        closing = self.codec.messages[self.profile.closing]
        try:
            paced = run_paced(self.transport, blobs, wire, dt, self.channel, last_in.frame_id, closing.frame_id,
                              grace=grace, out_step_bits=self.profile.closing_step_bits,
                              in_step_bits=last_in.signals["STEP"].length, in_step_start=last_in.signals["STEP"].start,
                              out_step_start=closing.signals["STEP"].start, wide=self.wide)
        finally:
            self.transport.set_filter(self.codec.from_estimator_ids)
        est = np.isin(paced.frames["id"], self.codec.from_estimator_ids)
        if not echo:
            rec.chunks.append(paced.frames[est].tobytes())
        t_in = np.where(paced.t_in_ns >= 0, paced.t_in_ns / 1e9, np.nan)
        t_out = np.where((paced.t_out_ns >= 0) & (paced.t_in_ns >= 0), paced.t_out_ns / 1e9, np.nan)
        rec.t_sent, rec.t_rx = t_in, t_out
        rec.deadlines = paced.deadlines_ns / 1e9
        rec.late_sends = int(np.sum(paced.t_in_ns - paced.deadlines_ns > int(dt * 1e9)))
        rec.timeouts = int(np.sum(paced.t_out_ns < 0))
        rec.elapsed = float(paced.deadlines_ns[-1] - paced.deadlines_ns[0]) / 1e9 + dt if len(blobs) else 0.0
        rec.paced = paced
        return rec

    # --- decoding --------------------------------------------------------------------------

    def decode_run(self, rec: RunRecord, inputs: StepInputs) -> Decoded:
        """Decode and E2E-check every estimate frame of a run (the bench's profile), placed by STEP into
        rows. `complete`: the step's every-step frames came; `carried[col]`: rows with that value."""
        prof = self.profile
        n = rec.n
        cols = {c: np.full(n, np.nan) for c in prof.results}
        carried = {c: np.zeros(n, dtype=bool) for c in prof.results}
        status = np.zeros(n, dtype=np.int64)
        out = Decoded(cols, np.zeros(n, dtype=bool), status, carried=carried)
        if not rec.chunks or n == 0:
            return out
        recs = self.records(b"".join(rec.chunks))
        out.frames = len(recs)
        ids = recs["id"].astype(np.int64)
        data = recs["data"]
        length = np.array([self.codec.by_id[i].length if i in self.codec.by_id else -1 for i in ids.tolist()])
        ok_dlc = recs["dlc"] == length
        out.bad_dlc = int(np.sum(~ok_dlc & np.isin(ids, self.codec.from_estimator_ids)))
        first_wire = int(inputs.wire_steps[rec.start])
        messages = sorted({s.message for s in prof.results.values()}, key=lambda m: m != prof.closing)
        every = {s.message for s in prof.results.values() if s.page is None}
        have = {m: np.zeros(n, dtype=bool) for m in every}
        for name in messages:
            info = self.codec.messages[name]
            sel = (ids == info.frame_id) & ok_dlc
            if not sel.any():
                continue
            d = data[sel][:, :info.length]
            if info.is_fd:
                good = e2e.e2e_crc16_np(info.data_id, d) == (d[:, 0] | (d[:, 1].astype(np.int64) << 8))
            else:
                good = e2e.e2e_crc_np(np.asarray(info.data_id), d) == d[:, 0]
            out.bad_crc += int(np.sum(~good))
            d = d[good]
            if not len(d):
                continue
            dup, jump, lost = e2e.counter_errors_np(d[:, 2 if info.is_fd else 1] & 15)
            out.counter_duplicates += dup
            out.counter_jumps += jump
            out.counter_lost += lost
            step_sig = info.signals["STEP"]
            mod = 1 << step_sig.length
            steps = self.codec.unpack(name, d, ["STEP"])["STEP"].astype(np.int64)
            # rows in arrival order: unwrap STEP (mod 2^bits) relative to the run's first step
            k = np.empty(len(steps), dtype=np.int64)
            k[0] = (steps[0] - first_wire) % mod
            if len(steps) > 1:
                diff = (np.diff(steps) + mod // 2) % mod - mod // 2
                k[1:] = k[0] + np.cumsum(diff)
            inside = (k >= 0) & (k < n)
            out.foreign_steps += int(np.sum(~inside))
            pages = None
            if "PAGE" in info.signals:
                pages = self.codec.unpack(name, d, ["PAGE"])["PAGE"].astype(np.int64)
            for col, src in prof.results.items():
                if src.message != name:
                    continue
                rows_ok = inside if src.page is None else inside & (pages == src.page)
                if not rows_ok.any():
                    continue
                vals = self.codec.unpack(name, d[rows_ok], [src.signal])[src.signal]
                uniq, first_idx = np.unique(k[rows_ok], return_index=True)
                cols[col][uniq] = vals[first_idx]
                carried[col][uniq] = True
                if src.page is None and name == prof.closing and col == next(iter(
                        c for c, s in prof.results.items() if s.message == name)):
                    out.duplicated_steps += int(rows_ok.sum()) - len(uniq)
            if name in have:
                have[name][np.unique(k[inside])] = True
        if "step_status" in cols:  # kept as Decoded.step_status, not a results column
            st = cols.pop("step_status")
            carried.pop("step_status")
            status[:] = np.where(np.isnan(st), 0, st).astype(np.int64)
        out.complete = np.logical_and.reduce([have[m] for m in have]) if have else out.complete
        return out

    # --- bus log --------------------------------------------------------------------------

    def write_log(self, path, clear: bool = True) -> int:
        """Write the journal as a `candump -L` log with python-can's CanutilsLogWriter."""
        if self.journal is None:
            raise BenchError("this bench was opened without record_log")
        n = write_journal(self.journal, path, self.channel, self.wall_offset)
        if clear:
            self.journal.clear()
        return n


class _batch_scheduling:
    """Context manager: this process is SCHED_BATCH inside (no-op where unsupported)."""

    def __init__(self, enable: bool) -> None:
        self.enable = enable and hasattr(os, "sched_setscheduler") and hasattr(os, "SCHED_BATCH")
        self.prev = None

    def __enter__(self):
        if self.enable:
            try:
                self.prev = os.sched_getscheduler(0)
                os.sched_setscheduler(0, os.SCHED_BATCH, os.sched_param(0))
            except OSError:
                self.prev = None
        return self

    def __exit__(self, *exc) -> None:
        if self.prev is not None:
            try:
                os.sched_setscheduler(0, self.prev, os.sched_param(0))
            except OSError:
                pass


def _progress_bar(total: int, desc: str, progress: Optional[bool]):
    """tqdm on a TTY (or when asked); None otherwise (no cost in the loops)."""
    if progress is None:
        progress = sys.stderr.isatty()
    if not progress:
        return None
    try:
        from tqdm import tqdm
    except ImportError:
        return None
    return tqdm(total=total, desc=desc, unit="step", mininterval=0.5, leave=False)


def latency_stats(rec: RunRecord) -> Dict[str, float]:
    """Latency (EST_STEP read - input frames sent) percentiles in seconds, and deadline misses
    (an estimate later than one period dt after its inputs, or never)."""
    if rec.t_sent is None or rec.t_rx is None:
        return {}
    lat = rec.t_rx - rec.t_sent
    got = np.isfinite(lat)
    out = {"steps": float(rec.n), "answered": float(got.sum()), "late_sends": float(rec.late_sends),
           "held": float(rec.held)}
    if got.any():
        lg = lat[got]
        out.update(p50=float(np.percentile(lg, 50)), p99=float(np.percentile(lg, 99)), max=float(lg.max()),
                   mean=float(lg.mean()))
    if rec.deadlines is not None:  # paced: the estimate must be on the bus before the next step is due
        out["misses"] = float(np.sum(~got) + np.sum(rec.t_rx[got] > rec.deadlines[got] + rec.dt))
    else:
        out["misses"] = float(np.sum(~got) + np.sum(lat[got] > rec.dt))
    return out
