"""The own error of a parabolic problem's reference run, measured from the two coarser
runs of its family (same grading and τ factor): u₁ (coarsest), u₂, u₃ = the reference.

d₁₂ = ‖u₁ − u₂‖ in the a-norm of u₂'s mesh and d₂₃ = ‖u₂ − u₃‖ in that of the
reference (L²(0,T; H^s), fracfem.transfer.SpaceTimeReference); with r = d₂₃/d₁₂, a
series converging geometrically with that ratio has ‖u₃ − u‖ = d₂₃ r/(1 − r).  The
manufactured-solution check (para_reference_check) measures this estimate against an
exact error.  One row: the distances, the estimate and the reference's size, time and
memory (para_errors copies it into every row of its table)."""

import pandas as pd

import fracfem as ff
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import reference_family_error
from fracfem_workflow.runs import parabolic_pieces, start, stored_reference

logger = script_logger("para_reference_error")


def main(ref, ref_row, coarser, quadrature, csv, log=None, threads=None, ref_operator=None):
    """ref, ref_row: the reference run and its row; coarser: its family's coarser runs
    (coarsest first; the last two measure its error); ref_operator: the reference's operator saved by
    para_reference_operator (None: assembled here)."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    reference, s = stored_reference(ref, quad, ref_operator)
    u1, _ = parabolic_pieces(coarser[-2])
    u2, _ = parabolic_pieces(coarser[-1])
    disc2 = ff.discretise(u2[0][2], s, 0.0, quadrature=quad, operator="auto")
    fam = reference_family_error(u1, (u2, disc2.A, disc2.free), reference)
    logger.info("reference family: d12 = %.4e, d23 = %.4e, ratio %.3f: reference error "
                "%.4e", fam["d12"], fam["d23"], fam["ratio"], fam["error"])
    row = pd.read_csv(ref_row).iloc[0]
    n_free, n_steps = len(reference.free), len(reference.values)
    info = {"reference_spacetime_dofs": n_free * n_steps,
            "reference_dofs": n_free, "reference_steps": n_steps,
            **{f"reference_{k}": v for k, v in fam.items()},
            "reference_t_wall": row.t_wall, "reference_peak_mem_mb": row.peak_mem_mb,
            "reference_operator": row.operator_used}
    write_table(pd.DataFrame([info]), csv)


if __name__ == "__main__":
    main(snakemake.input.ref, snakemake.input.ref_row,  # noqa: F821
         list(snakemake.input.coarser), snakemake.params.quadrature,  # noqa: F821
         snakemake.output.csv, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.input.operator)  # noqa: F821
