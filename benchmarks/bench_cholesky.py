"""Dense Cholesky at large n: SciPy's ``cho_factor`` beside fracfem's blocked one.

OpenBLAS's threaded dpotrf crashes with SIGSEGV on large matrices (here from n ≈ 23,000
on 2 threads). Each case runs in a child process, so that a crash is recorded as such:
the child builds a symmetric positive definite matrix (1e-3·(G + Gᵀ) for G of N(0, 1)
entries, its diagonal raised by 1e-3·n + 1), factorises it with one method and solves
A x = b. Per case: n, the method, seconds of the factorisation and of the solve, the
relative residual ‖Ax − b‖/‖b‖, the memory the factorisation and the solve add, the child's
peak resident memory, and how it ended ("ok", or the signal).

    python benchmarks/bench_cholesky.py --n 16000 22500 23170 28203 --md benchmarks/cholesky.md
"""
from __future__ import annotations

import argparse
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _tables import markdown, write  # noqa: E402

CHILD = """
import json, resource, sys, time
import numpy as np, scipy.linalg as la
from fracfem.solvers import cho_factor

def rss_mb():
    with open("/proc/self/statm") as fh:
        return int(fh.read().split()[1]) * resource.getpagesize() / 2 ** 20

def peak_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

n, method = int(sys.argv[1]), sys.argv[2]
rng = np.random.default_rng(0)
A = np.empty((n, n))
for i in range(0, n, 1024):                  # by rows: no second n × n array
    A[i:i + 1024] = rng.standard_normal((min(1024, n - i), n))
for i in range(0, n, 1024):                  # A + Aᵀ, tile by tile
    for j in range(i, n, 1024):
        T = A[i:i + 1024, j:j + 1024] + A[j:j + 1024, i:i + 1024].T
        A[i:i + 1024, j:j + 1024] = T
        A[j:j + 1024, i:i + 1024] = T.T
A *= 1e-3
A[np.diag_indices(n)] += n * 1e-3 + 1.0
b = rng.standard_normal(n)
# each method's own order, so that it factorises in place: LAPACK's column-major for SciPy,
# row-major for the blocked one
work = np.asfortranarray(A) if method == "scipy" else A.copy()
before = rss_mb()
t = time.perf_counter()
if method == "scipy":
    c = la.cho_factor(work, lower=True, overwrite_a=True)
else:
    c = cho_factor(work, overwrite_a=True, blocked_n=0)
factor_s = time.perf_counter() - t
after_factor = peak_mb()
t = time.perf_counter()
x = la.cho_solve(c, b)
solve_s = time.perf_counter() - t
res = float(np.linalg.norm(A @ x - b) / np.linalg.norm(b))
print(json.dumps(dict(factor_s=factor_s, solve_s=solve_s, relative_residual=res,
                      matrix_mb=8.0 * n * n / 2 ** 20,
                      factor_extra_mb=max(after_factor - before, 0.0),
                      solve_extra_mb=max(peak_mb() - after_factor, 0.0),
                      child_peak_mb=peak_mb())))
"""

COLUMNS = ["rows", "factorisation", "exit", "factor_s", "solve_s", "relative_residual",
           "matrix_mb", "factor_extra_mb", "solve_extra_mb", "child_peak_mb"]


def run(n: int, method: str) -> dict:
    proc = subprocess.run([sys.executable, "-c", CHILD, str(n), method],
                          capture_output=True, text=True)
    row = dict(rows=n, factorisation=method)
    if proc.returncode == 0:
        row.update(json.loads(proc.stdout.strip().splitlines()[-1]), exit="ok")
    elif proc.returncode < 0:
        row["exit"] = signal.Signals(-proc.returncode).name
    else:
        row["exit"] = f"exit {proc.returncode}: {proc.stderr.strip().splitlines()[-1]}"
    return row


def cell(value, column):
    if value is None:
        return "–"
    if column in ("factor_s", "solve_s"):
        return f"{value:.2f}"
    if column == "relative_residual":
        return f"{value:.1e}"
    if column.endswith("_mb"):
        return f"{value:,.0f}"
    if column == "rows":
        return f"{value:,}"
    return str(value)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, nargs="+", default=[4000, 8000])
    ap.add_argument("--md", type=Path)
    ap.add_argument("--csv", type=Path)
    args = ap.parse_args(argv)
    import numpy as np
    import scipy
    load = os.getloadavg()[0]
    rows = []
    for n in args.n:
        for method in ("scipy", "blocked"):
            rows.append(run(n, method))
            print(rows[-1], flush=True)
    threads = os.environ.get("OPENBLAS_NUM_THREADS", f"{os.cpu_count()} (all cores)")
    head = ("# Dense Cholesky at large n\n\n"
            f"`python benchmarks/bench_cholesky.py --n {' '.join(map(str, args.n))}`, "
            f"{time.strftime('%Y-%m-%d')}, 1-minute load average {load:.1f} at the start, "
            f"OpenBLAS threads: {threads}; NumPy {np.__version__}, SciPy {scipy.__version__}. "
            "`scipy`: scipy.linalg.cho_factor (LAPACK dpotrf); `blocked`: "
            "fracfem.solvers.cho_factor's blocked path (block "
            "fracfem.solvers.CHOLESKY_BLOCK), which fracfem takes above "
            "fracfem.solvers.BLOCKED_CHOLESKY_N rows. `exit`: ok, or the signal that ended "
            "the child process. Each factorises in place (SciPy a column-major copy of A, "
            "the blocked one a row-major copy); A is kept for the residual, so "
            "`child_peak_mb` holds two matrices besides what the factorisation and the "
            "solve add.\n\n")
    table = head + markdown(rows, COLUMNS, cell)
    print(table)
    write(rows, COLUMNS, table, args.csv, args.md)


if __name__ == "__main__":
    main()
