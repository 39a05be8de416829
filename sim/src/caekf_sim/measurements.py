"""Measurements in: a CSV or a candump log of the bus, checked like caekf-replay checks them.

A measurement CSV has a header whose columns include t, the mechanism's inputs (u, or u1..) and one
column per sensor (y<body>, yv<body>): t,u,y1,y4 for the paper (any others, e.g. a truth CSV's q1..q4,
v1..v4, delta, are read too), and numeric rows with the header's column count. Every sensor empty in a
row means a lost measurement (NaN: the estimator bridges it with caekf_predict); some of them empty is an
error. t must increase strictly, by the scenario's dt within DT_TOL, and there are at most MAX_ROWS rows:
the rules of host/common/csv.h, whose constants a test compares with these. Every refusal is one line,
"FILE:LINE: rule" (MeasurementError, a ValueError: exit 3); a missing or unreadable file is an OSError
with the same kind of message (exit 4).

A candump -L log of the bus is decoded through the DBC (read_candump_runs, cantools): the frames of the
scenario's mechanism, one run per configuration the bench sent.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .truth import TRUTH_COLUMNS, Truth

PathLike = Union[str, Path]

MAX_ROWS = 2_000_000  # CAEKF_CSV_MAX_ROWS (host/common/csv.h)
DT_TOL = 0.01  # CAEKF_CSV_DT_TOL: |t[k] - t[k-1] - dt| <= 1 % of dt


class MeasurementError(ValueError):
    """A measurement file that cannot be used; one line naming the file, the line and the rule."""


@dataclass
class Measurements:
    """One recorded run: t [s], u [N] ((n,) for one input, else (n, inputs)), y (n, sensors) [m or m/s] per
    sample (the paper: [q1, q4]; NaN rows: lost measurements), and the truth when the file has the paper's
    truth columns (a caekf-truth / caekf-sim truth CSV)."""

    name: str
    t: np.ndarray
    u: np.ndarray
    y: np.ndarray  # (n, sensors)
    truth: Optional[Truth] = None

    def __len__(self) -> int:
        return len(self.t)


def check_input_file(path: PathLike) -> Path:
    """The path of an existing regular file, or an OSError naming it (exit 4)."""
    p = Path(path)
    if p.is_dir():
        raise IsADirectoryError(f"{p}: is a directory, expected a file")
    if not p.exists():
        raise FileNotFoundError(f"{p}: cannot open: No such file or directory")
    return p


def _and(names: Sequence[str]) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


def columns_of(sc: Any) -> Tuple[Tuple[str, ...], Tuple[str, ...]]:
    """(input columns, sensor columns) of a scenario's mechanism: ("u",), ("y1", "y4") for the paper."""
    from .mechanism import Mechanism

    st = getattr(sc, "structure", None)
    if st is not None:  # a structure's sensors are rows, not bodies: y1, y2, ... by sensor number
        nu = int(sc.inputs)
        return (("u",) if nu == 1 else tuple(f"u{i}" for i in range(1, nu + 1)),
                tuple(f"y{i}" for i in range(1, int(sc.sensors) + 1)))
    mech = Mechanism.from_scenario(sc)
    return mech.input_names(), mech.sensor_names()


