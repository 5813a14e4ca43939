"""Obstacle and friction problems in the mixed form (Problem 5.15): set-up and solve.

The displacement lives on the fine mesh T_h = T_H.refined(), the multiplier λ_H is
P0 on the coarse mesh T_H (interior problems) or on coarse edges of a curve Γ̃
(thin problems).  :func:`mixed_problem` assembles everything once; :func:`solve`
runs Uzawa (Algorithm A) or the primal–dual active set method on it: with a
dense stiffness matrix through its Cholesky factor and the Schur complement
BᵀA⁻¹B, with the compressed operator (``operator="compressed"``) by inner
Krylov solves (:mod:`fracfem.krylov_vi`; no dense matrix at all).
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from scipy.spatial import cKDTree

from . import krylov_vi, mixed, solvers
from .assembly import QuadratureOptions
from .compressed import DEFAULT_TOL
from .exact import check_s
from .laplace import Discretisation, discretise
from .meshes import refine_disk, validates
from .preconditioners import multilevel_preconditioner
from .transfer import interpolate_at, locate

__all__ = ["MixedProblem", "mixed_problem", "solve", "solve_nested", "fine_mesh",
           "prolong_multiplier"]

KINDS = ("obstacle", "friction", "thin_obstacle", "thin_friction")


def fine_mesh(coarse):
    """T_h: the uniform refinement of a disk mesh T_H (parent of e is e mod n_H)."""
    return refine_disk(coarse)


@dataclass
class MixedProblem:
    """Everything Problem 5.15 needs on one pair of meshes."""

    kind: str
    coarse: object
    disc: Discretisation            # fine-mesh matrix and load, free nodes
    cset: object                    # constraint set of fracfem.mixed (holds B)
    edges: np.ndarray | None = None  # coarse edges of Γ̃ (thin problems)
    factor: object = None
    schur: np.ndarray | None = None   # S = Bᵀ A⁻¹ B, formed once
    preconditioner: object = None     # r ↦ M⁻¹r for a compressed A, built once
    timings: dict = field(default_factory=dict)

    @property
    def fine(self):
        return self.disc.mesh


@validates("coarse", "fine")
def mixed_problem(kind: str, coarse, s: float, f, *, chi: Callable | None = None,
                  F: float | None = None, subdomain: Callable | None = None,
                  edges: np.ndarray | None = None, height: Callable | None = None,
                  quadrature: QuadratureOptions | None = None,
                  fine=None, operator: str = "dense",
                  tol: float = DEFAULT_TOL, stiffness=None) -> MixedProblem:
    """Assemble the mixed problem of the given kind on T_H = coarse.

    kind: 'obstacle' (needs chi), 'friction' (F, optional subdomain),
    'thin_obstacle' (edges, height; s > 1/2), 'thin_friction' (edges, F; s > 1/2).
    operator, tol: the stiffness representation (:func:`fracfem.discretise`):
    'dense', 'compressed' (accuracy tol) or 'auto'.  stiffness: the ``disc`` of a
    problem on the same meshes and s, whose operator is reused (other data: f, χ, F).
    """
    if kind not in KINDS:
        raise ValueError(f"kind={kind!r} must be one of {KINDS}")
    s = check_s(s)
    if kind.startswith("thin"):
        check_s(s, name="s (thin problems need s > 1/2)", low=0.5)
        if edges is None:
            raise ValueError("thin problems need edges: the coarse edges of Γ̃")
    t0 = time.perf_counter()
    fine = fine_mesh(coarse) if fine is None else fine
    t_mesh = time.perf_counter() - t0
    disc = discretise(fine, s, f, quadrature=quadrature, operator=operator, tol=tol,
                      stiffness=stiffness)
    free = disc.free
    if kind == "obstacle":
        if chi is None:
            raise ValueError("the obstacle problem needs chi, the obstacle function")
        cset = mixed.obstacle_from_function(coarse, fine, chi, free)
    elif kind == "friction":
        if F is None:
            raise ValueError("the friction problem needs F, the friction bound")
        B = mixed.coupling_matrix(coarse, fine)[free]
        cset = mixed.Friction(B, mixed.friction_bound(coarse, F, subdomain))
    else:
        B = mixed.edge_coupling_matrix(coarse, fine, edges)[free]
        if kind == "thin_obstacle":
            if height is None:
                raise ValueError("the thin obstacle problem needs height, g on Γ̃")
            hv = np.asarray(height(fine.p[:, free]), dtype=float)
            cset = mixed.ThinObstacle(B, height=hv, s=s)
        else:
            if F is None:
                raise ValueError("the thin friction problem needs F, the friction bound")
            cset = mixed.ThinFriction(B, np.full(B.shape[1], float(F)), s=s)
    prob = MixedProblem(kind, coarse, disc, cset, edges=edges)
    prob.timings.update(mesh=t_mesh, assembly=disc.timings["assembly"])
    return prob


def solve(prob: MixedProblem, solver: str = "uzawa", **kwargs):
    """(u over all fine nodes, λ_H, info) by 'uzawa' (Algorithm A) or 'pdas'.

    A compressed operator (``prob.disc.dense`` False) is solved by
    :mod:`fracfem.krylov_vi` with the multilevel preconditioner; ``kwargs`` go
    to the solver.
    """
    if solver not in ("uzawa", "pdas"):
        raise ValueError(f"solver={solver!r} must be 'uzawa' or 'pdas'")
    if not prob.disc.dense:
        if prob.preconditioner is None:
            t0 = time.perf_counter()
            prob.preconditioner = multilevel_preconditioner(prob.fine, prob.disc.A)
            prob.timings["preconditioner"] = time.perf_counter() - t0
        run = krylov_vi.uzawa if solver == "uzawa" else krylov_vi.pdas
        t0 = time.perf_counter()
        u, lam, info = run(prob.disc.A, prob.cset.B, prob.disc.b, prob.cset,
                           M=prob.preconditioner, **kwargs)
        info["seconds_total"] = time.perf_counter() - t0
        return prob.disc.extend(u), lam, info
    if prob.factor is None:
        t0 = time.perf_counter()
        prob.factor = solvers.cholesky_factor(prob.disc.A)
        prob.timings["factorisation"] = time.perf_counter() - t0
    if prob.schur is None:
        # both solvers then iterate in the multiplier space (m² per step, m ≈ n/2)
        t0 = time.perf_counter()
        prob.schur = solvers.schur_complement(prob.factor, prob.cset.B)
        prob.timings["schur"] = time.perf_counter() - t0
    run = solvers.uzawa if solver == "uzawa" else solvers.pdas
    t0 = time.perf_counter()
    u, lam, info = run(None, prob.cset.B, prob.disc.b, prob.cset, factor=prob.factor,
                       schur=prob.schur, **kwargs)
    info["seconds_total"] = time.perf_counter() - t0
    return prob.disc.extend(u), lam, info


def prolong_multiplier(coarse_from, lam: np.ndarray, coarse_to) -> np.ndarray:
    """λ_H (P0 on coarse_from) on the elements of coarse_to: the value of the
    element holding each centroid (exact when coarse_to refines coarse_from;
    a centroid outside coarse_from takes the element with the nearest centroid)."""
    lam = np.asarray(lam, dtype=float)
    if lam.shape != (coarse_from.t.shape[1],):
        raise ValueError(f"lam has shape {lam.shape}, coarse_from has "
                         f"{coarse_from.t.shape[1]} elements")
    cent = coarse_to.p[:, coarse_to.t].mean(axis=1)
    el, _ = locate(coarse_from, cent)
    out = el < 0
    if np.any(out):
        tree = cKDTree(coarse_from.p[:, coarse_from.t].mean(axis=1).T)
        el[out] = tree.query(cent[:, out].T)[1]
    return lam[el]


def solve_nested(problems, solver: str = "pdas", **kwargs):
    """Nested iteration: solve mixed problems on successively finer meshes,
    each started from the previous solution (λ_H by :func:`prolong_multiplier`,
    u interpolated for the inner Krylov solves); yields (u, λ_H, info) of each.

    problems: an iterable of :class:`MixedProblem` of kind 'obstacle' or
    'friction' (built lazily by a generator, only one is held at a time);
    kwargs go to :func:`solve` (not lam0 or u0).  The active set of the coarser
    solution is nearly the finer one, so PDAS needs a few steps per level
    instead of a number growing with the resolution of the contact boundary.
    """
    if "lam0" in kwargs or "u0" in kwargs:
        raise ValueError("solve_nested sets lam0 and u0 itself")
    prev = None
    for prob in problems:
        if prob.kind not in ("obstacle", "friction"):
            raise ValueError(f"solve_nested needs 'obstacle' or 'friction' problems, "
                             f"got kind={prob.kind!r}")
        start = {}
        if prev is not None:
            coarse, fine, u, lam = prev
            start["lam0"] = prolong_multiplier(coarse, lam, prob.coarse)
            if not prob.disc.dense:
                start["u0"] = interpolate_at(fine, u, prob.fine.p[:, prob.disc.free])
        u, lam, info = solve(prob, solver, **start, **kwargs)
        prev = (prob.coarse, prob.fine, u, lam)
        del prob  # the operator goes before the next problem is assembled
        yield u, lam, info
