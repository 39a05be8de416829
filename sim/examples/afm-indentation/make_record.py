"""raw.csv -> record.csv: the approach segment as a caekf measurement CSV (t, u, y1). numpy only.

    python make_record.py [raw.csv] [record.csv]

The scenario (scenario.toml) is a probe (body 1) on the cantilever (spring 1 to ground, stiffness
K_C) whose base the piezo drives towards the sample; the base displacement enters as the equivalent
force u = K_C z(t), and the sensor is the tip's position y1 = z - d with d the cantilever's
deflection (README.md). Positive: towards the sample.

    z(t)  = h(0) - h(t)            height of the capacitive sensor, measured downwards from the start
    F0    = mean force over BASELINE (before the contact, at the approach speed)
    d(t)  = (F(t) - F0) / K_C      deflection; F0 holds the photodiode's zero and the drag offset
    u(t)  = K_C z(t)               [N]
    y1(t) = z(t) - d(t)            [m]

Only the approach (segment 0) is used: the retract pulls off with adhesion, a force of the other
sign that the contact law (it only pushes) does not have. The rows are the instrument's own, at its
2 kHz: nothing is resampled, cut or filtered.
"""
from __future__ import annotations

import sys
from pathlib import Path
from typing import Dict, Tuple

import numpy as np

HERE = Path(__file__).resolve().parent
K_C = 0.02230065831827453  # N/m: the cantilever's spring constant, the file's own calibration
BASELINE = (1.5, 2.4)  # s: the force's zero is its mean here (the contact begins near 2.6 s)


def read_raw(path: Path = HERE / "raw.csv") -> Dict[str, np.ndarray]:
    """raw.csv's columns in SI: t [s], segment, h [m] (capacitive sensor), f [N]."""
    d = np.loadtxt(path, delimiter=",", skiprows=1)
    return {"t": d[:, 0], "segment": d[:, 1].astype(int), "h": d[:, 2] * 1e-9, "f": d[:, 3] * 1e-9}


def approach(raw: Dict[str, np.ndarray]) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(t, z, d, f - F0) over the approach segment [s, m, m, N]."""
    a = raw["segment"] == 0
    t, h, f = raw["t"][a], raw["h"][a], raw["f"][a]
    base = (t >= BASELINE[0]) & (t <= BASELINE[1])
    f0 = float(np.mean(f[base]))
    z = h[0] - h
    fc = f - f0
    return t, z, fc / K_C, fc


def contact_point(t: np.ndarray, q: np.ndarray, fc: np.ndarray, f_min: float = 0.5e-9) -> float:
    """The tip position where the contact begins [m], the scenario's contact1_gap: for a law f = gamma
    delta^2, sqrt(f) is a straight line in the tip position q; the least-squares line through the
    approach's samples with f > f_min, extrapolated to f = 0. (A threshold on the force is late: at
    0.3 um the force is only 4 baseline standard deviations.)"""
    w = (fc > f_min) & (t > t[np.argmax(fc)] - 0.5)
    slope, icpt = np.polyfit(q[w], np.sqrt(fc[w]), 1)
    return float(-icpt / slope)


def write_record(raw_path: Path = HERE / "raw.csv", out: Path = HERE / "record.csv") -> None:
    t, z, d, fc = approach(read_raw(raw_path))
    with open(out, "w", encoding="utf-8", newline="\n") as f:
        f.write("t,u,y1,force\n")
        for row in zip(t, K_C * z, z - d, fc):
            f.write(f"{row[0]:.4f},{row[1]:.7e},{row[2]:.7e},{row[3]:.5e}\n")


if __name__ == "__main__":
    args = [Path(a) for a in sys.argv[1:3]]
    write_record(*args)
    t, z, d, fc = approach(read_raw(*args[:1]))
    print(f"contact point (contact1_gap): {contact_point(t, z - d, fc):.4e} m", file=sys.stderr)
