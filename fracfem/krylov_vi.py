"""Obstacle and friction solvers for a stiffness operator that is never formed.

Problem 5.15 (see :mod:`fracfem.solvers`), A u + B λ = f with λ in a box Λ_H,
when A is only known through products and its diagonal
(:class:`fracfem.compressed.CompressedOperator`): no n × n and no m × m dense
matrix is formed.

* :func:`pdas` — the active-set steps, stopping test and errors of
  :func:`fracfem.solvers.pdas`.  A step fixes λ at its bounds off E and solves

      min ½uᵀAu − (f − B_R λ_R)ᵀu   subject to   B_Eᵀu = g_E

  by projected preconditioned CG in the primal space from the previous u.  The
  projector Π = I − D⁻¹B_E K⁻¹B_Eᵀ, K = B_EᵀD⁻¹B_E, D = diag(A), needs one sparse
  factorisation of K per step; λ_E = K⁻¹B_EᵀD⁻¹(f − B_Rλ_R − A u), the D-weighted
  least-squares multiplier, makes A u + Bλ − f = Πᵀ(f − B_Rλ_R − A u) the very
  residual CG drives below ``inner_tol``.
* :func:`uzawa` — Algorithm A, each u^n = A⁻¹(f − Bλ^n) by PCG from u^{n−1};
  ρ = 1.9/σ_max of S = BᵀA⁻¹B, σ_max by Lanczos (one PCG solve per product).

Both log (logger ``fracfem.krylov_vi``) one summary line at the end (INFO,
DEBUG inside time stepping) and one DEBUG line per active-set step (PDAS).
"""
from __future__ import annotations

import logging
import time

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ._progress import solver_level
from .solvers import (SAFE_STEP, ConvergenceError, _check_globalize, _classify,
                      _fixed_point_residual, _globalize_reason, _initial_multiplier,
                      _uzawa_loop)

log = logging.getLogger(__name__)

__all__ = ["pdas", "uzawa", "schur_sigma_max"]

SINGULAR_PIVOT = 1e-10   # pivots of K below this times max diag(K): K is singular
KERNEL_SHIFT = 1e-8      # K + shift·max diag(K) stands in for a singular K
LOOSE_TOL = 1e-6         # inner accuracy of the PDAS steps before the sets settle
DATA_TOL = 1e-3          # inner accuracy of A⁻¹f, the scale of PDAS's stopping test
LANCZOS_TOL = 1e-6       # relative change of the top Ritz value that stops Lanczos
LANCZOS_STEPS = 60
SCHUR_SOLVE_TOL = 1e-10  # PCG tolerance of each product with S = BᵀA⁻¹B


# ------------------------------------------------------------------ projection


