"""Pointwise (−Δ)ˢu_h at the quadrature points: dense against compressed path.

On uniform disks ``disk_uniform(level)``, u_h the P1 interpolant of the
Example 1 solution C_s(1 − |x|²)^s (set to zero at the boundary nodes),
values of (−Δ)ˢu_h at the
points of ``triangle_rule(order)`` on every element
(:func:`fracfem.pointwise.fractional_laplacian_qp`).  Per level: points,
mesh edges, seconds of the dense path (run only while the previous level's
time scaled by the ratio of point–edge pairs stays below ``--dense-limit``,
else extrapolated that way and marked so) and of the compressed path (with
its phases), their largest difference relative to max|values| where both
ran, and the peak RSS of each run's process.

    python benchmarks/bench_pointwise.py --levels 4 5 6 7 8 --md benchmarks/pointwise.md

Each run is its own process (peak RSS per run); the load average of the
machine is recorded before and after every run.
"""
from __future__ import annotations

import argparse
import json
import logging
import os
import re
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from bench_validation import best      # this script's folder is on sys.path


def run_case(level: int, method: str, s: float, order: int, tol: float, out: str) -> dict:
    import fracfem as ff
    from fracfem.exact import disk_solution
    from fracfem.pointwise import fractional_laplacian_qp, normal_derivative_jumps

    small = ff.disk_uniform(4)          # loads (or compiles) every kernel of the path
    fractional_laplacian_qp(small, disk_solution(small.p, s), s, order, method=method)
    mesh = ff.disk_uniform(level)
    u = disk_solution(mesh.p, s)
    u[mesh.boundary_nodes()] = 0.0      # as a discrete solution (round-off leaves ~1e-8)
    phases = {}

    class Phases(logging.Handler):
        def emit(self, record):
            m = re.search(r"trees ([\d.]+) s, far field ([\d.]+) s, near field ([\d.]+) s",
                          record.getMessage())
            if m:
                phases.update(trees_s=float(m[1]), far_field_s=float(m[2]),
                              near_field_s=float(m[3]))

    logger = logging.getLogger("fracfem.pointwise")
    logger.setLevel(logging.INFO)
    logger.addHandler(Phases())
    load0 = os.getloadavg()[0]
    t0 = time.perf_counter()
    vals, pts, _ = fractional_laplacian_qp(mesh, u, s, order, method=method, tol=tol)
    seconds = time.perf_counter() - t0
    np.save(out, vals)
    edges = normal_derivative_jumps(mesh, u)[0]
    return dict(level=level, method=method, dofs=len(mesh.interior_nodes()),
                points=int(vals.size), edges=len(edges), seconds=seconds,
                peak_rss_mb=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                load_before=load0, load_after=os.getloadavg()[0], **phases)


def sample_case(level: int, s: float, order: int, n: int, out: str) -> dict:
    """The dense path at n random points of the rule (seed 0), for levels
    where it is too slow on all of them: values at a point do not depend on
    the other points."""
    import fracfem as ff
    from fracfem.exact import disk_solution
    from fracfem.pointwise import fractional_laplacian_at, quadrature_points

    mesh = ff.disk_uniform(level)
    u = disk_solution(mesh.p, s)
    u[mesh.boundary_nodes()] = 0.0
    pts, _, _ = quadrature_points(mesh, order)
    nq = pts.shape[1]
    idx = np.sort(np.random.default_rng(0).choice(pts.shape[0] * nq, n, replace=False))
    t0 = time.perf_counter()
    vals = fractional_laplacian_at(mesh, u, pts.reshape(-1, 2)[idx], idx // nq, s,
                                   method="dense")
    np.save(out, np.column_stack([idx, vals]))
    return dict(seconds=time.perf_counter() - t0)


