"""Matplotlib settings and panels shared by the workflow's figures.

One style for every figure: font sizes come from the rc settings below (scripts pass no
font sizes), axis labels from the names below, colour bars from :func:`colorbar`, and
every figure is laid out by matplotlib's constrained layout, which keeps labels of
neighbouring panels apart.
"""
import re
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

plt.rcParams.update({
    "figure.dpi": 120, "savefig.dpi": 150,
    "figure.constrained_layout.use": True,
    "font.size": 10, "axes.titlesize": 10, "axes.labelsize": 10,
    "xtick.labelsize": 9, "ytick.labelsize": 9, "legend.fontsize": 8,
    "figure.titlesize": 11,
    "axes.grid": True, "grid.alpha": 0.3,
})
MARKERS = {"uniform": "o", "graded": "s", "graded-sr": "D", "adaptive": "^"}
# how a legend names a mesh family (the tables keep the short names)
FAMILY_LABELS = {"uniform": "uniform", "graded": "2-graded (anisotropic)",
                 "graded-sr": "2-graded, shape-regular", "adaptive": "adaptive"}
# why a run of an error figure is left out of its fit (legend_below's ``why``): the rate
# table's rule, and for energy errors the runs whose energy lies below the reference's
LEFT_OUT_WHY = "below the 3× line"
LEFT_OUT_WHY_ENERGY = LEFT_OUT_WHY + r", or $E(u_h) < E_{\mathrm{ref}}$"


def rate_series(ax, x, y, family, reference_error=0.0, paper=None, exclude=None):
    """Plot one family's errors; the fitted rate (runs passing report.fit_mask and not in
    ``exclude`` only, as in the rate table) and the paper's go in the legend, runs left out
    of the fit are drawn hollow.  Returns the rate."""
    from .report import fit_mask, masked_rate
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    keep = fit_mask(y, reference_error)
    if exclude is not None:
        keep &= ~np.asarray(exclude, dtype=bool)
    rate = masked_rate(x, y, keep)
    label = (f"{FAMILY_LABELS[family]}: {rate:.3f}" if np.isfinite(rate)
             else f"{FAMILY_LABELS[family]}: no rate (< 2 runs above 3× reference error)")
    label += f" (paper {paper:.3f})" if paper is not None else ""
    (line,) = ax.loglog(x, y, marker=MARKERS[family], label=label)
    left_out_markers(ax, line, x, y, keep)
    return rate


LEFT_OUT = "left out of the fit"      # gid of the hollow markers of rate_series


def left_out_markers(ax, line, x, y, keep):
    """The runs of ``line`` outside a rate fit (``keep`` false) drawn hollow over it, with
    the line's marker and colour."""
    x, y, keep = np.asarray(x, dtype=float), np.asarray(y, dtype=float), np.asarray(keep)
    if not keep.all():
        (hollow,) = ax.loglog(x[~keep], y[~keep], ls="none", marker=line.get_marker(),
                              ms=line.get_markersize(), mfc="white", color=line.get_color(),
                              zorder=line.get_zorder() + 1)
        hollow.set_gid(LEFT_OUT)


UNCHANGED = "as configured"     # the case of an adaptive series with its configured settings


def change_label(case, steps):
    """An Algorithm B series (ex1-/ex2-adaptive-rate) as a legend names it: θ for theta,
    the start mesh disk_uniform(L) as the uniform mesh it is, by its number of triangles;
    the unchanged series with its settings (steps: its rows, with columns theta and
    start_level)."""
    from fracfem.meshes import disk_uniform

    if case == UNCHANGED:
        case = f"{UNCHANGED}: theta = {steps.theta.iloc[0]:g}, start_level = " \
               f"{steps.start_level.iloc[0]}"
    return re.sub(r"start_level = (\d+)",
                  lambda m: "start mesh uniform, "
                            f"{disk_uniform(int(m.group(1))).nelements} triangles",
                  case.replace("theta", "θ"))