class _Projector:
    """Π = I − D⁻¹B_E K⁻¹B_Eᵀ onto {v : B_Eᵀv = 0}, K = B_EᵀD⁻¹B_E (sparse LU).

    B_E has a kernel when E holds every multiplier of a mesh whose interior
    vertices all have even degree (the checkerboard of
    :func:`fracfem.solvers.schur_spectrum`); then K is shifted, its kernel
    found by inverse iteration and removed from every solve, which picks the
    minimum-norm multiplier as the dense path does.
    """

    def __init__(self, BE: sp.csc_matrix, inv_d: np.ndarray):
        self.BE, self.BEt, self.inv_d = BE, BE.T.tocsr(), inv_d
        self.kernel = np.zeros((BE.shape[1], 0))
        if BE.shape[1] == 0:
            return
        K = (self.BEt @ sp.diags(inv_d) @ BE).tocsc()
        top = float(K.diagonal().max())
        self._K = K
        lu = _splu(K)
        n_small = np.count_nonzero(np.abs(lu.U.diagonal()) < SINGULAR_PIVOT * top)
        if n_small:
            lu = _splu(K + KERNEL_SHIFT * top * sp.identity(K.shape[0], format="csc"))
            V = np.random.default_rng(0).standard_normal((K.shape[0], n_small))
            for _ in range(3):
                V = np.linalg.qr(lu.solve(V))[0]
            self.kernel = V
            log.debug("projector: K = B_EᵀD⁻¹B_E has a kernel of dimension %d", n_small)
        self._lu = lu

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """K⁻¹ rhs (minimum-norm part when K is singular)."""
        if rhs.size == 0:
            return rhs.copy()
        x = self._lu.solve(rhs)
        if self.kernel.shape[1]:
            x += self._lu.solve(rhs - self._K @ x)   # one refinement undoes the shift
            x -= self.kernel @ (self.kernel.T @ x)
        return x

    def residual(self, r: np.ndarray):
        """(Πᵀr, w): w = K⁻¹B_EᵀD⁻¹r the least-squares coefficients, Πᵀr = r − B_E w."""
        w = self.solve(self.BEt @ (self.inv_d * r))
        return (r - self.BE @ w if w.size else r), w

    def apply(self, z: np.ndarray) -> np.ndarray:
        """Π z."""
        if self.BE.shape[1] == 0:
            return z
        return z - self.inv_d * (self.BE @ self.solve(self.BEt @ z))

    def feasible(self, u: np.ndarray, gE: np.ndarray) -> np.ndarray:
        """The point of {B_Eᵀv = g_E} nearest u in the D-norm."""
        if self.BE.shape[1] == 0:
            return u.copy()
        return u - self.inv_d * (self.BE @ self.solve(self.BEt @ u - gE))


def _splu(K):
    """Sparse LU of the symmetric K, diagonal pivots (K is SPD or nearly so)."""
    return spla.splu(K, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                     options={"SymmetricMode": True})


def _cg(A, rhs, u, M, proj, tol, maxiter, what):
    """Projected PCG for min ½uᵀAu − rhsᵀu on u + null(B_Eᵀ), u feasible.

    Stops when ‖Πᵀ(rhs − A u)‖ ≤ tol·max(‖rhs‖, ‖A u‖) at the current iterate u (A u
    updated with the residual, no extra product): the scale is the solution's, not the
    start's, so a start far from the solution does not loosen the test.  Returns (u, w,
    iterations), w the least-squares multiplier (A u + B_E w ≈ rhs).
    """
    Au = A @ u
    r = rhs - Au
    rhs_norm = float(np.linalg.norm(rhs))
    scale = max(rhs_norm, float(np.linalg.norm(Au)))
    rr, w = proj.residual(r)
    res = float(np.linalg.norm(rr))
    it = 0
    if res <= tol * scale:
        return u, w, it
    z = proj.apply(M(rr))
    p = z
    rz = float(rr @ z)
    while True:
        if it >= maxiter:
            raise ConvergenceError(f"{what}: the inner PCG did not reach its tolerance",
                                   it, res / scale)
        q = A @ p
        pq = float(p @ q)
        if not pq > 0.0:
            raise ValueError(f"the operator A is not positive definite (pᵀAp = {pq:.3e})")
        alpha = rz / pq
        u = u + alpha * p
        r -= alpha * q
        Au += alpha * q
        rr, w = proj.residual(r)
        res = float(np.linalg.norm(rr))
        scale = max(rhs_norm, float(np.linalg.norm(Au)))
        it += 1
        if res <= tol * scale:
            return u, w, it
        z = proj.apply(M(rr))
        rz_new = float(rr @ z)
        p = z + (rz_new / rz) * p
        rz = rz_new


# ------------------------------------------------------------------ input checks


