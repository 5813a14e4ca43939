"""Examples 4, 5 on space-time adaptive meshes: Algorithm C, error per iteration."""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import peak_memory_mb, save_arrays, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start, stored_reference

logger = script_logger("para_adaptive")


def main(problem, example, data, T, theta, start_level, c_tau, max_spacetime_dofs,
         max_iterations, figure_iterations, output_times, tol, quadrature, ref, table, npz,
         log=None, threads=None, operator="dense", ref_operator=None):
    """problem: the run's name; example, data: fracfem.example(example, **data); ref: the
    reference run the errors are measured against; operator: each slab's stiffness
    ('dense', 'compressed', 'auto'); ref_operator: the reference's operator, saved by
    para_reference_operator (None: assembled here)."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    ex = ff.example(example, **data)
    obstacle = example == "ex4"
    t0 = time.perf_counter()
    reference, s = stored_reference(ref, quad, ref_operator)
    t_ref = time.perf_counter() - t0
    rows, arrays, t_start = [], {}, time.perf_counter()
    keep = {int(k) for k in figure_iterations}
    t_eval = [0.0]          # time spent measuring errors, not part of the method's cost

    def record(rec):
        t0 = time.perf_counter()
        err = reference.distance(rec.pieces)
        t_eval[0] += time.perf_counter() - t0
        rec.pieces = None                          # the steps are not needed any more
        rows.append({
            "problem": problem, "example": int(example[2:]),
            "variant": problem[4:] if obstacle else "",
            "family": "adaptive", "tag": f"it{rec.iteration}", "s": s,
            "dofs": max(sl.n_free for sl in rec.slabs), "slabs": len(rec.slabs),
            "steps": int(sum(sl.n_steps for sl in rec.slabs)),
            "spacetime_dofs": rec.dofs, "error": err, "eta": rec.eta,
            **{f"eta2_{k}": v for k, v in rec.eta_parts.items()},
            # the time term with the energy norm instead of its h^{−2s}‖·‖_{L²} proxy
            "eta2_time_anorm": float(np.sum(rec.steps["time_anorm"])),
            "first_contact": (np.nan if rec.first_contact_time is None
                              else rec.first_contact_time),
            **{f"t_{k}": v for k, v in rec.timings.items()},
            # all passes so far, without the error measurement (as for the other families)
            "t_wall": time.perf_counter() - t_start - t_eval[0],
            "t_error_measurement": t_eval[0], "peak_mem_mb": peak_memory_mb()})
        logger.info("iteration %d: %d space-time DOFs, %d slabs, eta %.4e, error %.4e "
                    "(measured in %.1f s)", rec.iteration, rec.dofs, len(rec.slabs), rec.eta,
                    err, time.perf_counter() - t0)
        st = rec.steps
        arrays.update({f"t_it{rec.iteration}": st["t"], f"tau_it{rec.iteration}": st["tau"],
                       f"eta2_it{rec.iteration}": st["total"],
                       f"time_it{rec.iteration}": st["time"]})
        if rec.iteration in keep:
            for j, (t_out, snap) in enumerate(sorted(rec.outputs.items())):
                m = snap["mesh"]
                arrays.update({f"p_it{rec.iteration}_{j}": m.p, f"t_it{rec.iteration}_{j}": m.t,
                               f"time_it{rec.iteration}_{j}": t_out})
        return rec.dofs >= max_spacetime_dofs

    recs = ff.algorithm_c(
        lambda coarse: ex.problem(coarse, quad, operator=operator),
        ff.disk_uniform(start_level),
        ex.initial_value, T=T, theta=theta, iterations=max_iterations, c_tau=c_tau,
        marking="maximum", solver="pdas", output_times=output_times, callback=record,
        keep_steps=True, solver_options={"tol": tol})
    last = recs[-1]
    for j, (t_out, snap) in enumerate(sorted(last.outputs.items())):
        # the last pass's state at each output time (Figure 14): u_hτ on that slab's T_h,
        # λ_H on its T_H (none at t = 0)
        arrays.update({f"p_last_{j}": snap["mesh"].p, f"t_last_{j}": snap["mesh"].t,
                       f"time_last_{j}": t_out, f"u_last_{j}": snap["u"], f"pc_last_{j}": snap["coarse"].p,
                       f"tc_last_{j}": snap["coarse"].t})
        if snap["lam"] is not None:
            arrays[f"lam_last_{j}"] = snap["lam"]
    arrays["last_iteration"] = last.iteration
    fin = last.final
    arrays.update(p=fin["mesh"].p, t=fin["mesh"].t, pc=fin["coarse"].p, tc=fin["coarse"].t,
                  u=fin["u"], lam=fin["lam"], s=s, T=T,
                  iterations=np.array([r.iteration for r in recs]),
                  figure_iterations=np.array(sorted(keep & {r.iteration for r in recs})))
    save_arrays(npz, **arrays)
    df = pd.DataFrame(rows)
    df["t_reference_assembly"] = t_ref
    df = df.assign(**parameter_columns(
        quadrature=quad, T=T, theta=theta, marking="maximum", c_tau=c_tau,
        start_level=start_level, solver="pdas", tol=tol, operator=operator))
    write_table(with_provenance(df), table)


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.params.example,  # noqa: F821
         snakemake.params.data, snakemake.params.T, snakemake.params.theta,  # noqa: F821
         snakemake.params.start_level, snakemake.params.c_tau,  # noqa: F821
         snakemake.params.max_spacetime_dofs, snakemake.params.max_iterations,  # noqa: F821
         snakemake.params.figure_iterations, snakemake.params.output_times,  # noqa: F821
         snakemake.params.tol, snakemake.params.quadrature, snakemake.input.ref,  # noqa: F821
         snakemake.output.table, snakemake.output.npz, snakemake.log[0],  # noqa: F821
         snakemake.threads, snakemake.params.operator,  # noqa: F821
         snakemake.input.operator)  # noqa: F821
