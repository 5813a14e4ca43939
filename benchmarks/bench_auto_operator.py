"""Where ``operator="auto"`` should switch from the dense matrix to the compressed operator:
assembly and solve of (−Δ)ˢu = f, both ways, on the meshes the pipeline's 'auto' jobs see.

    python benchmarks/bench_auto_operator.py [--threads 1] [--md benchmarks/auto-operator.md]
        [--csv benchmarks/auto-operator.csv]

Meshes: the uniform family (disk_uniform), the anisotropic graded family
(disk_graded_aniso), and the adaptive meshes of Algorithm B for Example 1 (graded towards
the boundary by its indicators) and for Example 2's fine mesh (refined at the free
boundary), made here with the compressed operator. The measurements run after
fracfem's warm-up (numba's kernels loaded), without the operator cache, with the
pipeline's threads per job (numba and BLAS: 1). ``u_rel_diff`` is
max |u_dense − u_compressed| / max |u_dense|: the two agree to the compression's
accuracy, so the choice is one of cost alone. This is one solve per operator, as in
Algorithm B; a time-stepping job factorises its dense matrix once for all its steps,
so its crossover can lie higher.
"""
from __future__ import annotations

import argparse
import re
import time
from pathlib import Path

import numpy as np

COLUMNS = ["mesh_kind", "dofs", "dense_total_s", "compressed_total_s",
           "dense_over_compressed", "u_rel_diff"]


def _time(mesh, s, f, operator):
    from fracfem.laplace import discretise, solve_laplace
    t0 = time.perf_counter()
    u = solve_laplace(discretise(mesh, s, f, operator=operator))
    return time.perf_counter() - t0, u


def _steps(make, f, max_dofs, **options):
    """The (fine) meshes of Algorithm B's steps up to the first with max_dofs DOFs."""
    from fracfem import adaptive, disk_uniform
    out = []
    for rec in adaptive.algorithm_b_steps(make, disk_uniform(2), theta=0.5, steps=30,
                                          marking="maximum", f=f, **options):
        out.append(rec.mesh)
        if rec.dofs >= max_dofs:
            break
    return out


def meshes(max_dofs):
    """(name, mesh, s, f) of every measured mesh, up to about max_dofs free nodes."""
    import fracfem as ff
    quad = ff.QuadratureOptions()
    ex1 = ff.Example1(0.5)
    out = []
    for level in (4, 5, 6):
        m = ff.disk_uniform(level)
        if len(m.interior_nodes()) <= max_dofs:
            out.append((f"uniform L{level}", m, 0.5, 1.0))
    for h in (0.1, 0.05, 0.035):
        out.append((f"graded h{h:g}", ff.disk_graded_aniso(h, 2.0), 0.5, 1.0))
    steps = _steps(lambda m: ex1.problem(m, quad, operator="compressed"), ex1.f, max_dofs)
    out += [(f"Example 1 Algorithm B step {k}", m, 0.5, ex1.f)
            for k, m in enumerate(steps) if len(m.interior_nodes()) >= 400]
    ex2 = ff.example("ex2", s=0.5, height=1.0, slope=4.0)
    steps = _steps(lambda c: ex2.problem(c, quad, operator="compressed"), ex2.f, max_dofs,
                   solver="pdas")
    out += [(f"Example 2 Algorithm B step {k} (fine mesh)", m, 0.5, 1.0)
            for k, m in enumerate(steps) if len(m.interior_nodes()) >= 400]
    return [o for o in out if len(o[1].interior_nodes()) <= max_dofs]


def main(threads, max_dofs):
    import numba
    from threadpoolctl import threadpool_limits

    import fracfem as ff
    from fracfem.warmup import warm_up
    numba.set_num_threads(threads)
    rows = []
    with threadpool_limits(threads), ff.operator_cache(None):
        warm_up()                                   # kernels loaded, not timed
        for name, mesh, s, f in meshes(max_dofs):
            td, ud = _time(mesh, s, f, "dense")
            tc, uc = _time(mesh, s, f, "compressed")
            rows.append({"mesh_kind": name, "dofs": len(mesh.interior_nodes()),
                         "dense_total_s": td, "compressed_total_s": tc,
                         "dense_over_compressed": td / tc,
                         "u_rel_diff": float(np.abs(ud - uc).max() / np.abs(ud).max())})
            print(rows[-1], flush=True)
    return sorted(rows, key=lambda r: (re.sub(r" step \d+", "", r["mesh_kind"])
                                       if "step" in r["mesh_kind"]
                                       else r["mesh_kind"].split()[0], r["dofs"]))


def _cell(v, c):
    if c in ("mesh_kind", "dofs"):
        return f"{v:,}" if c == "dofs" else str(v)
    if c == "u_rel_diff":
        return f"{v:.1e}"
    return f"{v:.2f}"


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--max-dofs", type=int, default=8100)
    ap.add_argument("--md", type=Path)
    ap.add_argument("--csv", type=Path)
    args = ap.parse_args()
    from _tables import markdown, write

    import os
    import sys
    load = os.getloadavg()[0]
    rows = main(args.threads, args.max_dofs)
    head = (f"`python benchmarks/bench_auto_operator.py {' '.join(sys.argv[1:])}`: seconds "
            "to assemble and solve (−Δ)ˢu = f (s = 0.5) with the dense matrix (Cholesky) "
            "and with the compressed operator (multilevel-preconditioned CG), "
            f"{args.threads} numba and BLAS thread(s), each case once; 1-minute load "
            f"average {load:.1f} before the first case and {os.getloadavg()[0]:.1f} after "
            "the last (2 cores). fracfem.laplace.AUTO_DENSE_NODES is set from this table."
            "\n\n")
    write(rows, COLUMNS, head + markdown(rows, COLUMNS, _cell), args.csv, args.md)
    print(markdown(rows, COLUMNS, _cell))