def _check(A, B, f, cset, M, tol, maxiter, inner_tol, inner_maxiter):
    """Validate; return (B csc, f, 1/diag(A), M)."""
    if not (isinstance(maxiter, (int, np.integer)) and maxiter >= 1):
        raise ValueError(f"maxiter must be a positive integer; got {maxiter!r}")
    if not (isinstance(inner_maxiter, (int, np.integer)) and inner_maxiter >= 1):
        raise ValueError(f"inner_maxiter must be a positive integer; got {inner_maxiter!r}")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive number; got {tol!r}")
    if not (np.isfinite(inner_tol) and 0 < inner_tol < 1):
        raise ValueError(f"inner_tol must be in (0, 1); got {inner_tol!r}")
    B = sp.csc_matrix(B)
    n = B.shape[0]
    f = np.asarray(f, dtype=float)
    if tuple(getattr(A, "shape", ())) != (n, n):
        raise ValueError(f"A must have shape ({n}, {n}) to match B {B.shape}; "
                         f"got {getattr(A, 'shape', None)}")
    if not callable(getattr(A, "diagonal", None)):
        raise ValueError("A must provide diagonal() (the Jacobi scaling D of the projector)")
    if f.shape != (n,) or not np.all(np.isfinite(f)):
        raise ValueError(f"f must be a finite vector of shape ({n},); got shape {f.shape}")
    if cset.n_multipliers != B.shape[1]:
        raise ValueError(f"the constraint set has {cset.n_multipliers} multipliers but "
                         f"B has {B.shape[1]} columns")
    d = np.asarray(A.diagonal(), dtype=float)
    if not np.all(np.isfinite(d) & (d > 0)):
        raise ValueError("A must be positive definite: its diagonal has entries <= 0 "
                         f"(min {d.min():.3e})")
    if M is not None and not callable(M):
        raise ValueError(f"M must be a callable r ↦ M⁻¹r (the preconditioner); got {M!r}")
    inv_d = 1.0 / d
    return B, f, inv_d, (M if M is not None else (lambda r: inv_d * r))


def _start(u0, n):
    """Warm start u⁰ (default 0)."""
    if u0 is None:
        return np.zeros(n)
    u0 = np.asarray(u0, dtype=float)
    if u0.shape != (n,) or not np.all(np.isfinite(u0)):
        raise ValueError(f"u0 must be a finite vector of shape ({n},); got shape {u0.shape}")
    return u0.copy()


# ---------------------------------------------------------------------------- PDAS


