"""Solvers for the discrete mixed problem (Problem 5.15).

Find u (free nodes) and λ ∈ Λ_H with

    A u + B λ = f,    (μ − λ)ᵀ (Bᵀu − g) ≤ 0  for all μ ∈ Λ_H,

for any dense symmetric positive definite A and any constraint set of
:mod:`fracfem.mixed` (a box {lower ≤ λ ≤ upper} with data g).  Equivalently λ
maximises the concave dual  −½ λᵀSλ + λᵀd  over Λ_H, with the Schur complement
S = BᵀA⁻¹B and d = BᵀA⁻¹f − g; the dual gradient is y = Bᵀu − g.

* :func:`uzawa` — Algorithm A (projected gradient ascent on the dual).
* :func:`pdas` — primal–dual active set / semismooth Newton method, an independent
  solver that terminates when the active sets repeat.

Both accept a precomputed Cholesky factor (``factor=``, from
:func:`cholesky_factor`) so that time stepping with a fixed A factorises once.

Both log (logger ``fracfem.solvers``) one summary line at the end (iterations,
residual, seconds; INFO, DEBUG inside time stepping) and DEBUG lines per
active-set step (PDAS) or every 1000 iterations (Uzawa); an iteration running
longer than ``fracfem._progress.SOLVER_SECONDS`` reports at INFO every so often.
"""

from __future__ import annotations

import logging
import time
import weakref

import numba
import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from ._progress import SOLVER_SECONDS, Ticker, solver_level
from .memory import check_dense

logger = logging.getLogger(__name__)

__all__ = [
    "ConvergenceError",
    "cho_factor",
    "cholesky_factor",
    "schur_complement",
    "schur_spectrum",
    "uzawa",
    "pdas",
]

DENSE_EIGEN_LIMIT = 2000  # multipliers up to which σ(S) comes from a dense eigvalsh
KERNEL_RTOL = 1e-10  # eigenvalues of S below KERNEL_RTOL·σ_max count as its kernel
SAFE_STEP = 1.9  # ρ·σ_max when σ_min is unknown
PINV_RCOND = 1e-12  # reduced Schur blocks with a smaller condition estimate are singular


class ConvergenceError(RuntimeError):
    """An iterative solver reached ``maxiter`` without meeting its tolerance."""

    def __init__(self, message, iterations, residual):
        super().__init__(f"{message} (iterations = {iterations}, "
                         f"residual = {residual:.3e})")
        self.iterations = iterations
        self.residual = residual


# ------------------------------------------------------------------ linear algebra


# OpenBLAS's threaded dpotrf crashes (SIGSEGV in dgemm_otcopy, under dsyrk_thread_LN in
# dpotrf_L_parallel) on large matrices: on this project's 2-core machine from n ≈ 23,000
# with 2 threads, both with SciPy's OpenBLAS 0.3.30 and NumPy's 0.3.31 (benchmarks/
# cholesky.md; reported elsewhere at other sizes and thread counts). Above
# BLOCKED_CHOLESKY_N, :func:`cho_factor` factorises by blocks instead: LAPACK's dpotrf only
# on diagonal blocks of CHOLESKY_BLOCK rows, matrix products and triangular solves for the
# rest.
BLOCKED_CHOLESKY_N = 16384
CHOLESKY_BLOCK = 2048


