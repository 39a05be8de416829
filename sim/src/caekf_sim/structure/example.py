"""One beam run end to end: the full finite-element truth, the filter's reduced model, noisy sensors, the
C estimator through the binding, the Cramer-Rao bound of gamma and the run's metrics (docs/structure.md).

The filter's model is the first `modes` elastic modes plus the attachment shapes of the stop and the shaker
(K^-1 w, K^-1 b: the static response to a force there), re-orthogonalised: modal truncation augmentation, the
reduction an FE user makes for loaded points (Craig-Bampton's boundary degrees of freedom do the same). The
filter is set by fixed rules (`scenario_values`), never by the truth: its sensors' R is their noise, its
gamma0 the run's drawn guess with a 100 % prior std, its Q_x a fixed allowance for the truncated modes and a
random walk of gamma (1 % of gamma0 per contact step) for the reduced model's remaining error, which keeps P
honest about it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Dict, Optional, Tuple

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

from .beam import SENSOR_KINDS, BeamSpec, assemble
from .files import Structure
from .truth import BeamTruth, simulate

Matrix = NDArray[np.float64]
KIND_INDEX = {"position": 0, "velocity": 1, "acceleration": 2}
SIGMA_QX_V = 1e-4  # Q_x velocity std per step of the modal coordinates: the truncated modes' allowance
SIGMA_QX_Q = 1e-9
SIGMA_Q0, SIGMA_V0 = 1e-4, 1e-2  # P0 of the modal coordinates (the beam starts at rest, P0 only has to cover it)
Q_GAMMA_REL = 1e-2  # gamma's random walk per step while in contact, relative to gamma0: the model error's allowance
CRB_STEP = 1e-4  # relative step of gamma for the bound's central differences


def filter_model(full: Structure, modes: int) -> Structure:
    """The first `modes` modes of (K, M) and the attachment shapes K^-1 w of each contact and K^-1 b of each
    input, as one mass-normalised modal basis of that Ritz space (M = I, K diagonal): modes + contacts + inputs
    degrees of freedom. Without the attachment shapes the truncated modes' static flexibility at the stop and the
    shaker is missing, which gamma absorbs (the default beam family's first ten runs: 6 of 10 within 2 % with the
    modes alone, 10 of 10 with them)."""
    if not 1 <= modes <= full.dofs - full.contacts:
        raise ValueError(f"modes {modes}: must be in 1..{full.dofs - full.contacts}")
    _, phi = scipy.linalg.eigh(full.K, full.M, subset_by_index=[0, modes - 1])
    basis = np.hstack([phi, np.linalg.solve(full.K, np.hstack([full.W, full.Bu]))])
    omega2, v = scipy.linalg.eigh(basis.T @ full.K @ basis, basis.T @ full.M @ basis)
    return full._project(basis @ v, omega2)


def scenario_values(gap: float, dt: float, sigmas: Tuple[float, ...], gamma0: float,
                    kinds: Tuple[str, ...] = SENSOR_KINDS) -> Dict[str, Any]:
    """The filter's scenario for a structure with one input and one Hertz contact: the line's keys at a
    placeholder (one body, no links: a structure's are unread), the sensors' kinds and noise, the contact's
    gap and law, and the filter's rules."""
    values: Dict[str, Any] = {"bodies": 1, "m1": 1.0, "springs": 0, "contacts": 1, "contact1_a": 1, "contact1_b": 0,
                              "contact1_gap": gap, "contact1_n": 1.5, "dt": dt, "sensors": len(kinds),
                              "gamma0": gamma0, "sigma_gamma0": gamma0, "sigma_q_gamma": Q_GAMMA_REL * gamma0,
                              "sigma_q0": SIGMA_Q0, "sigma_v0": SIGMA_V0, "sigma_qx_q": SIGMA_QX_Q,
                              "sigma_qx_v": SIGMA_QX_V, "sigma_r": float(min(sigmas)), "sigma_rv": float(min(sigmas))}
    for i, (kind, sigma) in enumerate(zip(kinds, sigmas), start=1):
        values.update({f"sensor{i}_kind": KIND_INDEX[kind], f"sensor{i}_body": 1, f"sensor{i}_sigma": float(sigma)})
    return values


@dataclass(frozen=True)
class BeamRun:
    """One run's record: the truth, the noisy sensors, the estimator's gamma and its variance per step."""

    spec: BeamSpec
    modes: int
    truth: BeamTruth
    y: Matrix
    sigmas: Matrix
    gamma: Matrix
    p_gg: Matrix
    nis: Matrix
    flags: Matrix
    x: Matrix  # the filter's state per step (modal coordinates, then gamma)
    model: Structure
    metrics: Dict[str, Any] = field(default_factory=dict)


def crb_gamma(full: Structure, spec: BeamSpec, truth: BeamTruth, sigmas: Matrix, dt: float, t_end: float,
              substeps: int) -> float:
    """The Cramer-Rao bound of gamma, relative, from the full model's sensitivities: the Fisher information
    sum_k sum_i (dy_ik / dgamma)^2 / sigma_i^2 with dy/dgamma by central differences of the truth (every other
    parameter known: the bound of the stiffness alone)."""
    ys = []
    for f in (1 + CRB_STEP, 1 - CRB_STEP):
        ys.append(simulate(full, spec.gap, spec.gamma * f, spec.n, spec.force(), dt, t_end, substeps,
                           kinds=truth.kinds).y)
    dy = (ys[0] - ys[1]) / (2 * CRB_STEP * spec.gamma)
    info = float(np.sum((dy / sigmas) ** 2))
    return math.inf if info <= 0 else 1.0 / math.sqrt(info) / spec.gamma


def run_beam(spec: BeamSpec, modes: int, *, dt: float = 1e-4, t_end: float = 5.0, substeps: int = 10,
             noise_fraction: float = 0.003, gamma0_ratio: float = 0.75, seed: int = 1,
             crb: bool = True, precision: str = "double") -> BeamRun:
    """Simulate the beam, read its sensors with white noise of `noise_fraction` of each one's rms, and estimate
    the stop's gamma with the reduced filter model."""
    from ..binding import Estimator
    from ..campaign.estimate import Estimate
    from ..campaign.metrics import run_metrics
    from ..scenario import scenario_from_values

    full, _ = assemble(spec)
    truth = simulate(full, spec.gap, spec.gamma, spec.n, spec.force(), dt, t_end, substeps, kinds=SENSOR_KINDS)
    rng = np.random.default_rng(seed)
    sigmas = noise_fraction * np.sqrt(np.mean(truth.y ** 2, axis=0))
    y = truth.y + rng.normal(size=truth.y.shape) * sigmas
    model = filter_model(full, modes)
    sc = scenario_from_values(scenario_values(spec.gap, dt, tuple(sigmas), gamma0_ratio * spec.gamma), "beam")
    est = Estimator(sc, precision=precision, structure=model)
    res = est.run(truth.u.reshape(len(truth.t), -1), y, t=truth.t)
    assert res.P_diag is not None  # asked for (p_diag defaults to True)
    gi = est.gamma_index
    gamma = res.x[:, gi]
    p_gg = res.P_diag[:, gi]
    metrics = run_metrics(truth.t, spec.gamma, truth.delta.reshape(-1),
                          Estimate(gamma=gamma, p_gg=p_gg, nis=res.nis, flags=res.flags))
    metrics.update({"modes": modes, "dofs": model.dofs, "gamma_true": spec.gamma, "gap": spec.gap,
                    "length": spec.length, "thickness": spec.thickness, "width": spec.width,
                    "noise_fraction": noise_fraction, "gamma0_ratio": gamma0_ratio,
                    "sigma_gamma_rel": float(math.sqrt(max(p_gg[-1], 0.0)) / spec.gamma),
                    "max_penetration": float(np.max(truth.delta)), "contact_fraction": float(np.mean(truth.delta > 0))})
    if crb:
        metrics["crb_gamma"] = crb_gamma(full, spec, truth, sigmas, dt, t_end, substeps)
    return BeamRun(spec, modes, truth, y, sigmas, gamma, p_gg, res.nis, res.flags, res.x, model, metrics)


def admitted(metrics: Dict[str, Any], sigmas: float = 3.0, tol: float = 0.02) -> Optional[bool]:
    """Whether the run's bound allows `tol` at `sigmas` bounds (the families' admission rule); None without it."""
    crb = metrics.get("crb_gamma")
    return None if crb is None else bool(sigmas * crb <= tol)


EXAMPLE_MODES = 6  # the shipped example's filter: 6 modes + the stop's and the shaker's attachment shapes
EXAMPLE_T_END = 1.0  # [s] of the shipped recording (10,000 samples)


def write_example(folder: Path, modes: int = EXAMPLE_MODES, t_end: float = EXAMPLE_T_END, dt: float = 1e-4,
                  seed: int = 1, noise_fraction: float = 0.003) -> BeamRun:
    """The shipped example (sim/scenarios/beam*): the default beam's filter model as a structure folder
    (beam-structure/), its scenario (beam.toml, which names the folder) and a noisy recording of its sensors
    with the truth's penetration (beam-recording.csv). Deterministic: regenerated bit for bit by the test."""
    from .files import write_structure

    spec = BeamSpec()
    run = run_beam(spec, modes, dt=dt, t_end=t_end, noise_fraction=noise_fraction, seed=seed, crb=False)
    folder.mkdir(parents=True, exist_ok=True)
    write_structure(folder / "beam-structure", run.model,
                    comment=f"the default cantilever (beam.BeamSpec()) reduced to {modes} modes and the stop's and "
                            "the shaker's attachment shapes (caekf_sim.structure.example.filter_model)")
    values = scenario_values(spec.gap, dt, tuple(float(s) for s in run.sigmas), 0.75 * spec.gamma)
    kinds = {KIND_INDEX[k]: k for k in KIND_INDEX}
    lines = ["# A clamped steel cantilever (400 x 25 x 5 mm) hitting a Hertz stop 0.5 mm away at 0.9 L, driven at",
             "# mid-span (docs/structure.md). The filter's model is the structure folder below: 6 modes and the",
             "# attachment shapes of the stop and the shaker. Sensors: accelerometers at 0.6 L and L, a strain gauge",
             "# at 0.1 L (its noise: 0.3 % of each one's rms). Written by caekf_sim.structure.example.write_example.",
             'structure = "beam-structure"',
             f"contact1_gamma = {spec.gamma!r}    # the truth's stop (for the comparison only)"]
    for k, v in values.items():
        text = f'"{kinds[int(v)]}"' if k.endswith("_kind") else repr(v)
        lines.append(f"{k} = {text}")
    (folder / "beam.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    t = run.truth.t
    table = np.column_stack([t, run.truth.u.reshape(len(t), -1), run.y, run.truth.delta.reshape(len(t), -1)])
    header = "t,u," + ",".join(f"y{i}" for i in range(1, run.y.shape[1] + 1)) + ",delta"
    np.savetxt(folder / "beam-recording.csv", table, delimiter=",", header=header, comments="", fmt="%.9g")
    return run


def plot_example(run: BeamRun, full: Structure, out: Path) -> None:
    """The example's figure: the beam's deflection at the deepest impact and before it, and the estimated
    stiffness with its 3-sigma band against the truth's."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    spec, tr = run.spec, run.truth
    x = np.linspace(0.0, spec.length, spec.elements + 1)
    ydof = np.arange(0, full.dofs, 2)  # each free node's transverse displacement (beam.py's layout)
    k = int(np.argmax(tr.delta.reshape(len(tr.t), -1)[:, 0]))
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(7, 6.5))
    for kk, style in ((max(k - int(0.012 / (tr.t[1] - tr.t[0])), 0), "--"), (k, "-")):
        a1.plot(x * 1e3, np.concatenate([[0.0], tr.q[kk, ydof]]) * 1e3, style, label=f"t = {tr.t[kk]:.4f} s")
    a1.plot([spec.stop_at * spec.length * 1e3], [spec.gap * 1e3], "kv", label="stop")
    a1.set(xlabel="x [mm]", ylabel="deflection [mm]", title="the cantilever at its deepest impact and 12 ms before")
    a1.legend()
    g, s = run.gamma, np.sqrt(np.maximum(run.p_gg, 0.0))
    a2.plot(tr.t, g / 1e6, label="estimate")
    a2.fill_between(tr.t, (g - 3 * s) / 1e6, (g + 3 * s) / 1e6, alpha=0.3, label="3 sigma")
    a2.axhline(spec.gamma / 1e6, color="k", ls=":", label="truth")
    a2.set(xlabel="t [s]", ylabel="gamma [1e6 N/m^1.5]", ylim=(0.4 * spec.gamma / 1e6, 1.3 * spec.gamma / 1e6),
           title="the stop's stiffness")
    a2.legend()
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)