def crossover(s_values=(0.5, 0.3), repeat: int = 3) -> list[dict]:
    """Dense and compressed seconds (best of ``repeat``) on small meshes and
    for few points on a large one: where "auto" should switch."""
    import fracfem as ff
    from fracfem.exact import disk_solution
    from fracfem.pointwise import (fractional_laplacian_at, fractional_laplacian_qp,
                                   quadrature_points)

    cases = [(lv, order, None) for lv in (3, 4, 5) for order in (2, 4)]
    cases += [(6, 4, n) for n in (1000, 4000)]
    small = ff.disk_uniform(4)
    rows = []
    for s in s_values:
        for meth in ("dense", "compressed"):
            fractional_laplacian_qp(small, disk_solution(small.p, s), s, 4, method=meth)
        for lv, order, n in cases:
            mesh = ff.disk_uniform(lv)
            u = disk_solution(mesh.p, s)
            u[mesh.boundary_nodes()] = 0.0
            pts, _, _ = quadrature_points(mesh, order)
            nq = pts.shape[1]
            idx = np.arange(pts.shape[0] * nq)
            if n is not None:
                idx = np.sort(np.random.default_rng(0).choice(idx, n, replace=False))
            x, el = pts.reshape(-1, 2)[idx], idx // nq
            sec = {m: best(lambda m=m: fractional_laplacian_at(mesh, u, x, el, s, method=m),
                           repeat) for m in ("dense", "compressed")}
            edges = mesh.facets.shape[1]
            rows.append(dict(s=s, level=lv, rule_order=order, points=len(idx), edges=edges,
                             point_edge_pairs=float(len(idx) * edges), dense_s=sec["dense"],
                             compressed_s=sec["compressed"],
                             speedup=sec["dense"] / sec["compressed"]))
            print(rows[-1], flush=True)
    return rows


def write_md(path, args, rows, cross, start_load, t_start):
    """The tables so far (rewritten after every level: a stopped run keeps them)."""
    import pandas as pd

    end_load = os.getloadavg()
    df = pd.DataFrame(rows)
    prev = df["compressed_s"].shift(1)
    df["compressed_growth"] = (df["compressed_s"] / prev).round(2)
    df["points_growth"] = (df["points"] / df["points"].shift(1)).round(2)
    cols = ["level", "dofs", "points", "edges", "dense_s", "compressed_s",
            "near_field_s", "far_field_s", "trees_s", "compressed_growth", "points_growth",
            "max_rel_diff", "dense_rss_mb", "compressed_rss_mb", "load"]
    with open(path, "w") as fh:
        fh.write("# Pointwise (−Δ)ˢu_h: dense and compressed path\n\n")
        fh.write(
            f"`python benchmarks/bench_pointwise.py --levels "
            f"{' '.join(map(str, args.levels))}{' --crossover' if args.crossover else ''} "
            f"--md {path}`: uniform disks, "
            f"s = {args.s}, points of the order-{args.order} triangle rule, u_h the "
            f"P1 interpolant of the Example 1 solution, tol = {args.tol:g}; "
            f"{os.cpu_count()} cores, {time.strftime('%Y-%m-%d', time.gmtime(t_start))}."
            "\n\nMachine load (1-minute load average; the machine is shared with "
            "other jobs, so seconds are wall times inflated by them): "
            f"{start_load[0]:.1f} / {start_load[1]:.1f} / {start_load[2]:.1f} "
            f"(1, 5, 15 min) at the start, {end_load[0]:.1f} / {end_load[1]:.1f} / "
            f"{end_load[2]:.1f} at the end; column `load` gives it before-after "
            "each run (compressed, then dense).\n\n"
            "dense_s: the dense path (every point against every edge); where it was "
            "not run, the last measured dense time scaled by the ratio of "
            "point–edge pairs. compressed_s: the compressed path, of which "
            "near_field_s (point–edge pairs of near blocks by the dense rules), "
            "far_field_s (H² "
            "passes) and trees_s (cluster and block trees, sources); "
            "compressed_growth and points_growth: ratios to the previous level. "
            "max_rel_diff: max|compressed − dense| / max|dense|; where the dense "
            "path was not run on all points, at that many random points (seed 0) "
            "relative to max|compressed| over all points, with the dense path's "
            "seconds for them. *_rss_mb: peak resident memory of the run's process."
            "\n\n")
        fh.write(df[cols].to_markdown(index=False, floatfmt=".4g"))
        fh.write("\n")
        if cross is not None:
            fh.write(
                "\n## Where \"auto\" switches\n\n"
                "Both paths on the same points in one process, best of 3 "
                "(`--crossover`): every point of the order-2 and order-4 rules on "
                "disk_uniform(3…5), and 1,000 or 4,000 random points of the order-4 "
                "rule on disk_uniform(6), for s = 0.5 (inverse square root) and "
                "s = 0.3 (exp/log). `fractional_laplacian_at(..., method=\"auto\")` "
                "takes the compressed path from `AUTO_PAIRS` point–edge pairs on.\n\n")
            cdf = pd.DataFrame(cross)
            ints = ["level", "rule_order", "points", "edges"]
            cdf[ints] = cdf[ints].astype(str)      # else printed as floats
            fh.write(cdf.to_markdown(index=False, floatfmt=".4g"))
            fh.write("\n")


