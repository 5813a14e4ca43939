"""Figures 13 and 15: L²(0,T; H^s) error vs space-time DOFs (Examples 4 and 5)."""
import pandas as pd

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (ERROR_LABELS, SPACETIME_DOFS, legend_below,
                                        para_error_panel, plt, problem_title, save)


def main(csvs, png, pdf):
    fig, axes = plt.subplots(1, len(csvs), figsize=(5.5 * len(csvs), 4), squeeze=False)
    for ax, csv in zip(axes[0], csvs):
        df = pd.read_csv(csv)
        para_error_panel(ax, df)
        # two lines, as Figures 7 and 9: what the y label's "(extrapolated)" means
        ax.set_title(f"{problem_title(df.problem.iloc[0])}, $s = {df.s.iloc[0]:g}$\n"
                     "distance to the limit of graded reference runs, extrapolated")
        ax.set_xlabel(SPACETIME_DOFS)
        legend_below(ax)
    axes[0][0].set_ylabel(ERROR_LABELS["parabolic"])
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.png, snakemake.output.pdf)  # noqa: F821
