"""An obstacle problem on the graded family at every ring count: T_H =
disk_graded_rings(n, grading) for each n of a range, solved as the graded series' runs are
(PDAS, T_h its refinement), one row per n.

The graded series takes h from config (n = ceil(1/h)); this runs every n in between, so
that its page can say whether the series' errors follow one power law of the DOFs or
depend on which ring counts the series picks.  Each row records the discrete contact set
(the elements of T_H where λ_H < 0): how many elements it has, and its area as the radius
of a disk.  The averaged constraint of the mixed form lets u_h dip below χ between the
multipliers' elements, which lowers E(u_h); each row also records the largest dip and the
energy of the lift ũ_h = max(u_h, χ) at the fine nodes (0 on ∂Ω): u_h with its dip
removed at the nodes (between them a P1 function can still lie below a concave χ).
"""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import vi
from fracfem_workflow.io import peak_memory_mb, provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import contact_extent
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("vi_graded_rings")


def lifted(prob, u, obstacle):
    """(ũ_h, largest dip): ũ_h = max(u_h, χ) at the nodes of T_h, 0 on ∂Ω; the dip is
    max(χ − u_h) over the free nodes (≤ 0 when u_h lies above χ at every node)."""
    chi = obstacle(prob.fine.p)
    free = prob.disc.free
    lift = np.zeros_like(u)
    lift[free] = np.maximum(u[free], chi[free])
    return lift, float((chi[free] - u[free]).max())


def main(problem, example, data, rings, grading, tol, quadrature, table, log=None,
         threads=None):
    """rings: [first, last] ring counts, both included."""
    first, last = (int(n) for n in rings)
    if not 2 <= first <= last:
        raise ValueError(f"rings={list(rings)} must be [first, last] ring counts with "
                         "2 <= first <= last")
    spec = ff.example(example, **data)
    if not hasattr(spec, "obstacle"):
        raise ValueError(f"problem={problem!r} ({type(spec).__name__}) has no obstacle: the "
                         "ring-count page measures a contact set and the lift onto χ")
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    rows = []
    for n in range(first, last + 1):
        t0 = time.perf_counter()
        prob = spec.problem(ff.disk_graded_rings(n, grading), quad)
        u, lam, info = vi.solve(prob, "pdas", tol=tol)
        lift, dip = lifted(prob, u, spec.obstacle)
        rows.append({
            "problem": problem, "n": n, "h": 1.0 / n, "dofs": len(prob.disc.free),
            "multipliers": prob.cset.n_multipliers, "energy": ff.discrete_energy(prob, u),
            "lifted energy": ff.discrete_energy(prob, lift), "largest dip": dip,
            **contact_extent(prob.coarse.p, prob.coarse.t, lam),
            "iterations_pdas": info["iterations"],
            "t_wall": time.perf_counter() - t0})
        logger.info("%s n=%d: %d DOFs, E = %.10f, lifted %.10f, contact %d elements, "
                    "radius %.4f, %.1f s", problem, n, rows[-1]["dofs"], rows[-1]["energy"],
                    rows[-1]["lifted energy"],
                    rows[-1]["contact elements"], rows[-1]["contact radius"],
                    rows[-1]["t_wall"])
    df = pd.DataFrame(rows)
    df["peak_mem_mb"] = peak_memory_mb()
    for key, value in {**parameter_columns(quadrature=quad, grading=grading, solver="pdas",
                                           tol=tol, data=data),
                       **provenance()}.items():
        df[key] = value
    write_table(df, table)


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.params.example,  # noqa: F821
         snakemake.params.data, snakemake.params.rings, snakemake.params.grading,  # noqa: F821
         snakemake.params.tol, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.table, snakemake.log[0], snakemake.threads)  # noqa: F821