def read_measurements_csv(path: PathLike, dt: float, columns: Optional[Tuple[Sequence[str], Sequence[str]]] = None
                          ) -> Measurements:
    """Read and check a measurement CSV (module docstring); dt <= 0 checks only that t increases.
    `columns`: the (inputs, sensors) column names of the mechanism (`columns_of(scenario)`; default the
    paper's ("u",), ("y1", "y4")). u is (n,) for one input, else (n, inputs); y is (n, sensors)."""
    in_cols, y_cols = (("u",), ("y1", "y4")) if columns is None else (tuple(columns[0]), tuple(columns[1]))
    required = ("t",) + in_cols + y_cols
    listed = ",".join(required)
    p = check_input_file(path)
    cols: Dict[str, List[float]] = {}
    try:
        f = open(p, encoding="utf-8", newline="")
    except OSError as exc:
        raise OSError(f"{p}: cannot open: {exc.strerror}") from None
    with f:
        try:
            header_line = f.readline()
        except UnicodeDecodeError:
            raise MeasurementError(f"{p}:1: not a text CSV (bytes that are not UTF-8)") from None
        if not header_line:
            raise MeasurementError(f"{p}:1: empty input")
        header = [c.strip() for c in header_line.rstrip("\r\n").split(",")]
        if "\0" in header_line or any(not c for c in header):
            raise MeasurementError(f"{p}:1: bad header: expected the columns {listed} (and optionally more)")
        missing = [c for c in required if c not in header]
        if missing:
            raise MeasurementError(f"{p}:1: bad header: no column(s) {', '.join(missing)} "
                                   f"(a measurement CSV has {listed})")
        if len(set(header)) != len(header):
            raise MeasurementError(f"{p}:1: bad header: a column name appears twice")
        for c in header:
            cols[c] = []
        i_t = header.index("t")
        i_y = [header.index(c) for c in y_cols]
        both = ("both" if len(y_cols) == 2 else "all")
        ncol = len(header)
        prev_t = math.nan
        lineno = 1
        try:
            for raw in f:
                lineno += 1
                line = raw.rstrip("\r\n")
                if not line.strip():
                    continue
                if len(cols["t"]) >= MAX_ROWS:
                    raise MeasurementError(f"{p}:{lineno}: more than {MAX_ROWS} data rows: the size limit is "
                                           f"{MAX_ROWS} rows")
                fields = line.split(",")
                if len(fields) != ncol:
                    raise MeasurementError(f"{p}:{lineno}: wrong column count: {len(fields)}, the header has {ncol}")
                lost = all(not fields[i].strip() for i in i_y)
                row = []
                for i, text in enumerate(fields):
                    text = text.strip()
                    if lost and i in i_y:
                        row.append(math.nan)
                        continue
                    if not text and i in i_y:
                        raise MeasurementError(f"{p}:{lineno}: {_and(y_cols)} must {both} be present or {both} "
                                               "be empty")
                    try:
                        v = float(text)
                    except ValueError:
                        raise MeasurementError(f"{p}:{lineno}: column {i + 1}: {text!r} is not a number") from None
                    if not math.isfinite(v):
                        raise MeasurementError(f"{p}:{lineno}: column {i + 1}: non-finite value {text!r}")
                    row.append(v)
                t = row[i_t]
                if not math.isnan(prev_t):
                    if t <= prev_t:
                        raise MeasurementError(f"{p}:{lineno}: t = {t:.9g} does not increase (previous row: "
                                               f"{prev_t:.9g}): t must strictly increase")
                    step = t - prev_t
                    if dt > 0 and abs(step - dt) > DT_TOL * dt:
                        raise MeasurementError(
                            f"{p}:{lineno}: t steps by {step:.9g} from the previous row, the scenario's dt is "
                            f"{dt:.9g} (tolerance {100 * DT_TOL:g} %)")
                prev_t = t
                for c, v in zip(header, row):
                    cols[c].append(v)
        except UnicodeDecodeError:
            raise MeasurementError(f"{p}:{lineno + 1}: not a text CSV (bytes that are not UTF-8)") from None
    if not cols["t"]:
        raise MeasurementError(f"{p}:1: no data rows after the header")
    arr = {c: np.asarray(v, dtype=float) for c, v in cols.items()}
    y = np.column_stack([arr[c] for c in y_cols])
    u = arr[in_cols[0]] if len(in_cols) == 1 else np.column_stack([arr[c] for c in in_cols]) if in_cols \
        else np.empty((len(arr["t"]), 0))
    truth = None
    if (in_cols, y_cols) == (("u",), ("y1", "y4")) and all(c in arr for c in TRUTH_COLUMNS):
        truth = Truth(t=arr["t"], u=arr["u"], y=y,
                      q=np.column_stack([arr[f"q{i}"] for i in range(1, 5)]),
                      v=np.column_stack([arr[f"v{i}"] for i in range(1, 5)]), delta=arr["delta"])
    return Measurements(p.name, arr["t"], u, y, truth)


