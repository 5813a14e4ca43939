"""How much does a reference solution distort the parabolic rates, and is its measured
error right?  The manufactured heat solution u = e^{−t}(1−|x|²)^{1+s} on the meshes and
time steps of Examples 4/5: the exact L²(0,T; H^s) error next to the error measured
against a reference run made like the examples' reference
(fracfem.transfer.SpaceTimeReference) and next to the distance to the limit of the
reference's family, extrapolated from the distances to its members with its measured
uncertainty (fracfem.transfer.ReferenceFamily); and the reference's exact error next to
its measured estimate d₂₃ r/(1 − r) from the two coarser runs of its family (para_errors)."""

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import exact, vi
from fracfem.meshes import mesh_size
from fracfem.transfer import ReferenceFamily, SpaceTimeReference
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import fit_rate, masked_rate, reference_family_error
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("para_reference_check")


def run(mesh, s, T, tau_factor, quad, operator="dense"):
    """Unconstrained DG(0) run of the manufactured solution with τ ≤ factor·h_max^{2s}."""
    disc = ff.discretise(mesh, s, 0.0, quadrature=quad, operator=operator)
    steps = ff.solve_parabolic(disc, lambda x: exact.bubble(x, s), T=T,
                               tau=ff.time_step(mesh_size(mesh), s, tau_factor),
                               f=lambda x, t: exact.heat_source(x, t, s))
    return disc, steps


def fine_mesh(tag, grading):
    """T_h of a series member of Examples 4/5: the refinement of its multiplier mesh."""
    return vi.fine_mesh(ff.multiplier_mesh(tag, grading))


def pieces_of(mesh, steps):
    return [(st.t - st.tau, st.t, mesh, st.u) for st in steps[1:]]


def check(s, T, grading, series, tau_factor, family_tags, reference_tau_factor, quad):
    """(runs table, summary rows, text) for one order s; series: [(family, tag)];
    family_tags: the reference's family, coarsest first (the last is the reference; with
    four or more members the extrapolation's uncertainty is measured)."""
    family = []
    for tag in family_tags:
        mesh = fine_mesh(tag, grading)
        disc, steps = run(mesh, s, T, reference_tau_factor, quad, operator="auto")
        family.append((disc, pieces_of(mesh, steps), ff.heat_error(steps, disc, s)))
        logger.info("s = %g: reference family %s, %d DOFs × %d steps, exact error %.4e", s,
                    tag, len(disc.free), len(steps) - 1, family[-1][2])
    (_, p1, e1), (disc2, p2, e2), (ref_disc, ref, ref_exact) = family[-3:]
    reference = SpaceTimeReference(ref, ref_disc.A, ref_disc.free)
    measured = reference_family_error(p1, (p2, disc2.A, disc2.free), reference)
    estimate = measured["error"]
    limit = ReferenceFamily([f[1] for f in family], ref_disc.A, ref_disc.free)
    rows = []
    for fam, tag in series:
        mesh = fine_mesh(tag, grading)
        disc, steps = run(mesh, s, T, tau_factor[fam], quad)
        exact_error = ff.heat_error(steps, disc, s)
        out = limit.error(pieces_of(mesh, steps))
        rows.append({"s": s, "family": fam, "tag": tag, "dofs": len(disc.free),
                     "spacetime_dofs": len(disc.free) * (len(steps) - 1),
                     "exact error": exact_error,
                     "error vs reference": reference.distance(pieces_of(mesh, steps)),
                     "extrapolated error": out["error"],
                     "uncertainty": out["uncertainty"],
                     "left out": ", ".join(family_tags[k] for k in out["left_out"]),
                     "extrapolated / exact − 1": out["error"] / exact_error - 1.0,
                     "vs reference / exact − 1": out["distances"][-1] / exact_error - 1.0,
                     **{f"distance to {t}": d for t, d in zip(family_tags, out["distances"])}})
        logger.info("%s", rows[-1])
    df = pd.DataFrame(rows)
    summary = []
    for fam, g in df.groupby("family"):
        summary.append({"s": s, "family": fam,
                        "rate, exact error": fit_rate(g.spacetime_dofs, g["exact error"]),
                        "rate, error vs reference": fit_rate(g.spacetime_dofs,
                                                             g["error vs reference"]),
                        # runs with no extrapolated error (too few family runs left
                        # after those on their mesh) are not fitted
                        "rate, extrapolated error": masked_rate(
                            g.spacetime_dofs, g["extrapolated error"],
                            np.isfinite(g["extrapolated error"])),
                        "finest exact error": g["exact error"].min(),
                        "reference's exact error": ref_exact,
                        # the bound the fits use (report.with_fit_bound): the
                        # uncertainty, or the reference's estimated error where it has none
                        "largest deviation / bound": float(np.max(
                            np.abs(g["extrapolated error"] - g["exact error"])
                            / g["uncertainty"].where(g["uncertainty"].notna(), estimate)))})
    estimate_row = {"s": s, "family": " → ".join(family_tags[-3:]),
                    "exact errors": ", ".join(f"{e:.4g}" for e in (e1, e2, ref_exact)),
                    "d12": measured["d12"], "d23": measured["d23"],
                    "ratio r": measured["ratio"],
                    "reference error estimate": estimate, "reference's exact error": ref_exact,
                    "estimate / exact": estimate / ref_exact}
    note = (f"s = {s:g}: reference {len(ref_disc.free)} DOFs × {len(ref)} steps, exact error "
            f"{ref_exact:.4g}, measured estimate {estimate:.4g}; family "
            f"{' → '.join(family_tags)}, exact errors "
            f"{', '.join(f'{f[2]:.4g}' for f in family)}, steps "
            f"{', '.join(f'{d:.4g}' for d in limit.steps)} (on the reference's mesh).")
    return df, summary, estimate_row, note


