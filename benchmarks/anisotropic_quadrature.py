"""How far the singular quadrature is from converged on anisotropic graded meshes.

    python benchmarks/anisotropic_quadrature.py [--s 0.5] [--n 8 16 24]

For ring meshes (disk_graded_rings, thin triangles near ∂Ω) and the shape-regular
graded meshes of the pipeline (disk_graded) it prints the change of (f, u_h) when
every quadrature order is raised, relative to the squared energy error of Example 1.
"""
import argparse

import numpy as np

import fracfem as ff
from fracfem.meshes import min_angle


def change(mesh, s):
    free = mesh.interior_nodes()
    b = ff.load_vector(mesh, 1.0)[free]
    fu = [b @ np.linalg.solve(ff.stiffness_matrix(mesh, s, quadrature=q)[np.ix_(free, free)], b)
          for q in (ff.QuadratureOptions(), ff.QuadratureOptions().raised())]
    return len(free), abs(fu[1] - fu[0]) / (ff.disk_energy(s) - fu[0])


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--s", type=float, default=0.5)
    ap.add_argument("--n", type=int, nargs="+", default=[8, 16, 24])
    args = ap.parse_args()
    print("mesh                      dofs  min_angle  change/err^2")
    for n in args.n:
        for name, mesh in ((f"disk_graded_rings({n}, 2)", ff.disk_graded_rings(n, 2.0)),
                           (f"disk_graded({2.2 / n:.3f}, 2)", ff.disk_graded(2.2 / n, 2.0))):
            dofs, rel = change(mesh, args.s)
            print(f"{name:25s} {dofs:5d} {min_angle(mesh):9.2f}  {rel:.2e}")
