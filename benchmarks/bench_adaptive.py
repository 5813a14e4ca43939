"""Algorithm B at scale: adaptive series with the compressed operator.

Example 1 (f = 1, exact energy) or Example 2 (obstacle χ = 1 − 4|x|², PDAS with
inner Krylov solves) from disk_uniform(2), the paper's marking η(Δ) > θ·η_max,
until a step has at least ``--max-dofs`` free nodes.  Operator "auto" (dense up to
``fracfem.laplace.AUTO_DENSE_NODES`` free nodes, compressed above) and pointwise
(−Δ)ˢu_h "auto" (compressed from ``fracfem.pointwise.AUTO_PAIRS`` point–edge pairs), so
no N × N matrix is formed at the large steps.  Per step: DOFs, multipliers, η, energy
(and for Example 1 the energy error), PDAS steps, seconds of assembly, solve
and estimate, the cumulative wall time and the peak RSS so far.

    python benchmarks/bench_adaptive.py --example ex2 --max-dofs 100000 \\
        --csv benchmarks/adaptive.csv --md benchmarks/adaptive.md
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import sys
import time
from pathlib import Path

import numpy as np

import _tables

COLUMNS = ["example", "tag", "dofs", "multipliers", "eta", "energy", "error",
           "pdas_steps", "assembly_s", "solve_s", "estimate_s", "cumulative_s",
           "peak_rss_mb"]


def run(example: str, s: float, theta: float, max_dofs: int, max_steps: int):
    import fracfem as ff
    from fracfem import adaptive

    ex = ff.example(example, s=s)
    rows = []
    t0 = time.perf_counter()
    steps = adaptive.algorithm_b_steps(
        lambda mesh: ex.problem(mesh, operator="auto"), ff.disk_uniform(2), theta=theta,
        steps=max_steps, marking="maximum", solver="pdas", f=ex.f,
        estimator_options={"method": "auto"})
    for rec in steps:
        err = None
        if example == "ex1":
            # ‖u − u_h‖²_a = 2(E(u_h) − E(u)) (Galerkin orthogonality)
            err = float(np.sqrt(max(2.0 * (rec.energy - ex.exact_energy), 0.0)))
        row = dict(example=example, tag=f"step{rec.step}", dofs=rec.dofs,
                   multipliers=rec.n_multipliers, eta=rec.eta, energy=rec.energy,
                   error=err, pdas_steps=rec.info.get("iterations", ""),
                   assembly_s=rec.timings.get("assemble"), solve_s=rec.timings.get("solve"),
                   estimate_s=rec.timings.get("estimate"),
                   cumulative_s=time.perf_counter() - t0,
                   peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
        rows.append(row)
        print(json.dumps(row), flush=True)
        if rec.dofs >= max_dofs:
            steps.close()
            break
    return rows


def _cell(v, col: str = "") -> str:
    if v is None or v == "":
        return ""
    if col == "energy":
        return f"{v:.8f}"
    if isinstance(v, float):
        return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.4g}"
    return f"{v:,}" if isinstance(v, int) else str(v)


def markdown(rows: list[dict]) -> str:
    cols = [c for c in COLUMNS if any(r.get(c) not in (None, "") for r in rows)]
    return _tables.markdown(rows, cols, _cell)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--example", choices=["ex1", "ex2"], default="ex2")
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--theta", type=float, default=0.5)
    ap.add_argument("--max-dofs", type=int, default=100_000)
    ap.add_argument("--max-steps", type=int, default=60)
    ap.add_argument("--csv", type=Path)
    ap.add_argument("--md", type=Path)
    args = ap.parse_args(argv)
    load = os.getloadavg()
    rows = run(args.example, args.s, args.theta, args.max_dofs, args.max_steps)
    from fracfem.laplace import AUTO_DENSE_NODES
    intro = (f"Algorithm B, {args.example} (s = {args.s}, θ = {args.theta}, marking "
             f"η(Δ) > θ·η_max, from disk_uniform(2)), operator 'auto' (compressed "
             f"above {AUTO_DENSE_NODES:,} free nodes) and pointwise (−Δ)ˢu_h 'auto', "
             f"each solve started from the previous step's solution (warm_start): "
             f"`python benchmarks/bench_adaptive.py {' '.join(argv or sys.argv[1:])}`. "
             f"1-minute load average {load[0]:.1f} before the first step and "
             f"{os.getloadavg()[0]:.1f} after the last (2 cores); peak_rss_mb is the "
             "largest so far.\n\n")
    table = intro + markdown(rows)
    print(table)
    _tables.write(rows, COLUMNS, table, args.csv, args.md)


if __name__ == "__main__":
    main()