def pdas(A, B, f, cset, *, M=None, tol: float = 1e-10, maxiter: int = 200, c=None,
         lam0=None, u0=None, inner_tol: float | None = None, inner_maxiter: int = 1000,
         warm_start: bool = True, loose: bool = True, globalize="auto",
         pair_start: bool = False):
    """Primal–dual active set method for Problem 5.15 with inner Krylov solves.

    The sets, the stopping test (fixed-point residual ‖λ − P_Λ(λ + c∘y)‖ below
    ``tol`` relative to max(‖λ‖, ‖c∘d‖), d = BᵀA⁻¹f − g), the cycle breaking and
    :class:`ConvergenceError` are those of :func:`fracfem.solvers.pdas`.

    Parameters
    ----------
    A : operator with ``@``, ``shape`` and ``diagonal()``, symmetric positive definite
    B, f, cset : as in :func:`fracfem.solvers.pdas`
    M : callable r ↦ M⁻¹r, preconditioner for A (default Jacobi); applied as ΠMΠᵀ
    c : complementarity weight; default 1/diag(BᵀMB) when M has
        ``congruence_diagonal`` (the multilevel preconditioner), else
        1/diag(BᵀD⁻¹B), D = diag(A): stand-ins for the dense path's 1/diag(BᵀA⁻¹B)
    lam0, u0 : starts for λ (projected onto Λ_H) and for the first inner solve
    inner_tol : the KKT residual ‖A u + Bλ − f‖ of every step below
        inner_tol·max(‖f − B_Rλ_R‖, ‖A u⁰‖); default ``tol``
    inner_maxiter : PCG iterations per step before :class:`ConvergenceError`
    warm_start : start each step from the previous u (else from the nearest
        feasible point to 0)
    loose : solve the steps to the relative KKT residual 1e-6 until the sets
        settle, then those sets once more to ``inner_tol`` (else every step
        to ``inner_tol``); a settled set is only accepted after the accurate solve
    pair_start : λ⁰ is the multiplier of a nearby problem and u⁰ near this
        problem's solution (the previous time step's λ and the predictor of
        this step's u: :class:`fracfem.parabolic.Stepper`); the first active
        sets are read off them, y = Bᵀu⁰ − g, instead of off a solve with λ⁰
        (which saves that solve); needs a λ⁰ nonzero in Λ and u⁰.  Only the
        start changes: the sets are iterated and solved to the same tolerance
    globalize : "auto" (default): when the active sets cycle or the residual
        stalls (not halved in ``solvers.STALL_STEPS`` steps), go on with feasible
        steps whose length maximises the dual energy (:func:`_feasible_newton`),
        which cannot cycle; True: from the first step; False: never (the plain
        active-set steps)

    Returns
    -------
    u, lam, info
        ``info``: ``iterations``, ``residuals``, ``residual``, ``n_constrained``,
        ``c``, ``inner_iterations`` (per solve: the first two unconstrained, one with
        ``pair_start``; the feasible steps of ``globalize`` add their own),
        ``seconds`` (``initial``, ``iterations``).
    """
    _check_globalize(globalize)
    inner_tol = min(tol, 0.1) if inner_tol is None else inner_tol
    B, f, inv_d, M = _check(A, B, f, cset, M, tol, maxiter, inner_tol, inner_maxiter)
    n, m = B.shape
    Bt = B.T.tocsr()
    colsum = np.asarray(B.multiply(B).T @ inv_d).ravel()  # diag(BᵀD⁻¹B)
    if np.any(colsum <= 0):
        raise ValueError("B has a zero column (a multiplier that no free node sees): "
                         f"column {int(np.argmin(colsum))}")
    if c is None:
        # 1/diag(BᵀA⁻¹B) as the dense path, with A⁻¹ ≈ M: measured on uniform
        # disks (s = 0.25 … 0.9) diag(BᵀA⁻¹B) is 0.3–2.5 times diag(BᵀMB) for
        # the multilevel M, but 0.9–6.5 times diag(BᵀD⁻¹B), the fallback
        c = 1.0 / (M.congruence_diagonal(B) if hasattr(M, "congruence_diagonal")
                   else colsum)
    else:
        c = np.broadcast_to(np.asarray(c, float), (m,)).copy()
    if not np.all(np.isfinite(c) & (c > 0)):
        raise ValueError("c must be positive and finite")
    lam = _initial_multiplier(cset, lam0)
    u = _start(u0, n)

    t0 = time.perf_counter()
    inner = []
    free = _Projector(sp.csc_matrix((n, 0)), inv_d)

    def solve(rhs, u, proj, gE, accuracy):
        x0 = proj.feasible(u if warm_start else np.zeros(n), gE)
        u, w, it = _cg(A, rhs, x0, M, proj, accuracy, inner_maxiter, f"PDAS ({cset.kind})")
        inner.append(it)
        return u, w

    # steps are solved to LOOSE_TOL until the sets settle, then once more to inner_tol
    accuracy = max(LOOSE_TOL, inner_tol) if loose else inner_tol
    if not isinstance(pair_start, (bool, np.bool_)):
        raise ValueError(f"pair_start must be True or False; got {pair_start!r}")
    if pair_start and (u0 is None or not np.any(lam)):
        got = ("None" if lam0 is None else "nonzero" if np.any(lam)
               else "zero once projected onto the admissible multipliers")
        raise ValueError("pair_start=True needs the pair it starts from: a lam0 nonzero in "
                         f"the admissible set and u0 (got lam0 {got}, "
                         f"u0 {'None' if u0 is None else 'given'})")
    if np.any(lam):
        # d = BᵀA⁻¹f − g only scales the stopping test: a rough A⁻¹f does, and it
        # starts the solve with λ⁰ (measured, Example 4 at 7k DOFs warm-started from
        # the last time step: 2–3 + 9 iterations where A⁻¹f to LOOSE_TOL took 10 + 7)
        data, _ = solve(f, u, free, None, max(DATA_TOL, accuracy))
        d = Bt @ data - cset.g
        if not pair_start:   # else u stays u⁰: (λ⁰, Bᵀu⁰ − g) give the first sets
            u, _ = solve(f - B @ lam, data, free, None, accuracy)
    else:
        u, _ = solve(f, u, free, None, accuracy)  # u(0), the data d and the first iterate
        d = Bt @ u - cset.g
    t_initial = time.perf_counter() - t0

    t0 = time.perf_counter()
    lower, upper = cset.lower, cset.upper
    fixed = lower == upper
    data_scale = np.linalg.norm(c * d)
    seen, history, n_constrained = set(), [], []
    state = None
    switched = None
    for step in range(maxiter + 1):
        y = Bt @ u - cset.g
        new_state = _classify(lam, y, c, lower, upper, fixed)
        residual = _fixed_point_residual(lam, y, c, cset,
                                         max(np.linalg.norm(lam), data_scale))
        reason = _globalize_reason(globalize, state, new_state, seen, history, residual)
        if reason:
            if state is not None:
                history.append(residual)
            switched = len(history)
            log.info("pdas (%s): %s at step %d; feasible steps from here", cset.kind,
                     reason, step)
            u, lam = _feasible_newton(
                A, B, Bt, f, cset, c, lam, u, inv_d, solve, free, accuracy, inner_tol, tol,
                data_scale, maxiter - step, history, n_constrained)
            break
        if state is not None:
            history.append(residual)
            log.debug("pdas (%s) step %d: |E| = %d, %d inner iterations, residual %.2e",
                      cset.kind, step, n_constrained[-1], inner[-1], residual)
            same = np.array_equal(new_state, state)
            settled = same or residual < 0.1 * tol
            if settled and accuracy > inner_tol and step < maxiter:
                accuracy = inner_tol  # the sets have settled: solve them accurately
                n_constrained.append(n_constrained[-1])
                lam[E] = 0.0
                u, lam[E] = solve(f - B @ lam, u, proj, cset.g[E], accuracy)
                continue
            if residual < tol and settled and accuracy <= inner_tol:
                break
            if same and accuracy <= inner_tol:
                raise ConvergenceError("PDAS: the active sets repeat but the residual "
                                       f"is above tol = {tol:g}", step, residual)
        if step == maxiter:
            raise ConvergenceError(f"PDAS ({cset.kind}) did not reach tol = {tol:g}",
                                   maxiter, residual)
        if new_state.tobytes() in seen:
            c = 0.5 * c  # a cycle of active sets: shorten the dual step
            log.info("pdas: active sets cycle at step %d; halving c", step)
            new_state = _classify(lam, y, c, lower, upper, fixed)
        seen.add(new_state.tobytes())
        state = new_state
        E = np.flatnonzero(state == 0)
        n_constrained.append(int(E.size))
        lam = np.where(state > 0, upper, np.where(state < 0, lower, 0.0))
        proj = _Projector(B[:, E], inv_d)
        u, lam[E] = solve(f - B @ lam, u, proj, cset.g[E], accuracy)
    info = {
        "iterations": len(history),
        "residuals": history,
        "residual": history[-1],
        "n_constrained": n_constrained,
        "c": c,
        "globalized_at": switched,
        "inner_iterations": inner,
        "seconds": {"initial": t_initial, "iterations": time.perf_counter() - t0},
    }
    log.log(solver_level(), "pdas (%s): %d steps, %d inner iterations, residual %.2e, "
            "%d unknowns, %.2f s", cset.kind, info["iterations"], sum(inner), info["residual"],
            n, t_initial + info["seconds"]["iterations"])
    return u, lam, info


