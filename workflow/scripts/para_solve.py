"""One parabolic run (Examples 4, 5): DG(0) steps of Problem 6.11 on one mesh pair."""
import logging
import time

import numba
import numpy as np
import pandas as pd
from vi_solve import coarse_mesh

import fracfem as ff
from fracfem import examples, parabolic, vi
from fracfem.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem.meshes import mesh_size


def para_problem(problem, coarse, cfg, quadrature, assemble=True):
    """(MixedProblem, u0) of Example 4 (obstacle) or 5 (friction); f = 0."""
    c = cfg["parabolic"]["examples"][problem]
    if not assemble:
        u0 = float(c["u0"]) if problem.startswith("ex4") else examples.ring_initial(c["r0"])
        return None, u0
    if problem.startswith("ex4"):
        chi = examples.paraboloid_obstacle(**cfg["example2"]["obstacle"])
        prob = vi.mixed_problem("obstacle", coarse, c["s"], 0.0, chi=chi, quadrature=quadrature)
        return prob, float(c["u0"])
    prob = vi.mixed_problem("friction", coarse, c["s"], 0.0, F=c["F"], quadrature=quadrature)
    return prob, examples.ring_initial(c["r0"])


def lam_summary(problem, lam, upper):
    if lam is None:
        return {}
    if problem.startswith("ex4"):
        return {"contact": int(np.sum(lam < 0))}
    return {"slip_plus": int(np.sum(np.isclose(lam, upper, rtol=1e-9))),
            "slip_minus": int(np.sum(np.isclose(lam, -upper, rtol=1e-9)))}


def main(problem, family, tag, cfg, quadrature, row_path, npz_path, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    pc = cfg["parabolic"]
    t_start = time.perf_counter()
    # the reference run is a graded mesh (tag h…) with its own time-step factor
    coarse = coarse_mesh("graded" if family == "reference" else family, tag,
                         cfg["example1"]["grading"])
    if family == "reference":
        factor = pc["reference"]["tau_factor"]
    else:
        factor = pc["tau_factor"][family]
    prob, u0 = para_problem(problem, coarse, cfg, ff.QuadratureOptions(**quadrature))
    s = prob.disc.s
    h = mesh_size(prob.fine)
    times = parabolic.time_grid(T=pc["T"], tau=factor * h ** (2 * s))
    U, LAM, per_step = [], [], []
    t_steps = time.perf_counter()
    stepper = parabolic.Stepper(prob)
    for st in parabolic.time_steps(stepper, u0, times, solver="pdas",
                                   solver_options={"tol": cfg["solver"]["tol"]}):
        U.append(st.u)
        if st.lam is not None:
            LAM.append(st.lam)
            per_step.append({"k": st.k, "t": st.t, **lam_summary(problem, st.lam, prob.cset.upper),
                             "iterations": st.info.get("iterations", -1)})
    t_steps = time.perf_counter() - t_steps
    U, LAM = np.array(U), np.array(LAM)
    steps = len(times) - 1
    first_contact = np.nan
    if problem.startswith("ex4"):
        hit = [r["t"] for r in per_step if r["contact"] > 0]
        first_contact = hit[0] if hit else np.nan
    row = {"problem": problem, "example": 4 if problem.startswith("ex4") else 5,
           "variant": problem[4:] if problem.startswith("ex4") else "",
           "family": family, "tag": tag, "s": s, "dofs": len(prob.disc.free),
           "multipliers": LAM.shape[1], "steps": steps, "tau": pc["T"] / steps, "h_max": h,
           "spacetime_dofs": len(prob.disc.free) * steps,
           "first_contact": first_contact,
           "t_assembly": prob.timings["assembly"], "t_mesh": prob.timings["mesh"],
           "t_factorisation": stepper.timings.get("factorisation", 0.0),
           "t_schur": stepper.timings.get("schur", 0.0), "t_steps": t_steps,
           "t_wall": time.perf_counter() - t_start,
           "pdas_iterations_max": max(r["iterations"] for r in per_step),
           "peak_mem_mb": peak_memory_mb(), **provenance()}
    logging.info("%s", row)
    save_arrays(npz_path, p=prob.fine.p, t=prob.fine.t, pc=prob.coarse.p, tc=prob.coarse.t,
                times=times, U=U, LAM=LAM, s=s, free=prob.disc.free,
                **{f"step_{key}": np.array([r[key] for r in per_step]) for key in per_step[0]})
    write_table(pd.DataFrame([row]), row_path)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    w = snakemake.wildcards  # noqa: F821
    main(w.problem, w.pfamily, w.tag, snakemake.params.config,  # noqa: F821
         snakemake.params.config["quadrature"], snakemake.output.row,  # noqa: F821
         snakemake.output.npz, snakemake.threads)  # noqa: F821