def legend_below(ax, ncols=1, why=None):
    """The legend of an error plot under its axes (inside them it covers the finest runs),
    one entry per line (in ``ncols`` columns) and one for the hollow markers of runs left
    out of a fit if there are any, with ``why`` (the rule that leaves them out) if given:
    the same place, size and distance from the axis label in every error figure (the pad
    is in font sizes, not a fraction of the axes' height)."""
    from matplotlib.lines import Line2D

    handles, labels = ax.get_legend_handles_labels()
    if any(ln.get_gid() == LEFT_OUT for ln in ax.lines):
        handles.append(Line2D([], [], ls="none", marker="o", mfc="white", color="grey"))
        labels.append("open markers: runs " + LEFT_OUT + (f" ({why})" if why else ""))
    ax.legend(handles, labels, loc="upper center", bbox_to_anchor=(0.5, 0.0),
              borderaxespad=5.0, fontsize=8, frameon=False, ncols=ncols)


def reference_error_lines(ax, reference_error, how):
    """The reference's own error (dashed; ``how`` it was obtained) and 3× it (dotted), the
    bound above which report.fit_mask lets a run into a rate fit."""
    ax.axhline(reference_error, color="grey", lw=0.7, ls="--",
               label=f"reference's own error ({how})")
    ax.axhline(3 * reference_error, color="grey", lw=0.7, ls=":",
               label="3× that: fits use only errors above")


def para_error_panel(ax, df, x="spacetime_dofs"):
    """One parabolic problem's errors on ax (Figures 13, 15): each family's error against
    ``x`` with its fitted and the paper's rate (rate_series), the estimator η and η with
    its time term in the energy norm beside the adaptive error, and each error's measured
    uncertainty (error bars; ``error_uncertainty``) or, where there is none, the
    reference's own error and 3× it.  df: para_errors' table, or Algorithm C's passes
    with a ``reference_error`` column.  Rates are fitted against space-time DOFs only: against
    wall time (``x="t_wall"``) the series are drawn without one, the runs outside the
    fit hollow as on the left."""
    from .report import eta_energy_time, fit_mask, fit_rate, paper_rate

    ex = int(df.example.iloc[0])
    # errors extrapolated to the limit of the reference's family: each with its own
    # measured uncertainty (error bars) instead of one reference error for all
    per_run = "error_uncertainty" in df and bool(df.error_uncertainty.notna().any())
    bars = False
    for fam, g in df.groupby("family"):
        g = g.sort_values(x)
        if x == "spacetime_dofs":
            rate_series(ax, g[x], g.error, fam, g.reference_error,
                        paper_rate(ex, fam, g.s.iloc[0], g.variant.fillna("").iloc[0]))
        else:
            (line,) = ax.loglog(g[x], g.error, marker=MARKERS[fam], label=FAMILY_LABELS[fam])
            left_out_markers(ax, line, g[x], g.error, fit_mask(g.error, g.reference_error))
        if per_run and g.error_uncertainty.notna().any():
            ax.errorbar(g[x], g.error, yerr=g.error_uncertainty.fillna(0.0), fmt="none",
                        ecolor="0.3", elinewidth=0.8, capsize=2, zorder=1,
                        label=None if bars else
                        "± measured uncertainty of the error (fits: error > 3× it)")
            bars = True
        if "eta" in g and g.eta.notna().any():
            rate = (f": {fit_rate(g[x], g.eta):.3f}" if x == "spacetime_dofs" else "")
            ax.loglog(g[x], g.eta, ls=":", marker=".", color="k",
                      label=rf"estimator $\eta$ ({FAMILY_LABELS[fam]}){rate}")
        eta_a = eta_energy_time(g)      # docs/differences.md
        if eta_a.notna().any():
            rate = (f": {fit_rate(g[x], eta_a):.3f}" if x == "spacetime_dofs" else "")
            ax.loglog(g[x], eta_a, ls="-.", marker=".", color="0.45",
                      label=r"$\eta$ with its time term in the energy norm" + rate)
    if not per_run:
        reference_error_lines(ax, df.reference_error.iloc[0], "measured")


# Axis labels: what is measured, in the paper's symbols.
DOFS = "degrees of freedom"
SPACETIME_DOFS = "space-time degrees of freedom"
WALL_TIME = "wall time [s]"
ERROR_LABELS = {
    "elliptic": r"$\|u-u_h\|_a$",                        # Example 1, exact solution
    "vi": r"$\sqrt{2\,|E(u_h)-E_{\mathrm{ref}}|}$",                # Examples 2, 3: energy distance
    "parabolic": r"$\|u-u_{h\tau}\|_{L^2(0,T;H^s)}$ (extrapolated)",  # Examples 4, 5: to the reference family's limit
}

