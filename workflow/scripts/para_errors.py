"""Errors of Examples 4, 5 in L²(0,T; H^s): ‖I u_hτ − u_ref‖ against the reference run.

I is nodal interpolation onto the reference's fine mesh (zero outside a run's
polygon); both functions are piecewise constant in time, the time integral is
exact on the union of the two time grids (fracfem.transfer.space_time_distance);
the norm is the a-norm of the reference mesh.
"""

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.transfer import space_time_distance
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import fit_rate
from fracfem_workflow.runs import parabolic_pieces, start

logger = script_logger("para_errors")


def main(rows, npzs, ref, adaptive, quadrature, csv, log=None, threads=None):
    """rows, npzs: the uniform and graded runs (same order); ref: the reference run;
    adaptive: Algorithm C's table (its errors are computed there)."""
    start(log, threads)
    ref_pieces, d = parabolic_pieces(ref)
    s = float(d["s"])
    logger.info("reference solution %s: %d time steps on %d nodes; assembling its matrix",
                ref, len(ref_pieces), ref_pieces[0][2].p.shape[1])
    disc = ff.discretise(ref_pieces[0][2], s, 0.0, quadrature=ff.QuadratureOptions(**quadrature))
    df = pd.concat([pd.read_csv(r) for r in rows], ignore_index=True)
    errors = {}
    for i, npz in enumerate(npzs):
        run, _ = parabolic_pieces(npz)
        errors[npz] = space_time_distance(run, ref_pieces, disc.A, disc.free)
        logger.info("run %d/%d, %s: error %.6e", i + 1, len(npzs), npz, errors[npz])
    df["error"] = [errors[n] for n in npzs]
    df = pd.concat([df, pd.read_csv(adaptive)], ignore_index=True)
    ref_dofs = len(disc.free) * len(ref_pieces)
    # the reference's own error, extrapolated along the graded series' rate
    g = df[df.family == "graded"].sort_values("spacetime_dofs")
    rate = fit_rate(g.spacetime_dofs, g.error)
    df["reference_spacetime_dofs"] = ref_dofs
    df["reference_error_estimate"] = (g.error.iloc[-1]
                                      * (ref_dofs / g.spacetime_dofs.iloc[-1]) ** rate)
    df["reference_error"] = df["reference_error_estimate"]   # what the rate table's rule uses
    if not np.all(np.isfinite(df.error)):
        raise RuntimeError("a parabolic error is not finite")
    write_table(df, csv)


if __name__ == "__main__":
    main(list(snakemake.input.rows), list(snakemake.input.npz),  # noqa: F821
         snakemake.input.ref, snakemake.input.adaptive,  # noqa: F821
         snakemake.params.quadrature, snakemake.output.csv, snakemake.log[0],  # noqa: F821
         snakemake.threads)  # noqa: F821
