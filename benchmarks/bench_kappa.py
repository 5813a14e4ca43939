"""The exterior term κ of the compressed operator: its two trees' leaves.

The compressed operator's exterior part (``t_exterior``) evaluates
κ(x) = ∫_{Ωᶜ}|x − y|^(−2−2s) dy at every quadrature point of
:func:`fracfem.assembly._kappa_local` by :class:`fracfem.compressed.CompressedKappa`:
an H² sum over the Gauss points of the boundary edges (the source tree) at the
quadrature points (the target tree), the edges near a point summed directly.
On meshes refined toward ∂Ω (``boundary_refined(k)``, shape-regular as Algorithm
B's meshes for Example 1 are, ``disk_graded(h)``, and ``disk_graded_aniso(h)``,
thin at ∂Ω) most points lie near ∂Ω and hundreds lie in each element there.

For each mesh and each pair of leaf sizes (source × target, ``--leaves``):
``exterior_min_s``, the least seconds of the whole exterior part with that κ (at the
operator's order and admissibility: the default tolerance), and
``max_rel_err``, the largest relative difference from the direct sum
:func:`fracfem.assembly.exterior_kernel` over ``--sample`` of its points.

    NUMBA_NUM_THREADS=1 python benchmarks/bench_kappa.py --md benchmarks/kappa.md \
        --csv benchmarks/kappa.csv

(one numba thread, as the default tier runs its jobs; the defaults are the committed
table's meshes and leaves).

Each mesh runs after compiling every kernel on a small mesh; each setting runs
``--repeat`` times, the settings in turn, so that a drift of the machine's speed
reaches all of them alike: ``exterior_min_s`` is the least of its runs,
``exterior_max_s`` the most; the load average is recorded.
"""
from __future__ import annotations

import argparse
import datetime
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _tables import markdown, write  # noqa: E402

COLUMNS = ["mesh", "s", "dofs", "triangles", "boundary_edges", "points", "source_leaf",
           "target_leaf", "exterior_min_s", "exterior_max_s", "max_rel_err", "load"]


def boundary_refined(steps: int, closeness: float = 1.5):
    """``disk_uniform(2)`` refined (``refine_disk``, with its closure) ``steps`` times at
    the elements whose centroid lies within ``closeness`` diameters of the unit circle: a
    mesh like those of Algorithm B for Example 1, whose error concentrates at ∂Ω (at the
    same step, about as many triangles and boundary edges)."""
    from fracfem.meshes import disk_uniform, element_diameters, refine_disk

    mesh = disk_uniform(2)
    for _ in range(steps):
        cent = mesh.p[:, mesh.t].mean(axis=1)
        mesh = refine_disk(mesh, np.flatnonzero(1.0 - np.hypot(*cent)
                                                < closeness * element_diameters(mesh)))
    return mesh


def _leaves(text: str) -> tuple[int, int]:
    try:
        a, b = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"--leaves {text!r}: give source x target leaf sizes, e.g. 12x192") from None
    if not (1 <= a <= 4096 and 1 <= b <= 4096):
        raise argparse.ArgumentTypeError(f"--leaves {text!r}: sizes must lie in [1, 4096]")
    return a, b


class _Kept:
    """A κ whose values at every call are kept, in the order of the calls."""

    def __init__(self, kappa):
        self.kappa, self.values = kappa, []

    def __call__(self, x):
        self.values.append(self.kappa(x))
        return self.values[-1]


def measure(name, mesh, s, settings, sample, repeat, rng) -> list[dict]:
    from fracfem import compressed
    from fracfem.assembly import (QuadratureOptions, _boundary_edges, _element_geometry,
                                  _kappa_local, exterior_kernel, mesh_arrays)

    p, t = mesh_arrays(mesh)
    edges, bnodes = _boundary_edges(p, t)
    quad = QuadratureOptions()
    geometry = _element_geometry(p, t)
    points = []

    def record(x):
        points.append(np.array(x))
        return np.ones(len(x))

    _kappa_local(p, t, bnodes, edges, s, quad, geometry, kappa=record)
    x = np.vstack(points)
    idx = rng.choice(len(x), min(sample, len(x)), replace=False)
    exact = exterior_kernel(x[idx], edges, s)
    rows = [dict(mesh=name, s=s, dofs=len(mesh.interior_nodes()), triangles=len(t),
                 boundary_edges=len(edges), points=len(x), source_leaf=a, target_leaf=b,
                 runs=[], load0=os.getloadavg()[0]) for a, b in settings]
    for _ in range(repeat):                  # round robin: a drift of the machine's
        for row in rows:                     # speed reaches every setting alike
            kappa = _Kept(compressed.operator_kappa(
                edges, s, compressed.chebyshev_order(compressed.DEFAULT_TOL),
                compressed.DEFAULT_ETA, source_leaf=row["source_leaf"],
                target_leaf=row["target_leaf"]))
            t0 = time.perf_counter()
            _kappa_local(p, t, bnodes, edges, s, quad, geometry, kappa=kappa)
            row["runs"].append(time.perf_counter() - t0)
            # the values the timed part used (its calls come in the order recorded above)
            row["max_rel_err"] = float(np.max(np.abs(np.concatenate(kappa.values)[idx]
                                                     - exact) / exact))
    for row in rows:
        runs = row.pop("runs")
        row.update(exterior_min_s=min(runs), exterior_max_s=max(runs),
                   load=f"{row.pop('load0'):.1f}-{os.getloadavg()[0]:.1f}")
        print(row, flush=True)
    return rows


