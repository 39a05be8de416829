"""The family table (within 1 %, within 5 %, diverged, consistent; split as the spec says) and the
campaign plots: error histogram, error against each drawn parameter, NEES/NIS chi-square bands.

A mechanism with several contacts counts by its worst contact (the metrics' `_worst` columns): its
largest |final error|, diverged if any contact diverged, within 3 sigma if every contact is. With one
contact these are contact 1's."""
from __future__ import annotations

from pathlib import Path
from typing import Any, Dict, List, Sequence

import numpy as np

from .runner import ADMIT_TOL
from .spec import TARGETS, Family

SUMMARY_COLUMNS = ("experiment", "group", "n", "within_1pct", "within_5pct", "diverged", "consistent_3sigma",
                   "flagged_mismatch_end", "silent_wrong", "median_abs_err")


def summary_rows(rows: Sequence[Dict[str, Any]], family: Family, experiments: Sequence[str]) -> List[Dict[str, Any]]:
    out = []
    for e in experiments:
        rs = [r for r in rows if r["experiment"] == e]
        groups: List[tuple] = [("all", np.ones(len(rs), dtype=bool))]
        for sp in family.splits:
            vals = np.array([r.get(sp.name, np.nan) for r in rs], dtype=float)
            idx = sp.index(vals)
            groups += [(lab, idx == i) for i, lab in enumerate(sp.labels())]
        err = np.array([r["abs_final_err_worst"] for r in rs], dtype=float)
        div = np.array([r["diverged_worst"] for r in rs], dtype=bool)
        cons = np.array([r["consistent_3sigma_worst"] for r in rs], dtype=bool)
        # None where the schema has no model_mismatch flag: the count is unavailable (None) then
        flag_known = all(r.get("flagged_mismatch_end") is not None for r in rs)
        flagged = np.array([bool(r.get("flagged_mismatch_end")) for r in rs], dtype=bool)
        silent = np.array([r.get("silent_wrong", not r["consistent_3sigma_worst"]) for r in rs], dtype=bool)
        # issue 27's admission by gamma's Cramer-Rao bound (--observability on a family declaring uncertainty):
        # its columns only where it was measured, so other campaigns' tables stay as they were
        admission = bool(rs) and all("crb_admitted" in r for r in rs)
        admitted = np.array([bool(r.get("crb_admitted")) for r in rs], dtype=bool)
        for label, m in groups:
            extra = {}
            if admission:
                ma = m & admitted
                extra = {"admitted": int(ma.sum()),
                         "within_2pct_admitted": int(np.count_nonzero(err[ma] <= ADMIT_TOL)),
                         "diverged_admitted": int(np.count_nonzero(div[ma])),
                         "consistent_3sigma_admitted": int(np.count_nonzero(cons[ma]))}
            out.append({
                "experiment": e, "group": label, "n": int(m.sum()),
                "within_1pct": int(np.count_nonzero(err[m] <= 0.01)),
                "within_5pct": int(np.count_nonzero(err[m] <= 0.05)),
                "diverged": int(np.count_nonzero(div[m])),
                "consistent_3sigma": int(np.count_nonzero(cons[m])),
                "flagged_mismatch_end": int(np.count_nonzero(flagged[m])) if flag_known else None,
                "silent_wrong": int(np.count_nonzero(silent[m])),
                "median_abs_err": float(np.median(err[m])) if m.any() else float("nan"),
                **extra,
            })
    return out


ADMISSION_COLUMNS = ("experiment", "group", "n", "admitted", "within_2pct_admitted", "diverged_admitted",
                     "consistent_3sigma_admitted")


