"""Figure 8: Example 3, u_h (left) and λ_H (right), with the boundaries of the slip sets."""
import numpy as np
from matplotlib.colors import TwoSlopeNorm

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (colorbar, map_axes, multiplier_panel, plt,
                                        problem_title, save, slip_boundaries,
                                        slip_legend)


def main(npz, problem, F, png, pdf):
    d = np.load(npz)
    p, t, u = d["p"], d["t"], d["u"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.6))
    # u_h as a map (P1: colours interpolated in each triangle), white where u_h = 0: the
    # steep layer at ∂Ω (u ~ dist^s) would hide a 3D surface behind its rim.
    bound = float(np.abs(u).max()) or 1.0
    tp = ax1.tripcolor(p[0], p[1], t.T, u, shading="gouraud", cmap="coolwarm",
                       norm=TwoSlopeNorm(0.0, -bound, bound))
    colorbar(fig, tp, ax1, "$u_h$")
    map_axes(ax1)
    ax1.set_title(f"{problem_title(problem)}: $u_h$, $s = {float(d['s']):g}$ "
                  f"({t.shape[1]} triangles)")
    multiplier_panel(fig, ax2, d, "coolwarm", vmin=-F, vmax=F)
    ax2.set_title(rf"$\lambda_H$ ($F = {F:g}$; {d['tc'].shape[1]} elements of $T_H$)")
    slip_legend(fig, [h for ax in (ax1, ax2)
                      for h in slip_boundaries(ax, d["pc"], d["tc"], d["lam"], F)])
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.params.problem, snakemake.params.F,  # noqa: F821
         snakemake.output.png, snakemake.output.pdf)  # noqa: F821
