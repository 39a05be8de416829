"""The one place a campaign calls the estimator.

`estimate(scenario, experiment, t, u, y)` returns gamma, P_gamma,gamma, NIS and the health flags
of every step. By default it runs the shipped C estimator in process through the binding
(`caekf_sim.run`, double); backend="replay" runs the same C code through `caekf-replay` (CSV over
pipes: an independent path, kept for cross-checks) and backend="numpy" the numpy reference (no NIS;
a preset without the innovation gate, "default" with the scenario's settings: gate, discretisation and
contact_substeps).
`experiment` is a preset of the settings schema, or "default" for none.
"""
from __future__ import annotations

import io
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..scenario import Scenario
from .spec import scenario_text
from .tools import require_tool

BACKENDS = ("binding", "replay", "numpy")
DEFAULT = "default"  # no preset: the schema's defaults over the scenario


@dataclass(frozen=True)
class Estimate:
    """Per step k = 1..N: gamma of contact 1 [N/m^n], its variance P_gamma,gamma, NIS (NaN when none), flags."""

    gamma: np.ndarray
    p_gg: np.ndarray
    nis: np.ndarray
    flags: np.ndarray


def _csv_in(t: np.ndarray, u: np.ndarray, y: np.ndarray) -> bytes:
    import pyarrow as pa
    import pyarrow.csv as pcsv

    buf = io.BytesIO()
    buf.write(b"t,u,y1,y4\n")
    table = pa.table({"t": np.asarray(t, float), "u": np.asarray(u, float),
                      "y1": np.asarray(y[:, 0], float), "y4": np.asarray(y[:, 1], float)})
    pcsv.write_csv(table, buf, pcsv.WriteOptions(include_header=False))  # shortest round-trip doubles
    return buf.getvalue()


def estimate(sc: Scenario, experiment: str, t: np.ndarray, u: np.ndarray, y: np.ndarray,
             backend: str = "binding") -> Estimate:
    """Run one estimator configuration (a preset name, or "default") over measurements y (N, sensors) and
    inputs u (N,) or (N, inputs). The binding runs any mechanism; the replay (t,u,y1,y4 CSV) and numpy
    backends the paper's only (another is a one-line ValueError)."""
    preset = None if experiment == DEFAULT else experiment
    if backend in ("replay", "numpy"):
        from ..binding import require_paper_mechanism

        require_paper_mechanism(sc, f"the {backend} estimator backend")
    if backend == "binding":
        from ..binding import run

        res = run(sc, np.asarray(u, float), np.ascontiguousarray(y, dtype=float), t=np.asarray(t, float),
                  experiment=preset)
        return Estimate(gamma=res.gamma.copy(), p_gg=np.asarray(res.p_gg, float).copy(), nis=res.nis.copy(),
                        flags=res.flags.astype(np.int64))
    if backend == "numpy":
        from ..experiments import experiment_config, scenario_config
        from ..estimator import run_estimator

        # "default": the scenario's own settings, as the binding runs them (discretisation, contact_substeps)
        cfg = scenario_config(sc) if preset is None else experiment_config(preset)
        ref = run_estimator(sc, cfg, t, u, y, keep_P=False)
        return Estimate(gamma=ref.gamma.copy(), p_gg=ref.p_gg.copy(), nis=np.full(len(t), np.nan),
                        flags=ref.flags.astype(np.int64))
    if backend != "replay":
        raise ValueError(f"unknown estimator backend {backend!r}; choose from {BACKENDS}")
    import pyarrow.csv as pcsv

    tool = require_tool("caekf-replay")
    with tempfile.TemporaryDirectory(prefix="caekf-est-") as tmp:
        scen = Path(tmp) / "scenario.toml"
        scen.write_text(scenario_text(sc), encoding="utf-8")
        cmd = [str(tool), "--scenario", str(scen)] + ([] if preset is None else ["--experiment", preset])
        proc = subprocess.run(cmd, input=_csv_in(t, u, y), capture_output=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"caekf-replay exit {proc.returncode}: {proc.stderr.decode(errors='replace').strip()}")
    tab = pcsv.read_csv(io.BytesIO(proc.stdout))
    col = lambda n: tab.column(n).to_numpy()  # noqa: E731
    return Estimate(gamma=col("gamma").astype(float), p_gg=col("p_gg").astype(float),
                    nis=col("nis").astype(float), flags=col("flags").astype(np.int64))
