"""Examples 2 and 3 on adaptive meshes: Algorithm B on the multiplier mesh T_H."""
import logging
import time

import numba
import numpy as np
import pandas as pd
from vi_solve import elliptic_builder

import fracfem as ff
from fracfem import adaptive, examples
from fracfem.io import peak_memory_mb, save_arrays, with_provenance, write_table


def main(problem, cfg, quadrature, table_path, npz_path, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    a = cfg["vi_adaptive"]
    builder = elliptic_builder(problem, cfg, ff.QuadratureOptions(**quadrature))
    if problem == "ex2":
        f = 1.0
    else:
        v = cfg["example3"]["variants"][problem[4:]]
        f = examples.radial_load(v["a"], v["b"])
    s = cfg["example2"]["s"] if problem == "ex2" else cfg["example3"]["s"]
    rows, meshes, t_start = [], {}, time.perf_counter()
    keep = {int(k) for k in a["figure_steps"]}

    def record(rec):
        lam = rec.lam
        F = 0.0 if problem == "ex2" else cfg["example3"]["variants"][problem[4:]]["F"]
        rows.append({
            "problem": problem, "family": "adaptive", "s": s, "tag": f"step{rec.step}",
            "dofs": rec.dofs, "multipliers": rec.n_multipliers, "triangles": rec.n_triangles,
            "h_max": rec.h_max, "h_min": rec.h_min, "energy": rec.energy, "eta": rec.eta,
            "eta_contact": rec.indicators["parts"]["contact_total"],
            "contact": int(np.sum(lam < 0)) if problem == "ex2" else -1,
            "slip": int(np.sum(np.isclose(np.abs(lam), F, rtol=1e-9))) if F > 0 else -1,
            "marked": -1 if rec.marked is None else len(rec.marked),
            "iterations_pdas": rec.info.get("iterations", -1),
            "t_assembly": rec.timings.get("assemble", np.nan),
            "t_solve": rec.timings.get("solve", np.nan),
            "t_estimate": rec.timings.get("estimate", np.nan),
            "t_total": sum(rec.timings.values()),
            "t_cumulative": time.perf_counter() - t_start,
            "peak_mem_mb": peak_memory_mb()})
        if rec.step in keep:
            meshes[rec.step] = (rec.mesh, rec.coarse, rec.indicators["eta2_coarse"])
        logging.info("step %d: %d dofs, eta %.4e, energy %.8f", rec.step, rec.dofs, rec.eta,
                     rec.energy)
        return rec.dofs >= a["max_dofs"]

    recs = adaptive.algorithm_b(lambda c: builder(c)[0], ff.disk_uniform(a["start_level"]),
                                theta=a["theta"], steps=a["max_steps"], marking="maximum",
                                solver="pdas", f=f, callback=record,
                                solver_options={"tol": cfg["solver"]["tol"]})
    last = recs[-1]
    meshes[last.step] = (last.mesh, last.coarse, last.indicators["eta2_coarse"])
    arrays = {"p": last.mesh.p, "t": last.mesh.t, "pc": last.coarse.p, "tc": last.coarse.t,
              "u": last.u, "lam": last.lam, "s": s, "steps": np.array(sorted(meshes))}
    for k, (fine, coarse, eta2) in meshes.items():
        arrays.update({f"p{k}": fine.p, f"t{k}": fine.t, f"pc{k}": coarse.p,
                       f"tc{k}": coarse.t, f"eta2_{k}": eta2})
    save_arrays(npz_path, **arrays)
    df = pd.DataFrame(rows)
    write_table(with_provenance(df), table_path)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.wildcards.problem, snakemake.params.config,  # noqa: F821
         snakemake.params.config["quadrature"], snakemake.output.table,  # noqa: F821
         snakemake.output.npz, snakemake.threads)  # noqa: F821