# The problems of the workflow (config keys) in the paper's words.
PROBLEM_TITLES = {
    "ex1": "Example 1",
    "ex2": "Example 2",
    "ex3-printed": "Example 3, $f = 1$",
    "ex3-signchange": "Example 3, $f = 1-3|x|^2$",
    "ex4-u1": "Example 4, $u_0 = 1$",
    "ex4-u2": r"Example 4, $\tilde u_0 = 2$",
    "ex5": "Example 5",
    "thin-obstacle": r"Thin obstacle on $\tilde\Gamma$",
    "thin-friction": r"Thin friction on $\tilde\Gamma$",
}


def problem_title(problem):
    """The paper's name of a problem key such as 'ex4-u1' ('Example 4, u₀ = 1').

    Keys without an entry (data sets added to the config) read 'Example n (key)'.
    """
    if problem in PROBLEM_TITLES:
        return PROBLEM_TITLES[problem]
    number, _, variant = str(problem).removeprefix("ex").partition("-")
    return f"Example {number}" + (f" ({variant})" if variant else "")


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


def colorbar(fig, mappable, ax, label):
    """A vertical colour bar at the right of ax, laid out with the figure.

    It is drawn in axes inset into ax (beside it, 90% of its drawn height, centred), so
    it follows ax when an equal aspect shrinks it, and its end tick labels stay below
    the top of ax: they never run into a title.
    """
    cax = ax.inset_axes([1.04, 0.05, 0.04, 0.9])
    cax.grid(False)
    return fig.colorbar(mappable, cax=cax, label=label)


def surface(ax, p, t, values, cmap="viridis", **kw):
    """A P1 function on the mesh (p, t) as a 3D surface, axes labelled x₁, x₂.  Drawn
    without antialiasing: with it, the seams between thousands of small facets show as
    white lines and a moiré through which the far side shows."""
    ax.plot_trisurf(p[0], p[1], values, triangles=t.T, cmap=cmap,
                    **{"linewidth": 0, "antialiased": False, **kw})
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    ax.set_xticks([-1, 0, 1])         # Ω = B₁(0); more ticks crowd the slanted axes
    ax.set_yticks([-1, 0, 1])


def solution_figure(npz_path, title, cmap="viridis"):
    """Load a mixed-problem result; left panel the surface of u_h.

    title may refer to {s}, {triangles} and, for parabolic runs, {T}.  Returns
    (data, fig, right axes) for the caller's second panel.
    """
    d = np.load(npz_path)
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    surface(ax, d["p"], d["t"], d["u"], cmap=cmap)
    fields = {"s": float(d["s"]), "triangles": d["t"].shape[1]}
    if "T" in d:                       # parabolic runs: the final time
        fields["T"] = float(d["T"])
    ax.set_title(title.format(**fields))
    return d, fig, fig.add_subplot(1, 2, 2)


def multiplier_panel(fig, ax, d, cmap, **kw):
    """λ_H as a piecewise constant on the coarse mesh T_H (flat triangles), with a
    colour bar; returns the mappable."""
    pc, tc = d["pc"], d["tc"]
    tp = ax.tripcolor(pc[0], pc[1], tc.T, facecolors=d["lam"], cmap=cmap,
                      edgecolors="none", **kw)
    colorbar(fig, tp, ax, r"$\lambda_H$")
    map_axes(ax)
    return tp


def map_axes(ax):
    """Axes of a map of Ω: equal scales, x₁, x₂ labels, few ticks."""
    ax.set_aspect("equal")
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    ax.locator_params(nbins=5)
    ax.grid(False)


def friction_states(lam, F, rtol=1e-6):
    """State of every element for friction: +1 slip with λ_H = F, −1 slip with λ_H = −F,
    0 stick (|λ_H| < F)."""
    state = np.zeros(len(lam), dtype=int)
    state[lam >= F * (1 - rtol)] = 1
    state[lam <= -F * (1 - rtol)] = -1
    return state


