"""Preconditioned conjugate gradients for operators that are never formed."""
from __future__ import annotations

import logging
import time

import numpy as np
import scipy.linalg as sla
import scipy.sparse.linalg as spla

from ._progress import SOLVER_SECONDS, solver_level
from .solvers import ConvergenceError

log = logging.getLogger(__name__)

__all__ = ["pcg", "jacobi", "ShiftedOperator"]

LOG_EVERY = SOLVER_SECONDS  # seconds between INFO lines of a long solve


def jacobi(diagonal: np.ndarray):
    """The diagonal preconditioner x ↦ x / diag, checked positive."""
    d = np.asarray(diagonal, dtype=np.float64)
    if not np.all(np.isfinite(d)) or np.any(d <= 0):
        bad = np.flatnonzero(~(np.isfinite(d) & (d > 0)))
        raise ValueError(f"the diagonal must be finite and positive; entry {bad[0]} is "
                         f"{d[bad[0]]!r}")
    inv = 1.0 / d
    return lambda r: inv * r


def pcg(A, b: np.ndarray, *, M=None, tol: float = 1e-10, maxiter: int = 1000,
        x0: np.ndarray | None = None) -> tuple[np.ndarray, dict]:
    """Solve A x = b for symmetric positive definite A (anything with ``@``).

    Stops when ‖b − A x‖ ≤ tol·‖b‖; raises :class:`ConvergenceError` after
    ``maxiter`` iterations.  M is the preconditioner, a callable r ↦ M⁻¹r.
    Returns x and {"iterations", "residual", "seconds", "eigenvalues",
    "condition"}: the extreme Ritz values of M⁻¹A from the CG coefficients
    (the Lanczos tridiagonal; estimates from inside the spectrum, nan before
    the first iteration) and their ratio.

    Logs (logger ``fracfem.krylov``) one summary line at the end (INFO, DEBUG
    inside time stepping), each iteration at DEBUG and, in a solve longer than
    ``LOG_EVERY`` seconds, one INFO line every ``LOG_EVERY`` seconds.
    """
    if not (np.isfinite(tol) and 0.0 < tol < 1.0):
        raise ValueError(f"tol={tol!r} must be in (0, 1)")
    if not (isinstance(maxiter, (int, np.integer)) and maxiter >= 1):
        raise ValueError(f"maxiter={maxiter!r} must be an integer >= 1")
    b = np.asarray(b, dtype=np.float64)
    if not np.all(np.isfinite(b)):
        raise ValueError("the right-hand side b has non-finite entries")
    t0 = last = time.perf_counter()
    prec = M if M is not None else (lambda r: r)
    nb = float(np.linalg.norm(b))
    x = np.zeros_like(b) if x0 is None else np.array(x0, dtype=np.float64)
    if nb == 0.0:
        log.log(solver_level(), "PCG: zero right-hand side, 0 iterations")
        return np.zeros_like(b), {"iterations": 0, "residual": 0.0, "seconds": 0.0,
                                  "eigenvalues": (np.nan, np.nan), "condition": np.nan}
    debug = log.isEnabledFor(logging.DEBUG)
    r = b - A @ x if x0 is not None else b.copy()
    z = prec(r)
    p = z.copy()
    rz = float(r @ z)
    res = float(np.linalg.norm(r)) / nb
    it = 0
    alphas, betas = [], []
    while res > tol:
        if it >= maxiter:
            raise ConvergenceError("PCG did not reach its tolerance", it, res)
        q = A @ p
        pq = float(p @ q)
        if not pq > 0.0:
            raise ValueError(f"the operator is not positive definite (pᵀAp = {pq:.3e})")
        alpha = rz / pq
        x += alpha * p
        r -= alpha * q
        z = prec(r)
        rz_new = float(r @ z)
        alphas.append(alpha)
        betas.append(rz_new / rz)
        p = z + betas[-1] * p
        rz = rz_new
        res = float(np.linalg.norm(r)) / nb
        it += 1
        now = time.perf_counter()
        if now - last > LOG_EVERY:
            log.info("PCG iteration %d: relative residual %.2e, %.1f s", it, res, now - t0)
            last = now
        elif debug:
            log.debug("PCG iteration %d: relative residual %.2e", it, res)
    sec = time.perf_counter() - t0
    lo, hi = _ritz_range(alphas, betas)
    log.log(solver_level(), "PCG: %d iterations, relative residual %.2e, %d unknowns, %.2f s, "
            "condition ≈ %.3g", it, res, len(b), sec, hi / lo)
    return x, {"iterations": it, "residual": res, "seconds": sec, "eigenvalues": (lo, hi),
               "condition": hi / lo}


def _ritz_range(alphas: list, betas: list) -> tuple[float, float]:
    """Smallest and largest eigenvalue of the Lanczos tridiagonal of CG
    (step lengths α_j, β_j = r_{j+1}ᵀz_{j+1} / r_jᵀz_j); nan without steps."""
    k = len(alphas)
    if k == 0:
        return np.nan, np.nan
    a, b = np.asarray(alphas), np.asarray(betas)
    diag = 1.0 / a
    diag[1:] += b[:-1] / a[:-1]
    ev = sla.eigvalsh_tridiagonal(diag, np.sqrt(b[:-1]) / a[:-1])
    return float(ev[0]), float(ev[-1])


class ShiftedOperator(spla.LinearOperator):
    """K = A + c·M for an operator A (``@``, ``diagonal()``) and a sparse M:
    the DG(0) matrix M/τ + A with c = 1/τ."""

    def __init__(self, A, M, c: float):
        if not (np.isfinite(c) and c > 0):
            raise ValueError(f"c={c!r} must be a positive number")
        if A.shape != M.shape:
            raise ValueError(f"A {A.shape} and M {M.shape} must have the same shape")
        super().__init__(dtype=np.float64, shape=A.shape)
        self.A, self.M, self.c = A, M, float(c)

    def _matvec(self, x):
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        return self.A @ x + self.c * (self.M @ x)

    def _rmatvec(self, x):
        return self._matvec(x)

    def diagonal(self) -> np.ndarray:
        return self.A.diagonal() + self.c * self.M.diagonal()