def cho_factor(A, *, overwrite_a: bool = False, check_finite: bool = True,
               blocked_n: int | None = None, block: int | None = None):
    """``scipy.linalg.cho_factor(A, lower=True)`` that does not crash on large matrices.

    Up to ``blocked_n`` (default :data:`BLOCKED_CHOLESKY_N`) rows it is SciPy's call itself.
    Above, a left-looking blocked Cholesky: for each block column j (``block`` rows,
    default :data:`CHOLESKY_BLOCK`), L[j:, j] −= L[j:, :j] L[j, :j]ᵀ (one threaded matrix
    product, no copy of A), LAPACK's dpotrf on the diagonal block and a triangular solve
    for the panel below it; the same flops as dpotrf and the same factor to round-off
    (tests/test_solvers.py). It works on a row-major copy of A (on A itself with
    ``overwrite_a`` when A is a row-major float64 array) and needs 8·n·block bytes more.

    Returns ``(c, lower)`` for ``scipy.linalg.cho_solve`` and LAPACK: SciPy's ``(c, True)``
    up to ``blocked_n``, else ``(Lᵀ, False)``: the blocked factor's transpose, column-major
    as LAPACK's own, so that a solve copies nothing; the triangle other than ``lower``'s is
    not to be read.

    Raises ``numpy.linalg.LinAlgError`` ("k-th leading minor of the array is not positive
    definite", k counted from 1 as SciPy's) and, when ``check_finite``, ``ValueError`` for
    infs or NaNs (blocked: in the lower triangle and the diagonal blocks, all it reads).
    """
    A = A if isinstance(A, np.ndarray) else np.asarray(A)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A must be a square matrix; got shape {A.shape}")
    if np.iscomplexobj(A):
        raise ValueError("A must be real (fracfem's matrices are)")
    n = A.shape[0]
    if n <= (BLOCKED_CHOLESKY_N if blocked_n is None else blocked_n):
        return la.cho_factor(A, lower=True, overwrite_a=overwrite_a,
                             check_finite=check_finite)
    if isinstance(block, bool) or not isinstance(block, (int, np.integer, type(None))) \
            or (block is not None and block < 1):
        raise ValueError(f"block={block!r} must be an integer >= 1")
    b = CHOLESKY_BLOCK if block is None else int(block)
    L = A if (overwrite_a and A.dtype == np.float64 and A.flags.c_contiguous
              and A.flags.writeable) else np.array(A, dtype=np.float64, order="C")
    for j in range(0, n, b):
        e = min(j + b, n)
        if check_finite and not np.isfinite(L[j:, j:e]).all():
            raise ValueError("array must not contain infs or NaNs")
        if j:
            L[j:, j:e] -= L[j:, :j] @ L[j:e, :j].T
        c, info = la.lapack.dpotrf(L[j:e, j:e], lower=1, clean=1)
        if info > 0:
            raise la.LinAlgError(f"{j + info}-th leading minor of the array is not "
                                 "positive definite")
        if info < 0:
            raise ValueError(f"LAPACK reported an illegal value in {-info}-th argument on "
                             'entry to "POTRF".')
        L[j:e, j:e] = c
        if e < n:
            L[e:, j:e] = la.solve_triangular(c, L[e:, j:e].T, lower=True,
                                             check_finite=False).T
    return L.T, False


def cho_factor_bytes(n: int) -> float:
    """Bytes :func:`cho_factor` allocates for an n × n matrix not overwritten: the factor,
    and above :data:`BLOCKED_CHOLESKY_N` rows one block column's product besides."""
    return 8.0 * n * n + (8.0 * n * CHOLESKY_BLOCK if n > BLOCKED_CHOLESKY_N else 0.0)


def cholesky_factor(A):
    """Cholesky factor of the dense SPD matrix A (:func:`cho_factor`)."""
    A = A.toarray() if sp.issparse(A) else np.asarray(A, dtype=float)
    if A.ndim != 2 or A.shape[0] != A.shape[1]:
        raise ValueError(f"A must be a square matrix; got shape {A.shape}")
    n = A.shape[0]
    check_dense(cho_factor_bytes(n),
                what=f"the Cholesky factor of the {n} × {n} free-node matrix",
                advice="use a coarser mesh")
    try:
        return cho_factor(A)
    except la.LinAlgError as err:
        raise ValueError("A must be symmetric positive definite (Cholesky "
                         f"failed: {err})") from err


def _solve(factor, rhs):
    """A⁻¹ rhs from the Cholesky factor."""
    return la.cho_solve(factor, rhs, check_finite=False)


def schur_complement(factor, B, block: int = 512) -> np.ndarray:
    """Dense S = Bᵀ A⁻¹ B, computed in column blocks to bound memory.

    Refused (:class:`fracfem.memory.DenseMemoryError`) before allocating if S and
    its symmetrisation (three m × m arrays) do not fit.
    """
    B = sp.csc_matrix(B)
    n, m = B.shape
    check_dense(8.0 * (3.0 * m * m + 2.0 * n * min(block, m)),
                what=f"the dense Schur complement S = Bᵀ A⁻¹ B of m = {m} multipliers",
                advice="use a coarser multiplier mesh")
    S = np.empty((m, m))
    Bt = B.T.tocsr()
    for start in range(0, m, block):
        cols = slice(start, min(start + block, m))
        S[:, cols] = Bt @ _solve(factor, B[:, cols].toarray())
    S = 0.5 * (S + S.T)     # exactly symmetric: a + b = b + a in floating point
    S.flags.writeable = False   # so that it stays so: _check_schur does not scan it again
    _SYMMETRIC[id(S)] = S
    return S


def _schur_operator(factor, B):
    """S = Bᵀ A⁻¹ B as a LinearOperator (one Cholesky solve per product)."""
    m = B.shape[1]
    Bt = B.T.tocsr()

    def matvec(x):
        return Bt @ _solve(factor, B @ np.ravel(x))

    return spla.LinearOperator((m, m), matvec=matvec, dtype=float)


