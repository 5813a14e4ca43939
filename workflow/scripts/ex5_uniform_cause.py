"""Why Example 5's uniform rate is steeper than the paper's: experiments that each change one
thing of Example 5.

The paper's uniform rates are those of the boundary layer, ‖u − u_hτ‖ ~ h^{1/2} with τ ~ h^{2s},
i.e. (space-time DOFs)^{−1/(4+4s)}.  The uniform series is measured against the limit of a
graded family made the same way for: Example 5 as it is; without friction (F = 0: the fractional heat equation
from the same u₀); and with u₀ = 1 instead of the ring (|x| − 1)(|x| − r₀), i.e. an initial
value that does not vanish on ∂Ω, as in Example 4.  Local slopes between consecutive runs
show whether a fitted rate is still pre-asymptotic.  Example 5's uniform runs solved again on
their meshes with m times their time steps (τ/m), measured against Example 5's family, say
how much of their error is the time discretisation's.

Example 5's own runs (its uniform series and the graded family) are the pipeline's
(rule para_solve), read from their files; the changed cases are solved here, each on
the operators assembled once per mesh for all of them (they change only F or u₀).
"""
import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.meshes import mesh_size
from fracfem.transfer import ReferenceFamily
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import (REFERENCE_MARGIN, error_interval, fit_mask, fit_rate,
                                     geometric_tail, local_slopes, masked_rate)
from fracfem_workflow.runs import (family_error, parabolic_pieces, parameter_columns,
                                   solved_pieces, start)

logger = script_logger("ex5_uniform_cause")


def run(ex, u0, tag, grading, T, tau_factor, tol, quad, operators):
    """(pieces [(t0, t1, mesh, u)], free-node operator, free nodes) of one DG(0) run;
    operators: {tag: disc} of the meshes assembled so far (reused, and filled)."""
    prob = ex.problem(ff.multiplier_mesh(tag, grading), quad, operator="auto",
                      stiffness=operators.get(tag))
    operators.setdefault(tag, prob.disc)
    times = ff.time_grid(T=T, tau=ff.time_step(mesh_size(prob.fine), prob.disc.s, tau_factor))
    return solved_pieces(prob, u0, times, tol), prob.disc.A, prob.disc.free


def stored(npz, tag, ex, grading, quad, operators):
    """run's result for a run of Example 5 made by the pipeline (para_solve's npz), with
    the operator of its mesh (assembled here once, for the changed cases too)."""
    pieces, d = parabolic_pieces(npz)
    if tag not in operators:
        operators[tag] = ex.problem(ff.multiplier_mesh(tag, grading), quad,
                                    operator="auto").disc
    disc = operators[tag]
    if disc.mesh.p.shape != pieces[0][2].p.shape or float(d["s"]) != disc.s:
        raise ValueError(f"{npz} is not the run {tag} of Example 5 with s = {disc.s:g}")
    return pieces, disc.A, disc.free


