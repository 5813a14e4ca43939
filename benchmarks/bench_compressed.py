"""Compressed operator benchmark: Example 1 (f = 1 on the unit disk, exact energy)
on uniform disks and 2-graded disks (the paper's anisotropic family,
``disk_graded_aniso``, and the shape-regular ``disk_graded``), for several s.

Per case: free nodes, assembly seconds (by phase), matvec seconds, memory of the
representation (nbytes) and peak RSS of the process, PCG iterations and solve
seconds (multilevel preconditioner, relative residual 1e-10), the energy error
‖u − u_h‖_a = √((f, u) − (f, u_h)), and, where the dense matrix fits (up to
8,065 free nodes), the relative matvec and energy differences to it.

    python benchmarks/bench_compressed.py --uniform 5 6 7 8 --graded 0.0045 --s 0.25 0.5 0.75 \\
        --csv benchmarks/compressed.csv --md benchmarks/compressed.md
    python benchmarks/bench_compressed.py --uniform --graded 0.0127 0.0064 0.0045 --s 0.5 \\
        --csv benchmarks/compressed-graded.csv --md benchmarks/compressed-graded.md \\
        --summary paper-figures/benchmark-scale.md

``--from-csv`` rewrites the summary from a committed CSV without running anything.

Each case runs in its own process so that peak memory is per case.  The
PyNucleus figures (benchmarks/pynucleus-reference.csv) were measured with
PyNucleus on this kind of machine (2 cores) and are printed beside ours.
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

DENSE_CHECK_NODES = 8100


def run_case(family: str, size: float, s: float) -> dict:
    import fracfem as ff
    from fracfem.compressed import stiffness_operator

    ff.discretise(ff.disk_uniform(2), s, operator="compressed")  # load cached kernels
    mesh = {"uniform": lambda: ff.disk_uniform(int(size)),
            "graded": lambda: ff.disk_graded_aniso(size),
            "graded-sr": lambda: ff.disk_graded(size)}[family]()
    t0 = time.perf_counter()
    disc = ff.discretise(mesh, s, operator="compressed")
    assembly = time.perf_counter() - t0
    op = disc.A
    x = np.random.default_rng(0).standard_normal(op.shape[0])
    op @ x
    t1 = time.perf_counter()
    for _ in range(3):
        op @ x
    matvec = (time.perf_counter() - t1) / 3
    u = ff.solve_laplace(disc)
    fu = float(disc.b @ u)
    exact = ff.disk_energy(s)
    row = dict(family=family, size=size, s=s, dofs=op.shape[0], order=op.info["order"],
               assembly_s=assembly, matvec_s=matvec,
               solve_s=disc.timings["solve"], iterations=disc.info["iterations"],
               nbytes_mb=op.nbytes / 2**20, f_u=fu,
               error=float(np.sqrt(max(exact - fu, 0.0))),
               **{f"t_{k}": v for k, v in op.info["timings"].items()})
    if op.shape[0] <= DENSE_CHECK_NODES:
        t2 = time.perf_counter()
        dense = ff.discretise(mesh, s, operator="dense")
        row["dense_assembly_s"] = time.perf_counter() - t2
        A = dense.A
        row["matvec_rel_diff"] = float(np.linalg.norm(op @ x - A @ x) / np.linalg.norm(A @ x))
        fud = float(dense.b @ np.linalg.solve(A, dense.b))
        row["energy_rel_diff"] = abs(fu - fud) / fud
    row["peak_rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    return row


def growth_table(df):
    """Exponents k of N^k of time (assembly + solve) and peak RSS between
    consecutive sizes of each family and s."""
    import pandas as pd
    out = []
    for (fam, s), g in df.groupby(["family", "s"], sort=False):
        g = g.sort_values("dofs")
        for (_, a), (_, b) in zip(g.iterrows(), g.iloc[1:].iterrows()):
            ln = np.log(b.dofs / a.dofs)
            out.append(dict(family=fam, s=s, dofs_from=int(a.dofs), dofs_to=int(b.dofs),
                            time_exponent=np.log((b.assembly_s + b.solve_s)
                                                 / (a.assembly_s + a.solve_s)) / ln,
                            rss_exponent=np.log(b.peak_rss_mb / a.peak_rss_mb) / ln))
    return pd.DataFrame(out)


def summary(df, source: str) -> str:
    """One sentence on the largest case and the growth up to it, for the README."""
    big = df.loc[df.dofs.idxmax()]
    mesh = {"uniform": f"disk_uniform({int(big['size'])})",
            "graded": f"disk_graded_aniso({big['size']:g})",
            "graded-sr": f"disk_graded({big['size']:g})"}[big.family]
    text = (f"Example 1, s = {big.s:g}, `{mesh}`, {int(big.dofs):,} unknowns: assembly "
            f"{big.assembly_s:.0f} s + PCG {big.solve_s:.0f} s ({int(big.iterations)} "
            f"iterations) on 2 cores, {big.peak_rss_mb / 1024:.1f} GiB peak, error "
            f"{big.error:.2g}")
    g = growth_table(df[(df.family == big.family) & (df.s == big.s)])
    if len(g):
        text += (f"; time ∝ N^{g.time_exponent.min():.2f}–{g.time_exponent.max():.2f}, "
                 f"memory ∝ N^{g.rss_exponent.min():.2f}–{g.rss_exponent.max():.2f} from "
                 f"{int(g.dofs_from.min()):,} unknowns")
    return text + f" (`{source}`).\n"


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--uniform", type=int, nargs="*", default=[5, 6, 7])
    ap.add_argument("--graded", type=float, nargs="*", default=[],
                    help="h of anisotropic 2-graded disks (disk_graded_aniso)")
    ap.add_argument("--graded-sr", type=float, nargs="*", default=[],
                    help="h of shape-regular 2-graded disks (disk_graded)")
    ap.add_argument("--s", type=float, nargs="+", default=[0.25, 0.5, 0.75])
    ap.add_argument("--csv")
    ap.add_argument("--md")
    ap.add_argument("--summary", help="write a one-sentence summary (Markdown) here")
    ap.add_argument("--from-csv", help="no runs: read the cases from this CSV "
                                       "(for --summary)")
    ap.add_argument("--case", nargs=3, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.from_csv:
        import pandas as pd
        if not args.summary:
            ap.error("--from-csv needs --summary")
        Path(args.summary).write_text(summary(pd.read_csv(args.from_csv), args.from_csv))
        return
    from fracfem_workflow.logs import log_to_stderr
    log_to_stderr()
    if args.case:
        fam, size, s = args.case
        print(json.dumps(run_case(fam, float(size), float(s))))
        return
    import pandas as pd
    rows = []
    load = os.getloadavg()
    cases = ([("uniform", lv) for lv in args.uniform] + [("graded", h) for h in args.graded]
             + [("graded-sr", h) for h in args.graded_sr])
    for fam, size in cases:
        for s in args.s:
            # the case's progress lines (stderr) go straight to this run's output
            out = subprocess.run([sys.executable, __file__, "--case", fam, str(size), str(s)],
                                 stdout=subprocess.PIPE, text=True, check=True)
            row = json.loads(out.stdout.strip().splitlines()[-1])
            rows.append(row)
            print(f"{fam:8s} {size:6g} s={s:4.2f} dofs={row['dofs']:7d} "
                  f"assembly={row['assembly_s']:7.1f}s matvec={row['matvec_s']:.3f}s "
                  f"it={row['iterations']:3d} solve={row['solve_s']:6.1f}s "
                  f"mem={row['nbytes_mb']:7.0f}MB rss={row['peak_rss_mb']:7.0f}MB "
                  f"err={row['error']:.4f}", flush=True)
    df = pd.DataFrame(rows)
    if args.summary:
        Path(args.summary).write_text(summary(df, args.csv or args.md or "this run"))
    if args.csv:
        df.to_csv(args.csv, index=False)
    if args.md:
        ref = pd.read_csv(Path(__file__).with_name("pynucleus-reference.csv"))
        cols = ["family", "size", "s", "dofs", "assembly_s", "matvec_s", "iterations",
                "solve_s", "nbytes_mb", "peak_rss_mb", "error"]
        extra = [c for c in ("matvec_rel_diff", "energy_rel_diff") if c in df]
        with open(args.md, "w") as fh:
            fh.write("# Compressed operator, Example 1\n\n")
            fh.write(f"`python benchmarks/bench_compressed.py {' '.join(argv or sys.argv[1:])}`"
                     f"; 1-minute load average {load[0]:.1f} before the first case and "
                     f"{os.getloadavg()[0]:.1f} after the last (2 cores).\n\n")
            fh.write(df[cols + extra].to_markdown(index=False, floatfmt=".4g"))
            phases = [c for c in df if c.startswith("t_") and c != "t_total"]
            fh.write("\n\nAssembly phases, seconds:\n\n")
            fh.write(df[["family", "size", "s", "dofs"] + phases]
                     .to_markdown(index=False, floatfmt=".4g"))
            growth = growth_table(df)
            if len(growth):
                fh.write("\n\nGrowth between consecutive sizes of one family and s: "
                         "the exponent k of N^k.\n\n")
                fh.write(growth.to_markdown(index=False, floatfmt=".3g"))
            fh.write("\n\n## PyNucleus, same problem (s = 0.5, uniform disk)\n\n")
            fh.write(ref.to_markdown(index=False, floatfmt=".4g"))
            fh.write("\n")


if __name__ == "__main__":
    main()
