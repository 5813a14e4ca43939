"""One Example 1 run: mesh → matrix → solve → one tidy row and the solution."""
import logging
import time

import numba
import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.io import peak_memory_mb, provenance, save_arrays, write_table
from fracfem.meshes import mesh_size


def make_mesh(family, tag, grading):
    if family == "uniform":
        return ff.disk_uniform(int(tag[1:]))
    return ff.disk_graded(float(tag[1:]), grading)


def main(family, s, tag, grading, quadrature, row_path, npz_path, threads, config):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    s = float(s)
    t0 = time.perf_counter()
    mesh = make_mesh(family, tag, grading)
    t_mesh = time.perf_counter() - t0
    disc = ff.discretise(mesh, s, 1.0, quadrature=ff.QuadratureOptions(**quadrature))
    u = ff.solve_laplace(disc)
    fu = float(disc.b @ u)
    exact = ff.disk_energy(s)
    err2 = exact - fu
    if not err2 > 0:
        raise RuntimeError(f"Galerkin bound violated: (f,u_h)={fu!r} >= (f,u)={exact!r}; "
                           "quadrature error exceeds the discretisation error")
    row = {
        "example": 1, "family": family, "s": s, "tag": tag, "grading": grading,
        "dofs": len(disc.free), "triangles": mesh.t.shape[1], "h_max": mesh_size(mesh),
        "fu_h": fu, "fu_exact": exact, "error": np.sqrt(err2),
        "t_mesh": t_mesh, "t_assembly": disc.timings["assembly"],
        "t_solve": disc.timings["solve"],
        "t_total": t_mesh + disc.timings["assembly"] + disc.timings["solve"],
        "threads": numba.get_num_threads(), "peak_mem_mb": peak_memory_mb(),
        **provenance(config),
    }
    logging.info("ex1 %s s=%g %s: %d dofs, error %.4e, %.1f s", family, s, tag,
                 row["dofs"], row["error"], row["t_total"])
    save_arrays(npz_path, p=mesh.p, t=mesh.t, u=disc.extend(u), s=s)
    write_table(pd.DataFrame([row]), row_path)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.wildcards.family, snakemake.wildcards.s, snakemake.wildcards.tag,  # noqa: F821
         snakemake.params.grading, snakemake.params.quadrature, snakemake.output.row,  # noqa: F821
         snakemake.output.npz, snakemake.threads, snakemake.params.config)  # noqa: F821
