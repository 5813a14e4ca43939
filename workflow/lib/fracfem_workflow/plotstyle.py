"""Matplotlib settings and panels shared by the workflow's figures."""
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

plt.rcParams.update({"figure.dpi": 120, "savefig.dpi": 150, "font.size": 10,
                     "axes.grid": True, "grid.alpha": 0.3})
MARKERS = {"uniform": "o", "graded": "s", "graded-sr": "D", "adaptive": "^"}
# how a legend names a mesh family (the tables keep the short names)
FAMILY_LABELS = {"uniform": "uniform", "graded": "2-graded (anisotropic)",
                 "graded-sr": "2-graded, shape-regular", "adaptive": "adaptive"}


def rate_series(ax, x, y, family, reference_error=0.0, paper=None):
    """Plot one family's errors; the fitted rate (runs passing report.fit_mask only) and the
    paper's go in the legend, runs left out of the fit are drawn hollow.  Returns the rate."""
    import numpy as np

    from .report import fit_mask, fit_rate
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = fit_mask(y, reference_error)
    rate = fit_rate(x[keep], y[keep]) if keep.sum() >= 2 else float("nan")
    label = (f"{FAMILY_LABELS[family]}: {rate:.3f}" if np.isfinite(rate)
             else f"{FAMILY_LABELS[family]}: no rate (< 2 runs above 3× reference error)")
    label += f" (paper {paper:.3f})" if paper is not None else ""
    (line,) = ax.loglog(x, y, marker=MARKERS[family], label=label)
    if not keep.all():
        ax.loglog(x[~keep], y[~keep], ls="none", marker=MARKERS[family], mfc="white",
                  color=line.get_color(), zorder=line.get_zorder() + 1)
    return rate


# PDFs get no creation date (matplotlib writes the time of the call, or
# SOURCE_DATE_EPOCH): the same figure drawn twice then gives the same bytes, so
# re-running a figure rule on unchanged data leaves the committed paper-figures/
# untouched.  PNGs hold no date; their one default entry, Software (the matplotlib
# version), is kept.
METADATA = {".pdf": {"CreationDate": None, "ModDate": None}}


def save(fig, *paths):
    """Write fig to every path (format from the suffix) without a date, then close it."""
    for path in paths:
        suffix = Path(path).suffix.lower()
        fig.savefig(path, bbox_inches="tight", metadata=METADATA.get(suffix))
    plt.close(fig)


def solution_figure(npz_path, title, cmap="viridis"):
    """Load a mixed-problem result; left panel the surface of u_h.

    title may refer to {s}, {triangles} and, for parabolic runs, {T}.  Returns
    (data, fig, right axes) for the caller's second panel.
    """
    import numpy as np
    d = np.load(npz_path)
    p, t = d["p"], d["t"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], d["u"], triangles=t.T, cmap=cmap, linewidth=0)
    fields = {"s": float(d["s"]), "triangles": t.shape[1]}
    if "T" in d:                       # parabolic runs: the final time
        fields["T"] = float(d["T"])
    ax.set_title(title.format(**fields))
    return d, fig, fig.add_subplot(1, 2, 2)


def multiplier_panel(fig, ax, d, cmap):
    """λ_H as a piecewise constant on the coarse mesh, with a colour bar."""
    pc, tc = d["pc"], d["tc"]
    tp = ax.tripcolor(pc[0], pc[1], tc.T, facecolors=d["lam"], cmap=cmap, edgecolors="none")
    fig.colorbar(tp, ax=ax, label=r"$\lambda_H$")
    ax.set_aspect("equal")


def time_panel(ax, d, name, xlabel="wall time [s]"):
    """Error against wall time of every family of d on ax; the time each family needs
    for the smallest error all of them reach, as one row of a summary table."""
    from .report import time_to_reach

    level = d.groupby("family").error.min().max()
    times = {}
    for fam, g in d.groupby("family"):
        g = g.sort_values("t_wall")
        ax.loglog(g.t_wall, g.error, marker=MARKERS[fam], label=fam)
        times[fam] = time_to_reach(g.t_wall.values, g.error.values, level)
    ax.axhline(level, color="grey", lw=0.6, ls="--")
    ax.set_title(name, fontsize=9)
    ax.set_xlabel(xlabel)
    ax.legend(fontsize=7)
    best = min(times, key=times.get)
    return {"common error": level, **{f"t_{k} [s]": v for k, v in sorted(times.items())},
            "fastest": best, "speed-up vs slowest": max(times.values()) / times[best]}