def main(s_list, T, grading, uniform_levels, graded_h, tau_factor, family_h,
         reference_tau_factor, quadrature, md, csv, log=None, threads=None):
    """tau_factor: {'uniform': …, 'graded': …}; the reference's family: the graded meshes
    of family_h (three, coarsest first; the last is the reference) with
    τ = reference_tau_factor · h_max^{2s}."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    series = ([("uniform", ff.series_tag("uniform", lv)) for lv in uniform_levels]
              + [("graded", ff.series_tag("graded", h)) for h in graded_h])
    family_tags = [ff.series_tag("graded", h) for h in family_h]
    reference_tag = family_tags[-1]
    frames, summary, estimates, notes = [], [], [], []
    for s in s_list:
        df, summ, est, note = check(float(s), T, grading, series, tau_factor, family_tags,
                                    reference_tau_factor, quad)
        frames.append(df)
        summary += summ
        estimates.append(est)
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
            "`extrapolated error`: the distance to the limit of the reference's family, "
            "extrapolated from the distances to its members (the three finest; "
            "`uncertainty`: its change from the three before, fracfem.transfer."
            "extrapolated_distance), against the exact error; `error vs reference`: the "
            "distance to the finest member alone.\n\n"
            + pd.DataFrame(summary).to_markdown(index=False, floatfmt=".3f") + "\n\n"
            + "The reference's own error, measured as for Examples 4 and 5 from the two "
            "coarser runs of its family, against its exact error:\n\n"
            + pd.DataFrame(estimates).to_markdown(index=False, floatfmt=".4g") + "\n\n"
            + df.drop(columns=[c for c in df if c.startswith("distance to ")])
            .to_markdown(index=False, floatfmt=".4g") + "\n")
    with atomic_path(md) as tmp:
        tmp.write_text(text)


if __name__ == "__main__":
    main(snakemake.params.s_list, snakemake.params.T, snakemake.params.grading,  # noqa: F821
         snakemake.params.uniform_levels, snakemake.params.graded_h,  # noqa: F821
         snakemake.params.tau_factor, snakemake.params.family_h,  # noqa: F821
         snakemake.params.reference_tau_factor, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.md, snakemake.output.csv, snakemake.log[0],  # noqa: F821
         snakemake.threads)  # noqa: F821
