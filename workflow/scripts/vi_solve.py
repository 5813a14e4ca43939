"""One obstacle / friction run (mixed form, Problem 5.15): both solvers, one row."""

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import vi
from fracfem.meshes import mesh_size
from fracfem_workflow.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("vi_solve")


def main(problem, family, tag, example, data, grading, tol, maxiter, quadrature, row, npz,
         log=None, threads=None):
    """problem, family, tag: the run's name; example, data: fracfem.example(example, **data)."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    prob = ff.example(example, **data).problem(ff.multiplier_mesh(tag, grading), quad)
    logger.info("%s %s %s: %d DOFs, %d multipliers; PDAS, then Uzawa as a cross-check",
                problem, family, tag, len(prob.disc.free), prob.cset.n_multipliers)
    u_p, lam_p, info_p = vi.solve(prob, "pdas", tol=tol)
    u_u, lam_u, info_u = vi.solve(prob, "uzawa", tol=tol, maxiter=maxiter)
    result = {
        "problem": problem, "family": family, "tag": tag, "s": prob.disc.s,
        "dofs": len(prob.disc.free), "h_max": mesh_size(prob.fine),
        "energy": ff.discrete_energy(prob, u_p),
        "iterations_uzawa": info_u["iterations"], "iterations_pdas": info_p["iterations"],
        "rho": info_u["rho"], "sigma_min": info_u["sigma_min"], "sigma_max": info_u["sigma_max"],
        "max_du_uzawa_pdas": float(np.abs(u_u - u_p).max()),
        "max_dlambda_uzawa_pdas": float(np.abs(lam_u - lam_p).max()),
        "max_lambda": float(np.abs(lam_p).max()),
        "t_mesh": prob.timings["mesh"], "t_assembly": prob.timings["assembly"],
        "t_factorisation": prob.timings["factorisation"], "t_schur": prob.timings["schur"],
        "t_uzawa": info_u["seconds_total"], "t_pdas": info_p["seconds_total"],
        **ff.kkt_report(prob, u_p, lam_p),
        "peak_mem_mb": peak_memory_mb(),
        **parameter_columns(quadrature=quad, grading=grading, solver="pdas",
                            cross_check="uzawa", tol=tol, maxiter=maxiter),
        **provenance(),
    }
    logger.info("%s", result)
    save_arrays(npz, p=prob.fine.p, t=prob.fine.t, pc=prob.coarse.p, tc=prob.coarse.t,
                u=u_p, lam=lam_p, edges=(prob.edges if prob.edges is not None
                                         else np.zeros((2, 0), int)), s=prob.disc.s)
    write_table(pd.DataFrame([result]), row)


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.wildcards.family,  # noqa: F821
         snakemake.wildcards.tag, snakemake.params.example, snakemake.params.data,  # noqa: F821
         snakemake.params.grading, snakemake.params.tol, snakemake.params.maxiter,  # noqa: F821
         snakemake.params.quadrature, snakemake.output.row, snakemake.output.npz,  # noqa: F821
         snakemake.log[0], snakemake.threads)  # noqa: F821