def schur_spectrum(factor, B, dense_limit: int = DENSE_EIGEN_LIMIT) -> dict:
    """Extreme eigenvalues of S = Bᵀ A⁻¹ B that set the Uzawa step ρ.

    S may have an exact kernel: on meshes whose interior vertices all have even
    degree (``MeshTri.init_circle``, structured meshes) the coarse elements can be
    2-coloured and the checkerboard λ_j = ±1/|T_j| satisfies ∫ λ_H φ_i = 0 for every
    interior hat function, so Lemma 5.17 fails by one dimension.  The kernel does not
    change u, so the step uses the smallest eigenvalue *above* it.

    Up to ``dense_limit`` multipliers S is formed (:func:`schur_complement`) and
    ``eigvalsh`` gives the whole spectrum: robust, exact kernel dimension.  Beyond,
    only σ_max is computed, by Lanczos (ARPACK ``eigsh``, ``which='LA'``, one
    Cholesky solve per product); Lanczos for the lower end was found unreliable here
    (a clustered, nearly singular lower spectrum), and σ_min ≪ σ_max anyway (ratios
    1e-3 … 1e-6 measured), so σ_min is reported as nan.

    Returns
    -------
    dict
        ``sigma_max``; ``sigma_min`` the smallest eigenvalue above the kernel
        (nan if not computed); ``sigma_lowest`` the smallest eigenvalue (≈ 0 when
        there is a kernel; nan if not computed); ``kernel_dim`` (eigenvalues
        ≤ 1e-10 σ_max; None if not computed); ``method`` ('dense' or 'lanczos').
    """
    B = sp.csr_matrix(B)
    m = B.shape[1]
    if m <= dense_limit:
        return _dense_spectrum(schur_complement(factor, B))
    op = _schur_operator(factor, B)
    sigma_max = float(spla.eigsh(op, k=1, which="LA", ncv=min(m, 40), tol=1e-8,
                                 v0=np.ones(m), return_eigenvectors=False)[0])
    return {"sigma_max": sigma_max, "sigma_min": float("nan"),
            "sigma_lowest": float("nan"), "kernel_dim": None, "method": "lanczos"}


def _dense_spectrum(S) -> dict:
    """:func:`schur_spectrum` of a formed S, by LAPACK syevd.

    NumPy's eigvalsh (divide and conquer) rather than SciPy's default driver:
    after numba's parallel loops the latter ran 4–9× slower here (threads)."""
    sigma = np.linalg.eigvalsh(S)
    sigma_max = float(sigma[-1])
    above = sigma[sigma > KERNEL_RTOL * sigma_max]
    return {"sigma_max": sigma_max,
            "sigma_min": float(above[0]) if above.size else float("nan"),
            "sigma_lowest": float(sigma[0]),
            "kernel_dim": int(S.shape[0] - above.size), "method": "dense"}


def _optimal_rho(spectrum) -> float:
    """ρ = 2/(σ_max + σ_min) (Section 7); 1.9/σ_max when σ_min is not known.

    1.9/σ_max keeps the top mode contracting (|1 − ρσ_max| = 0.9) and is within
    5% of the optimal rate whenever σ_min/σ_max < 0.05.
    """
    sigma_min, sigma_max = spectrum["sigma_min"], spectrum["sigma_max"]
    if not (np.isfinite(sigma_max) and sigma_max > 0):
        raise ValueError(f"BᵀA⁻¹B has no positive eigenvalue (σ_max = {sigma_max}); "
                         "is B zero?")
    if not np.isfinite(sigma_min):
        return SAFE_STEP / sigma_max
    return 2.0 / (sigma_max + sigma_min)


# ------------------------------------------------------------------- input checks


def _check_problem(A, B, f, cset, factor):
    """Validate shapes; return (factor, B as csr, f, seconds spent factorising)."""
    B = sp.csr_matrix(B)
    f = np.asarray(f, dtype=float)
    n = B.shape[0]
    if A is not None and tuple(np.shape(A)) != (n, n):
        raise ValueError(f"A must have shape ({n}, {n}) to match B {B.shape}; "
                         f"got {np.shape(A)}")
    if f.shape != (n,):
        raise ValueError(f"f must have shape ({n},); got {f.shape}")
    if not np.all(np.isfinite(f)):
        raise ValueError("f must be finite")
    if cset.n_multipliers != B.shape[1]:
        raise ValueError(f"the constraint set has {cset.n_multipliers} multipliers but "
                         f"B has {B.shape[1]} columns")
    t0 = time.perf_counter()
    if factor is None:
        if A is None:
            raise ValueError("give A or its Cholesky factor (factor=)")
        factor = cholesky_factor(A)
    elif factor[0].shape != (n, n):
        raise ValueError(f"factor must be a Cholesky factor of shape ({n}, {n}); "
                         f"got {factor[0].shape}")
    return factor, B, f, time.perf_counter() - t0


def _is_operator(A, factor, schur, krylov) -> bool:
    """Whether A is an operator (the Krylov path); refuses mixed-up options."""
    if isinstance(A, spla.LinearOperator):
        if factor is not None or schur is not None:
            raise ValueError("factor and schur belong to a dense A; A is an operator")
        return True
    if krylov:
        raise TypeError(f"options {sorted(krylov)} are for an operator A "
                        "(scipy LinearOperator); A is dense")
    return False


