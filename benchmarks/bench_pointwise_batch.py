"""Pointwise (−Δ)ˢu_h of K functions on one mesh: K calls against one batched call.

Algorithm C evaluates (−Δ)ˢu^k at the quadrature points of every time step of a
slab, all on the slab's mesh; :func:`fracfem.pointwise.fractional_laplacian_qp`
with u of shape (Nv, K) computes the kernel values, trees and near-field rules
once for the K columns.  On uniform disks ``disk_uniform(level)``, s = 0.6 (the
exp/log kernel, as in Example 5), the order-4 rule (Algorithm C's), the
compressed path and K functions u_r(x) = (1 − |x|²)^s cos(r x₁) (zero on the
boundary): seconds of K single calls, of one batched call, their ratio, and
max over r of |batched − single| / max|single|.

    python benchmarks/bench_pointwise_batch.py --levels 6 7 --K 1 4 7 16 --md benchmarks/pointwise-batch.md

Each level runs in one process after compiling every kernel on a small mesh;
single calls are timed once each (the batched call too); the load average is
recorded before and after each level.
"""
from __future__ import annotations

import argparse
import datetime
import os
import time

import numpy as np
import pandas as pd


def functions(mesh, s, K):
    x = mesh.p
    r2 = np.minimum(np.sum(x ** 2, axis=0), 1.0)
    U = np.column_stack([(1.0 - r2) ** s * np.cos(r * x[0]) for r in range(K)])
    U[mesh.boundary_nodes()] = 0.0
    return U


def measure(level: int, Ks, s: float, order: int) -> list[dict]:
    import fracfem as ff
    from fracfem.pointwise import fractional_laplacian_qp

    small = ff.disk_uniform(3)              # compiles every kernel of both shapes
    for K in (1, 2):
        fractional_laplacian_qp(small, functions(small, s, K)[:, 0] if K == 1
                                else functions(small, s, K), s, order, method="compressed")
    mesh = ff.disk_uniform(level)
    rows = []
    U = functions(mesh, s, max(Ks))
    singles, single_s = [], []
    for K in sorted(Ks):
        load0 = os.getloadavg()[0]
        while len(singles) < K:
            t0 = time.perf_counter()
            singles.append(fractional_laplacian_qp(mesh, U[:, len(singles)], s, order,
                                                   method="compressed")[0])
            single_s.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        batch = fractional_laplacian_qp(mesh, U[:, :K], s, order, method="compressed")[0]
        batch_s = time.perf_counter() - t0
        diff = max(np.abs(batch[..., r] - singles[r]).max() / np.abs(singles[r]).max()
                   for r in range(K))
        rows.append(dict(level=level, dofs=len(mesh.interior_nodes()),
                         points=int(batch.shape[0] * batch.shape[1]), K=K,
                         singles_s=sum(single_s[:K]), batch_s=batch_s,
                         batch_speedup=sum(single_s[:K]) / batch_s,
                         batch_per_function_s=batch_s / K, batch_rel_diff=diff,
                         load=f"{load0:.1f}-{os.getloadavg()[0]:.1f}"))
        print(rows[-1], flush=True)
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[6, 7])
    ap.add_argument("--K", type=int, nargs="+", default=[1, 4, 7, 16])
    ap.add_argument("--s", type=float, default=0.6)
    ap.add_argument("--order", type=int, default=4)
    ap.add_argument("--md", default=None)
    args = ap.parse_args(argv)
    if min(args.K) < 1:
        raise SystemExit(f"--K must be positive counts, got {args.K}")
    rows = []
    for level in args.levels:
        rows += measure(level, args.K, args.s, args.order)
    df = pd.DataFrame(rows)
    if args.md:
        with open(args.md, "w") as fh:
            fh.write("# Pointwise (−Δ)ˢu_h of K functions: K calls against one batched call\n\n")
            fh.write(f"`python benchmarks/bench_pointwise_batch.py --levels "
                     f"{' '.join(map(str, args.levels))} --K {' '.join(map(str, args.K))} "
                     f"--md {args.md}`: uniform disks, s = {args.s}, points of the order-"
                     f"{args.order} triangle rule, compressed path, u_r = (1 − |x|²)^s "
                     f"cos(r x₁); {os.cpu_count()} cores, {datetime.date.today()}.\n\n")
            fh.write("singles_s: K calls with one function each; batch_s: one call with "
                     "u of shape (Nv, K); batch_speedup: their ratio; batch_rel_diff: max "
                     "over r of max|batched − single| / max|single| (the same rules and "
                     "trees: round-off); load: 1-minute load average before-after.\n\n")
            fh.write(df.to_markdown(index=False, floatfmt=".4g"))
            fh.write("\n")
    print(df.to_string(index=False))


if __name__ == "__main__":
    main()
