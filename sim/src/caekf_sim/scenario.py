"""Read a scenario file (flat `key = value` lines, `#` comments) into a frozen dataclass.

The format is deliberately a tiny subset of TOML so that Python 3.9 (no tomllib) and the
C reader can both parse it without a TOML library.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Dict, Union

PathLike = Union[str, Path]


@dataclass(frozen=True)
class Scenario:
    """Every number of a scenario, SI units (see scenarios/paper.toml for the meaning)."""

    # plant (truth)
    m1: float
    m2: float
    m3: float
    m4: float
    k1: float
    k12: float
    k34: float
    k4: float
    c1: float
    c12: float
    c34: float
    c4: float
    gap: float
    gamma: float
    u_amp: float
    u_freq: float
    u_phase: float
    dt: float
    t_end: float
    truth_substeps: int
    noise_std: float
    seed: int
    # estimator
    gamma0: float
    sigma_q0: float
    sigma_v0: float
    sigma_gamma0: float
    sigma_qx_q: float
    sigma_qx_v: float
    sigma_q_gamma: float
    sigma_r: float
    gamma_min: float

    @property
    def n_steps(self) -> int:
        """Number of recorded samples N = round(t_end / dt); samples are k = 1..N."""
        return int(round(self.t_end / self.dt))

    def replace(self, **changes: float) -> "Scenario":
        """Copy with some values changed (handy for shortened test runs)."""
        return dataclasses.replace(self, **changes)


_INT_KEYS = {f.name for f in dataclasses.fields(Scenario) if f.type in ("int", int)}


def parse_flat(text: str) -> Dict[str, str]:
    """Parse `key = value` lines; drop comments and blank lines; reject anything else."""
    out: Dict[str, str] = {}
    for lineno, raw in enumerate(text.splitlines(), start=1):
        line = raw.split("#", 1)[0].strip()  # values are plain numbers, so '#' never occurs inside one
        if not line:
            continue
        key, sep, value = line.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not key or not value:
            raise ValueError(f"line {lineno}: expected 'key = value', got {raw!r}")
        if key in out:
            raise ValueError(f"line {lineno}: duplicate key {key!r}")
        out[key] = value
    return out


def scenario_from_text(text: str) -> Scenario:
    """Build a Scenario; every field must be present, unknown keys are an error (typo guard)."""
    raw = parse_flat(text)
    names = [f.name for f in dataclasses.fields(Scenario)]
    missing = [n for n in names if n not in raw]
    unknown = sorted(set(raw) - set(names))
    if missing or unknown:
        raise ValueError(f"scenario keys: missing {missing}, unknown {unknown}")
    values = {}
    for n in names:
        v = raw[n]
        if n in _INT_KEYS:
            f = float(v)
            if f != int(f):
                raise ValueError(f"{n} must be an integer, got {v!r}")
            values[n] = int(f)
        else:
            values[n] = float(v)
    sc = Scenario(**values)
    if sc.dt <= 0 or sc.t_end <= 0 or sc.truth_substeps < 1:
        raise ValueError("need dt > 0, t_end > 0, truth_substeps >= 1")
    return sc


def load_scenario(path: PathLike) -> Scenario:
    return scenario_from_text(Path(path).read_text(encoding="utf-8"))


def default_scenario_path() -> Path:
    """sim/scenarios/paper.toml when running from the source tree (editable install)."""
    return Path(__file__).resolve().parents[2] / "scenarios" / "paper.toml"