def _feasible_newton(A, B, Bt, f, cset, c, lam, u, inv_d, solve, free, accuracy,
                     inner_tol, tol, data_scale, maxiter, history, n_constrained):
    """Active-set steps made monotone: every iterate λ is feasible and increases
    the dual energy D(λ) = −½(f − Bλ)ᵀA⁻¹(f − Bλ) − gᵀλ, a concave quadratic
    whose maximiser over the box Λ is the solution.

    From λ with u = A⁻¹(f − Bλ) and y = Bᵀu − g = ∇D(λ): the active-set
    candidate λ̂ (:func:`pdas`'s step from the sets of λ + c∘y) projected onto
    Λ, or, when that is no ascent direction, the projected gradient point
    P_Λ(λ + c∘y) (yᵀd ≥ dᵀdiag(c)⁻¹d > 0 for d ≠ 0).  Along d = λ̃ − λ, u is
    affine (du = −A⁻¹B d, from the solve at λ̃: the candidate's own when the
    projection left it unchanged, else one more), so D is an exact 1D quadratic
    and the step α = min(1, yᵀd / dᵀBᵀ(−du)) maximises it without a further
    solve.  D cannot decrease, so the sets cannot cycle; near the solution λ̂
    is the solution, α = 1, and the active-set steps' fast local convergence
    is kept.  Appends to ``history`` and ``n_constrained``; returns (u, λ).
    """
    lower, upper = cset.lower, cset.upper
    fixed = lower == upper
    lam = cset.project(lam)
    u, _ = solve(f - B @ lam, u, free, None, accuracy)
    previous = None
    for it in range(maxiter + 1):
        y = Bt @ u - cset.g
        residual = _fixed_point_residual(lam, y, c, cset,
                                         max(np.linalg.norm(lam), data_scale))
        state = _classify(lam, y, c, lower, upper, fixed)
        settled = residual < tol or (previous is not None and np.array_equal(state, previous))
        if settled and accuracy > inner_tol:
            accuracy = inner_tol        # the sets have settled: on from accurate solves
            u, _ = solve(f - B @ lam, u, free, None, accuracy)
            previous = None
            continue
        history.append(residual)
        if residual < tol:
            return u, lam
        if it == maxiter:
            break
        previous = state
        E = np.flatnonzero(state == 0)
        n_constrained.append(int(E.size))
        cand = np.where(state > 0, upper, np.where(state < 0, lower, 0.0))
        u_c, cand[E] = solve(f - B @ cand, u, _Projector(B[:, E], inv_d), cset.g[E],
                             accuracy)
        feasible = cset.project(cand)
        if not np.array_equal(feasible, cand):
            u_c, _ = solve(f - B @ feasible, u_c, free, None, accuracy)
        d, du = feasible - lam, u_c - u
        slope = float(y @ d)
        if not slope > 0.0:             # no ascent: the projected gradient point
            feasible = cset.project(lam + c * y)
            u_c, _ = solve(f - B @ feasible, u, free, None, accuracy)
            d, du = feasible - lam, u_c - u
            slope = float(y @ d)
        curvature = -float(d @ (Bt @ du))   # dᵀ BᵀA⁻¹B d ≥ 0
        alpha = 1.0 if not curvature > 0.0 else min(1.0, slope / curvature)
        lam = cset.project(lam + alpha * d)
        u = u + alpha * du
        log.debug("pdas (%s) feasible step: |E| = %d, step %.3g, residual %.2e", cset.kind,
                  E.size, alpha, residual)
    raise ConvergenceError(f"PDAS ({cset.kind}) with feasible steps did not reach "
                           f"tol = {tol:g}", len(history), history[-1])