SCHUR_ASYMMETRY = 1e-8   # largest |S − Sᵀ| / max|S| taken as round-off in a given S
# the arrays schur_complement made (symmetric by construction), while they live
_SYMMETRIC = weakref.WeakValueDictionary()


def _check_schur(schur, m, block: int = 1024):
    """A precomputed S = BᵀA⁻¹B of shape (m, m): finite and symmetric (the step size's
    eigvalsh, PDAS and the Uzawa update assume it).  An asymmetry of round-off size (at
    most SCHUR_ASYMMETRY of its largest entry, as when S was formed column by column) is
    removed, S replaced by (S + Sᵀ)/2; a larger one is refused.  Compared in row blocks
    (no m × m temporary); an S that :func:`schur_complement` returned is not scanned
    again (it is symmetric by construction, and read-only)."""
    if _SYMMETRIC.get(id(schur)) is schur and schur.shape == (m, m):
        return schur
    schur = np.asarray(schur, dtype=float)
    if schur.shape != (m, m):
        raise ValueError(f"schur must have shape ({m}, {m}); got {schur.shape}")
    scale, asym = (max(schur.max(), -schur.min()) if m else 0.0), 0.0
    if not np.isfinite(scale):
        raise ValueError(f"schur must be finite; it holds {np.sum(~np.isfinite(schur))} "
                         "inf or nan entries")
    for i in range(0, m, block):
        rows = slice(i, min(i + block, m))
        asym = max(asym, np.max(np.abs(schur[rows] - schur[:, rows].T), initial=0.0))
    if asym > SCHUR_ASYMMETRY * scale:
        raise ValueError(f"schur must be symmetric (S = BᵀA⁻¹B): its largest |S − Sᵀ| is "
                         f"{asym:.3g}, {asym / scale:.3g} of its largest entry (allowed: "
                         f"{SCHUR_ASYMMETRY:g})")
    if asym > 0.0:
        schur = 0.5 * (schur + schur.T)
    return schur


def _initial_multiplier(cset, lam0):
    """λ⁰ ∈ Λ_H: zero by default, else the projection of ``lam0``."""
    if lam0 is None:
        return cset.project(np.zeros(cset.n_multipliers))
    lam0 = np.asarray(lam0, dtype=float)
    if lam0.shape != (cset.n_multipliers,) or not np.all(np.isfinite(lam0)):
        raise ValueError(f"lam0 must be a finite vector of shape "
                         f"({cset.n_multipliers},); got shape {lam0.shape}")
    return cset.project(lam0)


def _relative(num, scale):
    """num / scale with 0/0 = 0 (λ ≡ 0 is a legitimate exact solution)."""
    if num == 0.0:
        return 0.0
    return num / scale if scale > 0.0 else num


# -------------------------------------------------------------------------- Uzawa


