"""Figure 2: Example 1 energy error vs DOFs, uniform and 2-graded (anisotropic, and
shape-regular for comparison), fitted rates."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import FAMILY_LABELS, MARKERS, plt, save
from fracfem_workflow.report import fit_rate, paper_rate


def main(rows, s, png, pdf):
    df = pd.concat([pd.read_csv(f) for f in rows])
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for fam, g in df.groupby("family"):
        g = g.sort_values("dofs")
        rate = fit_rate(g.dofs, g.error)
        paper = paper_rate(1, fam, s)
        label = f"{FAMILY_LABELS[fam]}: rate {rate:.3f}" + (f" (paper {paper:.3f})" if paper is not None else "")
        ax.loglog(g.dofs, g.error, marker=MARKERS[fam], label=label)
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel(r"$\|u-u_h\|_a$")
    ax.set_title(f"Example 1, s = {s:g}")
    ax.legend()
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.rows), snakemake.params.s, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