def main(data, changes, T, grading, uniform_levels, uniform_tau_factor, family_h,
         reference_tau_factor, tol, quadrature, md, csv, log=None, threads=None,
         family_runs=None, uniform_runs=None, time_refinements=()):
    """data: Example 5's parameters; changes: {name: {'F': …} or {'u0': …}}, each one change
    of Example 5.  Each case's uniform runs are measured against the limit of its graded
    family family_h (τ = reference_tau_factor h_max^{2s}; at least four runs): their
    distance to it extrapolated through the family (fracfem.transfer.ReferenceFamily) with
    its uncertainty, the bound of the rate fit (report.fit_mask), as for the pipeline's
    parabolic errors.  family_runs, uniform_runs: para_solve's npz files of Example 5's
    family and uniform series made with these settings, read instead of solved again
    (None: solved here).  time_refinements: distinct integers m in [2, 64]; each adds
    the case "Example 5, τ/m": its uniform runs on the same meshes with m times the time
    steps, against Example 5's family."""
    if (any(not (isinstance(m, int) and 2 <= m <= 64) for m in time_refinements)
            or len(set(time_refinements)) != len(time_refinements)):
        raise ValueError(f"time_refinements={list(time_refinements)!r} must be distinct "
                         "integers in [2, 64]")
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    tags = [ff.series_tag("uniform", lv) for lv in uniform_levels]
    family = [ff.series_tag("graded", h) for h in family_h]
    if len(family) < 3:
        raise ValueError(f"family_h={list(family_h)!r} must name at least three runs "
                         "(four to measure the extrapolation's uncertainty)")
    for name, files, want in (("family_runs", family_runs, family),
                              ("uniform_runs", uniform_runs, tags)):
        if files is not None and len(files) != len(want):
            raise ValueError(f"{name} has {len(files)} files; the runs {want} need one each")
    rows, refs, operators = [], [], {}
    for name, change in {"Example 5": {}, **changes}.items():
        ex = ff.example("ex5", **{**data, **{k: v for k, v in change.items() if k != "u0"}})
        u0 = change.get("u0", ex.initial_value)
        own = name == "Example 5"

        def solved(tag, tau_factor, files, i, ex=ex, u0=u0, own=own):
            if own and files is not None:
                return stored(files[i], tag, ex, grading, quad, operators)
            return run(ex, u0, tag, grading, T, tau_factor, tol, quad, operators)

        members = [solved(tag, reference_tau_factor, family_runs, i)
                   for i, tag in enumerate(family)]
        _, A, free = members[-1]
        fam = ReferenceFamily([m[0] for m in members], A, free)
        ratio, ref_err = geometric_tail(*fam.steps[-2:])
        refs.append({"case": name, "reference run": family[-1],
                     "consecutive distances": ", ".join(f"{d:.4g}" for d in fam.steps),
                     "ratio r": ratio, "reference_run_error": ref_err})
        logger.info("%s: family steps %s, reference run error %.4g (r = %.3f)", name,
                    fam.steps, ref_err, ratio)
        for i, tag in enumerate(tags):
            pieces, _, fr = solved(tag, uniform_tau_factor, uniform_runs, i)
            rows.append({"case": name, "tag": tag, "spacetime_dofs": len(fr) * len(pieces),
                         **family_error(fam, pieces), "reference_run_error": ref_err})
        if own:                          # the same runs with m× the time steps
            for m in time_refinements:
                for i, tag in enumerate(tags):
                    pieces, _, fr = run(ex, u0, tag, grading, T, uniform_tau_factor / m, tol,
                                        quad, operators)
                    rows.append({"case": f"Example 5, τ/{m}", "tag": tag,
                                 "spacetime_dofs": len(fr) * len(pieces),
                                 **family_error(fam, pieces), "reference_run_error": ref_err})
    df = pd.DataFrame(rows)
    df["local slope"] = local_slopes(df.spacetime_dofs, df.error, df.case).to_numpy()
    bound = df.error_uncertainty.where(df.error_uncertainty.notna(), df.reference_run_error)
    df["fitted"] = fit_mask(df.error, bound)
    summary = []
    for name, g in df.groupby("case", sort=False):
        summary.append({"case": name,
                        "rate": masked_rate(g.spacetime_dofs, g.error, g.fitted),
                        "n_points": int(g.fitted.sum()),
                        "rate_vs_reference": fit_rate(g.spacetime_dofs, g.error_vs_reference),
                        "last local slope": g["local slope"].iloc[-1],
                        "smallest_error": g.error.min(),
                        "largest uncertainty / error": (g.error_uncertainty / g.error).max()})
    share = [share_table(df, tags, m) for m in time_refinements]
    s = float(data["s"])
    write_table(with_provenance(df.assign(**parameter_columns(
        quadrature=quad, grading=grading, T=T, tau_factor=uniform_tau_factor, tol=tol,
        data=data, changes=changes, family_h=list(family_h),
        reference_tau_factor=reference_tau_factor))), csv)
    with atomic_path(md) as tmp:
        tmp.write_text(
            f"Example 5's uniform series (s = {s:g}) against the limit of a graded family "
            f"made the same way ({', '.join(family)}, τ = {reference_tau_factor:g} "
            "h_max^(2s)), for Example 5 and for one change of it at a time: "
            + "; ".join(changes)
            + "".join(f"; Example 5 with {m}× the time steps on the same meshes (τ/{m}), "
                      "against Example 5's family" for m in time_refinements)
            + ". The error is the distance to the family's limit (extrapolated), fitted "
            f"where it exceeds {REFERENCE_MARGIN:g}× its uncertainty; rate_vs_reference is "
            "the rate of the distances to the family's finest run alone. The rate of the "
            f"boundary layer, h^(1/2) with τ ~ h^(2s), is −1/(4 + 4s) = {-1 / (4 + 4 * s):.3f}."
            "\n\n"
            + pd.DataFrame(summary).to_markdown(index=False, floatfmt=".4g") + "\n\n"
            + pd.DataFrame(refs).to_markdown(index=False, floatfmt=".4g") + "\n\n"
            + ("How much of Example 5's uniform error is the time steps': its error as run "
               "and with m× the steps on the same meshes; 1 − (e(τ/m)/e)² is the time "
               "steps' share of the squared error, as far as m× the steps remove it; "
               "least share: its least value with both errors anywhere within their "
               "uncertainty (−inf: none, e − u ≤ 0 or an infinite uncertainty; nan: an "
               "uncertainty not measured).\n\n"
               + pd.concat(share, ignore_index=True).to_markdown(index=False,
                                                                 floatfmt=".4g") + "\n\n"
               if share else "")
            + df.drop(columns=["reference_run_error", "fitted"]).to_markdown(
                index=False, floatfmt=".4g")
            + "\n")


