"""Why Example 1's adaptive rate, fitted over the whole series, differs from the paper's:
Algorithm B run again with one of its settings changed at a time (its start mesh, its
marking parameter θ), everything else as in the pipeline's adaptive series.

Example 1's error is exact, so every difference between the series is the algorithm's.  If
the series reach the same error at the same number of DOFs after a few steps while the rate
fitted through all their steps moves with the start mesh, the fitted rate is a property of
where the series starts, not of the adaptive meshes it reaches.
"""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (DOFS, ERROR_LABELS, UNCHANGED, change_label,
                                        legend_below, plt, save)
from fracfem_workflow.report import cut_series, fit_rate, local_slopes, paper_rate
from fracfem_workflow.runs import mismatched_parameters, parameter_names



def change_tables(series: dict, max_dofs: int):
    """(summary, steps) of the series {case: Algorithm B's steps (dofs, error, eta,
    efficiency, theta, start_level)}, the first case the unchanged one.  Each series is
    cut at max_dofs; its errors are compared with the unchanged series' at the same DOFs
    (log-log interpolation of the whole unchanged series, not cut; NaN outside its
    DOFs)."""
    series = {name: df.sort_values("dofs").reset_index(drop=True)
              for name, df in series.items()}
    cases = {name: cut_series(df, max_dofs, name) for name, df in series.items()}
    base = next(iter(series.values()))
    logn, loge = np.log(base.dofs.to_numpy(float)), np.log(base.error.to_numpy(float))
    rows = []
    for name, df in cases.items():
        x = np.log(df.dofs.to_numpy(float))
        inside = (x >= logn[0]) & (x <= logn[-1])
        at = np.where(inside, np.exp(np.interp(x, logn, loge)), np.nan)
        rows.append(pd.DataFrame({
            "case": name, "theta": df.theta.to_numpy(), "start_level": df.start_level.to_numpy(),
            "step": np.arange(len(df)), "dofs": df.dofs.to_numpy(),
            "error": df.error.to_numpy(), "eta": df.eta.to_numpy(),
            "efficiency": df.efficiency.to_numpy(), "marked": df.marked.to_numpy(),
            "innermost marked radius": df["innermost marked radius"].to_numpy(),
            "error / unchanged at the same DOFs": df.error.to_numpy() / at}))
    steps = pd.concat(rows, ignore_index=True)
    steps.insert(6, "local slope", local_slopes(steps.dofs, steps.error, steps.case).to_numpy())
    summary = pd.DataFrame([{
        "case": name, "theta": g.theta.iloc[0], "start_level": g.start_level.iloc[0],
        "start dofs": g.dofs.iloc[0], "Algorithm B steps": len(g), "last dofs": g.dofs.iloc[-1],
        "rate": fit_rate(g.dofs, g.error),
        "last local slope": g["local slope"].iloc[-1],
        "smallest_error": g.error.min(),
        "error / unchanged at the same DOFs": g["error / unchanged at the same DOFs"].iloc[-1]}
        for name, g in steps.groupby("case", sort=False)])
    return summary, steps


def main(series_table, change_files, changes, max_dofs, md, png):
    """series_table: the pipeline's adaptive series (ex1_adaptive); change_files: one
    steps table per entry of changes ({name: {setting: value}})."""
    if len(change_files) != len(changes):
        raise ValueError(f"{len(change_files)} tables for the {len(changes)} changes "
                         f"{list(changes)}")
    series = {UNCHANGED: pd.read_csv(series_table)}
    s = float(series[UNCHANGED].s.iloc[0])
    paper = paper_rate(1, "adaptive", s)
    paper = "" if paper is None else f" (the paper: {paper:.3f})"
    base = series[UNCHANGED].iloc[0]
    # every recorded setting but where the series stop (max_dofs), which may differ
    settings = ["s"] + [c for c in parameter_names(base.index) if c != "max_dofs"]
    for (name, change), f in zip(changes.items(), change_files):
        df = pd.read_csv(f)
        expected = {key: change.get(key, base[key]) for key in settings}
        differ = mismatched_parameters(df.iloc[0].to_dict(), expected)
        if differ:
            raise ValueError(f"{f} was not run with {differ[0]} = {expected[differ[0]]} "
                             f"(case {name!r}: the unchanged series' settings, with this "
                             "change)")
        series[name] = df
    summary, steps = change_tables(series, max_dofs)
    with atomic_path(md) as tmp:
        tmp.write_text(
            f"Example 1 (s = {s:g}, exact error) on adaptive meshes: Algorithm B as "
            "configured, and again with one of its settings changed at a time (start mesh "
            "disk_uniform(start_level); marking parameter θ), every series stopped after "
            f"its first step with at least {max_dofs} DOFs, so their last DOFs differ "
            "(`last dofs`). `rate` is fitted through every step of a series, as in the rate "
            f"table{paper}; `error / unchanged at the same DOFs` compares a step with the "
            "unchanged series at its DOFs (all its steps; nan beyond them).\n\n"
            + summary.to_markdown(index=False, floatfmt=".4g") + "\n\n"
            + steps.to_markdown(index=False, floatfmt=".4g") + "\n")
    fig, ax = plt.subplots(figsize=(5.5, 5))   # the legend below takes a line per series
    for i, (name, g) in enumerate(steps.groupby("case", sort=False)):
        rate = summary.loc[summary.case == name, "rate"].iloc[0]
        ax.loglog(g.dofs, g.error, marker="^osDvP*"[i % 7], ls="-" if i == 0 else ":",
                  color=f"C{i}", label=f"{change_label(name, g)}: {rate:.3f}")
    ax.set_xlabel(DOFS)
    ax.set_ylabel(ERROR_LABELS["elliptic"])
    ax.set_title(f"Example 1 ($s = {s:g}$): Algorithm B with one setting changed\n"
                 f"legend: rate through all steps{paper.replace('the paper:', 'paper')}")
    legend_below(ax)      # one column: two would be wider than the axes
    save(fig, png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.series, list(snakemake.input.changes),  # noqa: F821
         snakemake.params.changes, snakemake.params.max_dofs,  # noqa: F821
         snakemake.output.md, snakemake.output.png)  # noqa: F821
