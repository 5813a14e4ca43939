"""Obstacle benchmark with the compressed operator: Example 2 by PDAS with inner
Krylov solves, no dense matrix.

Example 2: (−Δ)^s u ≥ 1 above χ(x) = 1 − 4|x|² on the unit disk, s = 0.5, in the
mixed form (u P1 on T_h = T_H refined, λ_H P0 on T_H = disk_uniform(L)).  Per
level: free nodes (DOFs), multipliers, assembly seconds, preconditioner seconds,
PDAS steps, inner PCG iterations (total and per solve), solve seconds, memory of
the operator and peak RSS of the process; up to ``--dense-check`` the dense PDAS
(Cholesky factor and Schur complement) on the same mesh, and the differences.

    python benchmarks/bench_vi_compressed.py --levels 4 5 6 7 \\
        --csv benchmarks/vi_compressed.csv --md benchmarks/vi_compressed.md

Each level runs in its own process so that peak memory is per level.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import _tables

COLUMNS = ["level", "start", "coarse_s", "dofs", "multipliers", "order", "operator_mb", "assembly_s",
           "preconditioner_s", "pdas_steps", "inner_iterations", "inner_per_solve",
           "solve_s", "contact", "peak_rss_mb", "dense_solve_s", "du_rel", "dlam_rel"]


def run_level(level: int, s: float, tol: float, dense_check: int,
              nested: bool = False) -> dict:
    import fracfem as ff
    from fracfem import examples, vi

    chi = examples.paraboloid_obstacle(1.0, 4.0)
    vi.mixed_problem("obstacle", ff.disk_uniform(1), s, 1.0, chi=chi,
                     operator="compressed")  # load the cached kernels
    coarse = ff.disk_uniform(level)
    first = 2 if nested and level > 2 else level
    seen = {}

    def problems():
        # built lazily: solve_nested holds one operator at a time
        for k in range(first, level + 1):
            t = time.perf_counter()
            prob = vi.mixed_problem("obstacle", ff.disk_uniform(k), s, 1.0, chi=chi,
                                    operator="compressed", tol=tol)
            seen[k] = dict(assembly=time.perf_counter() - t, dofs=prob.disc.A.shape[0],
                           order=prob.disc.A.info["order"], mb=prob.disc.A.nbytes / 2**20,
                           timings=prob.timings)
            yield prob
            del prob          # before the next level is assembled

    t0 = time.perf_counter()
    t_coarse = 0.0
    levels = vi.solve_nested(problems(), "pdas")
    for k, (u, lam, info) in zip(range(first, level + 1), levels):
        if k == level - 1:
            t_coarse = time.perf_counter() - t0
    levels.close()                                      # the last operator goes too
    del levels
    fin = seen[level]
    solve = info["seconds_total"]                       # PDAS with its inner solves
    preconditioner = fin["timings"]["preconditioner"]
    assembly = fin["assembly"]
    inner = info["inner_iterations"]
    row = dict(level=level, start="nested" if first < level else "cold",
               coarse_s=t_coarse, dofs=fin["dofs"], multipliers=len(lam),
               order=fin["order"], operator_mb=fin["mb"],
               assembly_s=assembly, preconditioner_s=preconditioner,
               pdas_steps=info["iterations"], inner_iterations=int(sum(inner)),
               inner_per_solve=" ".join(map(str, inner)),
               solve_s=solve,
               contact=int(np.count_nonzero(lam < 0)),
               peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    if level <= dense_check:
        dense = vi.mixed_problem("obstacle", coarse, s, 1.0, chi=chi, operator="dense")
        t2 = time.perf_counter()
        ud, lamd, _ = vi.solve(dense, "pdas")
        row["dense_solve_s"] = time.perf_counter() - t2
        row["du_rel"] = float(np.abs(u - ud).max() / np.abs(ud).max())
        row["dlam_rel"] = float(np.abs(lam - lamd).max() / np.abs(lamd).max())
    return row


def _cell(v, col: str = "") -> str:
    if v is None:
        return ""
    return f"{v:.3g}" if isinstance(v, float) else str(v)


def markdown(rows: list[dict]) -> str:
    return _tables.markdown(rows, COLUMNS, _cell)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[4, 5, 6])
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--tol", type=float, default=1e-8, help="compression accuracy")
    ap.add_argument("--dense-check", type=int, default=4,
                    help="compare with the dense PDAS up to this level")
    ap.add_argument("--nested", action="store_true",
                    help="start each level from levels 2 … L−1 solved by nested iteration")
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--md", type=Path)
    ap.add_argument("--case", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case is not None:
        print(json.dumps(run_level(args.case, args.s, args.tol, args.dense_check,
                                   args.nested)))
        return
    rows = []
    load = os.getloadavg()
    for level in args.levels:
        out = subprocess.run([sys.executable, __file__, "--case", str(level), "--s",
                              str(args.s), "--tol", str(args.tol), "--dense-check",
                              str(args.dense_check)] + (["--nested"] if args.nested else []),
                             capture_output=True, text=True)
        if out.returncode:
            sys.stderr.write(out.stderr)
            raise SystemExit(f"level {level} failed")
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(json.dumps(rows[-1]), flush=True)
    table = markdown(rows)
    print(table)
    start = "nested iteration from level 2 (`vi.solve_nested`)" if args.nested \
        else "λ_H = 0 (cold)"
    intro = (f"Example 2 (obstacle, s = {args.s}, f = 1, χ = 1 − 4|x|²) by PDAS with the "
             f"compressed operator (tol {args.tol:g}), each level started by {start}: "
             f"`python benchmarks/bench_vi_compressed.py {' '.join(argv or sys.argv[1:])}`. "
             f"1-minute load average {load[0]:.1f} before the first level and "
             f"{os.getloadavg()[0]:.1f} after the last (2 cores). du_rel, dlam_rel: "
             "max-norm differences to the dense PDAS on the same mesh (compression error "
             "included); coarse_s: the levels below, assembled and solved.\n\n")
    _tables.write(rows, COLUMNS, intro + table, args.csv, args.md)


if __name__ == "__main__":
    main()