def _case(level, method, args, out):
    if method == "sample":
        cmd = [sys.executable, __file__, "--sample", str(level), str(args.s),
               str(args.order), str(args.samples), out]
    elif method == "crossover":
        cmd = [sys.executable, __file__, "--crossover-case"]
    else:
        cmd = [sys.executable, __file__, "--case", str(level), method, str(args.s),
               str(args.order), str(args.tol), out]
    res = subprocess.run(cmd, capture_output=True, text=True)
    if res.returncode:
        raise RuntimeError(f"{' '.join(cmd)} failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[4, 5, 6, 7])
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--order", type=int, default=4)
    ap.add_argument("--tol", type=float, default=1e-8)
    ap.add_argument("--dense-limit", type=float, default=120.0,
                    help="run the dense path while its predicted seconds stay below this")
    ap.add_argument("--samples", type=int, default=2000,
                    help="points at which the dense path checks levels it does not run on")
    ap.add_argument("--crossover", action="store_true",
                    help="also time both paths on small meshes (where 'auto' switches)")
    ap.add_argument("--md")
    ap.add_argument("--case", nargs=6, help=argparse.SUPPRESS)
    ap.add_argument("--sample", nargs=5, help=argparse.SUPPRESS)
    ap.add_argument("--crossover-case", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.case:
        lv, meth, s, order, tol, out = args.case
        print(json.dumps(run_case(int(lv), meth, float(s), int(order), float(tol), out)))
        return
    if args.sample:
        lv, s, order, n, out = args.sample
        print(json.dumps(sample_case(int(lv), float(s), int(order), int(n), out)))
        return
    if args.crossover_case:
        print(json.dumps(crossover()))
        return
    rows = []
    last_dense = None                  # (seconds, pairs) of the last dense run
    start_load = os.getloadavg()
    t_start = time.time()
    with tempfile.TemporaryDirectory() as tmp:
        for lv in args.levels:
            comp = _case(lv, "compressed", args, f"{tmp}/c{lv}.npy")
            pairs = comp["points"] * comp["edges"]
            row = dict(level=lv, dofs=comp["dofs"], points=comp["points"],
                       edges=comp["edges"], compressed_s=comp["seconds"],
                       trees_s=comp.get("trees_s"), far_field_s=comp.get("far_field_s"),
                       near_field_s=comp.get("near_field_s"),
                       compressed_rss_mb=comp["peak_rss_mb"],
                       load=f"{comp['load_before']:.1f}-{comp['load_after']:.1f}")
            predicted = None if last_dense is None else last_dense[0] * pairs / last_dense[1]
            if predicted is None or predicted <= args.dense_limit:
                dense = _case(lv, "dense", args, f"{tmp}/d{lv}.npy")
                last_dense = (dense["seconds"], pairs)
                d, c = np.load(f"{tmp}/d{lv}.npy"), np.load(f"{tmp}/c{lv}.npy")
                row.update(dense_s=f"{dense['seconds']:.4g}",
                           dense_rss_mb=dense["peak_rss_mb"],
                           max_rel_diff=f"{np.abs(c - d).max() / np.abs(d).max():.3g}",
                           load=row["load"] + f", {dense['load_before']:.1f}"
                                              f"-{dense['load_after']:.1f}")
            else:
                sample = _case(lv, "sample", args, f"{tmp}/s{lv}.npy")
                idx, d = np.load(f"{tmp}/s{lv}.npy").T
                c = np.load(f"{tmp}/c{lv}.npy").reshape(-1)
                row.update(dense_s=f"~{predicted:.4g} (extrapolated)", dense_rss_mb=np.nan,
                           max_rel_diff=f"{np.abs(c[idx.astype(int)] - d).max() / np.abs(c).max():.3g}"
                                        f" ({args.samples} points, {sample['seconds']:.0f} s)")
            rows.append(row)
            if args.md:
                write_md(args.md, args, rows, None, start_load, t_start)
            print(f"level {lv}: {row['points']} points, {row['edges']} edges, "
                  f"dense {row['dense_s']} s, compressed {row['compressed_s']:.2f} s "
                  f"(near {row['near_field_s']:.2f}, far {row['far_field_s']:.2f}, "
                  f"trees {row['trees_s']:.2f}), diff {row['max_rel_diff']}, "
                  f"rss {row['compressed_rss_mb']:.0f} MB, load {row['load']}", flush=True)
        cross = _case(0, "crossover", args, "") if args.crossover else None
    if args.md:
        write_md(args.md, args, rows, cross, start_load, t_start)


if __name__ == "__main__":
    main()
