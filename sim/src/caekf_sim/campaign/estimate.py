"""The one place a campaign calls the estimator.

`estimate(scenario, experiment, t, u, y)` returns every contact's gamma and P_gamma,gamma, the NIS
and the health flags of every step, for any mechanism (docs/mechanism.md). By default it runs the
shipped C estimator in process through the binding (`caekf_sim.run`, double); backend="replay" runs
the same C code through `caekf-replay` (CSV over pipes: an independent path, kept for cross-checks)
and backend="numpy" the numpy reference (no NIS; a preset without the innovation gate, "default" with
the scenario's settings: gate, discretisation and contact substeps). `experiment` is a preset of the
settings schema, or "default" for none.
"""
from __future__ import annotations

import io
import subprocess
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Dict

import numpy as np

from ..scenario import Scenario
from .spec import scenario_text
from .tools import require_tool

BACKENDS = ("binding", "replay", "numpy")
DEFAULT = "default"  # no preset: the schema's defaults over the scenario


@dataclass(frozen=True)
class Estimate:
    """Per step k = 1..N: gamma [N/m^n] and its variance P_gamma,gamma ((N,) for one contact, else (N,
    contacts), as caekf-replay's gamma, gamma2.. and p_gg, p_gg2.. columns), NIS (NaN when none), flags."""

    gamma: np.ndarray
    p_gg: np.ndarray
    nis: np.ndarray
    flags: np.ndarray
    # The estimated law parameters (docs/contact-law.md) by key "contact<c>_<n|lambda|gap>": per step, and
    # their variances.
    law: Dict[str, np.ndarray] = field(default_factory=dict)
    law_var: Dict[str, np.ndarray] = field(default_factory=dict)

    @property
    def gammas(self) -> np.ndarray:
        """gamma as (N, contacts)."""
        return self.gamma.reshape(len(self.nis), -1)

    @property
    def p_ggs(self) -> np.ndarray:
        """p_gg as (N, contacts)."""
        return self.p_gg.reshape(len(self.nis), -1)


def _one(a: np.ndarray) -> np.ndarray:
    """(N, 1) -> (N,); (N, contacts) as it is."""
    a = np.array(a, dtype=float)  # a copy: no view on a result's larger arrays
    return a[:, 0].copy() if a.shape[1] == 1 else a


def _csv_in(sc: Scenario, t: np.ndarray, u: np.ndarray, y: np.ndarray) -> bytes:
    """caekf-replay's input: t, the inputs, one column per sensor (the mechanism's names)."""
    import pyarrow as pa
    import pyarrow.csv as pcsv

    from ..mechanism import Mechanism

    mech = Mechanism.from_scenario(sc)
    n = len(t)
    u2 = np.asarray(u, float).reshape(n, -1)
    y2 = np.asarray(y, float).reshape(n, -1)
    cols = {"t": np.asarray(t, float)}
    cols.update({name: u2[:, i] for i, name in enumerate(mech.input_names())})
    cols.update({name: y2[:, i] for i, name in enumerate(mech.sensor_names())})
    buf = io.BytesIO()
    buf.write((",".join(cols) + "\n").encode())
    pcsv.write_csv(pa.table(cols), buf, pcsv.WriteOptions(include_header=False))  # shortest round-trip doubles
    return buf.getvalue()


def estimate(sc: Scenario, experiment: str, t: np.ndarray, u: np.ndarray, y: np.ndarray,
             backend: str = "binding") -> Estimate:
    """Run one estimator configuration (a preset name, or "default") over measurements y (N, sensors) and
    inputs u (N,) or (N, inputs), any mechanism, with any backend."""
    from ..mechanism import law_layout

    preset = None if experiment == DEFAULT else experiment
    nc = int(sc.contacts)
    law_keys = [f"contact{c + 1}_{name}" for c, name in law_layout(sc, nc)]
    law0 = 2 * int(sc.bodies) + nc  # the first law state
    if backend == "binding":
        from ..binding import run

        res = run(sc, np.asarray(u, float), np.ascontiguousarray(y, dtype=float), t=np.asarray(t, float),
                  experiment=preset)
        ig = res.gamma_index
        assert res.P_diag is not None  # run keeps the diagonal of P by default
        return Estimate(gamma=_one(res.x[:, ig:ig + nc]), p_gg=_one(res.P_diag[:, ig:ig + nc]),
                        nis=res.nis.copy(), flags=res.flags.astype(np.int64),
                        law={k: res.x[:, law0 + i].copy() for i, k in enumerate(law_keys)},
                        law_var={k: res.P_diag[:, law0 + i].copy() for i, k in enumerate(law_keys)})
    if backend == "numpy":
        from ..experiments import experiment_config, scenario_config
        from ..estimator import run_estimator

        # "default": the scenario's own settings, as the binding runs them (discretisation, contact_substeps)
        cfg = scenario_config(sc) if preset is None else experiment_config(preset)
        ref = run_estimator(sc, cfg, t, u, y, keep_P=bool(law_keys))
        assert ref.p_ggs is not None  # run_estimator fills it
        return Estimate(gamma=_one(ref.gammas), p_gg=_one(ref.p_ggs), nis=np.full(len(t), np.nan),
                        flags=ref.flags.astype(np.int64),
                        law={k: ref.x[:, law0 + i].copy() for i, k in enumerate(law_keys)},
                        law_var={k: ref.P[:, law0 + i, law0 + i].copy() for i, k in enumerate(law_keys)
                                 if ref.P is not None})
    if backend != "replay":
        raise ValueError(f"unknown estimator backend {backend!r}; choose from {BACKENDS}")
    if law_keys:
        raise ValueError("caekf-replay writes no law parameters: estimate them with the binding or numpy backend")
    import pyarrow.csv as pcsv

    tool = require_tool("caekf-replay")
    with tempfile.TemporaryDirectory(prefix="caekf-est-") as tmp:
        scen = Path(tmp) / "scenario.toml"
        scen.write_text(scenario_text(sc), encoding="utf-8")
        cmd = [str(tool), "--scenario", str(scen)] + ([] if preset is None else ["--experiment", preset])
        proc = subprocess.run(cmd, input=_csv_in(sc, t, u, y), capture_output=True, check=False)
    if proc.returncode != 0:
        raise RuntimeError(f"caekf-replay exit {proc.returncode}: {proc.stderr.decode(errors='replace').strip()}")
    tab = pcsv.read_csv(io.BytesIO(proc.stdout))
    col = lambda n: tab.column(n).to_numpy()  # noqa: E731
    names = lambda base: [base + ("" if c == 0 else str(c + 1)) for c in range(nc)]  # noqa: E731
    return Estimate(gamma=_one(np.column_stack([col(n) for n in names("gamma")])),
                    p_gg=_one(np.column_stack([col(n) for n in names("p_gg")])),
                    nis=col("nis").astype(float), flags=col("flags").astype(np.int64))
