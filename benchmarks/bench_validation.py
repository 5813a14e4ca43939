"""Cost of the mesh check next to assembly, and of refusing a dense problem that cannot fit.

    python benchmarks/bench_validation.py [--assembly-level 5] [--levels 5 6 7 8]

Prints, per disk_uniform level, the seconds of validate_mesh (best of 5) and, for
``--assembly-level``, of stiffness_matrix; then the seconds to build
disk_uniform(8) and to have stiffness_matrix refuse it (check included).
"""
from __future__ import annotations

import argparse
import time


def best(f, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main(levels, assembly_level):
    import fracfem as ff
    from fracfem.memory import DenseMemoryError
    from fracfem.meshes import validate_mesh

    ff.stiffness_matrix(ff.disk_uniform(1), 0.5)              # load cached kernels
    for level in levels:
        m = ff.disk_uniform(level)
        tv = best(lambda: validate_mesh(m.p, m.t), 5)
        line = f"disk_uniform({level}): {m.p.shape[1]:7d} nodes, validate_mesh {tv * 1e3:8.2f} ms"
        if level == assembly_level:
            ta = best(lambda: ff.stiffness_matrix(m, 0.5), 2)
            line += f", stiffness_matrix {ta:.2f} s (check = {tv / ta:.1e} of assembly)"
        print(line)
    t0 = time.perf_counter()
    m = ff.disk_uniform(8)
    t_mesh = time.perf_counter() - t0
    t0 = time.perf_counter()
    try:
        ff.stiffness_matrix(m, 0.5)
    except DenseMemoryError as err:
        t_refuse = time.perf_counter() - t0
        print(f"disk_uniform(8) built in {t_mesh:.2f} s; stiffness_matrix refused it in "
              f"{t_refuse:.3f} s:\n  {err}")
    else:
        print("disk_uniform(8) fits into the memory of this machine: nothing refused")


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--levels", type=int, nargs="+", default=[5, 6, 7, 8])
    ap.add_argument("--assembly-level", type=int, default=5)
    args = ap.parse_args()
    main(args.levels, args.assembly_level)
