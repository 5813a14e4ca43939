"""Thin obstacle / thin friction demonstration: u_h and λ_H along Γ̃."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import problem_title, save, solution_figure


def main(npz, problem, png):
    d, fig, ax2 = solution_figure(npz, problem_title(problem) + ": $u_h$, $s = {s:g}$ "
                                  "({triangles} triangles)")
    # seen from higher up: a solution below zero is a bowl whose steep rim (u ~ dist^s at
    # ∂Ω) would otherwise hide the inside, where Γ̃ is
    fig.axes[0].view_init(elev=55)
    p, u, pc, lam, edges = d["p"], d["u"], d["pc"], d["lam"], d["edges"]
    xm = pc[0, edges].mean(axis=0)
    order = np.argsort(xm)
    on = np.abs(p[1]) < 1e-12
    ax2.plot(np.sort(p[0, on]), u[on][np.argsort(p[0, on])], "k.-", ms=3,
             label=r"$u_h$ on $x_2 = 0$")
    ax2.step(xm[order], lam[order], where="mid",
             label=r"$\lambda_H$ on $\tilde\Gamma$ (one value per coarse edge)")
    ax2.set_xlabel("$x_1$")
    ax2.set_title(r"the line $x_2 = 0$, which contains $\tilde\Gamma$")
    ax2.legend()
    save(fig, png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, f"thin-{snakemake.wildcards.kind}",  # noqa: F821
         snakemake.output.png)  # noqa: F821