def format_admission(summary: Sequence[Dict[str, Any]]) -> str:
    """The runs gamma's Cramer-Rao bound admits (every declared parameter unknown; runner.admission_verdict)
    and, among them, within 2 %, diverged, within 3 sigma; empty when the campaign did not measure it."""
    rows = [s for s in summary if "admitted" in s]
    if not rows:
        return ""
    head = ["experiment", "group", "n", "admitted (share)", "within 2 % of admitted", "diverged admitted",
            "within 3 sigma admitted"]

    def share(k: int, n: int) -> str:
        return f"{k} ({100 * k / n:.0f} %)" if n else f"{k}"

    cells = [head] + [[s["experiment"], s["group"], str(s["n"]), share(s["admitted"], s["n"]),
                       share(s["within_2pct_admitted"], s["admitted"]), str(s["diverged_admitted"]),
                       share(s["consistent_3sigma_admitted"], s["admitted"])] for s in rows]
    w = [max(len(r[i]) for r in cells) for i in range(len(head))]
    lines = ["| " + " | ".join(c.ljust(x) for c, x in zip(r, w)) + " |" for r in cells]
    lines.insert(1, "|" + "|".join("-" * (x + 2) for x in w) + "|")
    return "\n".join(lines)


JOINT_COLUMNS = ("experiment", "group", "n", "observable", "crb_meets_targets", "joint_ok", "joint_diverged",
                 "gamma_2pct", "n_2pct", "lambda_10pct", "gap_100nm")


def joint_rows(rows: Sequence[Dict[str, Any]], family: Family, experiments: Sequence[str]) -> List[Dict[str, Any]]:
    """The whole law's table (runs estimating law parameters; metrics.JOINT_TOL): per experiment and
    group, the runs the observability tool calls observable and those whose bound allows the targets, and
    among the latter how many meet every target, diverge, and meet each parameter's. Contact 1's law."""
    out = []
    for e in experiments:
        rs = [r for r in rows if r["experiment"] == e and "joint_ok" in r]
        if not rs:
            continue
        groups: List[tuple] = [("all", np.ones(len(rs), dtype=bool))]
        for sp in family.splits:
            vals = np.array([r.get(sp.name, np.nan) for r in rs], dtype=float)
            idx = sp.index(vals)
            groups += [(lab, idx == i) for i, lab in enumerate(sp.labels())]
        col = lambda key, default=False: np.array([r.get(key, default) for r in rs])  # noqa: E731
        within = lambda key, tol: np.abs(np.nan_to_num(col(key, np.nan).astype(float), nan=np.inf)) <= tol  # noqa: E731
        sel = col("crb_meets_targets", True).astype(bool)  # without the tool's verdict: every run
        for label, m in groups:
            ms = m & sel
            out.append({
                "experiment": e, "group": label, "n": int(m.sum()),
                "observable": int(np.count_nonzero(m & col("observable_all", True).astype(bool))),
                "crb_meets_targets": int(ms.sum()),
                "joint_ok": int(np.count_nonzero(ms & col("joint_ok").astype(bool))),
                "joint_diverged": int(np.count_nonzero(ms & col("joint_diverged").astype(bool))),
                "gamma_2pct": int(np.count_nonzero(ms & within("final_err", 0.02))),
                "n_2pct": int(np.count_nonzero(ms & within("contact1_n_final_err", 0.02))),
                "lambda_10pct": int(np.count_nonzero(ms & within("contact1_lambda_final_err", 0.10))),
                "gap_100nm": int(np.count_nonzero(ms & within("contact1_gap_final_err", 1e-7))),
            })
    return out


def format_joint(summary: Sequence[Dict[str, Any]]) -> str:
    head = ["experiment", "group", "n", "observable", "bound allows targets", "all targets met", "diverged",
            "gamma 2 %", "n 2 %", "lambda 10 %", "gap 0.1 um"]
    cells = [head] + [[s["experiment"], s["group"]] + [str(s[k]) for k in JOINT_COLUMNS[2:]] for s in summary]
    w = [max(len(r[i]) for r in cells) for i in range(len(head))]
    lines = ["| " + " | ".join(c.ljust(x) for c, x in zip(r, w)) + " |" for r in cells]
    lines.insert(1, "|" + "|".join("-" * (x + 2) for x in w) + "|")
    return "\n".join(lines)


