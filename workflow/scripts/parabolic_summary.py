"""Tables of every parabolic run, of the reference runs and of Algorithm C's passes, and
the error against wall time (Examples 4, 5)."""
from pathlib import Path

import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger
from fracfem_workflow.plotstyle import ERROR_LABELS, plt, problem_title, save, time_panel
from fracfem_workflow.report import algorithm_c_table, local_slopes

logger = script_logger("parabolic_summary")

# columns of para_errors' tables shown in the reference table, under these names
REFERENCE_COLUMNS = {"reference_operator": "operator used", "reference_dofs": "dofs",
                     "reference_steps": "steps", "reference_spacetime_dofs": "spacetime_dofs", "reference_t_wall": "t_wall",
                     "reference_peak_mem_mb": "peak_mem_mb", "reference_d12": "d12",
                     "reference_d23": "d23", "reference_ratio": "ratio r",
                     "reference_error": "reference_error"}


def reference_table(df):
    """One row per problem: the reference run, its measured error and the finest errors it
    judges (their ratio to it: the margin of the 3× rule)."""
    rows = []
    if "reference_run_error" in df:     # report.with_fit_bound: the reference run's own
        df = df.drop(columns="reference_error").rename(
            columns={"reference_run_error": "reference_error"})
    for prob, d in df.groupby("problem"):
        ref = d.iloc[0]
        finest = d.loc[d.groupby("family").spacetime_dofs.idxmax()].set_index("family")
        rows.append({"problem": prob, **{name: ref[c] for c, name in
                                         REFERENCE_COLUMNS.items()},
                     "reference / finest spacetime_dofs": ref.reference_spacetime_dofs
                     / d.spacetime_dofs.max(),
                     "finest adaptive error": finest.error.get("adaptive", np.nan),
                     "finest error / reference_error": d.error.min() / ref.reference_error})
    return pd.DataFrame(rows)


def larger_reference_table(paths):
    """One row per committed <problem>-reference-error.csv of a larger tier: its reference
    run and measured error, under the names of :func:`reference_table`."""
    rows = []
    for path in paths:
        ref = pd.read_csv(path).iloc[0]
        problem = Path(path).name.removesuffix("-reference-error.csv")
        rows.append({"problem": problem, **{name: ref[c] for c, name in
                                            REFERENCE_COLUMNS.items()}})
    return pd.DataFrame(rows)


def larger_reference_passes(df, paths):
    """Algorithm C's passes of this tier against its reference and against a larger tier's
    finer one (paths: <problem>-coarser-tier-errors.csv, para_errors_commit): the error and
    local slope of each pass by both.  A problem whose committed passes are not this run's
    (other tags or space-time DOFs) is left out."""
    rows = []
    for path in paths:
        problem = Path(path).name.removesuffix("-coarser-tier-errors.csv")
        ours = df[(df.problem == problem) & (df.family == "adaptive")].sort_values(
            "spacetime_dofs")
        theirs = pd.read_csv(path)
        theirs = theirs[theirs.family == "adaptive"].sort_values("spacetime_dofs")
        if (len(ours) != len(theirs) or list(ours.tag) != list(theirs.tag)
                or not np.array_equal(ours.spacetime_dofs.to_numpy(),
                                      theirs.spacetime_dofs.to_numpy())):
            logger.warning("%s: other passes than this run's %s; left out", path, problem)
            continue
        n = ours.spacetime_dofs.to_numpy(float)
        slope = lambda e: local_slopes(n, e, np.zeros(len(n))).to_numpy()  # noqa: E731
        e1, e2 = ours.error.to_numpy(float), theirs.error.to_numpy(float)
        rows += [{"problem": problem, "pass": int(tag.removeprefix("it")),
                  "spacetime_dofs": int(n[k]), "error": e1[k], "local slope": slope(e1)[k],
                  "error (larger reference)": e2[k],
                  "local slope (larger reference)": slope(e2)[k]}
                 for k, tag in enumerate(ours.tag)]
    return pd.DataFrame(rows)


def main(csvs, md, png, larger=(), larger_runs=()):
    """csvs: para_errors' tables; larger: the measured errors of finer references of the
    same families committed by a larger tier (larger_reference_table); larger_runs: this
    tier's runs measured against them (larger_reference_passes)."""
    df = pd.concat([pd.read_csv(c) for c in csvs], ignore_index=True)
    df["efficiency"] = df.eta / df.error
    cols = ["problem", "family", "tag", "dofs", "steps", "spacetime_dofs", "error", "eta",
            "efficiency", "first_contact", "t_wall", "peak_mem_mb"]
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
        tmp.write_text("Reference runs (`t_wall`, `peak_mem_mb` of the run itself) and their "
                       "measured error:\n\n"
                       + reference_table(df).to_markdown(index=False, floatfmt=".4g")
                       + ("" if not len(larger) else
                          "\n\nThe same families one level finer: the reference of the "
                          "paper-scale tier (committed, `parabolic.reference.larger`), its "
                          "error measured the same way. Its `d12` is this tier's `d23` again "
                          "(with that tier's quadrature), its `d23` the distance of this tier's "
                          "reference from it:\n\n"
                          + larger_reference_table(larger).to_markdown(index=False,
                                                                       floatfmt=".4g"))
                       + _larger_passes_section(df, larger_runs)
                       + "\n\nAlgorithm C: rates of the error and of the estimator η over the "
                       "passes whose error exceeds 3× `reference_error`, the same for each "
                       "part of η (η_part = √ of its share of η²), and the efficiency "
                       "index η/error of every pass; η_a is η with its time term "
                       "τ_k Σ_i h_i^{−2s}‖u^k − u^{k−1}‖²_{L²(S_i)} replaced by the energy "
                       "norm τ_k a(u^k − u^{k−1}, u^k − u^{k−1}) that it stands in for "
                       "(η_time,a its square root):\n\n"
                       + algorithm_c_table(df).to_markdown(index=False, floatfmt=".3g")
                       + "\n\nTime each family needs to reach the smallest error all of them "
                       "reach (wall time of the run; adaptive: all passes so far, without the "
                       "error measurement):\n\n"
                       + pd.DataFrame(fastest).to_markdown(index=False, floatfmt=".4g")
                       + "\n\nEvery run:\n\n"
                       + table.to_markdown(index=False, floatfmt=".4g") + "\n")


def _larger_passes_section(df, paths):
    table = larger_reference_passes(df, paths) if len(paths) else pd.DataFrame()
    if table.empty:
        return ""
    return ("\n\nAlgorithm C's passes of this tier measured against its reference and against "
            "that finer one (`config/ex4-paper-reference.yaml`: the same runs; only the "
            "reference and the quadrature differ):\n\n"
            + table.to_markdown(index=False, floatfmt=".4g"))


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.csv), snakemake.output.md, snakemake.output.png,  # noqa: F821
         list(snakemake.input.larger), list(snakemake.input.larger_runs))  # noqa: F821
