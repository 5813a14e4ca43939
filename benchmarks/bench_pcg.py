"""PCG with the multilevel preconditioner: Example 1 (f = 1 on the unit disk) on
uniform, graded and anisotropic graded disks, for several s.

Per case: free nodes (DOFs), s, PCG iterations to the relative residual 1e-10,
the condition estimate of the preconditioned operator (extreme Ritz values from
the CG coefficients), preconditioner setup seconds and solve seconds; with
``--jacobi-max N`` also the iterations and condition estimate with the diagonal
alone, up to N DOFs.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_pcg.py --uniform 5 6 7 \\
        --graded 0.14 --aniso 0.05 0.025 --s 0.25 0.5 0.75 --jacobi-max 8100 \\
        --md benchmarks/pcg.md
"""
from __future__ import annotations

import argparse
import os
import time
from pathlib import Path

import numpy as np

MESHES = {"uniform": "disk_uniform({})", "graded": "disk_graded({})",
          "aniso": "disk_graded_aniso({}, 2.0)"}


def run_case(family: str, size, s: float, jacobi_max: int) -> dict:
    import fracfem as ff
    from fracfem.compressed import stiffness_operator
    from fracfem.krylov import jacobi, pcg

    mesh = {"uniform": lambda: ff.disk_uniform(int(size)),
            "graded": lambda: ff.disk_graded(float(size)),
            "aniso": lambda: ff.disk_graded_aniso(float(size), 2.0)}[family]()
    t0 = time.perf_counter()
    op = stiffness_operator(mesh, s)
    assembly = time.perf_counter() - t0
    b = ff.load_vector(mesh, 1.0)[mesh.interior_nodes()]
    t1 = time.perf_counter()
    M = ff.multilevel_preconditioner(mesh, op)
    setup = time.perf_counter() - t1
    _, st = pcg(op, b, M=M, tol=1e-10, maxiter=2000)
    row = dict(mesh=MESHES[family].format(size), dofs=op.shape[0], s=s,
               iterations=st["iterations"], condition=st["condition"],
               setup_s=setup, solve_s=st["seconds"], assembly_s=assembly,
               grid_levels=len(M.levels), order=M.order)
    if op.shape[0] <= jacobi_max:
        _, sj = pcg(op, b, M=jacobi(op.diagonal()), tol=1e-10, maxiter=5000)
        row.update(jacobi_iterations=sj["iterations"], jacobi_condition=sj["condition"])
    return row


def markdown(rows: list[dict], load: str) -> str:
    lines = ["# PCG with the multilevel preconditioner",
             "",
             "Example 1 (f = 1, unit disk), compressed operator, PCG to the relative "
             "residual 1e-10.",
             "Condition: the extreme Ritz values of the preconditioned operator from "
             "the CG coefficients.",
             "preconditioner_s: setting up the preconditioner; jacobi_*: the diagonal "
             "alone (up to the DOFs given by `--jacobi-max`).",
             f"Measured with `NUMBA_NUM_THREADS={os.environ.get('NUMBA_NUM_THREADS', '')}` "
             f"on a shared 2-core machine under load ({load}); the seconds are "
             "indicative only.",
             "",
             "| mesh | dofs | s | iterations | condition | preconditioner_s | solve_s "
             "| jacobi_iterations | jacobi_condition |",
             "|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        jit = r.get("jacobi_iterations")
        jac = (f"{jit} | {r['jacobi_condition']:.1f}" if jit is not None else "– | –")
        lines.append(f"| `{r['mesh']}` | {r['dofs']:,} | {r['s']} | {r['iterations']} | "
                     f"{r['condition']:.2f} | {r['setup_s']:.1f} | {r['solve_s']:.1f} | {jac} |")
    return "\n".join(lines) + "\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uniform", type=int, nargs="*", default=[5, 6])
    ap.add_argument("--graded", type=float, nargs="*", default=[])
    ap.add_argument("--aniso", type=float, nargs="*", default=[])
    ap.add_argument("--s", type=float, nargs="+", default=[0.25, 0.5, 0.75])
    ap.add_argument("--jacobi-max", type=int, default=0)
    ap.add_argument("--md", type=Path)
    args = ap.parse_args(argv)
    cases = ([("uniform", lv) for lv in args.uniform] + [("graded", h) for h in args.graded]
             + [("aniso", h) for h in args.aniso])
    rows, loads = [], []
    for family, size in cases:
        for s in args.s:
            loads.append(os.getloadavg()[0])
            rows.append(run_case(family, size, s, args.jacobi_max))
            r = rows[-1]
            print(f"{r['mesh']:28s} {r['dofs']:7d} s={s:<5} it={r['iterations']:4d} "
                  f"cond={r['condition']:7.2f} setup={r['setup_s']:6.1f}s "
                  f"solve={r['solve_s']:6.1f}s jacobi={r.get('jacobi_iterations', '-')}",
                  flush=True)
    load = f"1-minute load average {min(loads):.1f}–{max(loads):.1f}"
    md = markdown(rows, load)
    print(md)
    if args.md:
        args.md.write_text(md)


if __name__ == "__main__":
    main()
