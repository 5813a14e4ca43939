"""Extra figures of Example 1: error vs wall time; error vs DOFs for every s; and the table
of every run (ex1-errors.md), with the graded families' rates against their mesh size h."""
import numpy as np
import pandas as pd

import fracfem as ff

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import (DOFS, ERROR_LABELS, FAMILY_LABELS, MARKERS, WALL_TIME,
                                        legend_below, plain_log_ticks, plt, save)
from fracfem_workflow.report import fit_rate, local_slopes


def h_rates(df: pd.DataFrame) -> pd.DataFrame:
    """Per s and graded family (tags h<h>, r<h>): the rate of the error against DOFs (every
    run: Example 1's error is exact, so the rate table fits them all too); against the
    family's mesh size h (its tag); and the exponent p of the DOFs in h (N ~ h^p).  The
    rate against DOFs equals the rate in h over p when log N is a straight line in log h,
    and is close to it when nearly so: a rate against DOFs flatter than −(rate in h)/2
    then says that the DOFs grow faster than h⁻² over the series."""
    rows = []
    for (s, fam), g in df[df.family.isin(["graded", "graded-sr"])].groupby(["s", "family"]):
        g = g.sort_values("dofs")
        h = np.array([ff.parse_series_tag(t)[1] for t in g.tag], dtype=float)
        rows.append({"s": s, "family": fam, "runs": len(g), "h": f"{h.max():g} … {h.min():g}",
                     "rate": fit_rate(g.dofs, g.error),
                     "rate in h": fit_rate(h, g.error),      # log-log slopes against h
                     "dofs ~ h^p": fit_rate(h, g.dofs)})
    return pd.DataFrame(rows)


def main(table, time_png, orders_png, errors_md):
    df = pd.read_csv(table)
    cols = ["s", "family", "dofs", "error", "eta", "efficiency", "t_assembly", "t_solve",
            "t_total", "t_cumulative", "peak_mem_mb"]
    summary = df[cols].sort_values(["s", "family", "dofs"]).reset_index(drop=True)
    summary.insert(4, "local slope", local_slopes(summary.dofs, summary.error,
                                                  (summary.s, summary.family)).to_numpy())
    with atomic_path(errors_md) as tmp:
        tmp.write_text(summary.to_markdown(index=False, floatfmt=".4g") + "\n\n"
                       "The graded families against their mesh size h (the tags' h): "
                       "`rate` against DOFs as in the rate table, `rate in h`, and the "
                       "exponent p of the DOFs in h:\n\n"
                       + h_rates(df).to_markdown(index=False, floatfmt=(
                           ".4g", ".4g", ".4g", ".4g", ".3f", ".3f", ".3f")) + "\n")
    colours = {s: f"C{i}" for i, s in enumerate(sorted(df.s.unique()))}
    dashes = {"uniform": "--", "graded": "-", "graded-sr": "-.", "adaptive": ":"}
    fig, ax = plt.subplots(figsize=(5.5, 4))
    for (s, fam), g in df.groupby(["s", "family"]):
        g = g.sort_values("dofs")
        # adaptive: the cumulative time of all steps up to this one
        t = g.t_cumulative if fam == "adaptive" else g.t_total
        ax.loglog(t, g.error, marker=MARKERS[fam], color=colours[s], ls=dashes[fam],
                  label=f"$s = {s:g}$, {FAMILY_LABELS[fam]}")
    ax.set_xlabel(WALL_TIME + ": mesh + assembly + solve (adaptive: all steps so far)")
    ax.set_ylabel(ERROR_LABELS["elliptic"])
    ax.set_title("Example 1: error against run time")
    plain_log_ticks(ax.xaxis)
    legend_below(ax, ncols=2)      # inside, it covers the curves
    save(fig, time_png)

    fig, ax = plt.subplots(figsize=(5.5, 4))
    for (s, fam), g in df.groupby(["s", "family"]):
        g = g.sort_values("dofs")
        ax.loglog(g.dofs, g.error, marker=MARKERS[fam], color=colours[s], ls=dashes[fam],
                  label=f"$s = {s:g}$, {FAMILY_LABELS[fam]}: {fit_rate(g.dofs, g.error):.3f}")
    ax.set_xlabel(DOFS)
    ax.set_ylabel(ERROR_LABELS["elliptic"])
    ax.set_title("Example 1 for several $s$ (fitted rates)")
    legend_below(ax, ncols=2)      # inside, it covers the curves
    save(fig, orders_png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.table, snakemake.output.time, snakemake.output.orders,  # noqa: F821
         snakemake.output.errors)  # noqa: F821