# --------------------------------------------------------------------------- Uzawa


def schur_sigma_max(A, B, M=None, *, tol: float = LANCZOS_TOL,
                    maxsteps: int = LANCZOS_STEPS) -> dict:
    """σ_max of S = BᵀA⁻¹B by Lanczos from the constant vector (one PCG solve
    per product, full reorthogonalisation).  Returns {"sigma_max", "steps",
    "inner_iterations"}."""
    B = sp.csc_matrix(B)
    n, m = B.shape
    d = np.asarray(A.diagonal(), dtype=float)
    M = M if M is not None else (lambda r: r / d)
    free = _Projector(sp.csc_matrix((n, 0)), 1.0 / d)
    Bt = B.T.tocsr()
    inner = []

    def S(x):
        u, _, it = _cg(A, B @ x, np.zeros(n), M, free, SCHUR_SOLVE_TOL, 2000, "Lanczos")
        inner.append(it)
        return Bt @ u

    Q = np.zeros((m, 0))
    q = np.ones(m) / np.sqrt(m)
    alphas, betas, theta = [], [], 0.0
    for _ in range(min(m, maxsteps)):
        Q = np.column_stack([Q, q])
        w = S(q)
        alphas.append(float(q @ w))
        w -= Q @ (Q.T @ w)
        w -= Q @ (Q.T @ w)
        new = float(la.eigvalsh_tridiagonal(np.array(alphas), np.array(betas),
                                            select="i", select_range=(len(alphas) - 1,) * 2)[0])
        beta = float(np.linalg.norm(w))
        done = abs(new - theta) <= tol * abs(new) or beta <= 1e-12 * abs(new)
        theta = new
        if done:
            break
        betas.append(beta)
        q = w / beta
    if not theta > 0:
        raise ValueError(f"BᵀA⁻¹B has no positive eigenvalue (σ_max = {theta}); is B zero?")
    log.debug("Lanczos: σ_max(BᵀA⁻¹B) = %.4e after %d steps, %d inner iterations", theta,
              len(alphas), sum(inner))
    return {"sigma_max": theta, "steps": len(alphas), "inner_iterations": sum(inner)}


