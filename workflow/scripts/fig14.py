"""Figure 14: Example 5 from Algorithm C, u_hτ and λ_H at several times; where λ_H
switches sign over time in the reference run (ex5-free-boundary.md)."""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (colorbar, friction_states, map_axes, plt,
                                        problem_title, save, slip_boundaries, slip_legend,
                                        surface)


def slip_regions(pc, tc, lam, F, rtol=1e-6):
    """Counts of slip (λ = ±F) and stick elements and the radii bounding the slip sets."""
    r = np.hypot(*pc[:, tc].mean(axis=1))
    state = friction_states(lam, F, rtol)
    plus, minus = state == 1, state == -1
    return {"slip+ (λ=F)": int(plus.sum()), "slip− (λ=−F)": int(minus.sum()),
            "stick": int((state == 0).sum()),
            "slip+ outer radius": float(r[plus].max()) if plus.any() else np.nan,
            "slip− inner radius": float(r[minus].min()) if minus.any() else np.nan}


def is_zero(u, u0, tol):
    """u_hτ ≡ 0 up to the solver: max|u| ≤ tol · max|u_h(0)| (tol: the relative
    tolerance the time steps were solved to)."""
    return float(np.abs(u).max()) <= tol * float(np.abs(u0).max())


def sci(x):
    """x in LaTeX scientific notation, one significant digit: 3 \\times 10^{-12}."""
    mantissa, exponent = f"{x:.0e}".split("e")
    return (f"{mantissa} \\times " if mantissa != "1" else "") + f"10^{{{int(exponent)}}}"


def zero_panel(ax, p, t, title, note):
    """u_hτ drawn as the zero it is, with the title and a note saying why."""
    surface(ax, p, t, np.zeros(p.shape[1]), cmap="Greys", vmin=-1, vmax=1)
    ax.set_zlim(-1, 1)
    ax.set_zticks([0])
    ax.set_title(title)
    ax.text2D(0.5, 0.92, note, transform=ax.transAxes, ha="center", va="top",
              fontsize="small")


def adaptive_states(npz):
    """The last Algorithm C pass's states at its output times: [(t, p, t, u, pc, tc, λ_H
    or None)], ordered by t, and the pass number."""
    d = np.load(npz)
    states = []
    j = 0
    while f"time_last_{j}" in d:
        states.append((float(d[f"time_last_{j}"]), d[f"p_last_{j}"], d[f"t_last_{j}"], d[f"u_last_{j}"],
                       d[f"pc_last_{j}"], d[f"tc_last_{j}"],
                       d[f"lam_last_{j}"] if f"lam_last_{j}" in d else None))
        j += 1
    return sorted(states, key=lambda s: s[0]), int(d["last_iteration"])


def main(npz, reference_npz, times_shown, F, tol, png, pdf, md):
    """npz: the Algorithm C run (the figure); reference_npz: the reference run, whose
    every time step gives the free-boundary table."""
    states, iteration = adaptive_states(npz)
    at = {round(s[0], 12): s for s in states}
    missing = [ts for ts in times_shown if round(float(ts), 12) not in at]
    if missing or 0.0 not in at:
        raise ValueError(f"times {missing or [0.0]} are not output times of {npz} "
                         f"({sorted(at)}): add them to parabolic.output_times")
    u0_max = np.abs(at[0.0][3]).max()
    n = len(times_shown)
    fig = plt.figure(figsize=(3.4 * n, 6.8))
    lam_axes, tp, handles = [], None, []
    for j, ts in enumerate(times_shown):
        time, p, t, u, pc, tc, lam = at[round(float(ts), 12)]
        ax = fig.add_subplot(2, n, j + 1, projection="3d")
        stick = lam is not None and not friction_states(lam, F).any()
        peak = rf"$\max|u_{{h\tau}}| = {sci(np.abs(u).max())}$"
        if stick and not is_zero(u, u0_max, tol):
            # every coarse element sticks: the constraint holds all coarse means of u_hτ at
            # zero, and what is left is an oscillation within the fine space, not the solution
            zero_panel(ax, p, t, rf"$u_{{h\tau}}$, $t = {time:.2f}$: stick everywhere",
                       r"coarse means of $u_{h\tau}$ are 0;" "\n" + peak + " (fine-scale)")
        elif time > 0 and is_zero(u, u0_max, tol):
            # round-off of a solution that has decayed to zero: draw the zero it is
            zero_panel(ax, p, t, rf"$u_{{h\tau}}$, $t = {time:.2f}$: $u_{{h\tau}} \equiv 0$",
                       peak + "\n" rf"$\leq {sci(tol)}\,\max|u_h(0)|$ (solver tolerance)")
        else:
            surface(ax, p, t, u)
            ax.set_title(rf"$u_{{h\tau}}$, $t = {time:.2f}$ ({t.shape[1]:,} triangles)")
        ax2 = fig.add_subplot(2, n, n + j + 1)
        map_axes(ax2)
        if lam is not None:
            tp = ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=lam, cmap="coolwarm",
                               vmin=-F, vmax=F, edgecolors="none")
            handles += slip_boundaries(ax2, pc, tc, lam, F)
            ax2.set_title(rf"$\lambda_H$, $t = {time:.2f}$"
                          + (": stick everywhere" if stick else ""))
            lam_axes.append(ax2)
        else:
            ax2.set_axis_off()
            ax2.text(0.5, 0.5, r"$t = 0$: no $\lambda_H$" "\n" r"(initial value $P_h u_0$)",
                     transform=ax2.transAxes, ha="center", va="center")
    if tp is not None:
        colorbar(fig, tp, lam_axes[-1], r"$\lambda_H$")
        slip_legend(fig, handles)
    fig.suptitle(f"{problem_title('ex5')}, $F = {F:g}$: Algorithm C, pass {iteration} "
                 "(each time its slab's mesh)")
    save(fig, png, pdf)
    d = np.load(reference_npz)
    pc, tc, LAM, times = d["pc"], d["tc"], d["LAM"], d["times"]
    rows = [{"t": float(times[k + 1]), **slip_regions(pc, tc, LAM[k], F)}
            for k in range(len(LAM))]
    table = pd.DataFrame(rows)
    keep = np.unique(np.linspace(0, len(table) - 1, 12).round().astype(int))
    with atomic_path(md) as tmp:
        tmp.write_text(f"Example 5 (F = {F:g}): slip and stick sets of λ_H over time; the "
                       "free boundary is where λ_H jumps between them (radii of element "
                       "centroids):\n\n"
                       + table.iloc[keep].to_markdown(
                           index=False, floatfmt=(".3g", "g", "g", "g", ".3g", ".3g")) + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.input.reference, snakemake.params.times,  # noqa: F821
         snakemake.params.F,  # noqa: F821
         snakemake.params.tol, snakemake.output.png, snakemake.output.pdf,  # noqa: F821
         snakemake.output.md)  # noqa: F821
