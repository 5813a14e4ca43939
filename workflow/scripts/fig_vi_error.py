"""Figures 7 and 9: energy error of Examples 2 / 3 vs DOFs, estimator next to it."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import MARKERS, plt, save
from fracfem_workflow.report import fit_rate, paper_rate


def panel(ax, df):
    ex = int(df.example.iloc[0])
    var = df.variant.fillna("").iloc[0]
    for fam, g in df.groupby("family"):
        g = g.sort_values("dofs")
        paper = paper_rate(ex, fam, g.s.iloc[0], var)
        label = f"{fam}: {fit_rate(g.dofs, g.error):.3f}"
        label += f" (paper {paper:.3f})" if paper is not None else ""
        ax.loglog(g.dofs, g.error, marker=MARKERS[fam], label=label)
        if fam == "adaptive":
            ax.loglog(g.dofs, g.eta, ls=":", marker=".", color="k",
                      label=f"estimator η (adaptive): {fit_rate(g.dofs, g.eta):.3f}")
    ref = "exact" if ex == 3 and var == "printed" else "extrapolated"
    ax.set_title(f"Example {ex}{' (' + var + ')' if var else ''}, s = "
                 f"{df.s.iloc[0]:g}; reference energy {ref}", fontsize=9)
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel(r"$\sqrt{2|E(u_h)-E_{ref}|}$")
    ax.legend(fontsize=7)


def main(csvs, png, pdf):
    fig, axes = plt.subplots(1, len(csvs), figsize=(5.5 * len(csvs), 4), squeeze=False)
    for ax, csv in zip(axes[0], csvs):
        panel(ax, pd.read_csv(csv))
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.png, snakemake.output.pdf)  # noqa: F821
