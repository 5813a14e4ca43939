"""Figures 13 and 15: L²(0,T; H^s) error vs space-time DOFs (Examples 4 and 5)."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (ERROR_LABELS, FAMILY_LABELS, SPACETIME_DOFS,
                                        legend_below, plt, problem_title, rate_series,
                                        reference_error_lines, save)
from fracfem_workflow.report import eta_energy_time, fit_rate, paper_rate


def main(csvs, png, pdf):
    fig, axes = plt.subplots(1, len(csvs), figsize=(5.5 * len(csvs), 4), squeeze=False)
    for ax, csv in zip(axes[0], csvs):
        df = pd.read_csv(csv)
        ex = int(df.example.iloc[0])
        for fam, g in df.groupby("family"):
            g = g.sort_values("spacetime_dofs")
            rate_series(ax, g.spacetime_dofs, g.error, fam, g.reference_error.max(),
                        paper_rate(ex, fam, g.s.iloc[0], g.variant.fillna("").iloc[0]))
            if "eta" in g and g.eta.notna().any():
                ax.loglog(g.spacetime_dofs, g.eta, ls=":", marker=".", color="k",
                          label=rf"estimator $\eta$ ({FAMILY_LABELS[fam]}): "
                                f"{fit_rate(g.spacetime_dofs, g.eta):.3f}")
            eta_a = eta_energy_time(g)      # docs/differences.md
            if eta_a.notna().any():
                ax.loglog(g.spacetime_dofs, eta_a, ls="-.", marker=".", color="0.45",
                          label=r"$\eta$ with its time term in the energy norm: "
                                f"{fit_rate(g.spacetime_dofs, eta_a):.3f}")
        reference_error_lines(ax, df.reference_error.iloc[0], "measured")
        ax.set_title(f"{problem_title(df.problem.iloc[0])}, $s = {df.s.iloc[0]:g}$")
        ax.set_xlabel(SPACETIME_DOFS)
        legend_below(ax)
    axes[0][0].set_ylabel(ERROR_LABELS["parabolic"])
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.png, snakemake.output.pdf)  # noqa: F821
