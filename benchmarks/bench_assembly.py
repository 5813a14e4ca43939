"""Assembly benchmark: DOFs, triangles, pairs, seconds, pairs/s, peak memory,
and the ratio to the kernel floor (one |x−y|^(−2−2s) per unordered element
pair in a parallel numba loop, measured in the same process).

    python benchmarks/bench_assembly.py --levels 3 4 5 6 [--s 0.5] [--csv F --md F]

Each level runs in its own process so that peak memory is per level.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time

import numpy as np


def run_level(level: int, s: float) -> dict:
    import numba

    import fracfem as ff
    from fracfem import _kernels
    from fracfem.assembly import mesh_arrays
    from fracfem_workflow.io import peak_memory_mb

    ff.stiffness_matrix(ff.disk_uniform(1), s)            # load cached kernels
    mesh = ff.disk_uniform(level)
    p, t = mesh_arrays(mesh)
    cent = np.ascontiguousarray(p[t].mean(axis=1))
    nch = numba.get_num_threads()
    _kernels.kernel_floor(cent, s, nch)
    t0 = time.perf_counter()
    _kernels.kernel_floor(cent, s, nch)
    floor = time.perf_counter() - t0
    tim: dict = {}
    ff.stiffness_matrix(mesh, s, timings=tim)
    nt = t.shape[0]
    pairs = nt * (nt - 1) // 2
    return {"level": level, "dofs": len(mesh.interior_nodes()), "triangles": nt,
            "pairs": pairs, "threads": nch, "floor_s": floor,
            "singular_s": tim["singular"], "far_s": tim["far"],
            "exterior_s": tim["exterior"], "assembly_s": tim["total"],
            "pairs_per_s": pairs / tim["total"], "ratio_to_floor": tim["total"] / floor,
            "peak_mem_mb": peak_memory_mb()}


def main(levels, s):
    import pandas as pd
    rows = []
    for level in levels:
        # the level's progress lines (stderr) go straight to this run's output
        out = subprocess.run([sys.executable, __file__, "--single", str(level), "--s", str(s)],
                             stdout=subprocess.PIPE, text=True, check=True)
        rows.append(json.loads(out.stdout.strip().splitlines()[-1]))
        print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return pd.DataFrame(rows)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[3, 4, 5, 6])
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--single", type=int, help=argparse.SUPPRESS)
    ap.add_argument("--csv")
    ap.add_argument("--md")
    args = ap.parse_args()
    from fracfem_workflow.logs import log_to_stderr
    log_to_stderr()
    if args.single is not None:
        print(json.dumps(run_level(args.single, args.s)))
        sys.exit(0)
    df = main(args.levels, args.s)
    fmt = df.round({"floor_s": 2, "singular_s": 2, "far_s": 2, "exterior_s": 2,
                    "assembly_s": 2, "ratio_to_floor": 1, "peak_mem_mb": 0})
    fmt["pairs_per_s"] = fmt["pairs_per_s"].map(lambda v: f"{v:.3g}")
    print(fmt.to_string(index=False))
    if args.csv:
        from fracfem_workflow.io import write_table
        write_table(df, args.csv)
    if args.md:
        from fracfem_workflow.io import atomic_path
        with atomic_path(args.md) as tmp:
            tmp.write_text(fmt.to_markdown(index=False) + "\n")
