"""Table of every parabolic run and error against wall time (Examples 4, 5)."""
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import ERROR_LABELS, plt, problem_title, save, time_panel


def main(csvs, md, png):
    df = pd.concat([pd.read_csv(c) for c in csvs], ignore_index=True)
    cols = ["problem", "family", "tag", "dofs", "steps", "spacetime_dofs", "error", "eta",
            "first_contact", "t_wall", "peak_mem_mb", "reference_error_estimate"]
    table = df[[c for c in cols if c in df]].sort_values(["problem", "family",
                                                          "spacetime_dofs"])
    fig, axes = plt.subplots(1, len(csvs), figsize=(4.2 * len(csvs), 3.8), squeeze=False)
    fastest = []
    for ax, (prob, d) in zip(axes[0], df.groupby("problem")):
        fastest.append({"problem": prob, **time_panel(
            ax, d, problem_title(prob), xlabel="wall time [s] (adaptive: all passes so far)")})
    axes[0][0].set_ylabel(ERROR_LABELS["parabolic"])
    save(fig, png)
    with atomic_path(md) as tmp:
        tmp.write_text("Time each family needs to reach the smallest error all of them reach "
                       "(wall time of the run; adaptive: all passes so far, without the error "
                       "measurement):\n\n"
                       + pd.DataFrame(fastest).to_markdown(index=False, floatfmt=".4g")
                       + "\n\nEvery run:\n\n"
                       + table.to_markdown(index=False, floatfmt=".4g") + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.md, snakemake.output.png)  # noqa: F821
