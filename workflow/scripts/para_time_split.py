"""How much of Algorithm C's error is the time discretisation's: each pass solved again on
its own space-time mesh with m times the time steps of every slab, the space meshes kept
(fracfem.solve_slabs); and the same for the graded series, each run solved again on its
mesh with m times its uniform time steps.  One change (τ → τ/m): what the error loses is
the time steps' part; what remains is the space meshes' part plus τ/m's own.  Like every
error here, it is the distance to the limit of the reference's family with its measured
uncertainty, which the fits' 3× rule keeps in view (runs.family_error).
"""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.meshes import mesh_size
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import (fit_mask, local_slopes, masked_rate, paper_rate,
                                     whole_numbers, with_fit_bound)
from fracfem_workflow.runs import (family_error, parameter_columns, solved_pieces, start,
                                   stored_family)

logger = script_logger("para_time_split")
# the re-solves' own cache, beside Algorithm C's (which keeps its default)
CACHE_BYTES = "1G"
# a graded run solved again agrees with its stored self to round-off
# (test_solved_pieces_reproduce_a_run_stored_by_para_solve), and so does its error measured
# against the same reference family; against another family it differs far more
RTOL_SAME_FAMILY = 1e-6


def main(problem, example, data, T, theta, start_level, c_tau, max_spacetime_dofs,
         max_iterations, refinements, tol, quadrature, ref, errors, csv, md, log=None,
         threads=None, operator="dense", ref_operator=None, coarser=(), family=None,
         graded_h=(), grading=2.0, graded_tau_factor=0.5):
    """refinements: the factors m (1 is always included: the pass itself); graded_h,
    grading, graded_tau_factor: the graded series, solved again on its meshes with m× its
    time steps (none: graded_h empty); ref: the reference run, coarser: the coarser runs of
    its family (family: para_reference_family's file of them, read instead of built);
    errors: the problem's errors table (its graded runs, whose errors the re-solves with
    their own time steps must reproduce, and the reference run's own error, where an
    error's uncertainty is not measured);
    ref_operator: the reference's operator saved by para_reference_operator (None:
    assembled here)."""
    start(log, threads)
    refinements = sorted({int(m) for m in refinements} | {1})
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    known = pd.read_csv(errors)
    ref_error = float((known.reference_run_error if "reference_run_error" in known
                       else known.reference_error).max())
    reference, s = stored_family(ref, list(coarser), quad, ref_operator, family)

    def make(coarse, operator=operator):
        return ex.problem(coarse, quad, operator=operator)

    # first, as it may refuse the errors table: cheap beside Algorithm C's passes
    graded = graded_series(make, ex, known, graded_h, grading, graded_tau_factor, T,
                           refinements, tol, reference, problem)

    rows = []

    def record(rec):
        for m in refinements:
            t0 = time.perf_counter()
            run = rec if m == 1 else ff.solve_slabs(
                make, rec.slabs, ex.initial_value, T=T, time_refinement=m, solver="pdas",
                solver_options={"tol": tol}, iteration=rec.iteration,
                cache_bytes=CACHE_BYTES)
            t_solve = time.perf_counter() - t0
            measured = family_error(reference, run.pieces)
            err = measured["error"]
            rows.append({"problem": problem, "pass": rec.iteration, "m": m,
                         "pass_spacetime_dofs": rec.dofs, "spacetime_dofs": run.dofs,
                         "steps": int(sum(sl.n_steps for sl in run.slabs)),
                         "dofs": max(sl.n_free for sl in run.slabs), **measured,
                         "eta": run.eta, "eta2_time": run.eta_parts["time"],
                         "t_resolve": t_solve if m > 1 else rec.timings.get("total", np.nan)})
            logger.info("pass %d, m = %d: %d space-time DOFs, error %.4e, eta %.4e",
                        rec.iteration, m, run.dofs, err, run.eta)
            run.pieces = None
        rec.pieces = None
        return rec.dofs >= max_spacetime_dofs

    ff.algorithm_c(make, ff.disk_uniform(start_level), ex.initial_value, T=T, theta=theta,
                   iterations=max_iterations, c_tau=c_tau, marking="maximum", solver="pdas",
                   callback=record, keep_steps=True, solver_options={"tol": tol})
    df = pd.DataFrame(rows)
    df = with_fit_bound(df.assign(reference_error=ref_error))
    graded = with_fit_bound(graded.assign(reference_error=ref_error)) if len(graded) \
        else graded
    write_table(with_provenance(pd.concat(
        [df.assign(series="adaptive"), graded.assign(series="graded")],
        ignore_index=True).assign(**parameter_columns(
            quadrature=quad, T=T, theta=theta, c_tau=c_tau, start_level=start_level,
            solver="pdas", tol=tol, operator=operator, refinements=refinements,
            grading=grading, data=data))), csv)
    variant = problem[4:] if example == "ex4" else ""
    paper = paper_rate(int(example[2:]), "adaptive", s, variant)
    with atomic_path(md) as tmp:
        per_run = bool(df.error_uncertainty.notna().any())
        tmp.write_text(report(df, None if per_run else ref_error, refinements, paper,
                              graded, paper_rate(int(example[2:]), "graded", s, variant)))


