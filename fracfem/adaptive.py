"""Adaptive refinement: marking strategies and Algorithm B (Section 7).

SOLVE → ESTIMATE → MARK → REFINE.  For the mixed problems (obstacle, friction)
the mesh that is adapted is the multiplier mesh T_H; the displacement mesh is
always T_h = refine_disk(T_H) (uniform refinement, new boundary nodes on the
circle), so that the pair stays nested with H = 2h (Lemma 5.17) and the coarse
indicator of T_j is the sum over its four children.  For the unconstrained
problem (Example 1) there is no coarse mesh and the P1 mesh itself is adapted.

Differences from the paper's Algorithm B (documented, deliberate):

* the paper stops when Σ_Δ η(Δ) ≤ ε (a sum of η, not of η²); we stop when the
  global estimator η = (Σ_i η_i² + Lemma 5.21 terms)^{1/2} ≤ tol, which is the
  quantity of Theorem 5.20 and does not grow with the number of elements;
* marking uses η(Δ) > θ·max η (step 5, "maximum"), i.e. η² > θ²·max η², or
  Dörfler's bulk criterion ("doerfler") on request.

Progress: one INFO line per step (logger ``fracfem.adaptive``: DOFs, η, solver
iterations, seconds) and one when the loop stops.
"""
from __future__ import annotations

import logging
import numbers
import time
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np

from . import estimators
from ._progress import Ticker
from .kkt import discrete_energy
from .laplace import Discretisation, solve_laplace
from .meshes import element_diameters, refine_disk

__all__ = ["mark_maximum", "mark_doerfler", "algorithm_b", "algorithm_b_steps",
           "StepRecord", "MARKINGS"]

logger = logging.getLogger(__name__)


def _check_theta(theta) -> float:
    ok = isinstance(theta, numbers.Real) and not isinstance(theta, (bool, np.bool_))
    if not ok or not np.isfinite(theta) or not 0.0 < theta < 1.0:
        raise ValueError(f"θ (theta) = {theta!r} must be a number in the open "
                         f"interval (0, 1)")
    return float(theta)


def _check_eta2(eta2) -> np.ndarray:
    eta2 = np.asarray(eta2, dtype=float)
    if eta2.ndim != 1 or eta2.size == 0:
        raise ValueError(f"eta2 must be a non-empty 1-D array of squared indicators, "
                         f"got shape {eta2.shape}")
    if not np.all(np.isfinite(eta2)) or np.any(eta2 < 0):
        raise ValueError("eta2 must be finite and >= 0 (squared indicators η(Δ)²)")
    return eta2


def mark_maximum(eta2, theta) -> np.ndarray:
    """Elements with η(Δ) > θ · max η (Algorithm B, step 5), as sorted indices.

    ``eta2`` holds the squared indicators η(Δ)²; the test is on η itself, so it
    reads η² > θ² · max η².  Nothing is marked when all indicators vanish.
    """
    theta = _check_theta(theta)
    eta2 = _check_eta2(eta2)
    eta = np.sqrt(eta2)
    return np.flatnonzero(eta > theta * eta.max())


def mark_doerfler(eta2, theta) -> np.ndarray:
    """Smallest set M with Σ_{Δ∈M} η(Δ)² ≥ θ Σ_Δ η(Δ)² (Dörfler), sorted indices.

    Takes the largest indicators first (stable order among ties).  Nothing is
    marked when all indicators vanish.
    """
    theta = _check_theta(theta)
    eta2 = _check_eta2(eta2)
    total = eta2.sum()
    if total <= 0.0:
        return np.empty(0, dtype=np.int64)
    order = np.argsort(-eta2, kind="stable")
    csum = np.cumsum(eta2[order])
    # guard against round-off in the cumulative sum
    k = int(np.searchsorted(csum, theta * total * (1.0 - 1e-14), side="left")) + 1
    return np.sort(order[:min(k, len(order))])


MARKINGS = {"maximum": mark_maximum, "doerfler": mark_doerfler}


