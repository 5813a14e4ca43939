"""How much does a reference solution distort the parabolic rates?  The manufactured
heat solution u = e^{−t}(1−|x|²)^{1+s} on the meshes and time steps of Examples 4/5:
the exact L²(0,T; H^s) error next to the error measured against a reference run made
exactly like the examples' reference (fracfem.transfer.space_time_distance)."""
import logging

import numba
import pandas as pd

import fracfem as ff
from fracfem import exact, parabolic
from fracfem.io import atomic_path, with_provenance, write_table
from fracfem.meshes import mesh_size
from fracfem.report import fit_rate
from fracfem.transfer import space_time_distance


def run(mesh, s, T, factor, quad):
    """Unconstrained DG(0) run of the manufactured solution with τ ≤ factor·h_max^{2s}."""
    disc = ff.discretise(mesh, s, 0.0, quadrature=quad)
    steps = parabolic.solve_parabolic(disc, lambda x: exact.bubble(x, s), T=T,
                                      tau=factor * mesh_size(mesh) ** (2 * s),
                                      f=lambda x, t: exact.heat_source(x, t, s))
    return disc, steps


def check(cfg, quad, s):
    """(runs table, summary rows, text) for one order s."""
    pc = cfg["parabolic"]
    grading, T = cfg["example1"]["grading"], pc["T"]
    ref_mesh = ff.refine_disk(ff.disk_graded(pc["reference"]["graded_h"], grading))
    ref_disc, ref_steps = run(ref_mesh, s, T, pc["reference"]["tau_factor"], quad)
    ref = [(st.t - st.tau, st.t, ref_mesh, st.u) for st in ref_steps[1:]]
    ref_exact = exact.heat_error(ref_steps, ref_disc, s)
    rows = []
    series = [("uniform", f"L{l}", ff.disk_uniform(int(l))) for l in pc["uniform_levels"]]
    series += [("graded", f"h{h:g}", ff.refine_disk(ff.disk_graded(h, grading)))
               for h in pc["graded_h"]]
    for fam, tag, mesh in series:
        disc, steps = run(mesh, s, T, pc["tau_factor"][fam], quad)
        pieces = [(st.t - st.tau, st.t, mesh, st.u) for st in steps[1:]]
        rows.append({"s": s, "family": fam, "tag": tag, "dofs": len(disc.free),
                     "spacetime_dofs": len(disc.free) * (len(steps) - 1),
                     "exact error": exact.heat_error(steps, disc, s),
                     "error vs reference": space_time_distance(pieces, ref, ref_disc.A,
                                                               ref_disc.free)})
        logging.info("%s", rows[-1])
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


def main(cfg, quadrature, s_list, md, csv, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    quad = ff.QuadratureOptions(**quadrature)
    frames, summary, notes = [], [], []
    for s in s_list:
        df, summ, note = check(cfg, quad, float(s))
        frames.append(df)
        summary += summ
        notes.append(note)
    df = pd.concat(frames, ignore_index=True)
    write_table(with_provenance(df), csv)
    text = (f"Manufactured solution e^(−t)(1−|x|²)^(1+s), T = {cfg['parabolic']['T']:g}, on the "
            "meshes and time steps of the parabolic examples, for the orders of Examples 4 "
            "and 5; the reference run is made like theirs. " + " ".join(notes) + "\n\n"
            + pd.DataFrame(summary).to_markdown(index=False, floatfmt=".3f") + "\n\n"
            + df.to_markdown(index=False, floatfmt=".4g") + "\n")
    with atomic_path(md) as tmp:
        tmp.write_text(text)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.params.config, snakemake.params.config["quadrature"],  # noqa: F821
         snakemake.params.s_list, snakemake.output.md, snakemake.output.csv,  # noqa: F821
         snakemake.threads)  # noqa: F821
