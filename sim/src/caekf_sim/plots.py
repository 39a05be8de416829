"""Figures from results CSVs (matplotlib, Agg backend; PNG, SVG or PDF): Figs 3-6 of the paper from the four
experiments, and `plot_runs` for any run or set of runs, with or without the truth."""
from __future__ import annotations

from pathlib import Path
from typing import Dict, List, Optional, Sequence, Tuple, Union

import numpy as np

from .estimator import EstimateResult
from .results import read_result_csv
from .truth import Truth, contact_episodes, read_truth_csv

PathLike = Union[str, Path]
PLOT_FORMATS = ("png", "svg", "pdf")

# Paper colours: canonical blue, switched red, constrained green, reference black.
COLORS = {
    "canonical": "tab:blue",
    "switched": "tab:red",
    "switched-highq": "tab:red",
    "switched-highq-constrained": "tab:green",
    "truth": "black",
}
LABELS = {
    "canonical": "AEKF (canonical)",
    "switched": "AEKF for contact",
    "switched-highq": "AEKF for contact, unconstrained",
    "switched-highq-constrained": "AEKF for contact, constrained",
}


def _pyplot():
    try:
        import matplotlib
    except ImportError:
        raise ImportError("figures need matplotlib: pip install 'caekf-sim[plot]'") from None

    matplotlib.use("Agg")  # files only, no display
    import matplotlib.pyplot as plt

    return plt


def _episodes(truth: Truth) -> List[Tuple[float, float]]:
    """The truth's contact episodes, any contact closed (the deepest penetration over the contacts), merging
    the short initial bounces."""
    return contact_episodes(truth.t, truth.deltas.max(axis=1), merge_gap=0.1)


def _shade_contact(ax, truth: Optional[Truth]) -> None:
    """Grey bands where the truth is in contact (merging the short initial bounces); none without truth."""
    if truth is None:
        return
    for i, (a, b) in enumerate(_episodes(truth)):
        ax.axvspan(a, b, color="0.9", zorder=0, label="contact (truth)" if i == 0 else None)


def fig3_p_norm(res: Dict[str, EstimateResult], truth: Optional[Truth], out: Path, fmt: str = "png") -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    _shade_contact(ax, truth)
    for name in ("canonical", "switched"):
        r = res[name]
        ax.semilogy(r.t, r.p_norm, color=COLORS[name], label=LABELS[name])
    ax.set_xlabel("time [s]")
    ax.set_ylabel(r"$\|\mathbf{P}\|_2$ (physical units)")
    ax.set_title("Fig. 3: norm of the error covariance")
    ax.grid(True, which="major", alpha=0.4)
    ax.legend(loc="upper left")
    return _save(fig, out / f"fig3_p_norm.{fmt}")


def fig4_gamma(res: Dict[str, EstimateResult], truth: Optional[Truth], gamma_true: float, out: Path,
               fmt: str = "png") -> Path:
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    _shade_contact(ax, truth)
    for name in ("canonical", "switched"):
        r = res[name]
        ax.plot(r.t, r.gamma, color=COLORS[name], label=LABELS[name])
    if np.isfinite(gamma_true):
        ax.axhline(gamma_true, color=COLORS["truth"], lw=1.2, label=r"reference $\gamma$")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(r"$\hat\gamma$ [N/m$^{1.5}$]")
    ax.set_title("Fig. 4: contact stiffness estimate")
    ax.grid(True, alpha=0.4)
    ax.legend(loc="upper left")
    return _save(fig, out / f"fig4_gamma.{fmt}")


def fig5_q2(
    res: Dict[str, EstimateResult], truth: Truth, out: Path,
    windows: Optional[List[Tuple[float, float]]] = None, fmt: str = "png",
) -> Path:
    """q2 estimate vs truth and its error around the first two contact events.

    The first episode (about 12-16 s) is where the paper looks; the second one (about
    32-36 s) is where the canonical filter enters contact with its drifted gamma.
    """
    plt = _pyplot()
    if windows is None:
        starts = [a for a, _ in _episodes(truth)][:2]
        windows = [(round(a) - 1.0, round(a) + 3.0) for a in starts]
    fig, axes = plt.subplots(2, len(windows), figsize=(6 * len(windows), 6.5), sharex="col",
                             gridspec_kw={"height_ratios": [3, 2]}, squeeze=False)
    for col, window in enumerate(windows):
        ax, ax_err = axes[0, col], axes[1, col]
        sel = (truth.t >= window[0]) & (truth.t <= window[1])
        for a in (ax, ax_err):
            _shade_contact(a, truth)
        ax.plot(truth.t[sel], 1e3 * truth.q[sel, 1], color=COLORS["truth"], lw=2.5,
                label="reference")
        for name in ("canonical", "switched"):
            r = res[name]
            s = (r.t >= window[0]) & (r.t <= window[1])
            err = r.x[s, 1] - np.interp(r.t[s], truth.t, truth.q[:, 1])
            rms = float(np.sqrt(np.mean(err**2)))
            ax.plot(r.t[s], 1e3 * r.x[s, 1], color=COLORS[name], lw=1.0, label=LABELS[name])
            ax_err.plot(r.t[s], 1e6 * err, color=COLORS[name], lw=0.8,
                        label=f"{LABELS[name]}: rms {1e9 * rms:.1f} nm")
        ax.set_ylabel(r"$q_2$ [mm]")
        ax.set_title(f"Fig. 5: position of body 2, {window[0]:g}-{window[1]:g} s")
        ax.legend(loc="lower right", fontsize=8)
        ax.grid(True, alpha=0.4)
        ax_err.set_ylabel(r"$\hat q_2 - q_2$ [$\mu$m]")
        ax_err.set_xlabel("time [s]")
        ax_err.grid(True, alpha=0.4)
        ax_err.legend(loc="upper right", fontsize=8)
        ax_err.set_xlim(*window)
    return _save(fig, out / f"fig5_q2.{fmt}")


