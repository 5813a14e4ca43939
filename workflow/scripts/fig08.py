"""Figure 8: Example 3, u_h (left) and λ_H (right)."""
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import multiplier_panel, save, solution_figure


def main(npz, title, png, pdf):
    d, fig, ax2 = solution_figure(npz, title + ": $u_h$, s = {s:g}", cmap="coolwarm")
    multiplier_panel(fig, ax2, d, "coolwarm")
    p, t = d["p"], d["t"]
    ax2.tricontour(p[0], p[1], t.T, d["u"], levels=[0.0], colors="k", linewidths=1)
    ax2.set_title(r"$\lambda_H$ and the zero level of $u_h$ (black)")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.params.title, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