def _candump_runs(path: Path, dt: float, sc: Any = None) -> List[Measurements]:
    """The runs of a candump -L log of the bench: what the bench sent per STEP (the inputs and the sensors).

    The frames are those of scenario `sc`'s mechanism (bench.profiles.mechanism_profile: BENCH_U, BENCH_U2,
    BENCH_Y1, BENCH_Y4, BENCH_S3_POS, .., BENCH_S<s>_VEL); default and for the paper's mechanism BENCH_U,
    BENCH_Y1 and BENCH_Y4, or BENCH_YP of the production profile. One record per configuration (a CTRL_RESET
    the bench sent starts the next). Frames with a bad E2E CRC are dropped; a step without every sensor's
    frame is a lost measurement (NaN), a step without an input holds its last value (as the firmware does).
    t = step * dt, each frame's step counter unwrapped by its own width (16 bits, BENCH_YP's 8).
    """
    from .bench.buslog import read_log
    from .bench.codec import Codec
    from .bench.e2e import crc_ok
    from .bench.profiles import DIAGNOSTICS, INPUT_KEYS, SENSOR_KEYS, mechanism_profile, production

    profile = DIAGNOSTICS
    if sc is not None:
        from .mechanism import Mechanism

        profile = mechanism_profile(Mechanism.from_scenario(sc))
    signals: Dict[str, Tuple[Tuple[str, str], ...]] = dict(profile.inputs)  # frame -> (signal, step key)
    if profile is DIAGNOSTICS:  # the paper's mechanism: its production profile's frames too (BENCH_YP)
        signals.update(production().inputs)
    keys = {k for sigs in signals.values() for _, k in sigs}
    in_keys = [k for k in INPUT_KEYS if k in keys]
    y_keys = [k for k in SENSOR_KEYS if k in keys]
    codec = Codec()
    frames = read_log(path, codec.from_estimator_ids)
    ids = {codec.messages[n].frame_id: n for n in (*signals, "CTRL_RESET") if n in codec.messages}
    data_id = {fid: codec.messages[n].data_id for fid, n in ids.items()}
    segments: List[List[Tuple[str, bytes]]] = [[]]
    for f in frames:
        if not f.sent_by_bench or f.frame_id not in ids or not crc_ok(data_id[f.frame_id], f.data):
            continue
        name: str = ids[f.frame_id]
        if name == "CTRL_RESET":
            if segments[-1]:
                segments.append([])
            continue
        segments[-1].append((name, f.data))
    out: List[Measurements] = []
    for i, seg in enumerate(s for s in segments if s):
        steps: Dict[int, Dict[str, float]] = {}
        base = None
        for name, data in seg:
            vals = codec.unpack(name, np.frombuffer(data, dtype=np.uint8))
            wire = int(vals["STEP"][0])
            if base is None:
                base = wire
            else:  # unwrap the frame's counter (16 bits, BENCH_YP's 8) to the step nearest the last one
                mod = 1 << codec.messages[name].signals["STEP"].length
                base += (wire - base + mod // 2) % mod - mod // 2
            for sig, key in signals[name]:
                steps.setdefault(base, {})[key] = float(vals[sig][0])
        ks = np.array(sorted(steps))
        k0 = ks[0]
        n = int(ks[-1] - k0 + 1)
        u = np.full((n, len(in_keys)), np.nan)
        y = np.full((n, len(y_keys)), np.nan)
        for k, v in steps.items():
            j = k - k0
            u[j] = [v.get(key, np.nan) for key in in_keys]
            if all(key in v for key in y_keys):
                y[j] = [v[key] for key in y_keys]
        # hold the last known value of each input over steps whose frame was lost
        idx = np.where(np.isfinite(u), np.arange(n)[:, None], 0)
        np.maximum.accumulate(idx, axis=0, out=idx)
        held = np.take_along_axis(u, idx, axis=0)
        u = np.where(np.isfinite(held), held, 0.0)
        out.append(Measurements(f"{path.name}#{i + 1}", (k0 + np.arange(n)) * dt,
                          u[:, 0].copy() if len(in_keys) == 1 else u, y))
    if not out:
        raise ValueError(f"{path}: no {'/'.join(signals)} frames")
    return out


def read_candump_runs(path: PathLike, dt: float, sc: Any = None) -> List[Measurements]:
    """Every run of a candump -L log of the bus (decoded with the DBC, one per configuration the bench sent),
    with the refusals of this module: one line each."""
    p = check_input_file(path)
    try:
        import can  # noqa: F401  (python-can reads the log, cantools the DBC: the [hil] extra)
        import cantools  # noqa: F401
    except ImportError as exc:
        raise ImportError(f"reading a candump log needs python-can and cantools ({exc}): "
                           "pip install 'caekf-sim[hil]'") from None
    try:
        records = _candump_runs(p, dt, sc)
    except UnicodeDecodeError:
        raise MeasurementError(f"{p}: not a candump -L log (bytes that are not text)") from None
    except (ValueError, IndexError) as exc:
        raise MeasurementError(f"{p}: not a candump -L log of the bench: {exc}") from None
    return records


def read_candump(path: PathLike, dt: float, run: Optional[int] = None, sc: Any = None) -> Measurements:
    """One run of a candump -L log of the bus (decoded with the DBC): the only one, or number `run` (1..)."""
    p = Path(path)
    records = read_candump_runs(p, dt, sc)
    if run is None:
        if len(records) > 1:
            raise MeasurementError(f"{p}: {len(records)} runs in the log (one per configuration): choose one "
                                   f"with --run 1..{len(records)}")
        run = 1
    if not 1 <= run <= len(records):
        raise MeasurementError(f"{p}: no run {run}: the log has {len(records)} (--run 1..{len(records)})")
    return records[run - 1]
