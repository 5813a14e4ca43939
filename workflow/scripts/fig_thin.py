"""Thin obstacle / thin friction demonstration: u_h as a map of Ω with Γ̃ marked, and u_h and
λ_H along the line x₂ = 0 that contains Γ̃."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import colorbar, map_axes, plt, problem_title, save


def main(npz, problem, png):
    d = np.load(npz)
    p, t, u, pc, lam, edges = d["p"], d["t"], d["u"], d["pc"], d["lam"], d["edges"]
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    # a map, not a surface: the steep layer at ∂Ω (u ~ dist^s) drawn in 3D shows as a
    # fence of thin faces along the rim and along Γ̃
    tp = ax1.tripcolor(p[0], p[1], t.T, u, shading="gouraud", cmap="viridis")
    colorbar(fig, tp, ax1, "$u_h$")
    seg = pc[:, edges]                                   # (2, 2, n): the edges of Γ̃
    ax1.plot(seg[0], seg[1], color="w", lw=2.0)
    ax1.plot([], [], color="w", lw=2.0, label=r"$\tilde\Gamma$")
    map_axes(ax1)
    ax1.set_title(f"{problem_title(problem)}: $u_h$, $s = {float(d['s']):g}$ "
                  f"({t.shape[1]} triangles)")
    ax1.legend(loc="upper right", facecolor="0.6")
    xm = pc[0, edges].mean(axis=0)
    order = np.argsort(xm)
    on = np.abs(p[1]) < 1e-12
    ax2.plot(np.sort(p[0, on]), u[on][np.argsort(p[0, on])], "k.-", ms=3,
             label=r"$u_h$ on $x_2 = 0$")
    ax2.step(xm[order], lam[order], where="mid",
             label=r"$\lambda_H$ on $\tilde\Gamma$ (one value per coarse edge)")
    ax2.set_xlabel("$x_1$")
    ax2.set_ylabel(r"$u_h$, $\lambda_H$")
    ax2.set_title(r"the line $x_2 = 0$, which contains $\tilde\Gamma$")
    ax2.legend()
    save(fig, png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, f"thin-{snakemake.wildcards.kind}",  # noqa: F821
         snakemake.output.png)  # noqa: F821
