"""One product of the compressed stiffness operator, part by part.

Every Krylov iteration of an elliptic solve and of every time step of
Algorithm C is one product ``op @ x``.  On uniform disks ``disk_uniform(level)``,
s = 0.6 (Example 5's order), the default tolerance and leaves: seconds of one
product (median of ``--repeat``) with

* ``reference_product_s``: the element sources and leaf kernels
  (:meth:`fracfem.CompressedOperator.far_matvec_reference`, scipy's one-thread
  near-field product), BLAS on one thread in the coupling;
* ``before_s``: the same with BLAS threading each call inside the numba
  threads — the product as it was before the leaf matrix and the BLAS limit;
* ``product_s``: the operator as built (leaf matrix, near field on all threads);

and the parts of the latter: ``near_field_s``, ``far_field_s`` and, within the far field,
``couple_s`` (the coupling of the admissible blocks) with BLAS on one thread
(as the operator runs it) and ``couple_blas_threads_s`` with BLAS on its own
default number of threads inside the numba threads.  ``product_rel_diff`` is
|product − reference| / |reference| (round-off: the same sums in another
order); ``leaf_matrix_mb`` the leaf matrix's share of ``nbytes_mb``.

    python benchmarks/bench_matvec.py --levels 5 6 7 --md benchmarks/matvec.md

``column_in_block_<k>_s``: seconds per column of ``op @ X`` for a block X of columns
taken k at a time (:meth:`fracfem.CompressedOperator._matmat`, as the error measurements
of the parabolic runs apply the reference's operator; 1: one product per column), and
``block_used_<k>`` the block the operator used (at most k: its far-field work arrays are
held within ``compressed.MATMAT_BYTES``), and ``block_rel_diff`` the largest relative
difference from the products column by column.

Each level runs after compiling every kernel on a small mesh; the load
average is recorded before and after each level.
"""
from __future__ import annotations

import argparse
import contextlib
import datetime
import os
import time

import numpy as np
import pandas as pd


def _median_s(fn, x, repeat):
    fn(x)
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn(x)
        ts.append(time.perf_counter() - t0)
    return float(np.median(ts))


def _block_columns(op, blocks, repeat) -> dict:
    """Seconds per column of ``op @ X`` (X of 2·max(blocks) columns) in blocks of each
    size k of ``blocks`` (compressed.MATMAT_COLUMNS = k; 1: column by column; the block
    the operator used, at most k within its memory bound: ``block_used_<k>``), and the
    largest relative difference of a block's product from the products column by
    column."""
    from fracfem import compressed

    X = np.random.default_rng(2).standard_normal((op.shape[0], 2 * max(blocks)))
    single = np.column_stack([op @ X[:, j] for j in range(X.shape[1])])
    out, diff = {}, 0.0
    keep = compressed.MATMAT_COLUMNS
    try:
        for k in blocks:
            compressed.MATMAT_COLUMNS = k
            out[f"block_used_{k}"] = op.matmat_block()
            out[f"column_in_block_{k}_s"] = _median_s(
                (lambda Y: np.column_stack([op @ Y[:, j] for j in range(Y.shape[1])]))
                if k == 1 else op.matmat, X, repeat) / X.shape[1]
            if k > 1:
                diff = max(diff, float(np.linalg.norm(op.matmat(X) - single)
                                       / np.linalg.norm(single)))
    finally:
        compressed.MATMAT_COLUMNS = keep
    return {**out, "block_rel_diff": diff}