def fig6_constrained(
    res: Dict[str, EstimateResult], truth: Optional[Truth], gamma_true: float, gamma_min: float, out: Path,
    detail: Optional[Tuple[float, float]] = None, fmt: str = "png",
) -> List[Path]:
    """(a) unconstrained vs constrained gamma over the run; (b) zoom on the first contact (with truth)."""
    plt = _pyplot()
    paths = []
    un, co = res["switched-highq"], res["switched-highq-constrained"]
    views = [("a", (float(co.t[0]), float(co.t[-1])))]
    if detail is None and truth is not None:
        episodes = _episodes(truth)
        if episodes:
            detail = (episodes[0][0] - 0.2, episodes[0][0] + 1.5)
    if detail is not None:
        views.append(("b", detail))
    if not np.isfinite(gamma_true):  # no truth gamma: scale the views on the estimate
        gamma_true = float(np.nanmax(np.abs(co.gamma)))
    for tag, (t0, t1) in views:
        fig, ax = plt.subplots(figsize=(8, 4.5))
        _shade_contact(ax, truth)
        for name, r, lw in (("switched-highq", un, 1.0), ("switched-highq-constrained", co, 1.6)):
            s = (r.t >= t0) & (r.t <= t1)
            ax.plot(r.t[s], r.gamma[s], color=COLORS[name], lw=lw, label=LABELS[name])
        ax.axhline(gamma_true, color=COLORS["truth"], lw=1.2, label=r"reference $\gamma$")
        ax.axhline(gamma_min, color="0.4", lw=1.0, ls="--", label=r"$\gamma_{min}$")
        ax.set_xlim(t0, t1)
        if tag == "a":
            # Symmetric log axis: the unconstrained excursions span decades on both signs.
            ax.set_yscale("symlog", linthresh=gamma_min)
            vals = np.abs(np.r_[un.gamma, co.gamma])
            top = int(np.ceil(np.log10(max(np.nanmax(vals[np.isfinite(vals)]), gamma_true))))
            dec = [10.0**e for e in range(int(np.log10(gamma_min)), top + 1)]
            ax.set_yticks([-d for d in reversed(dec)] + [0.0] + dec)  # one label per decade
            ax.set_title(r"Fig. 6(a): $\hat\gamma$ with $Q_\gamma \times 1000$: unconstrained vs constrained")
        else:
            ax.axhline(0.0, color="0.6", lw=0.6)
            # Fit the constrained estimate and the zero line; the unconstrained one leaves the frame.
            s = (co.t >= t0) & (co.t <= t1)
            hi = max(np.nanmax(co.gamma[s]), gamma_true)
            ax.set_ylim(-0.6 * hi, 1.5 * hi)
            ax.set_title("Fig. 6(b): detail of the first contact episode")
        ax.set_xlabel("time [s]")
        ax.set_ylabel(r"$\hat\gamma$ [N/m$^{1.5}$]")
        ax.grid(True, alpha=0.4)
        ax.legend(loc="lower right" if tag == "a" else "upper right", fontsize=8)
        paths.append(_save(fig, out / f"fig6{tag}_gamma_constrained.{fmt}"))
    return paths


def _save(fig, path: Path) -> Path:
    """Write the figure whole or not at all (a temporary file renamed), format from the suffix."""
    from .outputs import atomic_output

    fig.tight_layout()
    fmt = path.suffix.lstrip(".").lower()
    if fmt not in PLOT_FORMATS:
        raise ValueError(f"{path}: unknown figure format '{path.suffix}': use one of "
                         + ", ".join("." + f for f in PLOT_FORMATS))
    import matplotlib.pyplot as plt

    try:
        with atomic_output(path) as tmp:
            fig.savefig(tmp, dpi=120, format=fmt)
    finally:
        plt.close(fig)
    return path


EXPERIMENT_FILES = tuple(f"{n}.csv" for n in LABELS)