def uzawa(A, B, f, cset, *, rho=None, tol: float = 1e-10, maxiter: int = 100_000,
          lam0=None, factor=None, schur=None, dense_limit: int = DENSE_EIGEN_LIMIT,
          **krylov):
    """Uzawa iteration, Algorithm A, for Problem 5.15.

    u^n = A⁻¹(f − Bλ^n),  λ^{n+1} = P_Λ(λ^n + ρ(Bᵀu^n − g)).

    Parameters
    ----------
    A : (n, n) dense SPD matrix on the free nodes (may be None if ``factor`` given)
    B : (n, m) sparse coupling matrix, free rows
    f : (n,) load vector f_i = ∫ f φ_i
    cset : constraint set of :mod:`fracfem.mixed`
    rho : float, optional
        Step ρ; default 2/(σ_max + σ_min) of S = BᵀA⁻¹B (σ_min: smallest
        eigenvalue above a possible kernel), computed by :func:`schur_spectrum`
        (dense up to ``dense_limit`` multipliers; beyond, Lanczos σ_max and
        ρ = 1.9/σ_max).  Converges for 0 < ρ < 2/σ_max.
    tol : float
        Stops when the relative change of λ, ‖λ^n − λ^{n−1}‖, and the fixed-point
        (complementarity) residual ‖λ^n − P_Λ(λ^n + ρ(Bᵀu^n − g))‖ at the returned
        pair are both below ``tol`` relative to max(‖λ^n‖, ρ‖BᵀA⁻¹f − g‖).
        (For a linear rate q the error in λ can be ~tol/(1 − q), i.e. up to
        ~κ(S)·tol: choose tol accordingly.)
    maxiter : int
        Raise :class:`ConvergenceError` after this many updates of λ.
    lam0 : (m,) array, optional
        Start λ⁰ (projected onto Λ_H); default 0.
    factor : optional
        Cholesky factor of A (:func:`cholesky_factor`), reused if given.
    schur : (m, m) array, optional
        Precomputed S = BᵀA⁻¹B (:func:`schur_complement`).  Then the same
        iteration runs in the multiplier space, Bᵀu^n − g = BᵀA⁻¹f − g − Sλ^n
        (at most m² instead of n² work per step, and only the columns of S where λ
        changed once the active sets have settled: :class:`_SchurGradient`; u is
        formed once at the end), and σ(S) comes from it.

    Returns
    -------
    u : (n,) displacement on the free nodes
    lam : (m,) multiplier λ_H ∈ Λ_H
    info : dict
        ``iterations``, ``residuals`` (history), ``residual``, ``rho``,
        ``sigma_min``, ``sigma_max``, ``kernel_dim`` (see :func:`schur_spectrum`;
        None if ρ was given), ``seconds`` (``factorisation``, ``eigenvalues``,
        ``iterations``).

    An A that is a ``scipy.sparse.linalg.LinearOperator`` (e.g. the compressed
    operator) goes to :func:`fracfem.krylov_vi.uzawa` with the options
    ``krylov`` (M, u0, inner_tol, inner_maxiter): nothing dense is formed.
    """
    if _is_operator(A, factor, schur, krylov):
        from .krylov_vi import uzawa as uzawa_operator
        return uzawa_operator(A, B, f, cset, rho=rho, tol=tol, maxiter=maxiter, lam0=lam0,
                              **krylov)
    if not (isinstance(maxiter, (int, np.integer)) and maxiter >= 1):
        raise ValueError(f"maxiter must be a positive integer; got {maxiter!r}")
    if not (np.isfinite(tol) and tol > 0):
        raise ValueError(f"tol must be a positive number; got {tol!r}")
    factor, B, f, t_factor = _check_problem(A, B, f, cset, factor)

    t0 = time.perf_counter()
    spectrum = {"sigma_min": None, "sigma_max": None, "kernel_dim": None}
    if schur is not None:
        schur = _check_schur(schur, B.shape[1])
    if rho is None:
        spectrum = (_dense_spectrum(schur) if schur is not None
                    else schur_spectrum(factor, B, dense_limit))
        rho = _optimal_rho(spectrum)
    elif not (np.isfinite(rho) and rho > 0):
        raise ValueError(f"rho must be a positive number; got {rho!r}")
    t_eigen = time.perf_counter() - t0

    t0 = time.perf_counter()
    dual_gradient = _dual_gradient(factor, B, f, cset.g, schur)
    lam, residuals = _uzawa_loop(dual_gradient, cset, float(rho), tol, maxiter,
                                 _initial_multiplier(cset, lam0))
    u = _solve(factor, f - B @ lam)
    info = {
        "iterations": len(residuals) - 1,
        "residuals": residuals,
        "residual": residuals[-1],
        "rho": float(rho),
        "sigma_min": spectrum["sigma_min"],
        "sigma_max": spectrum["sigma_max"],
        "kernel_dim": spectrum["kernel_dim"],
        "seconds": {"factorisation": t_factor, "eigenvalues": t_eigen,
                    "iterations": time.perf_counter() - t0},
    }
    logger.log(solver_level(), "uzawa (%s): %d iterations, residual %.2e, rho %.3e, "
               "%d multipliers, %.2f s", cset.kind, info["iterations"], info["residual"], rho,
               len(lam), t_factor + t_eigen + info["seconds"]["iterations"])
    return u, lam, info


def _dual_gradient(factor, B, f, g, schur):
    """λ ↦ Bᵀu(λ) − g with u(λ) = A⁻¹(f − Bλ): one solve, or with S, a product."""
    Bt = B.T.tocsr()
    if schur is None:
        return lambda lam: Bt @ _solve(factor, f - B @ lam) - g  # u^n, step 1
    d = Bt @ _solve(factor, f) - g
    return _SchurGradient(d, schur)


@numba.njit(cache=True)
def _add_rows(out, S, rows, coef):
    """out += Σ_a coef[a] S[rows[a], :], reading the rows of S in place (no copy of them)."""
    for a in range(rows.size):
        k = rows[a]
        c = coef[a]
        for j in range(S.shape[1]):
            out[j] += c * S[k, j]