def measure(level: int, s: float, repeat: int, blocks=(1, 8, 32)) -> dict:
    import numba
    from threadpoolctl import threadpool_limits

    import fracfem as ff
    from fracfem import _h2_kernels as hk
    from fracfem import compressed

    small = ff.stiffness_operator(ff.disk_uniform(3), s, leaf_size=8)
    small @ np.ones(small.shape[0])
    load0 = os.getloadavg()[0]
    op = ff.stiffness_operator(ff.disk_uniform(level), s)
    x = np.random.default_rng(0).standard_normal(op.shape[0])

    def reference(v):
        return op.near @ v + op.far_matvec_reference(v)

    ref, new = reference(x), op @ x
    f = op._far
    nc = len(f["tgt"]["boxes"])
    W = np.random.default_rng(1).standard_normal((nc, 2, len(f["z"]) ** 2))
    nth = numba.get_num_threads()

    def couple(_):
        return hk.couple_grouped(W, f["K"], f["grp_ptr"], f["grp_rows"], f["grp_cols"],
                                 nc, nth).sum(axis=0)

    with threadpool_limits(1, "blas"):
        couple_1 = _median_s(couple, None, repeat)
    with threadpool_limits(None, "blas"):
        couple_n = _median_s(couple, None, repeat)
    limit = compressed._blas_one_thread
    compressed._blas_one_thread = contextlib.nullcontext      # BLAS as it comes
    try:
        before = _median_s(reference, x, repeat)
    finally:
        compressed._blas_one_thread = limit
    return dict(level=level, dofs=op.shape[0], far_blocks=op.info["far_blocks"],
                before_s=before, reference_product_s=_median_s(reference, x, repeat),
                product_s=_median_s(op.matvec, x, repeat),
                near_field_s=_median_s(op.near_matvec, x, repeat),
                far_field_s=_median_s(op.far_matvec, x, repeat),
                couple_s=couple_1, couple_blas_threads_s=couple_n,
                product_rel_diff=float(np.linalg.norm(new - ref) / np.linalg.norm(ref)),
                nbytes_mb=op.nbytes / 2**20,
                leaf_matrix_mb=compressed._csr_bytes(op.leaf_matrix) / 2**20,
                **_block_columns(op, blocks, repeat),
                load=f"{load0:.1f}-{os.getloadavg()[0]:.1f}")


def numba_threads() -> int:
    import numba
    return numba.get_num_threads()


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--levels", type=int, nargs="+", default=[5, 6, 7])
    ap.add_argument("--s", type=float, default=0.6)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--blocks", type=int, nargs="+", default=[1, 8, 32],
                    help="block sizes of the products of several columns (1: one by one)")
    ap.add_argument("--md", default=None)
    args = ap.parse_args(argv)
    if not 0.0 < args.s < 1.0:
        raise SystemExit(f"--s={args.s} must lie in (0, 1)")
    if args.repeat < 1:
        raise SystemExit(f"--repeat={args.repeat} must be a positive count")
    if min(args.blocks) < 1:
        raise SystemExit(f"--blocks={args.blocks} must be positive column counts")
    rows = []
    for level in args.levels:
        rows.append(measure(level, args.s, args.repeat, sorted(set(args.blocks))))
        print(rows[-1], flush=True)
    df = pd.DataFrame(rows)
    df["product_speedup"] = df["before_s"] / df["product_s"]
    if args.md:
        with open(args.md, "w") as fh:
            fh.write("# One product of the compressed operator\n\n")
            fh.write(f"`python benchmarks/bench_matvec.py --levels "
                     f"{' '.join(map(str, args.levels))} --md {args.md}`: uniform disks, "
                     f"s = {args.s}, default tolerance and leaves, median of {args.repeat} "
                     f"products; {os.cpu_count()} cores, {numba_threads()} numba threads, "
                     f"{datetime.date.today()}.\n\n")
            fh.write("before_s: the product before the leaf matrix and the BLAS limit "
                     "(element sources and leaf kernels, scipy's one-thread near-field "
                     "product, BLAS threading each call inside the numba threads); "
                     "reference_product_s: the same with BLAS on one thread; product_s: the "
                     "operator as built (leaf matrix, sparse products on all threads), split "
                     "into near_field_s and far_field_s; couple_s: the coupling of the "
                     "admissible blocks with BLAS on one thread, couple_blas_threads_s: "
                     "with BLAS threading each call; product_rel_diff: |product − "
                     "reference| / |reference|; column_in_block_<k>_s: seconds per "
                     "column of the product of a block of columns, k at a time "
                     "(CompressedOperator._matmat; 1: column by column), block_used_<k>: "
                     "the block it used (at most k, within its memory bound), "
                     "block_rel_diff: "
                     "its largest relative difference from the products column by column; "
                     "product_speedup: before_s / product_s; "
                     "load: 1-minute load average before-after.\n\n")
            fh.write(df.to_markdown(index=False, floatfmt=".4g"))
            fh.write("\n")
    print(df.to_string(index=False))


if __name__ == "__main__":
    main()
