"""One Example 1 run: mesh → matrix → solve → one tidy row and the solution."""
import time

import numba
import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.meshes import mesh_size
from fracfem_workflow.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("ex1_solve")


def main(family, tag, s, grading, quadrature, row, npz, log=None, threads=None,
         operator="dense"):
    """operator: 'dense', 'compressed' or 'auto' (dense up to 2,000 free nodes, compressed
    above; the row's ``operator`` is the one used)."""
    start(log, threads)
    quad = ff.QuadratureOptions(**quadrature)
    example = ff.Example1(s)
    t0 = time.perf_counter()
    mesh = ff.series_mesh(tag, grading)
    t_mesh = time.perf_counter() - t0
    logger.info("ex1 %s s=%g %s: %d triangles, %d free nodes; assembling", family, example.s,
                tag, mesh.t.shape[1], len(mesh.interior_nodes()))
    disc = example.problem(mesh, quad, operator=operator)
    u = ff.solve_laplace(disc)
    fu = float(disc.b @ u)
    exact = ff.disk_energy(example.s)
    err2 = exact - fu
    if not err2 > 0:
        raise RuntimeError(f"Galerkin bound violated: (f,u_h)={fu!r} >= (f,u)={exact!r}; "
                           "quadrature error exceeds the discretisation error")
    result = {
        "example": 1, "family": family, "s": example.s, "tag": tag, "grading": grading,
        "dofs": len(disc.free), "triangles": mesh.t.shape[1], "h_max": mesh_size(mesh),
        "fu_h": fu, "fu_exact": exact, "error": np.sqrt(err2),
        "t_mesh": t_mesh, "t_assembly": disc.timings["assembly"],
        "t_solve": disc.timings["solve"],
        "t_total": t_mesh + disc.timings["assembly"] + disc.timings["solve"],
        "threads": numba.get_num_threads(), "peak_mem_mb": peak_memory_mb(),
        "operator": disc.info["operator"],
        "pcg_iterations": disc.info.get("iterations", 0),   # 0: Cholesky
        **parameter_columns(quadrature=quad, operator_setting=operator), **provenance(),
    }
    logger.info("ex1 %s s=%g %s: %d dofs, %s operator, error %.4e, %.1f s", family, example.s,
                tag, result["dofs"], result["operator"], result["error"], result["t_total"])
    save_arrays(npz, p=mesh.p, t=mesh.t, u=disc.extend(u), s=example.s)
    write_table(pd.DataFrame([result]), row)


if __name__ == "__main__":
    main(snakemake.wildcards.family, snakemake.wildcards.tag,  # noqa: F821
         float(snakemake.wildcards.s), snakemake.params.grading,  # noqa: F821
         snakemake.params.quadrature, snakemake.output.row, snakemake.output.npz,  # noqa: F821
         snakemake.log[0], snakemake.threads, snakemake.params.operator)  # noqa: F821
