"""Figure 2: Example 1 energy error vs DOFs, uniform and 2-graded (anisotropic, and
shape-regular for comparison), fitted rates."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (DOFS, ERROR_LABELS, legend_below, plt, problem_title,
                                        rate_series, save)
from fracfem_workflow.report import paper_rate


def main(rows, s, png, pdf):
    df = pd.concat([pd.read_csv(f) for f in rows])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for fam, g in df.groupby("family"):
        g = g.sort_values("dofs")
        rate_series(ax, g.dofs, g.error, fam, 0.0, paper_rate(1, fam, s))   # exact solution
    ax.set_xlabel(DOFS)
    ax.set_ylabel(ERROR_LABELS["elliptic"])
    ax.set_title(f"{problem_title('ex1')}, $s = {s:g}$; fitted rates")
    legend_below(ax)
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.rows), snakemake.params.s, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