class _SchurGradient:
    """λ ↦ d − Sλ for a dense S, updated from the last product where λ changed:
    S λ = S λ' + Σ_{k: λ_k ≠ λ'_k} (λ_k − λ'_k) S[:, k].  Once Uzawa's active sets have
    settled only the free multipliers change (contact; stick), a few per cent of them, so a
    step reads those columns of S (its rows: S is symmetric) instead of all of it.  The same
    iteration up to round-off: the product is formed afresh every ``refresh`` updates and
    whenever more than ``dense_fraction`` of λ changed, so the updates' rounding cannot
    accumulate."""

    def __init__(self, d, S, *, refresh: int = 64, dense_fraction: float = 0.25):
        # S symmetric (schur_complement, _check_schur): the update reads S[:, k] as row k
        self.d, self.S = d, np.ascontiguousarray(S, dtype=float)
        self.refresh, self.dense_fraction = int(refresh), float(dense_fraction)
        self._lam = None
        self._Slam = None
        self._updates = 0
        self.rows_read = 0         # rows of S read so far (m per full product)
        self.full_products = 0

    def __call__(self, lam):
        lam = np.asarray(lam, dtype=float)
        m = lam.shape[0]
        if self._lam is not None and self._updates < self.refresh:
            changed = np.flatnonzero(lam != self._lam)
            if changed.size <= self.dense_fraction * m:
                if changed.size:
                    _add_rows(self._Slam, self.S, changed,
                              lam[changed] - self._lam[changed])
                    self._lam = lam.copy()
                    self.rows_read += changed.size
                self._updates += 1
                return self.d - self._Slam
        self._lam = lam.copy()
        self._Slam = self.S @ lam
        self.rows_read += m
        self.full_products += 1
        self._updates = 0
        return self.d - self._Slam


def _uzawa_loop(dual_gradient, cset, rho, tol, maxiter, lam):
    """The iteration of Algorithm A; returns (λ, residual history)."""
    lam_ref = rho * np.linalg.norm(dual_gradient(np.zeros_like(lam)))  # λ scale
    residuals = []
    previous_change = np.inf
    clock = Ticker(SOLVER_SECONDS)
    for n in range(maxiter + 1):
        step = cset.project(lam + rho * dual_gradient(lam))  # λ^{n+1}, step 2
        scale = max(np.linalg.norm(lam), lam_ref)
        residual = _relative(np.linalg.norm(step - lam), scale)  # at (u^n, λ^n)
        residuals.append(residual)
        if residual < tol and previous_change < tol:
            return lam, residuals
        if n == maxiter:
            break
        previous_change = _relative(np.linalg.norm(step - lam),
                                    max(np.linalg.norm(step), lam_ref))
        lam = step
        if clock.due():
            logger.info("uzawa: iteration %d, residual %.3e, %.1f s", n + 1, residual,
                        clock.elapsed)
        elif n % 1000 == 999:
            logger.debug("uzawa: iteration %d, residual %.3e", n + 1, residual)
    raise ConvergenceError(f"Uzawa ({cset.kind}) did not reach tol = {tol:g}",
                           maxiter, residuals[-1])


# ---------------------------------------------------------------------------- PDAS