def share_table(df: pd.DataFrame, tags, m: int) -> pd.DataFrame:
    """The time steps' share of Example 5's squared error per uniform run (``tags``):
    1 − (e(τ/m)/e)² from the rows of the cases "Example 5" and "Example 5, τ/m" of ``df``,
    and its least value with both errors anywhere within their measured uncertainty
    (report.error_interval; the two measured against the same family, so their errors
    may move together: the least value is a safe one): 1 − ((e_m + u_m)/(e − u))²; −inf,
    no bound, where e − u ≤ 0 or u_m is infinite (the family bounds no finer error); NaN
    where either uncertainty is not measured."""
    base = df[df.case == "Example 5"].set_index("tag").loc[list(tags)]
    fine = df[df.case == f"Example 5, τ/{m}"].set_index("tag").loc[list(tags)]
    lo, _ = error_interval(base.error, base.error_uncertainty)
    _, hi = error_interval(fine.error, fine.error_uncertainty)
    with np.errstate(divide="ignore"):
        least = 1.0 - (hi / lo) ** 2
    return pd.DataFrame({"tag": list(tags), "m": m, "error": base.error.to_numpy(),
                         "error (τ/m)": fine.error.to_numpy(),
                         "1 − (e(τ/m)/e)²": 1.0 - (fine.error / base.error).to_numpy() ** 2,
                         "least share": least})


if __name__ == "__main__":
    main(snakemake.params.data, snakemake.params.changes, snakemake.params.T,  # noqa: F821
         snakemake.params.grading, snakemake.params.uniform_levels,  # noqa: F821
         snakemake.params.uniform_tau_factor, snakemake.params.family_h,  # noqa: F821
         snakemake.params.reference_tau_factor, snakemake.params.tol,  # noqa: F821
         snakemake.params.quadrature, snakemake.output.md, snakemake.output.csv,  # noqa: F821
         snakemake.log[0], snakemake.threads,  # noqa: F821
         list(snakemake.input.family), list(snakemake.input.uniform),  # noqa: F821
         list(snakemake.params.time_refinements))  # noqa: F821
