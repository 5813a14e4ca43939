"""Figures 7 and 9: energy error of Examples 2 / 3 vs DOFs, estimator next to it."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (DOFS, ERROR_LABELS, LEFT_OUT_WHY_ENERGY, legend_below,
                                        plt, problem_title, rate_series, reference_error_lines,
                                        save)
from fracfem_workflow.report import fit_rate, paper_rate


def panel(ax, df):
    ex = int(df.example.iloc[0])
    var = df.variant.fillna("").iloc[0]
    for fam, g in df.groupby("family"):
        g = g.sort_values("dofs")
        rate_series(ax, g.dofs, g.error, fam, g.reference_error.max(),
                    paper_rate(ex, fam, g.s.iloc[0], var),
                    exclude=g.below_reference.astype(bool))   # E_h < E_ref: no valid error
        if fam == "adaptive":
            ax.loglog(g.dofs, g.eta, ls=":", marker=".", color="k",
                      label=rf"estimator $\eta$ (adaptive): {fit_rate(g.dofs, g.eta):.3f}")
    ref_err = df.reference_error.max()
    if ref_err > 0:
        reference_error_lines(ax, ref_err, "measured uncertainty")
    ref = "exact" if ex == 3 and var == "printed" else "extrapolated (large adaptive run)"
    ax.set_title(f"{problem_title(df.problem.iloc[0])}, $s = {df.s.iloc[0]:g}$\n"
                 f"reference energy {ref}")        # two lines: no wider than the axes
    ax.set_xlabel(DOFS)
    legend_below(ax, why=LEFT_OUT_WHY_ENERGY)


def main(csvs, png, pdf):
    fig, axes = plt.subplots(1, len(csvs), figsize=(5.5 * len(csvs), 4), squeeze=False)
    for ax, csv in zip(axes[0], csvs):
        panel(ax, pd.read_csv(csv))
    axes[0][0].set_ylabel(ERROR_LABELS["vi"])   # one label: the panels share the measure
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.png, snakemake.output.pdf)  # noqa: F821
