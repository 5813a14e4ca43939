"""Errors of Examples 4, 5 in L²(0,T; H^s): ‖I u_hτ − u_ref‖ against the reference run,
with the reference's own error (para_reference_error) in every row.

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
from fracfem_workflow.runs import parabolic_pieces, start, stored_reference

logger = script_logger("para_errors")


def main(rows, npzs, ref, ref_error, adaptive, quadrature, csv, log=None,
         threads=None, ref_operator=None):
    """rows, npzs: the uniform and graded runs (same order); ref: the reference run;
    ref_error: its own error (para_reference_error's row); adaptive: Algorithm C's table
    (its errors are computed there)."""
    start(log, threads)
    reference, _ = stored_reference(ref, ff.QuadratureOptions(**quadrature), ref_operator)
    info = pd.read_csv(ref_error).iloc[0].to_dict()
    df = pd.concat([pd.read_csv(r) for r in rows], ignore_index=True)
    errors = {}
    for i, npz in enumerate(npzs):
        run, _ = parabolic_pieces(npz)
        errors[npz] = reference.distance(run)
        logger.info("run %d/%d, %s: error %.6e", i + 1, len(npzs), npz, errors[npz])
    df["error"] = [errors[n] for n in npzs]
    df = pd.concat([df, pd.read_csv(adaptive)], ignore_index=True).assign(**info)
    if not np.all(np.isfinite(df.error)):
        raise RuntimeError("a parabolic error is not finite")
    write_table(df, csv)


if __name__ == "__main__":
    main(list(snakemake.input.rows), list(snakemake.input.npz),  # noqa: F821
         snakemake.input.ref, snakemake.input.ref_error,  # noqa: F821
         snakemake.input.adaptive, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.csv, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.input.operator)  # noqa: F821