def pdas(A, B, f, cset, *, tol: float = 1e-10, maxiter: int = 200, c=None,
         lam0=None, factor=None, schur=None, globalize="auto", **krylov):
    """Primal–dual active set (semismooth Newton) method for Problem 5.15.

    With y = Bᵀu − g and z = λ + c∘y, each step takes the sets
    upper = {z > upper bound}, lower = {z < lower bound} (λ fixed there at the
    bound: no contact / slip) and the rest E (contact / stick: y_E = 0 imposed,
    λ_E unknown), and solves the reduced saddle system through the dense Schur
    complement S_EE = B_EᵀA⁻¹B_E (all of S = BᵀA⁻¹B is formed once, 2n²m flops,
    then each step costs one Cholesky factorisation of S_EE).  It stops when the
    sets repeat, which means the KKT system holds exactly.  For an S that is no
    M-matrix the sets can cycle or the residual stall; then (``globalize``) the
    steps go on from feasible multipliers with the step length that maximises the
    dual energy, which cannot cycle (:func:`fracfem.krylov_vi._feasible_newton`).
    Exactly singular S_EE (see :func:`schur_spectrum`) are solved in the
    minimum-norm sense.

    Parameters
    ----------
    A, B, f, cset : as in :func:`uzawa`
    tol : float
        The fixed-point residual ‖λ − P_Λ(λ + c∘y)‖ / max(‖λ‖, ‖c∘d‖),
        d = BᵀA⁻¹f − g, must be below ``tol`` at the returned pair.
    maxiter : int
        Raise :class:`ConvergenceError` after this many active-set steps.
    c : float or (m,) array, optional
        Complementarity weight; default 1/diag(S), which puts λ and c∘y on the same
        scale.  It only steers the path, not the solution.
    lam0 : (m,) array, optional
        Start (projected onto Λ_H); default 0.
    factor : optional
        Cholesky factor of A (:func:`cholesky_factor`), reused if given.
    schur : (m, m) array, optional
        Precomputed S = BᵀA⁻¹B (:func:`schur_complement`), reused if given.
    globalize : "auto", True or False
        "auto": feasible, energy-maximising steps once the sets cycle or the
        residual stalls; True: from the first step; False: never.

    Returns
    -------
    u, lam, info
        ``info`` holds ``iterations``, ``residuals``, ``residual``, ``n_constrained``
        (|E| per step: contact resp. stick multipliers), ``c``, ``globalized_at``
        (the step from which the steps were feasible, or None), ``seconds``
        (``factorisation``, ``schur``, ``iterations``).

    An A that is a ``scipy.sparse.linalg.LinearOperator`` goes to
    :func:`fracfem.krylov_vi.pdas` with the options ``krylov`` (M, u0,
    inner_tol, inner_maxiter, warm_start): inner Krylov solves, nothing dense.
    """
    if _is_operator(A, factor, schur, krylov):
        from .krylov_vi import pdas as pdas_operator
        return pdas_operator(A, B, f, cset, tol=tol, maxiter=maxiter, c=c, lam0=lam0,
                             globalize=globalize, **krylov)
    if not (isinstance(maxiter, (int, np.integer)) and maxiter >= 1):
        raise ValueError(f"maxiter must be a positive integer; got {maxiter!r}")
    _check_globalize(globalize)
    factor, B, f, t_factor = _check_problem(A, B, f, cset, factor)
    m = B.shape[1]

    t0 = time.perf_counter()
    S = schur_complement(factor, B) if schur is None else _check_schur(schur, m)
    d = B.T @ _solve(factor, f) - cset.g  # dual gradient at λ = 0
    t_schur = time.perf_counter() - t0

    if np.any(np.diag(S) <= 0):
        raise ValueError("B has a zero column (a multiplier that no free node sees): "
                         f"column {int(np.argmin(np.diag(S)))}")
    c = 1.0 / np.diag(S) if c is None else np.broadcast_to(np.asarray(c, float), (m,))
    if not np.all(np.isfinite(c) & (c > 0)):
        raise ValueError("c must be positive and finite")

    t0 = time.perf_counter()
    lam, history, n_constrained, c, switched = _pdas_loop(
        S, d, cset, c, tol, maxiter, _initial_multiplier(cset, lam0), globalize)
    u = _solve(factor, f - B @ lam)
    info = {
        "iterations": len(history),
        "residuals": history,
        "residual": history[-1],
        "n_constrained": n_constrained,
        "c": c,
        "globalized_at": switched,
        "seconds": {"factorisation": t_factor, "schur": t_schur,
                    "iterations": time.perf_counter() - t0},
    }
    logger.log(solver_level(), "pdas (%s): %d steps, residual %.2e, %d multipliers, %.2f s",
               cset.kind, info["iterations"], info["residual"], m,
               t_factor + t_schur + info["seconds"]["iterations"])
    return u, lam, info


def _classify(lam, y, c, lower, upper, fixed):
    """State per multiplier: +1 at upper bound, −1 at lower bound, 0 in E."""
    z = lam + c * y
    state = np.where(z > upper, 1, np.where(z < lower, -1, 0))
    state[fixed] = 1  # lower == upper: λ is determined, never in E
    return state


STALL_STEPS = 10         # globalize when the residual was not halved in this many steps


def _check_globalize(globalize):
    if globalize not in ("auto", True, False):
        raise ValueError(f"globalize={globalize!r} must be 'auto', True or False")


def _stalled(history) -> bool:
    """The residual has not been halved in the last STALL_STEPS active-set steps."""
    return (len(history) > STALL_STEPS
            and min(history[-STALL_STEPS:]) > 0.5 * history[-STALL_STEPS - 1])


def _globalize_reason(globalize, state, new_state, seen, history, residual):
    """Why the active-set steps go on as feasible steps now, or None: always
    (globalize=True), or with "auto" once the sets come back to an earlier
    (not the current) one or the residual stalls."""
    if globalize is True:
        return "globalised"
    if globalize != "auto" or state is None:
        return None
    if new_state.tobytes() in seen and not np.array_equal(new_state, state):
        return "active sets cycle"
    if _stalled(history + [residual]):
        return "residual stalls"
    return None


def _feasible_steps_dense(S, d, cset, c, tol, maxiter, lam, data_scale, history,
                          n_constrained):
    """:func:`fracfem.krylov_vi._feasible_newton` with S = BᵀA⁻¹B at hand: y = d − Sλ
    and the curvature dᵀSd directly.  Appends to ``history`` and ``n_constrained``."""
    lower, upper = cset.lower, cset.upper
    fixed = lower == upper
    lam = cset.project(lam)
    for it in range(maxiter + 1):
        y = d - S @ lam
        residual = _fixed_point_residual(lam, y, c, cset,
                                         max(np.linalg.norm(lam), data_scale))
        history.append(residual)
        if residual < tol:
            return lam
        if it == maxiter:
            break
        state = _classify(lam, y, c, lower, upper, fixed)
        n_constrained.append(int(np.count_nonzero(state == 0)))
        step = cset.project(_reduced_solve(S, d, state, lower, upper)) - lam
        slope = float(y @ step)
        if not slope > 0.0:              # no ascent: the projected gradient point
            step = cset.project(lam + c * y) - lam
            slope = float(y @ step)
        curvature = float(step @ (S @ step))
        alpha = 1.0 if not curvature > 0.0 else min(1.0, slope / curvature)
        lam = cset.project(lam + alpha * step)
    raise ConvergenceError(f"PDAS ({cset.kind}) with feasible steps did not reach "
                           f"tol = {tol:g}", len(history), history[-1])


