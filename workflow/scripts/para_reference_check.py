"""How much does a reference solution distort the parabolic rates?  The manufactured
heat solution u = e^{−t}(1−|x|²)^{1+s} on the meshes and time steps of Examples 4/5:
the exact L²(0,T; H^s) error next to the error measured against a reference run made
exactly like the examples' reference (fracfem.transfer.space_time_distance)."""

import pandas as pd

import fracfem as ff
from fracfem import exact, vi
from fracfem.meshes import mesh_size
from fracfem.transfer import space_time_distance
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import fit_rate
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("para_reference_check")


def run(mesh, s, T, tau_factor, quad):
    """Unconstrained DG(0) run of the manufactured solution with τ ≤ factor·h_max^{2s}."""
    disc = ff.discretise(mesh, s, 0.0, quadrature=quad)
    steps = ff.solve_parabolic(disc, lambda x: exact.bubble(x, s), T=T,
                               tau=ff.time_step(mesh_size(mesh), s, tau_factor),
                               f=lambda x, t: exact.heat_source(x, t, s))
    return disc, steps


def fine_mesh(tag, grading):
    """T_h of a series member of Examples 4/5: the refinement of its multiplier mesh."""
    return vi.fine_mesh(ff.multiplier_mesh(tag, grading))


def check(s, T, grading, series, tau_factor, reference_tag, reference_tau_factor, quad):
    """(runs table, summary rows, text) for one order s; series: [(family, tag)]."""
    ref_mesh = fine_mesh(reference_tag, grading)
    logger.info("s = %g: reference solution on %s (%d nodes)", s, reference_tag,
                ref_mesh.p.shape[1])
    ref_disc, ref_steps = run(ref_mesh, s, T, reference_tau_factor, quad)
    ref = [(st.t - st.tau, st.t, ref_mesh, st.u) for st in ref_steps[1:]]
    ref_exact = ff.heat_error(ref_steps, ref_disc, s)
    logger.info("s = %g: reference solution done, %d DOFs × %d steps, exact error %.4e", s,
                len(ref_disc.free), len(ref_steps) - 1, ref_exact)
    rows = []
    for fam, tag in series:
        mesh = fine_mesh(tag, grading)
        disc, steps = run(mesh, s, T, tau_factor[fam], quad)
        pieces = [(st.t - st.tau, st.t, mesh, st.u) for st in steps[1:]]
        rows.append({"s": s, "family": fam, "tag": tag, "dofs": len(disc.free),
                     "spacetime_dofs": len(disc.free) * (len(steps) - 1),
                     "exact error": ff.heat_error(steps, disc, s),
                     "error vs reference": space_time_distance(pieces, ref, ref_disc.A,
                                                               ref_disc.free)})
        logger.info("%s", rows[-1])
    df = pd.DataFrame(rows)
    summary = []
    for fam, g in df.groupby("family"):
        summary.append({"s": s, "family": fam,
                        "rate, exact error": fit_rate(g.spacetime_dofs, g["exact error"]),
                        "rate, error vs reference": fit_rate(g.spacetime_dofs,
                                                             g["error vs reference"]),
                        "finest exact error": g["exact error"].min(),
                        "reference's exact error": ref_exact})
    note = (f"s = {s:g}: reference {len(ref_disc.free)} DOFs × {len(ref)} steps, exact error "
            f"{ref_exact:.4g}.")
    return df, summary, note


def main(s_list, T, grading, uniform_levels, graded_h, tau_factor, reference_graded_h,
         reference_tau_factor, quadrature, md, csv, log=None, threads=None):
    """tau_factor: {'uniform': …, 'graded': …}; the reference run is the graded mesh of
    h = reference_graded_h with τ = reference_tau_factor · h_max^{2s}."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    series = ([("uniform", ff.series_tag("uniform", lv)) for lv in uniform_levels]
              + [("graded", ff.series_tag("graded", h)) for h in graded_h])
    reference_tag = ff.series_tag("graded", reference_graded_h)
    frames, summary, notes = [], [], []
    for s in s_list:
        df, summ, note = check(float(s), T, grading, series, tau_factor, reference_tag,
                               reference_tau_factor, quad)
        frames.append(df)
        summary += summ
        notes.append(note)
    df = pd.concat(frames, ignore_index=True)
    params = parameter_columns(quadrature=quad, grading=grading, T=T,
                               reference_tag=reference_tag,
                               reference_tau_factor=reference_tau_factor)
    write_table(with_provenance(df.assign(
        tau_factor=df.family.map(tau_factor), **params)), csv)
    text = (f"Manufactured solution e^(−t)(1−|x|²)^(1+s), T = {T:g}, on the "
            "meshes and time steps of the parabolic examples, for the orders of Examples 4 "
            "and 5; the reference run is made like theirs. " + " ".join(notes) + "\n\n"
            + pd.DataFrame(summary).to_markdown(index=False, floatfmt=".3f") + "\n\n"
            + df.to_markdown(index=False, floatfmt=".4g") + "\n")
    with atomic_path(md) as tmp:
        tmp.write_text(text)


if __name__ == "__main__":
    main(snakemake.params.s_list, snakemake.params.T, snakemake.params.grading,  # noqa: F821
         snakemake.params.uniform_levels, snakemake.params.graded_h,  # noqa: F821
         snakemake.params.tau_factor, snakemake.params.reference_graded_h,  # noqa: F821
         snakemake.params.reference_tau_factor, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.md, snakemake.output.csv, snakemake.log[0],  # noqa: F821
         snakemake.threads)  # noqa: F821
