"""Quadrature convergence and Example 1 rates on anisotropic graded disk meshes.

    python benchmarks/anisotropic_convergence.py [--part quadrature|rate|all] [--out FILE]

Part ``quadrature``: on disk_graded_rings(n, 2) (n = 8, 16, 24, 32) and
disk_graded_rings(n, 3) (n = 8, 16, 24), Example 1 (f = 1), s = 0.5, and on the
grading-2 series also s = 0.25 and 0.75: (f, u_h) with the default rules and with
``QuadratureOptions().raised()``, the change relative to the squared energy error
(f, u) − (f, u_h), and whether (f, u_h) increases along the series below (f, u).

Part ``rate``: Example 1, s = 0.5, on disk_graded_aniso(h, 2) for h = 2^(−k/2);
error = sqrt((f, u) − (f, u_h)), rate = slope of log error against log DOFs
(the paper reports −0.540 on its 2-graded meshes; theory −1/2).
"""
import argparse
import sys
import time

import numpy as np
import scipy.linalg as la

import fracfem as ff


NCHUNKS = None


def galerkin_energy(mesh, s, quad=None):
    """(f, u_h) = bᵀA⁻¹b for f = 1, and the assembly timings."""
    free = mesh.interior_nodes()
    tim = {}
    A = ff.stiffness_matrix(mesh, s, quadrature=quad, timings=tim,
                            nchunks=NCHUNKS)[np.ix_(free, free)]
    b = ff.load_vector(mesh, 1.0)[free]
    t0 = time.perf_counter()
    fu = float(b @ la.cho_solve(la.cho_factor(A, overwrite_a=True), b))
    tim["solve"] = time.perf_counter() - t0
    return fu, len(free), tim


def quadrature_table(out, s_values=(0.5, 0.25, 0.75)):
    series = [(2.0, 0.5, (8, 16, 24, 32)), (3.0, 0.5, (8, 16, 24)),
              (2.0, 0.25, (8, 16, 24, 32)), (2.0, 0.75, (8, 16, 24, 32))]
    series = [x for x in series if x[1] in s_values]
    print("| mesh | s | DOFs | (f,u_h) | (f,u_h) raised | change / err² | err | increasing, < (f,u) "
          "| assembly s (raised) |", file=out)
    print("|---|---|---|---|---|---|---|---|---|", file=out)
    for grading, s, ns in series:
        exact = ff.disk_energy(s)
        prev = -np.inf
        for n in ns:
            mesh = ff.disk_graded_rings(n, grading)
            fu, dofs, tim = galerkin_energy(mesh, s)
            fr, _, timr = galerkin_energy(mesh, s, ff.QuadratureOptions().raised())
            err2 = exact - fu
            ok = prev < fu < exact
            prev = fu
            print(f"| disk_graded_rings({n}, {grading:g}) | {s:g} | {dofs} | {fu:.8f} | {fr:.8f} | "
                  f"{(fr - fu) / err2:+.2e} | {np.sqrt(err2):.4f} | {ok} | "
                  f"{tim['total']:.1f} ({timr['total']:.1f}) |", file=out, flush=True)


def rate_table(out, ks=(6, 7, 8, 9, 10, 11, 12)):
    s = 0.5
    exact = ff.disk_energy(s)
    dofs, errs = [], []
    print("| mesh | DOFs | (f,u_h) | err | local rate | assembly s | solve s |", file=out)
    print("|---|---|---|---|---|---|---|", file=out)
    for k in ks:
        h = 2.0 ** (-k / 2)
        mesh = ff.disk_graded_aniso(h, 2.0)
        fu, n, tim = galerkin_energy(mesh, s)
        dofs.append(n)
        errs.append(np.sqrt(exact - fu))
        local = (np.log(errs[-1] / errs[-2]) / np.log(dofs[-1] / dofs[-2])
                 if len(errs) > 1 else float("nan"))
        print(f"| disk_graded_aniso(2^-{k}/2, 2) | {n} | {fu:.8f} | {errs[-1]:.5f} | {local:.3f} | "
              f"{tim['total']:.1f} | {tim['solve']:.1f} |", file=out, flush=True)
    slope = np.polyfit(np.log(dofs), np.log(errs), 1)[0]
    print(f"\nrate of the error against DOFs (fit over {len(dofs)} meshes): {slope:.3f} "
          f"(paper, 2-graded: -0.540; theory -0.5)", file=out, flush=True)


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--part", choices=["quadrature", "rate", "all"], default="all")
    ap.add_argument("--out", default=None, help="also write the tables to this file")
    ap.add_argument("--s", type=float, nargs="+", default=[0.5, 0.25, 0.75],
                    help="s values of the quadrature table")
    ap.add_argument("--k", type=int, nargs="+", default=[6, 7, 8, 9, 10, 11, 12],
                    help="meshes of the rate table, h = 2^(-k/2)")
    ap.add_argument("--nchunks", type=int, default=None,
                    help="far-field chunks (each an N x N copy; 1 for the largest meshes)")
    args = ap.parse_args()
    NCHUNKS = args.nchunks
    outs = [sys.stdout] + ([open(args.out, "w")] if args.out else [])

    class Tee:
        def write(self, x):
            for o in outs:
                o.write(x)

        def flush(self):
            for o in outs:
                o.flush()

    tee = Tee()
    if args.part in ("quadrature", "all"):
        quadrature_table(tee, tuple(args.s))
    if args.part in ("rate", "all"):
        print(file=tee)
        rate_table(tee, tuple(args.k))
