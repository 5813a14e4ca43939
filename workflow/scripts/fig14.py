"""Figure 14: Example 5, u_hτ and λ_H at several times; where λ_H switches sign."""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (colorbar, friction_states, map_axes, plt,
                                        problem_title, save, slip_boundaries, surface)


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


def main(npz, times_shown, F, tol, png, pdf, md):
    d = np.load(npz)
    p, t, U, LAM, times = d["p"], d["t"], d["U"], d["LAM"], d["times"]
    pc, tc = d["pc"], d["tc"]
    n = len(times_shown)
    fig = plt.figure(figsize=(3.4 * n, 6.8))
    lam_axes, tp = [], None
    for j, ts in enumerate(times_shown):
        k = int(np.argmin(np.abs(times - ts)))
        ax = fig.add_subplot(2, n, j + 1, projection="3d")
        if is_zero(U[k], U[0], tol):
            # round-off of a solution that has decayed to zero: draw the zero it is
            surface(ax, p, t, np.zeros_like(U[k]), cmap="Greys", vmin=-1, vmax=1)
            ax.set_zlim(-1, 1)
            ax.set_zticks([0])
            ax.set_title(rf"$u_{{h\tau}}$, $t = {times[k]:.2f}$: $u_{{h\tau}} \equiv 0$")
            ax.text2D(0.5, 0.92, rf"$\max|u_{{h\tau}}| = {sci(np.abs(U[k]).max())}$"
                      "\n" rf"$\leq {sci(tol)}\,\max|u_h(0)|$ (solver tolerance)",
                      transform=ax.transAxes, ha="center", va="top", fontsize="small")
        else:
            surface(ax, p, t, U[k])
            ax.set_title(rf"$u_{{h\tau}}$, $t = {times[k]:.2f}$")
        ax2 = fig.add_subplot(2, n, n + j + 1)
        map_axes(ax2)
        if k > 0:
            lam = LAM[k - 1]
            tp = ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=lam, cmap="coolwarm",
                               vmin=-F, vmax=F, edgecolors="none")
            slip_boundaries(ax2, pc, tc, lam, F)
            stick = not friction_states(lam, F).any()
            ax2.set_title(rf"$\lambda_H$, $t = {times[k]:.2f}$"
                          + (": stick everywhere" if stick else ""))
            lam_axes.append(ax2)
        else:
            ax2.set_axis_off()
            ax2.text(0.5, 0.5, r"$t = 0$: no $\lambda_H$" "\n" r"(initial value $P_h u_0$)",
                     transform=ax2.transAxes, ha="center", va="center")
    if tp is not None:
        colorbar(fig, tp, lam_axes[-1], r"$\lambda_H$")
        fig.legend(handles=lam_axes[-1].collections[-1:], loc="outside lower center",
                   frameon=False)
    fig.suptitle(f"{problem_title('ex5')}, $F = {F:g}$: {t.shape[1]} triangles, "
                 f"{len(times) - 1} time steps")
    save(fig, png, pdf)
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
    main(snakemake.input.npz, snakemake.params.times, snakemake.params.F,  # noqa: F821
         snakemake.params.tol, snakemake.output.png, snakemake.output.pdf,  # noqa: F821
         snakemake.output.md)  # noqa: F821
