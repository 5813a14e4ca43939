"""Figures 4, 5 and 10: an obstacle solution (Example 2 uniform / adaptive, Example 4 at
T on its last adaptive mesh) with λ_H and the contact set."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import multiplier_panel, problem_title, save, solution_figure

TITLES = {
    "fig04": problem_title("ex2") + ": $u_h$, uniform mesh ({triangles} triangles)",
    "fig05": problem_title("ex2") + ": $u_h$, adaptive mesh ({triangles} triangles)",
    "fig10": problem_title("ex4-u1") + r": $u_{{h\tau}}$ at $T = {T:g}$, adaptive mesh "
             "({triangles} triangles)",
}


def main(npz, figure, png, pdf):
    d, fig, ax2 = solution_figure(npz, TITLES[figure])
    multiplier_panel(fig, ax2, d, "magma")
    ax2.set_title(rf"$\lambda_H$; contact where $\lambda_H < 0$: "
                  f"{int(np.sum(d['lam'] < 0))} of {len(d['lam'])} elements")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.params.figure, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