def graded_series(make, ex, known, graded_h, grading, tau_factor, T, refinements, tol,
                  reference, problem):
    """The graded runs of errors.csv solved again on their meshes with m times their time
    steps, measured against the reference's family (runs.family_error); m = 1 must give
    the table's own errors (same_family)."""
    rows = []
    runs = known[known.family == "graded"] if "family" in known else known.iloc[:0]
    for h in graded_h:
        tag = ff.series_tag("graded", h)
        row = runs[runs.tag == tag]
        if row.empty:
            raise ValueError(f"graded_h={list(graded_h)!r}: the errors table has no graded "
                             f"run {tag} (it has {sorted(runs.tag)})")
        row = row.iloc[0]
        # with the run's own operator (para_solve's), which the check below needs
        prob = make(ff.multiplier_mesh(tag, grading), operator=str(row.get("operator",
                                                                           "dense")))
        n = len(ff.time_grid(T=T, tau=ff.time_step(mesh_size(prob.fine), prob.disc.s,
                                                     tau_factor))) - 1
        if n != int(row.steps) or len(prob.disc.free) != int(row.dofs):
            raise ValueError(f"graded run {tag}: {int(row.dofs)} DOFs × {int(row.steps)} "
                             f"steps in the errors table, {len(prob.disc.free)} × {n} with "
                             f"grading={grading:g}, tau_factor={tau_factor:g}")
        for m in refinements:
            t0 = time.perf_counter()
            times = np.linspace(0.0, T, n * m + 1)
            measured = family_error(reference, solved_pieces(prob, ex.initial_value, times,
                                                             tol))
            if m == 1:
                same_family(measured, row, tag)
            rows.append({"problem": problem, "tag": tag, "m": m, "tau_factor": tau_factor,
                         "spacetime_dofs": int(row.dofs) * n * m, "steps": n * m,
                         "dofs": int(row.dofs), **measured,
                         "t_resolve": time.perf_counter() - t0})
            logger.info("graded %s, m = %d: %d steps, error %.4e", tag, m, n * m,
                        measured["error"])
    return pd.DataFrame(rows)


def same_family(measured, row, tag, rtol=RTOL_SAME_FAMILY):
    """Refuse a graded run whose error, solved again and measured against this job's
    reference family, is not the errors table's: that table (a kept copy, made where it was
    measured) was measured against another family, and the page would compare its runs
    with re-solves measured against this one."""
    for key in ("error", "error_uncertainty", "error_vs_reference"):
        if key in row and not np.isclose(measured[key], float(row[key]), rtol=rtol,
                                         atol=0.0, equal_nan=True):
            raise ValueError(
                f"graded run {tag}: {key} {measured[key]:.10g} against this job's reference "
                f"family, {float(row[key]):.10g} in the errors table (relative tolerance "
                f"{rtol:g}): the table was measured against another family (other code, "
                "settings or runs); rebuild the table or its family")