def load_results(results_dir: PathLike, names: Optional[List[str]] = None) -> Dict[str, EstimateResult]:
    d = Path(results_dir)
    names = names or list(LABELS)
    return {n: read_result_csv(d / f"{n}.csv") for n in names if (d / f"{n}.csv").exists()}


def make_all(
    results: Dict[str, EstimateResult], truth: Optional[Truth], gamma_true: float, gamma_min: float,
    outdir: PathLike, fmt: str = "png",
) -> List[Path]:
    """Every figure whose inputs are present (Fig. 5 needs the truth); returns the paths."""
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths: List[Path] = []
    if {"canonical", "switched"} <= results.keys():
        paths.append(fig3_p_norm(results, truth, out, fmt=fmt))
        paths.append(fig4_gamma(results, truth, gamma_true, out, fmt=fmt))
        if truth is not None:
            paths.append(fig5_q2(results, truth, out, fmt=fmt))
    if {"switched-highq", "switched-highq-constrained"} <= results.keys():
        paths.extend(fig6_constrained(results, truth, gamma_true, gamma_min, out, fmt=fmt))
    return paths


def make_all_from_files(
    results_dir: PathLike, truth_csv: PathLike, gamma_true: float, gamma_min: float,
    outdir: PathLike,
) -> List[Path]:
    return make_all(load_results(results_dir), read_truth_csv(truth_csv), gamma_true, gamma_min, outdir)


def _gamma_unit(n: float) -> str:
    """The unit of a contact's gamma for the exponent n of its law: N/m^n."""
    return "N/m" if n == 1 else f"N/m$^{{{n:g}}}$"


def run_figure(runs: Dict[str, EstimateResult], truth: Optional[Truth], gamma_true: Union[float, Sequence[float]],
               exponents: Sequence[float] = (1.5,)):
    """The figure of plot_runs (matplotlib Figure): one gamma panel per contact (the most any run has; the
    reference gamma_true[c] where finite, contact c's own bands with the truth), the norm of P, and with the
    truth the position error of body 2 (of body 1 in a one-body mechanism), shaded while any contact is
    closed."""
    plt = _pyplot()
    refs = np.atleast_1d(np.asarray(gamma_true, dtype=float))
    nc = max(r.n_contacts for r in runs.values())
    with_truth = truth is not None
    body = min(1, truth.q.shape[1] - 1) if truth is not None else 1  # body 2's error (body 1 when alone)
    rows = nc + (2 if with_truth else 1)
    fig, axes = plt.subplots(rows, 1, figsize=(9, 2.8 * rows), sharex=True)
    cycle = plt.rcParams["axes.prop_cycle"].by_key()["color"]
    for c in range(nc):
        if truth is not None and c < truth.deltas.shape[1]:  # contact c's own episodes
            eps = contact_episodes(truth.t, truth.deltas[:, c], merge_gap=0.1)
            for i, (a, b) in enumerate(eps):
                axes[c].axvspan(a, b, color="0.9", zorder=0, label=f"contact {c + 1} (truth)" if i == 0 else None)
    for ax in axes[nc:]:
        _shade_contact(ax, truth)
    for i, (label, r) in enumerate(runs.items()):
        color = cycle[i % len(cycle)]
        for c in range(r.n_contacts):
            axes[c].plot(r.t, r.gammas[:, c], color=color, lw=1.0, label=label)
        axes[nc].semilogy(r.t, r.p_norm, color=color, lw=1.0, label=label)
        if truth is not None:
            err = r.x[:, body] - np.interp(r.t, truth.t, truth.q[:, body])
            axes[nc + 1].plot(r.t, 1e6 * err, color=color, lw=0.8, label=label)
    for c in range(nc):
        sym = r"\gamma" if nc == 1 else rf"\gamma_{c + 1}"
        if c < len(refs) and np.isfinite(refs[c]):
            axes[c].axhline(refs[c], color=COLORS["truth"], lw=1.2, label=rf"reference ${sym}$")
        axes[c].set_ylabel(rf"$\hat{sym}$ [{_gamma_unit(exponents[min(c, len(exponents) - 1)])}]")
        axes[c].legend(loc="best", fontsize=8)
    axes[0].set_title(("contact stiffness estimate" if nc == 1 else f"stiffness estimates of {nc} contacts")
                      + ("" if len(runs) == 1 else f", {len(runs)} runs"))
    axes[nc].set_ylabel(r"$\|\mathbf{P}\|_2$")
    if truth is not None:
        axes[nc + 1].set_ylabel(rf"$\hat q_{body + 1} - q_{body + 1}$ [$\mu$m]")
    axes[-1].set_xlabel("time [s]")
    for ax in axes:
        ax.grid(True, alpha=0.4)
    return fig


def plot_runs(runs: Dict[str, EstimateResult], truth: Optional[Truth], gamma_true: Union[float, Sequence[float]],
              out: PathLike, exponents: Sequence[float] = (1.5,)) -> Path:
    """One figure of any set of runs (estimate CSVs by label), run_figure's; format from out's suffix."""
    return _save(run_figure(runs, truth, gamma_true, exponents), Path(out))