@dataclass
class StepRecord:
    """One pass of SOLVE → ESTIMATE (→ MARK → REFINE) of Algorithm B."""

    step: int
    dofs: int                       # free fine (P1) nodes
    n_multipliers: int              # coarse multipliers (0 for Example 1)
    n_triangles: int                # fine elements
    n_coarse: int | None            # coarse elements (None for Example 1)
    eta: float                      # global estimator (each node once)
    energy: float                   # ½uᵀAu − bᵀu (+ j_H(u) for friction)
    load_dot_u: float               # bᵀu = (f, u_h): Example 1's error is √((f,u) − this)
    h_max: float
    h_min: float
    mesh: object                    # fine mesh T_h (the mesh of u)
    coarse: object | None           # T_H
    u: np.ndarray                   # over all fine nodes
    lam: np.ndarray | None          # λ_H per coarse element
    indicators: dict                # output of estimators.estimate / estimate_laplace
    marked: np.ndarray | None = None  # elements of the adapted mesh marked this step
    timings: dict = field(default_factory=dict)  # assemble, solve, estimate, mark, refine
    info: dict = field(default_factory=dict)     # solver info
    stop: str | None = None         # why the loop stopped after this step, if it did


def algorithm_b_steps(make_problem: Callable, coarse0, *, theta: float, steps: int,
                      marking: str = "maximum", solver: str = "pdas",
                      tol: float | None = None, f=None, order: int = 4,
                      solver_options: dict | None = None,
                      estimator_options: dict | None = None,
                      callback: Callable | None = None,
                      warm_start: bool = True) -> Iterator[StepRecord]:
    """Algorithm B as a generator of :class:`StepRecord` (see :func:`algorithm_b`)."""
    from .transfer import interpolate_at
    from .vi import MixedProblem, prolong_multiplier, solve as vi_solve

    theta = _check_theta(theta)
    if marking not in MARKINGS:
        raise ValueError(f"marking={marking!r} must be one of {tuple(MARKINGS)}")
    if not isinstance(steps, numbers.Integral) or isinstance(steps, bool) or steps < 1:
        raise ValueError(f"steps={steps!r} must be a positive integer")
    if tol is not None and not (isinstance(tol, numbers.Real) and tol >= 0):
        raise ValueError(f"tol={tol!r} must be a number >= 0 or None")
    mark = MARKINGS[marking]
    solver_options = dict(solver_options or {})
    if warm_start and ("lam0" in solver_options or "u0" in solver_options):
        raise ValueError("solver_options must not set lam0 or u0 when warm_start=True: "
                         "each step starts from the previous step's solution")
    estimator_options = dict(estimator_options or {})
    mesh = coarse0
    previous = None   # (T_H, T_h, u_h, λ_H) of the last step, the start of the next solve
    clock = Ticker(0.0)
    logger.info("Algorithm B: at most %d steps, marking %s, theta %g, tol %s", steps, marking,
                theta, tol)
    for k in range(steps):
        tim = {}
        t0 = time.perf_counter()
        prob = make_problem(mesh)
        tim["assemble"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        if isinstance(prob, MixedProblem):
            start = {}
            if warm_start and previous is not None and prob.kind in ("obstacle", "friction"):
                # the refined problem's active sets are nearly the last step's: PDAS needs a
                # few steps instead of a number growing with the contact boundary's resolution
                c_prev, f_prev, u_prev, lam_prev = previous
                start["lam0"] = prolong_multiplier(c_prev, lam_prev, prob.coarse)
                if not prob.disc.dense:
                    start["u0"] = interpolate_at(f_prev, u_prev,
                                                 prob.fine.p[:, prob.disc.free])
            u, lam, info = vi_solve(prob, solver, **start, **solver_options)
            previous = (prob.coarse, prob.fine, u, lam)
            tim["solve"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            est = estimators.estimate(prob, u, lam, order, f=f, **estimator_options)
            tim["estimate"] = time.perf_counter() - t0
            disc, fine, coarse = prob.disc, prob.fine, prob.coarse
            to_mark = est["eta2_coarse"]
            n_mult = len(lam)
        elif isinstance(prob, Discretisation):
            if f is None and getattr(prob, "f", None) is None:
                raise ValueError("algorithm_b needs f= (the load) for the residual of "
                                 "the unconstrained problem")
            u_free = solve_laplace(prob)
            u, lam, info = prob.extend(u_free), None, {}
            tim["solve"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            est = estimators.estimate_laplace(prob, u, f if f is not None else prob.f,
                                              order, **estimator_options)
            tim["estimate"] = time.perf_counter() - t0
            disc, fine, coarse = prob, prob.mesh, None
            to_mark = est["eta2_fine"]
            n_mult = 0
        else:
            raise TypeError(f"make_problem must return a vi.MixedProblem or a "
                            f"laplace.Discretisation, got {type(prob).__name__}")
        iterations = info.get("iterations", disc.info.get("iterations", "none (Cholesky)"))
        uf = u[disc.free]
        energy = discrete_energy(prob, u)
        lengths = element_diameters(fine)
        rec = StepRecord(step=k, dofs=len(disc.free), n_multipliers=n_mult,
                         n_triangles=fine.t.shape[1],
                         n_coarse=None if coarse is None else coarse.t.shape[1],
                         eta=est["eta"], energy=energy,
                         load_dot_u=float(disc.b @ uf), h_max=float(lengths.max()),
                         h_min=float(lengths.min()), mesh=fine, coarse=coarse, u=u,
                         lam=lam, indicators=est, timings=tim, info=info)
        del prob, disc  # the dense matrix is not kept between steps
        if tol is not None and est["eta"] <= tol:
            rec.stop = "tol"
        elif k == steps - 1:
            rec.stop = "steps"
        else:
            t0 = time.perf_counter()
            marked = mark(to_mark, theta)
            tim["mark"] = time.perf_counter() - t0
            rec.marked = marked
            if marked.size == 0:
                rec.stop = "nothing marked"
            else:
                t0 = time.perf_counter()
                mesh = refine_disk(coarse if coarse is not None else fine, marked)
                tim["refine"] = time.perf_counter() - t0
        logger.info("Algorithm B step %d: %d DOFs, %d multipliers, %d triangles, eta %.4e, "
                    "solver iterations: %s, %s marked, %.2f s (elapsed %.1f s)", k, rec.dofs,
                    n_mult, rec.n_triangles, rec.eta, iterations,
                    "-" if rec.marked is None else len(rec.marked), sum(tim.values()),
                    clock.elapsed)
        if callback is not None and callback(rec) and rec.stop is None:
            rec.stop = "callback"
        if rec.stop is not None:
            logger.info("Algorithm B stops after step %d: %s", k, rec.stop)
        yield rec
        if rec.stop is not None:
            return


def algorithm_b(make_problem: Callable, coarse0, *, theta: float, steps: int,
                marking: str = "maximum", solver: str = "pdas",
                tol: float | None = None, callback: Callable | None = None, f=None,
                order: int = 4, solver_options: dict | None = None,
                estimator_options: dict | None = None,
                warm_start: bool = True) -> list[StepRecord]:
    """Algorithm B: SOLVE → ESTIMATE → MARK → REFINE, ``steps`` passes at most.

    Parameters
    ----------
    make_problem : callable
        ``make_problem(mesh)`` returns a :class:`fracfem.vi.MixedProblem` on the
        coarse mesh ``mesh`` = T_H (obstacle or friction; T_h = refine_disk(T_H))
        or a :class:`fracfem.laplace.Discretisation` on the P1 mesh ``mesh``
        (Example 1).  E.g. ``lambda c: vi.mixed_problem("obstacle", c, 0.5, 1.0,
        chi=chi)`` or ``lambda m: laplace.discretise(m, 0.5, 1.0)``.
    coarse0 : skfem.MeshTri
        Start mesh (T_H, resp. the P1 mesh for Example 1).
    theta : float in (0, 1)
        Marking parameter.
    steps : int
        Maximal number of SOLVE passes (the last one is not refined).
    marking : 'maximum' (η(Δ) > θ η_max, the paper) or 'doerfler'
    solver : 'pdas' or 'uzawa' (mixed problems; ``solver_options`` go to vi.solve)
    tol : stop as soon as the estimator η ≤ tol (None: never)
    callback : called with each :class:`StepRecord` after it is complete (with
        ``marked`` set); a truthy return value stops the loop after that step
    f : the load for the residual (neither MixedProblem nor Discretisation
        stores it); required
    order : triangle rule of the indicators (estimators module docstring)
    estimator_options : further keywords of estimators.estimate(_laplace)
    warm_start : start each obstacle or friction solve from the last step's solution
        (λ_H by :func:`fracfem.vi.prolong_multiplier`, u_h interpolated for the inner
        Krylov solves), as :func:`fracfem.vi.solve_nested`; the solution is the same
        to the solver's tolerance

    Returns
    -------
    list of :class:`StepRecord` (dofs, triangles, eta, energy, timings, meshes,
    u, λ_H, indicators, marked elements); the last one's ``stop`` says why it
    stopped ('steps', 'tol', 'nothing marked', 'callback').
    """
    return list(algorithm_b_steps(make_problem, coarse0, theta=theta, steps=steps,
                                  marking=marking, solver=solver, tol=tol, f=f,
                                  order=order, solver_options=solver_options,
                                  estimator_options=estimator_options,
                                  callback=callback, warm_start=warm_start))