def format_targets(family: Family, summary: Sequence[Dict[str, Any]], joint: Sequence[Dict[str, Any]]) -> str:
    """The spec's [targets] against the group "all" of each experiment: one line per experiment, each
    target with its value and met / NOT met; empty without targets (a joint target without the joint
    table is reported as not measured)."""
    if not family.targets:
        return ""
    lines = []
    for e in dict.fromkeys(s["experiment"] for s in summary):
        row = next(s for s in summary if s["experiment"] == e and s["group"] == "all")
        jrow = next((j for j in joint if j["experiment"] == e and j["group"] == "all"), None)
        cells, all_met = [], True
        for name, bound in family.targets:
            kind = TARGETS[name]
            if name.startswith("joint"):
                src, total = jrow, (jrow["crb_meets_targets"] if jrow else 0)
            elif name.endswith("_admitted"):  # over the runs gamma's bound admits; None: not measured
                src, total = (row, row["admitted"]) if "admitted" in row else (None, 0)
            else:
                src, total = row, row["n"]
            if name == "not_silent_wrong" and src is not None:  # the runs that are not silently wrong
                src = {name: row["n"] - row["silent_wrong"]}
            if src is None:
                cells.append(f"{name}: not measured" + (" (--observability)" if name.endswith("_admitted") else ""))
                all_met = False
                continue
            v = float(src[name])
            # the admitted targets say how many runs the bound admits (the share of all runs)
            of = (f" of {total} admitted ({100 * total / row['n']:.1f} % of {row['n']})"
                  if name.endswith("_admitted") and row["n"] else "")
            if kind == "fraction":
                frac = v / total if total else float("nan")
                met = frac >= bound
                cells.append(f"{name} {100 * frac:.1f} %{of} >= {100 * bound:g} %: {'met' if met else 'NOT met'}")
            else:
                met = v <= bound
                cells.append(f"{name} {v:g}{of} <= {bound:g}: {'met' if met else 'NOT met'}")
            all_met &= met
        lines.append(f"{e}: " + "; ".join(cells) + f" -> {'every target met' if all_met else 'targets NOT met'}")
    return "\n".join(lines)


def format_summary(summary: Sequence[Dict[str, Any]]) -> str:
    """The family table; "flagged" is the runs whose last step carries model_mismatch ("n/a" while the schema
    has no such flag), "silent wrong" those neither within 3 sigma nor flagged."""
    head = ["experiment", "group", "n", "within 1 %", "within 5 %", "diverged", "within 3 sigma", "flagged",
            "silent wrong", "median |err|"]
    na = lambda v: "n/a" if v is None else str(v)  # noqa: E731
    cells = [head] + [[s["experiment"], s["group"], str(s["n"]), str(s["within_1pct"]), str(s["within_5pct"]),
                       str(s["diverged"]), str(s["consistent_3sigma"]), na(s.get("flagged_mismatch_end")),
                       na(s.get("silent_wrong")), f"{100 * s['median_abs_err']:.3g} %"]
                      for s in summary]
    w = [max(len(r[i]) for r in cells) for i in range(len(head))]
    lines = ["| " + " | ".join(c.ljust(x) for c, x in zip(r, w)) + " |" for r in cells]
    lines.insert(1, "|" + "|".join("-" * (x + 2) for x in w) + "|")
    return "\n".join(lines)


