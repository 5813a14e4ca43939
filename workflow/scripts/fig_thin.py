"""Thin obstacle / thin friction demonstration: u_h and λ_H along Γ̃."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import save, solution_figure


def main(npz, png):
    d, fig, ax2 = solution_figure(npz, "$u_h$, s = {s:g}")
    p, u, pc, lam, edges = d["p"], d["u"], d["pc"], d["lam"], d["edges"]
    xm = pc[0, edges].mean(axis=0)
    order = np.argsort(xm)
    on = np.abs(p[1]) < 1e-12
    ax2.plot(np.sort(p[0, on]), u[on][np.argsort(p[0, on])], "k.-", ms=3, label=r"$u_h$ on $y=0$")
    ax2.step(xm[order], lam[order], where="mid", label=r"$\lambda_H$ on $\tilde\Gamma$")
    ax2.set_xlabel("$x_1$")
    ax2.legend()
    save(fig, png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png)  # noqa: F821