def interface_segments(p, t, label):
    """Edges of the mesh (p, t) shared by two triangles of different label, as an array
    of segments (n, 2, 2) for a LineCollection: the boundaries between the regions."""
    edges = np.concatenate([t[[0, 1]], t[[1, 2]], t[[2, 0]]], axis=1)      # (2, 3 Nt)
    owner = np.tile(np.arange(t.shape[1]), 3)
    key = np.sort(edges, axis=0)
    order = np.lexsort(key)
    key, owner = key[:, order], owner[order]
    # an interior edge appears twice, its two occurrences adjacent after sorting
    pair = np.flatnonzero((key[:, 1:] == key[:, :-1]).all(axis=0))
    differ = pair[label[owner[pair]] != label[owner[pair + 1]]]
    return p[:, key[:, differ]].transpose(2, 1, 0)


# the kinds of slip edge slip_boundaries draws, by the sign of λ_H = ±F (their gid), in
# the order slip_legend lists them
SLIP_EDGE = {1: "slip edge +F", -1: "slip edge -F"}


def slip_boundaries(ax, pc, tc, lam, F, **kw):
    """Draw the edges of T_H = (pc, tc) around the two slip sets, where λ_H jumps: solid
    around λ_H = F, dashed around λ_H = −F (the stick set |λ_H| < F lies between; where
    it is thin the two lines meet, the dashes tell them apart).  Returns the two line
    collections (legend handles)."""
    from matplotlib.collections import LineCollection

    state = friction_states(lam, F)
    out = []
    for sign, style, name in ((1, "solid", "F"), (-1, "dashed", "-F")):
        seg = interface_segments(pc, tc, (state == sign).astype(int))
        out.append(ax.add_collection(LineCollection(
            seg, label=rf"edge of the slip set $\lambda_H = {name}$",
            gid=SLIP_EDGE[sign],
            **{"colors": "k", "linewidths": 1.0, "linestyles": style, **kw})))
    return out


def slip_legend(fig, handles):
    """The figure's legend of slip_boundaries' lines (handles: those of every panel): one
    entry per kind of edge drawn in some panel, λ_H = F first; a kind no panel draws
    (no slip set of that sign at any time shown) has no entry, and no legend is drawn if
    neither is."""
    kinds = {}
    for h in handles:
        if len(h.get_segments()):
            kinds.setdefault(h.get_gid(), h)
    order = list(SLIP_EDGE.values())
    drawn = sorted(kinds.values(), key=lambda h: order.index(h.get_gid()))
    if drawn:
        fig.legend(handles=drawn, loc="outside lower center", ncols=2, frameon=False)


def plain_log_ticks(axis):
    """Ticks of a log axis at 1, 2, 5 × 10^k labelled as plain numbers (0.2, 5, 100):
    the default labels minor ticks of a short range as 3×10⁻¹, 4×10⁻¹, … and they
    overlap."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    axis.set_major_locator(LogLocator(subs=(1.0, 2.0, 5.0)))
    axis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    axis.set_minor_formatter(NullFormatter())


def time_panel(ax, d, name, xlabel=WALL_TIME):
    """Error against wall time of every family of d on ax; the time each family needs
    for the smallest error all of them reach, as one row of a summary table."""
    from .report import time_to_reach

    level = d.groupby("family").error.min().max()
    times = {}
    for fam, g in d.groupby("family"):
        g = g.sort_values("t_wall")
        ax.loglog(g.t_wall, g.error, marker=MARKERS[fam], label=FAMILY_LABELS[fam])
        times[fam] = time_to_reach(g.t_wall.values, g.error.values, level)
    ax.axhline(level, color="grey", lw=0.6, ls="--",
               label="smallest error every family reaches")
    plain_log_ticks(ax.xaxis)
    ax.set_title(name)
    ax.set_xlabel(xlabel)
    legend_below(ax)                  # inside, it covers the curves
    best = min(times, key=times.get)
    return {"common error": level, **{f"t_{k} [s]": v for k, v in sorted(times.items())},
            "fastest": best, "speed-up vs slowest": max(times.values()) / times[best]}