def uzawa(A, B, f, cset, *, M=None, rho=None, tol: float = 1e-10, maxiter: int = 100_000,
          lam0=None, u0=None, inner_tol: float | None = None, inner_maxiter: int = 1000):
    """Uzawa iteration (Algorithm A) with inner PCG solves warm-started from u^{n−1}.

    u^n = A⁻¹(f − Bλ^n),  λ^{n+1} = P_Λ(λ^n + ρ(Bᵀu^n − g)); stopping test and
    :class:`ConvergenceError` of :func:`fracfem.solvers.uzawa`.  Default
    ρ = 1.9/σ_max(BᵀA⁻¹B) (:func:`schur_sigma_max`).  Each u^n has the relative
    residual ``inner_tol`` (default tol/10) with respect to ‖f − Bλ^n‖.

    Returns u, lam, info (``iterations``, ``residuals``, ``residual``, ``rho``,
    ``sigma_max``, ``inner_iterations`` (total), ``seconds``).
    """
    inner_tol = min(max(0.1 * tol, 1e-14), 0.1) if inner_tol is None else inner_tol
    B, f, inv_d, M = _check(A, B, f, cset, M, tol, maxiter, inner_tol, inner_maxiter)
    n = B.shape[0]
    Bt = B.T.tocsr()
    t0 = time.perf_counter()
    spectrum = {"sigma_max": None}
    if rho is None:
        spectrum = schur_sigma_max(A, B, M)
        rho = SAFE_STEP / spectrum["sigma_max"]
    elif not (np.isfinite(rho) and rho > 0):
        raise ValueError(f"rho must be a positive number; got {rho!r}")
    t_eigen = time.perf_counter() - t0
    lam = _initial_multiplier(cset, lam0)
    free = _Projector(sp.csc_matrix((n, 0)), inv_d)
    last = {"u": _start(u0, n), "inner": 0}

    def dual_gradient(lam):
        """Bᵀu − g, u = A⁻¹(f − Bλ) from the previous u."""
        u, _, it = _cg(A, f - B @ lam, last["u"], M, free, inner_tol, inner_maxiter,
                       f"Uzawa ({cset.kind})")
        last["u"], last["inner"] = u, last["inner"] + it
        return Bt @ u - cset.g

    t0 = time.perf_counter()
    lam, residuals = _uzawa_loop(dual_gradient, cset, float(rho), tol, maxiter, lam)
    info = {
        "iterations": len(residuals) - 1,
        "residuals": residuals,
        "residual": residuals[-1],
        "rho": float(rho),
        "sigma_max": spectrum["sigma_max"],
        "inner_iterations": last["inner"],
        "seconds": {"eigenvalues": t_eigen, "iterations": time.perf_counter() - t0},
    }
    log.log(solver_level(), "uzawa (%s): %d iterations, %d inner iterations, residual %.2e, "
            "rho %.3e, %.2f s", cset.kind, info["iterations"], last["inner"], info["residual"],
            rho, t_eigen + info["seconds"]["iterations"])
    return last["u"], lam, info