def _reduced_solve(S, d, state, lower, upper):
    """λ at the bounds off E; on E solve S_EE λ_E = d_E − S_{E,R} λ_R (y_E = 0)."""
    lam = np.where(state > 0, upper, np.where(state < 0, lower, 0.0))
    E = np.flatnonzero(state == 0)
    if E.size:
        R = np.flatnonzero(state != 0)
        rhs = d[E] - S[np.ix_(E, R)] @ lam[R]
        lam[E] = _spd_solve(S[np.ix_(E, E)], rhs)
    return lam


def _spd_solve(S, rhs):
    """Solve with the symmetric PSD block S: Cholesky, or the minimum-norm solution.

    A block can be exactly singular (the checkerboard kernel of BᵀA⁻¹B, see
    :func:`schur_spectrum`, when E is everything); then λ_E is not unique and the
    pseudo-inverse picks the minimum-norm one.
    """
    try:
        factor = cho_factor(S, check_finite=False)
        rcond, info = la.lapack.dpocon(factor[0], np.linalg.norm(S, 1),
                                       uplo="L" if factor[1] else "U")
        if info == 0 and rcond > PINV_RCOND:
            return la.cho_solve(factor, rhs, check_finite=False)
    except la.LinAlgError:
        pass
    w, V = la.eigh(S, check_finite=False)
    keep = w > KERNEL_RTOL * w[-1]
    logger.debug("pdas: singular reduced Schur block (%d of %d eigenvalues kept)",
                 np.count_nonzero(keep), w.size)
    return V[:, keep] @ ((V[:, keep].T @ rhs) / w[keep])


def _fixed_point_residual(lam, y, c, cset, scale):
    """‖λ − P_Λ(λ + c∘y)‖ relative to ``scale`` (zero iff the KKT system holds)."""
    return _relative(np.linalg.norm(lam - cset.project(lam + c * y)), scale)


def _pdas_loop(S, d, cset, c, tol, maxiter, lam, globalize="auto"):
    """Active-set steps in the multiplier space; returns (λ, history, |E|, c, the
    step from which they were feasible or None)."""
    lower, upper = cset.lower, cset.upper
    fixed = lower == upper  # e.g. F_j = 0 outside the friction subdomain
    data_scale = np.linalg.norm(c * d)
    seen, history, n_constrained = set(), [], []
    state = None
    for step in range(maxiter + 1):
        y = d - S @ lam  # Bᵀu − g
        new_state = _classify(lam, y, c, lower, upper, fixed)
        residual = _fixed_point_residual(lam, y, c, cset,
                                         max(np.linalg.norm(lam), data_scale))
        reason = _globalize_reason(globalize, state, new_state, seen, history, residual)
        if reason:
            if state is not None:
                history.append(residual)
            switched = len(history)
            logger.info("pdas (%s): %s at step %d; feasible steps from here", cset.kind,
                        reason, step)
            lam = _feasible_steps_dense(S, d, cset, c, tol, maxiter - step, lam,
                                        data_scale, history, n_constrained)
            return lam, history, n_constrained, c, switched
        if state is not None:
            history.append(residual)
            if residual < tol and (np.array_equal(new_state, state)
                                   or residual < 0.1 * tol):
                return lam, history, n_constrained, c, None
            if np.array_equal(new_state, state):
                raise ConvergenceError("PDAS: the active sets repeat but the residual "
                                       f"is above tol = {tol:g}", step, residual)
        if step == maxiter:
            raise ConvergenceError(f"PDAS ({cset.kind}) did not reach tol = {tol:g}",
                                   maxiter, residual)
        if new_state.tobytes() in seen:
            c = 0.5 * c  # a cycle of active sets: shorten the dual step
            logger.info("pdas: active sets cycle at step %d; halving c", step)
            new_state = _classify(lam, y, c, lower, upper, fixed)
        seen.add(new_state.tobytes())
        state = new_state
        n_constrained.append(int(np.count_nonzero(state == 0)))
        logger.debug("pdas step %d: residual %.2e, |E| = %d", step, residual,
                     n_constrained[-1])
        lam = _reduced_solve(S, d, state, lower, upper)
