"""Example 1 on adaptive meshes: Algorithm B, one row per step."""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import adaptive
from fracfem_workflow.io import peak_memory_mb, save_arrays, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("ex1_adaptive")


def main(s, theta, start_level, max_dofs, max_steps, quadrature, table, npz, log=None,
         threads=None, operator="dense"):
    """operator: 'dense', 'compressed' or 'auto' (dense up to 2,000 free nodes); npz: the
    last step's mesh and u_h, or None (not written)."""
    start(log, threads, operator_cache=False)   # its own meshes; it times each step
    quad = ff.QuadratureOptions(**quadrature)
    example = ff.Example1(s)
    exact = ff.disk_energy(example.s)
    rows, t_start = [], time.perf_counter()

    def record(rec):
        err2 = exact - rec.load_dot_u
        marked = np.asarray([] if rec.marked is None else rec.marked, dtype=int)
        # where the step refines: the marked triangle nearest the disk's centre
        inner = (np.hypot(*rec.mesh.p[:, rec.mesh.t[:, marked]].mean(axis=1)).min()
                 if len(marked) else np.nan)
        if not err2 > 0:
            raise RuntimeError(f"Galerkin bound violated at step {rec.step}: (f,u_h) >= (f,u)")
        rows.append({
            "example": 1, "family": "adaptive", "s": example.s, "tag": f"step{rec.step}",
            "dofs": rec.dofs, "triangles": rec.n_triangles, "h_max": rec.h_max,
            "h_min": rec.h_min, "fu_h": rec.load_dot_u, "fu_exact": exact,
            "error": np.sqrt(err2), "eta": rec.eta, "efficiency": rec.eta / np.sqrt(err2),
            "marked": -1 if rec.marked is None else len(marked),
            "innermost marked radius": inner,
            "t_assembly": rec.timings.get("assemble", np.nan),
            "t_solve": rec.timings.get("solve", np.nan),
            "t_estimate": rec.timings.get("estimate", np.nan),
            "t_total": sum(rec.timings.values()),
            "t_cumulative": time.perf_counter() - t_start,
            "peak_mem_mb": peak_memory_mb()})
        logger.info("adaptive step %d: %d dofs, error %.4e, eta %.4e, efficiency %.3f",
                    rec.step, rec.dofs, rows[-1]["error"], rec.eta, rows[-1]["efficiency"])
        return rec.dofs >= max_dofs

    recs = adaptive.algorithm_b(lambda mesh: example.problem(mesh, quad, operator=operator),
                                ff.disk_uniform(start_level), theta=theta, steps=max_steps,
                                marking="maximum", f=example.f, callback=record)
    last = recs[-1]
    if npz is not None:
        save_arrays(npz, p=last.mesh.p, t=last.mesh.t, u=last.u, s=example.s)
    df = pd.DataFrame(rows).assign(**parameter_columns(
        quadrature=quad, theta=theta, marking="maximum", start_level=start_level,
        max_dofs=max_dofs, operator=operator))
    write_table(with_provenance(df), table)


if __name__ == "__main__":
    main(float(snakemake.wildcards.s), snakemake.params.theta,  # noqa: F821
         snakemake.params.start_level, snakemake.params.max_dofs,  # noqa: F821
         snakemake.params.max_steps, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.table, snakemake.output.get("npz"), snakemake.log[0],  # noqa: F821
         snakemake.threads, snakemake.params.operator)  # noqa: F821
