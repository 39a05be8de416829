"""The profile likelihood of each identified parameter (caekf-sim identify --plot): the rise of -log L
with the parameter held and the others re-fitted, the threshold of the 95 % interval, the interval, the
Fisher interval's quadratic, the start and the truth where known."""
from __future__ import annotations

import math
from pathlib import Path
from typing import Union

import numpy as np

from .identify import IdentifyResult

PathLike = Union[str, Path]


def plot_profiles(r: IdentifyResult, path: PathLike) -> None:
    from .plots import _pyplot, _save

    plt = _pyplot()
    n = len(r.estimates)
    cols = min(n, 2)
    rows = math.ceil(n / cols)
    fig, axes = plt.subplots(rows, cols, figsize=(5.5 * cols, 3.6 * rows), squeeze=False)
    for ax, e in zip(axes.ravel(), r.estimates):
        pts = np.array(r.profiles.get(e.key, []), dtype=float).reshape(-1, 2)
        if len(pts):
            ax.plot(pts[:, 0], pts[:, 1], "o-", color="tab:blue", ms=3, label="profile -log L rise")
        lo, hi = e.fisher
        if math.isfinite(lo) and math.isfinite(hi) and hi > lo:
            xs = np.linspace(2 * lo - e.value, 2 * hi - e.value, 101)
            half = (hi - lo) / 2
            ax.plot(xs, r.threshold * ((xs - e.value) / half) ** 2, "--", color="tab:gray",
                    label="Fisher (quadratic)")
        ax.axhline(r.threshold, color="tab:red", lw=0.8, label=f"95 % threshold ({r.threshold:.3g})")
        ax.axvspan(e.interval[0], e.interval[1], color="tab:green", alpha=0.15, label="95 % interval")
        ax.axvline(e.value, color="tab:green", lw=1.2, label=f"estimate {e.value:.6g}")
        if e.truth is not None:
            ax.axvline(e.truth, color="black", lw=1.2, ls=":", label=f"truth {e.truth:.6g}")
        top = 3 * r.threshold
        ax.set_ylim(-0.05 * top, top)
        if len(pts):
            ax.set_xlim(pts[:, 0].min(), pts[:, 0].max())
        ax.set_xlabel(e.key + ("" if e.pinned else "  (not pinned down)"))
        ax.set_ylabel("-log L - min")
        ax.legend(fontsize=7, loc="upper center")
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    fig.suptitle("identify: profile likelihood of each parameter")
    fig.tight_layout()
    _save(fig, Path(path))
    plt.close(fig)