def _cell(v, col):
    if isinstance(v, float):
        return f"{v:.3g}" if col != "s" else f"{v:g}"
    return f"{v:,}" if isinstance(v, int) and col not in ("source_leaf", "target_leaf") \
        else str(v)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--refined", type=int, nargs="*", default=[4, 6, 8],
                    help="steps k of boundary_refined(k)")
    ap.add_argument("--graded", type=float, nargs="*", default=[],
                    help="mesh sizes h of disk_graded(h) (shape-regular)")
    ap.add_argument("--aniso", type=float, nargs="*", default=[0.0127],
                    help="mesh sizes h of disk_graded_aniso(h) (thin triangles at ∂Ω)")
    ap.add_argument("--uniform", type=int, nargs="*", default=[6, 7],
                    help="levels of disk_uniform(level)")
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--leaves", type=_leaves, nargs="+",
                    default=[(24, 24), (12, 96), (12, 192)],
                    help="source x target leaf sizes")
    ap.add_argument("--sample", type=int, default=20000,
                    help="points compared with the direct sum")
    ap.add_argument("--repeat", type=int, default=3,
                    help="timed runs of each setting, in turn")
    ap.add_argument("--csv", type=Path, default=None)
    ap.add_argument("--md", type=Path, default=None)
    args = ap.parse_args(argv)
    if not 0.0 < args.s < 1.0:
        raise SystemExit(f"--s={args.s} must lie in (0, 1)")
    for level in args.uniform:
        if not 1 <= level <= 8:
            raise SystemExit(f"--uniform {level} must lie in [1, 8]")
    if args.repeat < 1:
        raise SystemExit(f"--repeat={args.repeat} must be a positive count")
    if args.sample < 1:
        raise SystemExit(f"--sample={args.sample} must be a positive count")
    for k in args.refined:
        if not 0 <= k <= 12:
            raise SystemExit(f"--refined {k} must lie in [0, 12]")
    for h in args.graded + args.aniso:
        if not 0.001 <= h <= 0.5:
            raise SystemExit(f"--graded/--aniso {h} must lie in [0.001, 0.5]")

    import numba

    import fracfem as ff
    from fracfem import compressed

    small = ff.disk_uniform(3)
    ff.stiffness_operator(small, args.s)          # compiles every kernel
    rng = np.random.default_rng(0)
    meshes = [(f"boundary_refined({k})", lambda k=k: boundary_refined(k)) for k in args.refined]
    meshes += [(f"disk_graded({h:g})", lambda h=h: ff.disk_graded(h)) for h in args.graded]
    meshes += [(f"disk_graded_aniso({h:g})", lambda h=h: ff.disk_graded_aniso(h))
               for h in args.aniso]
    meshes += [(f"disk_uniform({L})", lambda L=L: ff.disk_uniform(L)) for L in args.uniform]
    rows = []
    for name, make in meshes:
        rows += measure(name, make(), args.s, args.leaves, args.sample, args.repeat, rng)
    table = markdown(rows, COLUMNS, _cell)
    cmd = ("python benchmarks/bench_kappa.py"
           + f" --refined {' '.join(map(str, args.refined))}"
           + (f" --graded {' '.join(f'{h:g}' for h in args.graded)}" if args.graded else "")
           + (f" --aniso {' '.join(f'{h:g}' for h in args.aniso)}" if args.aniso else "")
           + (f" --uniform {' '.join(map(str, args.uniform))}" if args.uniform else "")
           + f" --s {args.s:g} --leaves {' '.join(f'{a}x{b}' for a, b in args.leaves)}"
           + f" --sample {args.sample} --repeat {args.repeat}")
    head = (f"# The exterior term κ: leaves of its trees\n\n`{cmd}`: "
            f"{os.cpu_count()} cores, {numba.get_num_threads()} numba threads, "
            f"{datetime.date.today()}.\n\n"
            "The operator's defaults: source leaf "
            f"{compressed.KAPPA_SOURCE_LEAF}, target leaf {compressed.KAPPA_TARGET_LEAF}. "
            f"exterior_min_s, exterior_max_s: least and most seconds of {args.repeat} runs "
            "of the exterior part of the assembly with that κ (the settings in turn); "
            "max_rel_err: largest |κ − direct sum| / direct sum over a random sample "
            f"of at most {args.sample} of κ's values in the timed part; points: κ's "
            "points in the part; "
            "load: 1-minute load average before-after. Source and target leaves 24 were "
            "κ's before it had leaves of its own (the operator's).\n\n")
    write(rows, COLUMNS, head + table, args.csv, args.md)
    print(table)


if __name__ == "__main__":
    main()
