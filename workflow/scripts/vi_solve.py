"""One obstacle / friction run (mixed form, Problem 5.15): both solvers, one row."""
import logging

import numba
import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import examples, vi
from fracfem.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem.meshes import mesh_size


def coarse_mesh(family, tag, grading):
    """T_H: the fine mesh of tag L is disk_uniform(L), so T_H = disk_uniform(L − 1)."""
    if family == "uniform":
        return ff.disk_uniform(int(tag[1:]) - 1)
    return ff.disk_graded(float(tag[1:]), grading)


def build(problem, family, tag, cfg, quadrature):
    if problem == "ex2" or problem.startswith("ex3-"):
        coarse = coarse_mesh(family, tag, cfg["example1"]["grading"])
        return elliptic_builder(problem, cfg, quadrature)(coarse)[0]
    c = cfg["thin"]
    coarse = ff.disk_uniform(c["level"] - 1)
    edges = examples.segment_edges(coarse, *c["segment"])
    if problem == "thin-obstacle":
        h = c["obstacle"]["height"]
        return vi.mixed_problem("thin_obstacle", coarse, c["s"], c["obstacle"]["f"],
                                edges=edges, height=lambda x: np.full(x.shape[1:], h),
                                quadrature=quadrature)
    return vi.mixed_problem("thin_friction", coarse, c["s"], c["friction"]["f"], edges=edges,
                            F=c["friction"]["F"], quadrature=quadrature)


def elliptic_builder(problem, cfg, quadrature):
    """coarse ↦ (MixedProblem, f) of Example 2 or a variant of Example 3."""
    if problem == "ex2":
        c = cfg["example2"]
        return lambda coarse: examples.example2(coarse, s=c["s"], **c["obstacle"],
                                                quadrature=quadrature)
    c = cfg["example3"]
    v = c["variants"][problem[4:]]
    return lambda coarse: examples.example3(coarse, s=c["s"], a=v["a"], b=v["b"], F=v["F"],
                                            quadrature=quadrature)


def constraint_report(prob, u_free, lam):
    """Feasibility / complementarity numbers and the active-set sizes."""
    cs = prob.cset
    y = cs.B.T @ u_free - cs.g                   # Bᵀu − g per multiplier
    scale = max(np.abs(lam).max(), 1e-300)
    out = {"multipliers": len(lam), "lambda_in_set": bool(cs.contains(lam, 0.0))}
    if prob.kind.endswith("obstacle"):
        contact = lam < -1e-9 * scale
        out.update(contact=int(contact.sum()),
                   min_gap=float(y.min()),                      # ≥ −tol: feasible
                   max_complementarity=float(np.abs(lam * y).max()))
    else:
        F = cs.upper
        plus = np.isclose(lam, F, rtol=1e-9, atol=0) & (F > 0)
        minus = np.isclose(lam, -F, rtol=1e-9, atol=0) & (F > 0)
        out.update(slip_plus=int(plus.sum()), slip_minus=int(minus.sum()),
                   stick=int((~plus & ~minus).sum()),
                   max_stick_residual=float(np.abs(y[~plus & ~minus]).max(initial=0.0)),
                   max_friction_excess=float((np.abs(lam) - F).max()))
    return out


def main(problem, family, tag, cfg, quadrature, row_path, npz_path, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    prob = build(problem, family, tag, cfg, ff.QuadratureOptions(**quadrature))
    sol = cfg["solver"]
    u_p, lam_p, info_p = vi.solve(prob, "pdas", tol=sol["tol"])
    u_u, lam_u, info_u = vi.solve(prob, "uzawa", tol=sol["tol"], maxiter=sol["maxiter"])
    free = prob.disc.free
    A, b = prob.disc.A, prob.disc.b
    uf = u_p[free]
    energy = 0.5 * uf @ (A @ uf) - b @ uf
    if prob.kind.endswith("friction"):
        energy += float(np.sum(prob.cset.upper * np.abs(prob.cset.B.T @ uf)))  # j_H(u_h)
    row = {
        "problem": problem, "family": family, "tag": tag, "s": prob.disc.s,
        "dofs": len(free), "h_max": mesh_size(prob.fine), "energy": energy,
        "iterations_uzawa": info_u["iterations"], "iterations_pdas": info_p["iterations"],
        "rho": info_u["rho"], "sigma_min": info_u["sigma_min"], "sigma_max": info_u["sigma_max"],
        "max_du_uzawa_pdas": float(np.abs(u_u - u_p).max()),
        "max_dlambda_uzawa_pdas": float(np.abs(lam_u - lam_p).max()),
        "max_lambda": float(np.abs(lam_p).max()),
        "t_mesh": prob.timings["mesh"], "t_assembly": prob.timings["assembly"],
        "t_factorisation": prob.timings["factorisation"], "t_schur": prob.timings["schur"],
        "t_uzawa": info_u["seconds_total"], "t_pdas": info_p["seconds_total"],
        **constraint_report(prob, uf, lam_p),
        "peak_mem_mb": peak_memory_mb(), **provenance(),
    }
    logging.info("%s", row)
    save_arrays(npz_path, p=prob.fine.p, t=prob.fine.t, pc=prob.coarse.p, tc=prob.coarse.t,
                u=u_p, lam=lam_p, edges=(prob.edges if prob.edges is not None
                                         else np.zeros((2, 0), int)), s=prob.disc.s)
    write_table(pd.DataFrame([row]), row_path)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    w = snakemake.wildcards  # noqa: F821
    main(w.problem, w.family, w.tag, snakemake.params.config,  # noqa: F821
         snakemake.params.config["quadrature"], snakemake.output.row,  # noqa: F821
         snakemake.output.npz, snakemake.threads)  # noqa: F821
