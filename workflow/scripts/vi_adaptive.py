"""Examples 2 and 3 on adaptive meshes: Algorithm B on the multiplier mesh T_H."""
import json
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import adaptive
from fracfem_workflow.io import peak_memory_mb, save_arrays, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("vi_adaptive")


def main(problem, example, data, theta, start_level, max_dofs, max_steps, figure_steps, tol,
         quadrature, table, npz, log=None, threads=None, operator="dense", family="adaptive",
         every_step=False):
    """problem: the run's name; example, data: fracfem.example(example, **data);
    operator: 'dense', 'compressed' or 'auto' (dense up to 2,000 free nodes), the
    matrix of every step and, through the estimator's default, its (−Δ)ˢu_h.
    npz: the meshes of figure_steps and the last step's mesh, u_h and λ_H; every_step:
    the meshes and u_h (u<k>) of every step instead of figure_steps'."""
    start(log, threads, operator_cache=False)   # its own meshes; it times each step
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    obstacle = example == "ex2"
    F = 0.0 if obstacle else ex.F
    rows, meshes, t_start = [], {}, time.perf_counter()
    keep = {int(k) for k in figure_steps}

    def record(rec):
        lam = rec.lam
        rows.append({
            "problem": problem, "family": family, "s": ex.s, "tag": f"step{rec.step}",
            "dofs": rec.dofs, "multipliers": rec.n_multipliers, "triangles": rec.n_triangles,
            "h_max": rec.h_max, "h_min": rec.h_min, "energy": rec.energy, "eta": rec.eta,
            "eta_contact": rec.indicators["parts"]["contact_total"],
            "contact": int(np.sum(lam < 0)) if obstacle else -1,
            "slip": int(np.sum(np.isclose(np.abs(lam), F, rtol=1e-9))) if F > 0 else -1,
            "marked": -1 if rec.marked is None else len(rec.marked),
            "iterations_pdas": rec.info.get("iterations", -1),
            "t_assembly": rec.timings.get("assemble", np.nan),
            "t_solve": rec.timings.get("solve", np.nan),
            "t_estimate": rec.timings.get("estimate", np.nan),
            "t_total": sum(rec.timings.values()),
            "t_cumulative": time.perf_counter() - t_start,
            "peak_mem_mb": peak_memory_mb()})
        if every_step or rec.step in keep:
            meshes[rec.step] = (rec.mesh, rec.coarse, rec.indicators["eta2_coarse"], rec.dofs,
                                rec.u)
        logger.info("adaptive step %d: %d dofs, eta %.4e, energy %.8f", rec.step, rec.dofs,
                    rec.eta, rec.energy)
        return rec.dofs >= max_dofs

    recs = adaptive.algorithm_b(lambda coarse: ex.problem(coarse, quad, operator=operator),
                                ff.disk_uniform(start_level), theta=theta, steps=max_steps,
                                marking="maximum", solver="pdas", f=ex.f, callback=record,
                                solver_options={"tol": tol})
    last = recs[-1]
    meshes[last.step] = (last.mesh, last.coarse, last.indicators["eta2_coarse"], last.dofs,
                         last.u)
    arrays = {"p": last.mesh.p, "t": last.mesh.t, "pc": last.coarse.p, "tc": last.coarse.t,
              "u": last.u, "lam": last.lam, "s": ex.s, "steps": np.array(sorted(meshes))}
    for k, (fine, coarse, eta2, dofs, u) in meshes.items():
        arrays.update({f"p{k}": fine.p, f"t{k}": fine.t, f"pc{k}": coarse.p,
                       f"tc{k}": coarse.t, f"eta2_{k}": eta2, f"dofs{k}": dofs})
        if every_step:
            arrays[f"u{k}"] = u
    save_arrays(npz, **arrays)
    df = pd.DataFrame(rows).assign(**parameter_columns(
        quadrature=quad, theta=theta, marking="maximum", start_level=start_level,
        max_dofs=max_dofs, solver="pdas", tol=tol, operator=operator,
        data=json.dumps(data, sort_keys=True)))
    write_table(with_provenance(df), table)


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.params.example,  # noqa: F821
         snakemake.params.data, snakemake.params.theta,  # noqa: F821
         snakemake.params.start_level, snakemake.params.max_dofs,  # noqa: F821
         snakemake.params.max_steps, snakemake.params.figure_steps,  # noqa: F821
         snakemake.params.tol, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.table, snakemake.output.npz, snakemake.log[0],  # noqa: F821
         snakemake.threads, snakemake.params.operator,  # noqa: F821
         snakemake.params.family,  # noqa: F821
         snakemake.params.get("every_step", False))  # noqa: F821
