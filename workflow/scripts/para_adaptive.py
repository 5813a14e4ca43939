"""Examples 4, 5 on space-time adaptive meshes: Algorithm C, error per iteration."""
import logging
import time

import numba
import numpy as np
import pandas as pd
from para_errors import pieces
from para_solve import para_problem

import fracfem as ff
from fracfem.io import peak_memory_mb, save_arrays, with_provenance, write_table
from fracfem.transfer import space_time_distance


def main(problem, cfg, quadrature, ref_npz, table_path, npz_path, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    pc = cfg["parabolic"]
    a = pc["adaptive"]
    quad = ff.QuadratureOptions(**quadrature)
    _, u0 = para_problem(problem, None, cfg, quad, assemble=False)
    ref, d = pieces(ref_npz)
    s = float(d["s"])
    t0 = time.perf_counter()
    ref_disc = ff.discretise(ref[0][2], s, 0.0, quadrature=quad)
    t_ref = time.perf_counter() - t0
    rows, arrays, t_start = [], {}, time.perf_counter()
    keep = {int(k) for k in a["figure_iterations"]}
    t_eval = [0.0]          # time spent measuring errors, not part of the method's cost

    def record(rec):
        t0 = time.perf_counter()
        err = space_time_distance(rec.pieces, ref, ref_disc.A, ref_disc.free)
        t_eval[0] += time.perf_counter() - t0
        rec.pieces = None                          # the steps are not needed any more
        rows.append({
            "problem": problem, "example": 4 if problem.startswith("ex4") else 5,
            "variant": problem[4:] if problem.startswith("ex4") else "",
            "family": "adaptive", "tag": f"it{rec.iteration}", "s": s,
            "dofs": max(sl.n_free for sl in rec.slabs), "slabs": len(rec.slabs),
            "steps": int(sum(sl.n_steps for sl in rec.slabs)),
            "spacetime_dofs": rec.dofs, "error": err, "eta": rec.eta,
            **{f"eta2_{k}": v for k, v in rec.eta_parts.items()},
            "first_contact": (np.nan if rec.first_contact_time is None
                              else rec.first_contact_time),
            **{f"t_{k}": v for k, v in rec.timings.items()},
            # all passes so far, without the error measurement (as for the other families)
            "t_wall": time.perf_counter() - t_start - t_eval[0],
            "t_error_measurement": t_eval[0], "peak_mem_mb": peak_memory_mb()})
        logging.info("iteration %d: %d space-time DOFs, %d slabs, eta %.4e, error %.4e",
                     rec.iteration, rec.dofs, len(rec.slabs), rec.eta, err)
        st = rec.steps
        arrays.update({f"t_it{rec.iteration}": st["t"], f"tau_it{rec.iteration}": st["tau"],
                       f"eta2_it{rec.iteration}": st["total"],
                       f"time_it{rec.iteration}": st["time"]})
        if rec.iteration in keep:
            for j, (t_out, snap) in enumerate(sorted(rec.outputs.items())):
                m = snap["mesh"]
                arrays.update({f"p_it{rec.iteration}_{j}": m.p, f"t_it{rec.iteration}_{j}": m.t,
                               f"time_it{rec.iteration}_{j}": t_out})
        return rec.dofs >= a["max_spacetime_dofs"]

    recs = ff.algorithm_c(
        lambda c: para_problem(problem, c, cfg, quad)[0], ff.disk_uniform(a["start_level"]),
        u0, T=pc["T"], theta=a["theta"], iterations=a["max_iterations"], c_tau=a["c_tau"],
        output_times=pc["output_times"], callback=record, keep_steps=True,
        solver_options={"tol": cfg["solver"]["tol"]})
    last = recs[-1]
    for j, (t_out, snap) in enumerate(sorted(last.outputs.items())):
        arrays.update({f"p_last_{j}": snap["mesh"].p, f"t_last_{j}": snap["mesh"].t,
                       f"time_last_{j}": t_out})
    fin = last.final
    arrays.update(p=fin["mesh"].p, t=fin["mesh"].t, pc=fin["coarse"].p, tc=fin["coarse"].t,
                  u=fin["u"], lam=fin["lam"], s=s, T=pc["T"],
                  iterations=np.array([r.iteration for r in recs]),
                  figure_iterations=np.array(sorted(keep & {r.iteration for r in recs})))
    save_arrays(npz_path, **arrays)
    df = pd.DataFrame(rows)
    df["t_reference_assembly"] = t_ref
    write_table(with_provenance(df), table_path)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.wildcards.problem, snakemake.params.config,  # noqa: F821
         snakemake.params.config["quadrature"], snakemake.input.ref,  # noqa: F821
         snakemake.output.table, snakemake.output.npz, snakemake.threads)  # noqa: F821
