"""Algorithm C's passes measured against its own last pass, as the paper measures its
adaptive runs against its finest adaptive mesh, beside the same passes measured against
the limit of the reference's family (every other error here).  The same passes, fitted
alike: what changing the reference does to the fitted rate is the part of a rate that
comes from where the error is measured, not from the runs.

The last pass's space mesh changes from slab to slab: a pass is measured slab by slab,
interpolated onto that slab's mesh and in its a-norm (fracfem.transfer.SlabwiseReference),
as the paper would on its benchmark's mesh.  The family's distances are in the a-norm of
the reference run's mesh, so the page separates the steps: the family's finest run alone
(error_vs_reference), then the last pass interpolated onto that run's mesh and measured
there (error_vs_last_on_reference: only the function changes), then slab by slab.
"""
import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.transfer import SlabwiseReference, SpaceTimeReference, pieces_on
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import (fit_mask, local_slopes, masked_rate, paper_rate,
                                     whole_numbers, with_fit_bound)
from fracfem_workflow.runs import family_error, parameter_columns, start, stored_family

logger = script_logger("para_self_reference")


def main(problem, example, data, T, theta, start_level, c_tau, max_spacetime_dofs,
         max_iterations, tol, quadrature, ref, ref_error, csv, md, log=None, threads=None,
         operator="dense", ref_operator=None, coarser=(), family=None):
    """Algorithm C as para_adaptive (to the first pass with ``max_spacetime_dofs``), every
    pass kept; ref, coarser, family: the reference run and its family as para_adaptive's;
    ref_error: para_reference_error's row (the reference run's own error)."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    reference, s = stored_family(ref, list(coarser), quad, ref_operator, family)
    passes, rows = [], []

    def record(rec):
        rows.append({"problem": problem, "pass": rec.iteration, "spacetime_dofs": rec.dofs,
                     "slabs": len(rec.slabs), "eta": rec.eta,
                     **family_error(reference, rec.pieces)})
        logger.info("pass %d: %d space-time DOFs, error %.4e against the family",
                    rec.iteration, rec.dofs, rows[-1]["error"])
        passes.append(rec.pieces)
        rec.pieces = None
        return rec.dofs >= max_spacetime_dofs

    recs = ff.algorithm_c(
        lambda coarse: ex.problem(coarse, quad, operator=operator),
        ff.disk_uniform(start_level), ex.initial_value, T=T, theta=theta,
        iterations=max_iterations, c_tau=c_tau, marking="maximum", solver="pdas",
        callback=record, keep_steps=True, solver_options={"tol": tol})
    stop = recs[-1].stop
    if len(passes) < 3:
        raise ValueError(f"max_spacetime_dofs={max_spacetime_dofs!r} gives {len(passes)} "
                         f"passes (Algorithm C stopped: {stop}): a rate against the last "
                         "needs at least 3")
    if stop != "callback":
        logger.warning("Algorithm C stopped (%s) before a pass with %d space-time DOFs: "
                       "the last pass has %d", stop, max_spacetime_dofs, recs[-1].dofs)
    # the last pass on the family's finest mesh, in its a-norm: only the function changes
    on_ref = on_mesh_of(reference, passes[-1])
    d_on_ref = [on_ref.distance(pcs) for pcs in passes[:-1]]
    del reference, on_ref                  # its operator: not held beside the slabs' ones

    def slab_operator(mesh):          # a slab's fine mesh: its a-norm, as the reference's
        disc = ff.discretise(mesh, s, 0.0, quadrature=quad, operator="auto")
        return disc.A, np.asarray(disc.free)

    last = SlabwiseReference(passes[-1], slab_operator)
    d = last.distances(passes[:-1])
    logger.info("passes against the last (%d slabs measured): %s", len(last.slabs),
                ", ".join(f"{x:.4e}" for x in d))
    df = pd.DataFrame(rows)
    df["error_vs_last_on_reference"] = np.append(d_on_ref, np.nan)
    df["error_vs_last"] = np.append(d, np.nan)
    df = with_fit_bound(df.assign(**pd.read_csv(ref_error).iloc[0].to_dict()))
    variant = problem[4:] if example == "ex4" else ""
    text = report(df, paper_rate(int(example[2:]), "adaptive", s, variant))
    write_table(with_provenance(df.assign(**parameter_columns(
        quadrature=quad, T=T, theta=theta, c_tau=c_tau, start_level=start_level,
        solver="pdas", tol=tol, operator=operator, data=data))), csv)
    with atomic_path(md) as tmp:
        tmp.write_text(text)


def on_mesh_of(reference, pieces):
    """A SpaceTimeReference of ``pieces`` interpolated onto the mesh of ``reference`` (a
    ReferenceFamily: its finest member's; a SpaceTimeReference: its own), in its a-norm,
    as ReferenceFamily holds its coarser members."""
    fine = reference.references[-1] if hasattr(reference, "references") else reference
    return SpaceTimeReference(pieces_on(pieces, fine.mesh), fine.A, fine.free)


def report(df, paper):
    """The page: the rates of the passes before the last against each reference, one
    change from row to row, and the passes' errors."""
    before = df.iloc[:-1]
    N = before.spacetime_dofs.to_numpy(float)
    last = f"the last pass ({int(df.spacetime_dofs.iloc[-1]):,} space-time DOFs)"
    rows = [("the family's limit, passes above 3× their uncertainty", "error",
             fit_mask(before.error, before.reference_error)),
            ("the family's limit, every pass", "error", None),
            ("the family's finest run alone, on its mesh, every pass", "error_vs_reference",
             None),
            (f"{last}, on that run's mesh, every pass", "error_vs_last_on_reference", None),
            (f"{last}, slab by slab on its own meshes, every pass", "error_vs_last", None)]
    fits = []
    for label, column, keep in rows:
        values = before[column].to_numpy(float)
        keep = np.isfinite(values) & (True if keep is None else keep)
        fits.append({"measured against": label, "rate": masked_rate(N, values, keep),
                     "passes in the fit": ", ".join(str(int(p))
                                                    for p in before["pass"][keep])})
    table = df[["pass", "spacetime_dofs", "slabs", "error", "error_uncertainty",
                "error_vs_reference", "error_vs_last_on_reference", "error_vs_last"]].copy()
    one = np.zeros(len(df))
    table["local slope"] = local_slopes(df.spacetime_dofs, df.error, one).to_numpy()
    table["local slope (last)"] = local_slopes(df.spacetime_dofs, df.error_vs_last,
                                               one).to_numpy()
    return ("Algorithm C's passes before its last, measured against the limit of the "
            "reference's family (error ± error_uncertainty, as everywhere here) and against "
            "its own last pass, as the paper measures its adaptive runs against its finest "
            "adaptive mesh. From row to row one thing changes: the family's limit → its "
            "finest run (error_vs_reference) → the last pass on that run's mesh and in its "
            "a-norm (error_vs_last_on_reference: only the function) → the last pass slab by "
            "slab on its own meshes (error_vs_last: only the mesh and norm). Rates against the "
            f"passes' space-time DOFs; the paper's adaptive rate is {paper}.\n\n"
            + pd.DataFrame(fits).to_markdown(index=False, floatfmt=".3f") + "\n\n"
            + whole_numbers(table).to_markdown(index=False, floatfmt=".4g") + "\n")


if __name__ == "__main__":
    sm = snakemake  # noqa: F821
    main(sm.wildcards.problem, sm.params.example, sm.params.data, sm.params.T,
         sm.params.theta, sm.params.start_level, sm.params.c_tau,
         sm.params.max_spacetime_dofs, sm.params.max_iterations, sm.params.tol,
         sm.params.quadrature, sm.input.ref, sm.input.ref_error, sm.output.csv,
         sm.output.md, sm.log[0], sm.threads, sm.params.operator, sm.input.operator,
         list(sm.input.coarser), sm.input.get("family"))