def write_plots(rows: Sequence[Dict[str, Any]], family: Family, experiments: Sequence[str], outdir: Path,
                dt: float) -> List[Path]:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from scipy.stats import chi2

    outdir.mkdir(parents=True, exist_ok=True)
    written = []
    by_exp = {e: [r for r in rows if r["experiment"] == e] for e in experiments}
    floor = 1e-6

    def abs_err(rs):
        return np.clip(np.nan_to_num(np.array([r["abs_final_err_worst"] for r in rs], float), nan=10.0, posinf=10.0),
                       floor, 10.0)

    fig, ax = plt.subplots(figsize=(7, 4))
    bins = np.logspace(np.log10(floor), 1, 36)
    for e, rs in by_exp.items():
        ax.hist(abs_err(rs), bins=list(bins), histtype="step", lw=1.5, label=e)
    for x, lab in ((0.01, "1 %"), (0.05, "5 %"), (0.5, "diverged")):
        ax.axvline(x, color="k", ls=":", lw=0.8)
        ax.text(x, ax.get_ylim()[1] * 0.95, lab, rotation=90, va="top", ha="right", fontsize=8)
    ax.set_xscale("log")
    ax.set_xlabel("|final gamma error| of the worst contact (clipped to [1e-6, 10])")
    ax.set_ylabel("runs")
    ax.set_title(f"{family.name}: final gamma error, {len(family.runs)} mechanisms")
    ax.legend(fontsize=8)
    fig.tight_layout()
    p = outdir / "error_histogram.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    written.append(p)

    names = [n for n in family.drawn if n != "seed"]
    if names:
        ncol = 4
        nrow = -(-len(names) // ncol)
        fig, axes = plt.subplots(nrow, ncol, figsize=(3.2 * ncol, 2.6 * nrow), squeeze=False)
        for ax, name in zip(axes.flat, names):
            span = []
            for e, rs in by_exp.items():
                xs = np.array([r.get(name, np.nan) for r in rs], float)
                ax.scatter(xs, abs_err(rs), s=6, alpha=0.6, label=e)
                span += xs[np.isfinite(xs)].tolist()
            ax.set_yscale("log")
            if span and min(span) > 0 and max(span) > 30 * min(span):  # over decades (a stiffness)
                ax.set_xscale("log")
            ax.axhline(0.01, color="k", ls=":", lw=0.6)
            ax.axhline(0.05, color="k", ls="--", lw=0.6)
            ax.set_xlabel(name, fontsize=8)
            ax.tick_params(labelsize=7)
        for ax in list(axes.flat)[len(names):]:
            ax.axis("off")
        axes.flat[0].legend(fontsize=6)
        axes.flat[0].set_ylabel("|final error|")
        fig.tight_layout()
        p = outdir / "error_vs_parameters.png"
        fig.savefig(p, dpi=110)
        plt.close(fig)
        written.append(p)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 4))
    lo1, hi1 = chi2.ppf([0.025, 0.975], 1)
    for e, rs in by_exp.items():
        nees = np.sort(np.nan_to_num(np.array([r["nees_final_worst"] for r in rs], float), nan=1e12, posinf=1e12))
        a1.plot(np.arange(1, len(nees) + 1) / len(nees), np.clip(nees, 1e-6, 1e12), ".", ms=3, label=e)
        nis = np.array([r["nis_mean"] / r.get("sensors", 2) for r in rs], float)  # per degree of freedom
        ok = np.isfinite(nis)
        a2.plot(np.flatnonzero(ok), nis[ok], ".", ms=3, label=e)
    a1.axhspan(lo1, hi1, color="g", alpha=0.15, label="chi2(1) 95 %")
    a1.axhline(9.0, color="k", ls=":", lw=0.8, label="3 sigma")
    a1.set_yscale("log")
    a1.set_xlabel("fraction of runs (sorted)")
    a1.set_ylabel("final NEES of gamma (worst contact)")
    a1.legend(fontsize=7)
    steps = max(1, int(np.median([r.get("nis_steps", 1) or 1 for r in rows])))
    dof = max(1, int(np.median([r.get("sensors", 2) for r in rows])))  # NIS: chi2(sensors)
    lo2, hi2 = chi2.ppf([0.025, 0.975], dof * steps) / (dof * steps)
    a2.axhspan(lo2, hi2, color="g", alpha=0.3, label=f"mean of {steps} chi2({dof}) / {dof}: 95 %")
    a2.axhline(1.0, color="g", lw=0.8)
    a2.set_yscale("log")
    a2.set_xlabel("run")
    a2.set_ylabel("mean NIS / sensors")
    a2.legend(fontsize=7)
    fig.suptitle(f"{family.name}: consistency (a consistent filter: NEES ~ chi2(1), NIS ~ chi2(sensors))")
    fig.tight_layout()
    p = outdir / "consistency.png"
    fig.savefig(p, dpi=120)
    plt.close(fig)
    written.append(p)
    return written
