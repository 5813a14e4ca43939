"""Errors of Examples 4, 5 in L²(0,T; H^s): the distance of each run to the limit of the
reference's family, extrapolated from ‖I u_hτ − u_k‖ to its members u_k (the reference run
and its coarser runs), with its measured uncertainty, the distance to the reference run
alone and the reference's own error (para_reference_error) in every row
(runs.family_error, report.with_fit_bound).

I is nodal interpolation onto the reference's fine mesh (zero outside a run's
polygon); both functions are piecewise constant in time, the time integral is
exact on the union of the two time grids (fracfem.transfer.SpaceTimeReference);
the norm is the a-norm of the reference mesh.
"""

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import with_fit_bound
from fracfem_workflow.runs import family_error, parabolic_pieces, start, stored_family

logger = script_logger("para_errors")


def main(rows, npzs, ref, ref_error, adaptive, quadrature, csv, log=None,
         threads=None, ref_operator=None, coarser=(), family=None):
    """rows, npzs: the uniform and graded runs (same order); ref: the reference run;
    ref_error: its own error (para_reference_error's row); adaptive: Algorithm C's table
    (its errors are computed there); coarser: the coarser runs of the reference's family;
    family: para_reference_family's file of them (read instead of built)."""
    start(log, threads)
    family, _ = stored_family(ref, list(coarser), ff.QuadratureOptions(**quadrature),
                              ref_operator, family)
    info = pd.read_csv(ref_error).iloc[0].to_dict()
    df = pd.concat([pd.read_csv(r) for r in rows], ignore_index=True)
    errors = {}
    for i, npz in enumerate(npzs):
        run, _ = parabolic_pieces(npz)
        errors[npz] = family_error(family, run)
        logger.info("run %d/%d, %s: error %.6e ± %.2e (against the reference run %.6e)",
                    i + 1, len(npzs), npz, errors[npz]["error"],
                    errors[npz]["error_uncertainty"], errors[npz]["error_vs_reference"])
    for col in ("error", "error_uncertainty", "error_vs_reference"):
        df[col] = [errors[n][col] for n in npzs]
    df = with_fit_bound(pd.concat([df, pd.read_csv(adaptive)], ignore_index=True)
                        .assign(**info))
    if not np.all(np.isfinite(df.error_vs_reference)):
        raise RuntimeError("a parabolic error is not finite")
    if not np.all(np.isfinite(df.error)):       # e² ≤ 0 at the limit: not in any fit
        logger.warning("no extrapolated error for %s",
                       ", ".join(f"{f} {t}" for f, t in zip(df.family[~np.isfinite(df.error)],
                                                            df.tag[~np.isfinite(df.error)])))
    write_table(df, csv)


if __name__ == "__main__":
    main(list(snakemake.input.rows), list(snakemake.input.npz),  # noqa: F821
         snakemake.input.ref, snakemake.input.ref_error,  # noqa: F821
         snakemake.input.adaptive, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.csv, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.input.operator, list(snakemake.input.coarser),  # noqa: F821
         snakemake.input.get("family"))  # noqa: F821
