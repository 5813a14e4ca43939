"""Algorithm C's passes of one parabolic problem from its own run and its reference's
measured error alone, without the uniform and graded series of Figures 13 and 15: a table
of every pass (estimator, error, efficiency index, local slopes, time, memory) and the
error and η against space-time DOFs and against wall time."""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger
from fracfem_workflow.plotstyle import (ERROR_LABELS, SPACETIME_DOFS, legend_below,
                                        para_error_panel, plt, problem_title, save)
from fracfem_workflow.report import (REFERENCE_MARGIN, algorithm_c_table, fit_mask,
                                     local_slopes, markdown_table, with_fit_bound)

logger = script_logger("para_passes")

REFERENCE = ["reference_spacetime_dofs", "reference_d12", "reference_d23", "reference_ratio",
             "reference_error"]


def passes(iterations, reference):
    """Algorithm C's passes (para_adaptive's table) with the reference's own error
    (para_reference_error's row) beside each."""
    d = pd.read_csv(iterations)
    ref = pd.read_csv(reference).iloc[0]
    missing = sorted({"family", "tag", "spacetime_dofs", "error", "eta"} - set(d.columns))
    families = sorted(set(d.get("family", ())))
    if missing or len(d) == 0 or families != ["adaptive"]:
        raise ValueError(f"{iterations}: not a table of Algorithm C's passes "
                         f"(missing columns {missing}, families {families})")
    d = d.sort_values("spacetime_dofs", ignore_index=True)
    return with_fit_bound(d.assign(**{c: ref[c] for c in REFERENCE}))


def pass_table(d):
    """One row per pass: its size, η, error, efficiency index, margin over the reference's
    own error and whether a rate is fitted through it, the local slopes of the error and of
    η, its own time and that of all passes so far, the time its error measurement took, and
    the job's peak memory so far."""
    slope = lambda y: local_slopes(d.spacetime_dofs, y, d.problem).to_numpy()  # noqa: E731
    table = pd.DataFrame({
        "pass": d.tag.str.removeprefix("it").astype(int), "slabs": d.slabs,
        "steps": d.steps, "dofs": d.dofs, "spacetime_dofs": d.spacetime_dofs,
        "eta": d.eta, "error": d.error, "reference_error": d.reference_error,
        "efficiency": d.eta / d.error,
        "error / reference_error": d.error / d.reference_error,
        "in fit": np.where(fit_mask(d.error, d.reference_error), "yes", "no"),
        "local slope": slope(d.error), "local slope η": slope(d.eta)})
    if "error_vs_reference" in d:
        table.insert(7, "error_vs_reference", d.error_vs_reference)
    for col in ("t_total", "t_wall"):
        if col in d:
            table[col] = d[col]
    if "t_error_measurement" in d:      # para_adaptive: all passes' measurements so far
        table["t_error_pass"] = d.t_error_measurement.diff().fillna(d.t_error_measurement)
    if "peak_mem_mb" in d:
        table["peak_mem_mb"] = d.peak_mem_mb
    return table


# seconds to a tenth and megabytes whole: ".4g" would print a time past 10^4 s (a paper-scale
# pass) in exponent form, 1.031e+04
FIXED_COLUMNS = {"t_total": ".1f", "t_wall": ".1f", "t_error_pass": ".1f", "peak_mem_mb": ".0f"}
COUNTS = ("slabs", "steps", "dofs", "spacetime_dofs")


def pass_table_markdown(table):
    """The pass table as the page prints it: the counts whole, the times and the memory in
    fixed notation (FIXED_COLUMNS), the rest to four significant digits."""
    return markdown_table(table, COUNTS, FIXED_COLUMNS)


def figure(d, png):
    """Error and η of every pass against space-time DOFs (with the rates fitted as in
    Figure 13/15) and against the wall time of all passes so far."""
    fig, axes = plt.subplots(1, 2, figsize=(11.0, 4.4), sharey=True)
    for ax, x, label in ((axes[0], "spacetime_dofs", SPACETIME_DOFS),
                         (axes[1], "t_wall", "wall time of all passes so far [s]")):
        para_error_panel(ax, d, x)
        ax.set_xlabel(label)
        legend_below(ax)
    axes[0].set_ylabel(ERROR_LABELS["parabolic"])
    fig.suptitle(f"Algorithm C, {problem_title(d.problem.iloc[0])}, $s = {d.s.iloc[0]:g}$")
    save(fig, png)


def page(d):
    ref = d.iloc[0]
    if "error_vs_reference" in d and d.error_uncertainty.notna().any():
        how = ("Algorithm C pass by pass: `error` is the distance to the limit of the "
               "reference's family, extrapolated from the distances to its runs "
               f"(the finest: {int(ref.reference_spacetime_dofs):,} space-time DOFs; "
               "fracfem.transfer.extrapolated_distance); `reference_error` is its measured "
               "uncertainty, the change from the extrapolation through the family's coarser "
               "runs; `error_vs_reference` is the distance to the finest run alone, whose own "
               f"error {ref.reference_run_error:.4g} is measured from its family's two "
               f"coarser runs (d12 = {ref.reference_d12:.4g}, d23 = "
               f"{ref.reference_d23:.4g}, r = {ref.reference_ratio:.3g}). A pass enters a "
               f"rate fit only if its error exceeds {REFERENCE_MARGIN:g}× its uncertainty "
               "(`in fit`).")
    else:
        how = ("Algorithm C pass by pass: error measured against the reference run "
               f"({int(ref.reference_spacetime_dofs):,} space-time DOFs), whose own error "
               f"{ref.reference_run_error:.4g} is measured from its family's two coarser "
               f"runs (d12 = {ref.reference_d12:.4g}, d23 = {ref.reference_d23:.4g}, "
               f"r = {ref.reference_ratio:.3g}). A pass enters a rate fit only if its "
               f"error exceeds {REFERENCE_MARGIN:g}× that (`in fit`); at or below that "
               "bound the measured error is as much the reference's as the pass's, and its "
               "local slope says nothing.")
    return (how + "\n\n"
            + pass_table_markdown(pass_table(d))
            + "\n\nRates over the passes in the fit (η's also over all passes), and the "
            "efficiency index η/error of every pass:\n\n"
            + algorithm_c_table(d).to_markdown(index=False, floatfmt=".3g") + "\n")


def main(iterations, reference, md, png):
    d = passes(iterations, reference)
    figure(d, png)
    with atomic_path(md) as tmp:
        tmp.write_text(page(d))
    logger.info("%s: %d passes to %d space-time DOFs", md, len(d), d.spacetime_dofs.max())


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.table, snakemake.input.ref_error,  # noqa: F821
         snakemake.output.md, snakemake.output.png)  # noqa: F821