def _split(df, key, refinements, ref_error, itself="as the run", fitted="fitted tag"):
    """(fits, table) of one series solved with m× the time steps: per run (``key``, in
    the order of its own space-time DOFs) the error with τ and with τ/m, local slopes
    against the run's own space-time DOFs, and the rate of each m over the runs whose error
    exceeds 3× the reference's own error (ref_error; None: each error's own bound, the
    column ``reference_error``); itself, fitted: the labels of m = 1 and of the fitted runs."""
    own = df[df.m == 1].set_index(key).sort_values("spacetime_dofs")
    order = own.index
    wide = df.pivot(index=key, columns="m", values="error").loc[order]
    bound = (df.pivot(index=key, columns="m", values="reference_error").loc[order]
             if ref_error is None else None)
    out = own[["spacetime_dofs", "steps", "dofs"]].astype(int)
    rates = []
    for m in refinements:
        e = wide[m]
        out[f"error (τ/{m})" if m > 1 else "error"] = e
        out[f"local slope (τ/{m})" if m > 1 else "local slope"] = local_slopes(
            out.spacetime_dofs, e, np.zeros(len(e))).to_numpy()
        keep = fit_mask(e, ref_error if bound is None else bound[m])
        rates.append({"time steps": itself if m == 1 else f"{m}× (τ/{m})",
                      "rate": masked_rate(out.spacetime_dofs, e, keep),
                      "n_points": int(keep.sum()), fitted: ", ".join(
                          str(p) for p in np.asarray(e.index)[keep])})
    m_max = max(refinements)
    if m_max > 1:
        out[f"1 − (e(τ/{m_max})/e)²"] = 1 - (wide[m_max] / wide[1]) ** 2
    return pd.DataFrame(rates), out.reset_index()


def report(df, ref_error, refinements, paper=None, graded=None, paper_graded=None) -> str:
    """The Markdown page: Algorithm C's passes (df) and, if given, the graded series
    (graded: rows with ``tag``) each with τ and with τ/m (:func:`_split`); ref_error: the
    reference's own error bounding every fit (None: each error's own uncertainty, the
    column ``reference_error``); paper, paper_graded: the paper's adaptive and graded
    rates."""
    fits, out = _split(df, "pass", refinements, ref_error, "as the pass", "fitted passes")
    head = ("Algorithm C's passes solved again on their own space-time meshes with m times "
            "the time steps of every slab (the space meshes unchanged), "
            + (f"errors against the reference (its own error {ref_error:.3g}); rates against "
               "the pass's space-time DOFs over the passes whose error exceeds 3× the "
               "reference's" if ref_error is not None else
               "errors: the distance to the limit of the reference's family "
               "(extrapolated); rates against the pass's space-time DOFs over the passes "
               "whose error exceeds 3× its measured uncertainty"))
    if paper is not None:
        head += f"; the paper's adaptive rate is {paper:g}"
    text = (head + ".\n\n" + fits.to_markdown(index=False, floatfmt=".3f")
            + "\n\n" + whole_numbers(out).to_markdown(index=False, floatfmt=".4g") + "\n")
    if graded is not None and len(graded):
        gfits, gout = _split(graded, "tag", refinements, ref_error)
        text += ("\nThe graded series solved again on the same meshes with m times its time "
                 "steps (τ = " + f"{graded.tau_factor.iloc[0]:g}" + " h_max^(2s) as the run), "
                 "measured and fitted alike, rates against the run's own space-time DOFs"
                 + (f"; the paper's graded rate is {paper_graded:g}"
                    if paper_graded is not None and np.isfinite(paper_graded) else "")
                 + ".\n\n" + gfits.to_markdown(index=False, floatfmt=".3f") + "\n\n"
                 + whole_numbers(gout).to_markdown(index=False, floatfmt=".4g") + "\n")
    return text


if __name__ == "__main__":
    sm = snakemake  # noqa: F821
    main(sm.wildcards.problem, sm.params.example, sm.params.data, sm.params.T,
         sm.params.theta, sm.params.start_level, sm.params.c_tau,
         sm.params.max_spacetime_dofs, sm.params.max_iterations, sm.params.refinements,
         sm.params.tol, sm.params.quadrature, sm.input.ref, sm.input.errors, sm.output.csv,
         sm.output.md, sm.log[0], sm.threads, sm.params.operator, sm.input.operator,
         list(sm.input.coarser), sm.input.get("family"), sm.params.graded_h,
         sm.params.grading, sm.params.graded_tau_factor)
