"""Error against wall time for Examples 1–3 and the time each family needs for a
common error level (the smallest error every family reaches)."""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import ERROR_LABELS, plt, problem_title, save, time_panel


def main(ex1_csv, vi_csvs, s, png, md):
    ex1 = pd.read_csv(ex1_csv)
    ex1 = ex1[np.isclose(ex1.s, s)].copy()
    ex1["t_wall"] = np.where(ex1.family == "adaptive", ex1.t_cumulative, ex1.t_total)
    ex1["name"] = "Example 1"
    ex1["problem"] = "ex1"
    frames = [ex1[["name", "problem", "family", "dofs", "error", "t_wall"]]]
    for csv in vi_csvs:
        d = pd.read_csv(csv)
        var = d.variant.fillna("").iloc[0]
        d["name"] = f"Example {d.example.iloc[0]}" + (f" ({var})" if var else "")
        frames.append(d[["name", "problem", "family", "dofs", "error", "t_wall"]])
    df = pd.concat(frames, ignore_index=True)
    names = list(dict.fromkeys(df.name))
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.8), squeeze=False)
    rows = []
    for ax, name in zip(axes[0], names):
        d = df[df.name == name]
        problem = d.problem.iloc[0]
        rows.append({"example": name, **time_panel(ax, d, problem_title(problem))})
        # Example 1 against its exact solution, Examples 2, 3 by the energy distance
        ax.set_ylabel(ERROR_LABELS["elliptic" if problem == "ex1" else "vi"])
    fig.suptitle("Error against wall time (adaptive: all steps so far; Examples 2, 3: with "
                 "the PDAS solve)")
    save(fig, png)
    with atomic_path(md) as tmp:
        tmp.write_text(pd.DataFrame(rows).to_markdown(index=False, floatfmt=".4g") + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.ex1, list(snakemake.input.vi), snakemake.params.s,  # noqa: F821
         snakemake.output.png, snakemake.output.md)  # noqa: F821
