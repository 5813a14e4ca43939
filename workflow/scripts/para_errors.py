"""Errors of Examples 4, 5 in L²(0,T; H^s): ‖I u_hτ − u_ref‖ against the reference run,
and the reference's own error, measured.

I is nodal interpolation onto the reference's fine mesh (zero outside a run's
polygon); both functions are piecewise constant in time, the time integral is
exact on the union of the two time grids (fracfem.transfer.SpaceTimeReference);
the norm is the a-norm of the reference mesh.

The reference's error: its family (same grading and τ factor) at two coarser h,
u₁ (coarsest), u₂, u₃ = the reference.  With d₁₂ = ‖u₁ − u₂‖ (a-norm of u₂'s
mesh) and d₂₃ = ‖u₂ − u₃‖ and the ratio r = d₂₃/d₁₂ of consecutive distances,
a series converging geometrically with that ratio has ‖u₃ − u‖ = d₂₃ r/(1 − r).
The manufactured-solution check (para_reference_check) measures this estimate
against an exact error.
"""

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import reference_family_error
from fracfem_workflow.runs import parabolic_pieces, start, stored_reference

logger = script_logger("para_errors")


def reference_error(ref, coarser, quadrature, ref_operator=None):
    """(SpaceTimeReference of the reference run, its info: the measured error and the
    distances behind it); coarser: the family's two coarser runs; ref_operator: the
    reference's operator saved by para_reference_operator (None: assembled here)."""
    quad = ff.QuadratureOptions(**quadrature)
    reference, s = stored_reference(ref, quad, ref_operator)
    u1, _ = parabolic_pieces(coarser[0])
    u2, _ = parabolic_pieces(coarser[1])
    disc2 = ff.discretise(u2[0][2], s, 0.0, quadrature=quad, operator="auto")
    fam = reference_family_error(u1, (u2, disc2.A, disc2.free), reference)
    logger.info("reference family: d12 = %.4e, d23 = %.4e, ratio %.3f: reference error "
                "%.4e", fam["d12"], fam["d23"], fam["ratio"], fam["error"])
    n_free, n_steps = len(reference.free), len(reference.values)
    info = {"reference_spacetime_dofs": n_free * n_steps,
            "reference_dofs": n_free, "reference_steps": n_steps,
            **{f"reference_{k}": v for k, v in fam.items()}}
    return reference, info


def main(rows, npzs, ref, ref_row, coarser, adaptive, quadrature, csv, log=None,
         threads=None, ref_operator=None):
    """rows, npzs: the uniform and graded runs (same order); ref, ref_row: the reference
    run and its row; coarser: its family's two coarser runs (coarsest first); adaptive:
    Algorithm C's table (its errors are computed there)."""
    start(log, threads)
    reference, info = reference_error(ref, coarser, quadrature, ref_operator)
    row = pd.read_csv(ref_row).iloc[0]
    info.update(reference_t_wall=row.t_wall, reference_peak_mem_mb=row.peak_mem_mb,
                reference_operator=row.operator_used)
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
         snakemake.input.ref, snakemake.input.ref_row,  # noqa: F821
         list(snakemake.input.coarser),  # noqa: F821
         snakemake.input.adaptive, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.csv, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.input.operator)  # noqa: F821
