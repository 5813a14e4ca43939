"""One parabolic run (Examples 4, 5): DG(0) steps of Problem 6.11 on one mesh pair."""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.meshes import mesh_size
from fracfem_workflow.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("para_solve")


def multiplier_counts(obstacle, lam, upper):
    """Contact (obstacle) or slip (friction) elements of one step's λ_H."""
    if obstacle:
        return {"contact": int(np.sum(lam < 0))}
    return {"slip_plus": int(np.sum(np.isclose(lam, upper, rtol=1e-9))),
            "slip_minus": int(np.sum(np.isclose(lam, -upper, rtol=1e-9)))}


def cached_assembly(disc) -> float:
    """Seconds to add to a run's wall time when its operator was read back from the
    operator cache (fracfem.opcache) instead of assembled: the assembly's seconds less the
    read's, so that t_wall is the run's cost whichever job assembled the operator."""
    load = disc.timings.get("operator_load")
    return 0.0 if load is None else disc.timings["assembly"] - load


def main(problem, family, tag, example, data, grading, T, tau_factor, tol, quadrature, row,
         npz, log=None, threads=None, operator="dense"):
    """problem, family, tag: the run's name; example, data: fracfem.example(example, **data);
    τ = tau_factor · h_max^{2s}; operator: 'dense', 'compressed' or 'auto' (the large
    reference run)."""
    start(log, threads)
    t_start = time.perf_counter()
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    obstacle = example == "ex4"
    prob = ex.problem(ff.multiplier_mesh(tag, grading), quad, operator=operator)
    s = prob.disc.s
    h = mesh_size(prob.fine)
    times = ff.time_grid(T=T, tau=ff.time_step(h, s, tau_factor))
    logger.info("%s %s %s%s: %d DOFs, %d multipliers, %d time steps of τ = %.4g on [0, %g]",
                problem, family, tag, " (the reference solution)" if family == "reference"
                else "", len(prob.disc.free), prob.cset.n_multipliers, len(times) - 1,
                times[1] - times[0], T)
    U, LAM, per_step = [], [], []
    t_steps = time.perf_counter()
    stepper = ff.Stepper(prob)
    for st in ff.time_steps(stepper, ex.initial_value, times, solver="pdas",
                            solver_options={"tol": tol}):
        U.append(st.u)
        if st.lam is not None:
            LAM.append(st.lam)
            per_step.append({"k": st.k, "t": st.t,
                             **multiplier_counts(obstacle, st.lam, prob.cset.upper),
                             "iterations": st.info.get("iterations", -1)})
    t_steps = time.perf_counter() - t_steps
    U, LAM = np.array(U), np.array(LAM)
    steps = len(times) - 1
    first_contact = np.nan
    if obstacle:
        hit = [r["t"] for r in per_step if r["contact"] > 0]
        first_contact = hit[0] if hit else np.nan
    result = {
        "problem": problem, "example": int(example[2:]),
        "variant": problem[4:] if obstacle else "",
        "family": family, "tag": tag, "s": s, "dofs": len(prob.disc.free),
        "multipliers": LAM.shape[1], "steps": steps, "tau": T / steps, "h_max": h,
        "spacetime_dofs": len(prob.disc.free) * steps,
        "first_contact": first_contact,
        "t_assembly": prob.timings["assembly"], "t_mesh": prob.timings["mesh"],
        "t_factorisation": stepper.timings.get("factorisation", 0.0),
        "t_schur": stepper.timings.get("schur", 0.0), "t_steps": t_steps,
        "t_wall": time.perf_counter() - t_start + cached_assembly(prob.disc),
        "pdas_iterations_max": max(r["iterations"] for r in per_step),
        "peak_mem_mb": peak_memory_mb(),
        "operator_used": prob.disc.info["operator"],
        **parameter_columns(quadrature=quad, grading=grading, T=T, tau_factor=tau_factor,
                            solver="pdas", tol=tol, operator=operator, data=data),
        **provenance()}
    logger.info("%s", result)
    save_arrays(npz, p=prob.fine.p, t=prob.fine.t, pc=prob.coarse.p, tc=prob.coarse.t,
                times=times, U=U, LAM=LAM, s=s, free=prob.disc.free,
                **{f"step_{key}": np.array([r[key] for r in per_step]) for key in per_step[0]})
    write_table(pd.DataFrame([result]), row)


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.wildcards.family,  # noqa: F821
         snakemake.wildcards.tag, snakemake.params.example, snakemake.params.data,  # noqa: F821
         snakemake.params.grading, snakemake.params.T, snakemake.params.tau_factor,  # noqa: F821
         snakemake.params.tol, snakemake.params.quadrature, snakemake.output.row,  # noqa: F821
         snakemake.output.npz, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.params.operator)  # noqa: F821
