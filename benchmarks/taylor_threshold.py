"""Where the Taylor rule starts: near-field size against energy change.

The compressed operator puts a block in its far field only when every element
pair of it is at least R·h apart, R = ``QuadratureOptions.far_thresholds[0]``,
the separation ratio from which the assembly uses the Taylor-corrected centroid
rule (config.yaml: R = 8).  On locally refined meshes the clusters of coarse
elements then couple as near blocks with most of the domain.  This script
measures both sides of starting the Taylor rule at R = 4 instead (far_orders
(0, 4, 8), far_thresholds (4, 2)):

* near field: node pairs of the near blocks (the sparse matrix of the compressed
  operator), R = 8 against R = 4, on disk_uniform(6) and on disk_uniform(4)
  refined k times at the elements within 0.6·2^(1−k) of the circle r = 0.6 (the
  kind of mesh Algorithm C makes around Example 5's free boundary);
* accuracy: the energy (f, u_h) of Example 1 (f = 1 on the unit disk, exact
  energy known) with R = 8, with R = 4 and with every singular and near rule
  raised (QuadratureOptions.raised(keep_taylor=True): the Taylor rule kept for the
  farthest class, from R = 16 as every class's ratio doubles), compressed operator: the changes
  against the energy error E − E_h.

Counts and energies only (no timings).

    python benchmarks/taylor_threshold.py --md benchmarks/taylor-threshold.md
"""
from __future__ import annotations

import argparse
import datetime

import numpy as np
import pandas as pd

R8 = dict(far_orders=(0, 2, 4, 8), far_thresholds=(8.0, 4.0, 2.0))
R4 = dict(far_orders=(0, 4, 8), far_thresholds=(4.0, 2.0))


def refined(k: int):
    """disk_uniform(4) refined k times around the circle r = 0.6."""
    from fracfem import meshes
    from fracfem.adaptive import refine_disk
    m = meshes.disk_uniform(4)
    for j in range(k):
        c = m.p[:, m.t].mean(axis=1)
        r = np.hypot(c[0], c[1])
        m = refine_disk(m, np.flatnonzero(np.abs(r - 0.6) < 0.6 * 0.5 ** j))
    return m


def mesh_of(name: str):
    from fracfem import meshes
    if name.startswith("uniform"):
        return meshes.disk_uniform(int(name[len("uniform"):]))
    return refined(int(name[len("refined"):]))


def near_row(name: str) -> dict:
    from fracfem import compressed as C
    from fracfem.assembly import _element_geometry, mesh_arrays
    mesh = mesh_of(name)
    p, t = mesh_arrays(mesh)
    _, cent, diam = _element_geometry(p, t)
    tree = C.cluster_tree(cent, diam, C.DEFAULT_LEAF)
    row = dict(mesh=name, dofs=len(mesh.interior_nodes()), diam_min=diam.min(),
               h_max=diam.max())
    for R in (8.0, 4.0):
        _, near = C.block_tree(tree, tree, C.DEFAULT_ETA, R)
        row[f"near_nnz_R{R:g}"] = len(C._near_pattern(tree, near, t, len(p))[1])
    row["near_ratio"] = row["near_nnz_R8"] / row["near_nnz_R4"]
    row["near_share_R8"] = row["near_nnz_R8"] / len(p) ** 2
    return row


def energy_row(name: str, s: float) -> dict:
    import fracfem as ff
    mesh = mesh_of(name)
    q8 = ff.QuadratureOptions(**R8)
    quads = {"R8": q8, "R4": ff.QuadratureOptions(**R4),
             "raised": q8.raised(keep_taylor=True)}
    E = {}
    for key, q in quads.items():
        d = ff.discretise(mesh, s, quadrature=q, operator="compressed")
        E[key] = float(d.b @ ff.solve_laplace(d))
    err = ff.disk_energy(s) - E["R8"]
    return dict(mesh=name, s=s, dofs=len(mesh.interior_nodes()), energy_error=err,
                change_R4=abs(E["R4"] - E["R8"]), change_raised=abs(E["raised"] - E["R8"]),
                error_over_change_R4=abs(err) / abs(E["R4"] - E["R8"]))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--near", nargs="+", default=["uniform6", "refined2", "refined3",
                                                  "refined4", "refined5", "refined6"])
    ap.add_argument("--energy", nargs="+", default=["uniform5", "refined2"])
    ap.add_argument("--s", type=float, nargs="+", default=[0.2, 0.6, 0.9])
    ap.add_argument("--md", default=None)
    args = ap.parse_args(argv)
    for name in args.near + args.energy:
        if not (name.startswith(("uniform", "refined")) and name.lstrip("unifomred").isdigit()):
            raise SystemExit(f"mesh {name!r} must be uniform<level> or refined<k>")
    if any(not 0.0 < s < 1.0 for s in args.s):
        raise SystemExit(f"--s={args.s} must lie in (0, 1)")
    near = []
    for name in args.near:
        near.append(near_row(name))
        print(near[-1], flush=True)
    energy = []
    for s in args.s:
        for name in args.energy:
            energy.append(energy_row(name, s))
            print(energy[-1], flush=True)
    if args.md:
        with open(args.md, "w") as fh:
            fh.write("# Where the Taylor rule starts: near field against energy change\n\n")
            fh.write(f"`python benchmarks/taylor_threshold.py --md {args.md}` "
                     f"({datetime.date.today()}); R = 8: far_orders (0, 2, 4, 8), "
                     "far_thresholds (8, 4, 2) (config.yaml); R = 4: far_orders (0, 4, 8), "
                     "far_thresholds (4, 2) (config/paper.yaml). uniformL: "
                     "disk_uniform(L); refinedk: disk_uniform(4) refined k times around "
                     "the circle r = 0.6.\n\n")
            fh.write("## Node pairs of the near field\n\n")
            fh.write(pd.DataFrame(near).to_markdown(index=False, floatfmt=".3g"))
            fh.write("\n\n## Energy of Example 1's u_h (compressed operator)\n\n")
            fh.write(pd.DataFrame(energy).to_markdown(index=False, floatfmt=".3g"))
            fh.write("\n")


if __name__ == "__main__":
    main()
