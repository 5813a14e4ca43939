"""Parabolic obstacle and friction problems: DG(0) in time (Problem 6.11).

Time stepping
-------------
Discontinuous Galerkin of order 0 in time with the jump term is implicit Euler:
on I_k = (t_{k−1}, t_k], τ_k = t_k − t_{k−1}, with one multiplier λ^k ∈ Λ_H per
step (λ_Hτ piecewise constant in time),

    (M/τ_k + A) u^k + B λ^k = M u^{k−1}/τ_k + f̄_k,
    (μ − λ^k)ᵀ (Bᵀu^k − g) ≤ 0   for all μ ∈ Λ_H,

with M the P1 mass matrix and A the fractional stiffness matrix on the free
(interior) fine nodes, B, g and Λ_H the constraint set of the elliptic mixed
problem (:mod:`fracfem.vi`; Remark 6.12: w = χ for the obstacle, w = g for the
thin obstacle, w = 0 for friction; the same set every step because χ, g, F do
not depend on time) and the load

    f̄_k,i = (1/τ_k) ∫_{I_k} (f(t), φ_i) dt

by a Gauss–Legendre rule in time (``time_quadrature`` points, default 3).
Each step is the elliptic mixed problem with A replaced by A_τ = M/τ + A, so
:func:`fracfem.solvers.pdas` / :func:`fracfem.solvers.uzawa` solve it; the
Cholesky factor of A_τ and the Schur complement S_τ = Bᵀ A_τ⁻¹ B are cached per
distinct τ (:class:`Stepper`), so a run with a constant τ factorises once.

The load ``f``
--------------
``f`` is a number (constant in space and time), a callable ``f(x)`` (constant
in time) or a callable ``f(x, t)``; x has shape (2, ...), t is a float.  Which
callable it is, is read from its signature (one or two required positional
parameters); pass ``f_time=True`` / ``False`` to say it explicitly (needed for
callables without an inspectable signature).

Initial data
------------
The jump term at t₀ is ⟨u^{0,+} − u₀, v⟩ for v ∈ V_h: DG(0) needs u₀ only
through (u₀, φ_i) for the free nodes i.  Starting from u₀ is therefore the same
as starting from its L² projection P_h u₀ onto V_h (zero on ∂Ω_h),
M P_h u₀ = ((u₀, φ_i))_i — also when u₀ ∉ V_h, e.g. u₀ = 1 which does not
vanish on ∂Ω.  :func:`initial_projection` computes P_h u₀ (quadrature of order
6 for callables; exact for arrays, which are read as P1 functions on the fine
mesh: an array that lies in V_h is its own projection).  The step-0 record of
:func:`time_steps` holds P_h u₀, and the indicators
(:mod:`fracfem.spacetime_estimators`) add the term ‖u₀ − P_h u₀‖²_{L²(S_i)} of
Theorem 6.18.  Space-time adaptivity (Algorithm C) is
:mod:`fracfem.spacetime_adaptive`.

Progress
--------
:func:`time_steps` logs (logger ``fracfem.parabolic``) one line per time step:
INFO for the last step of the grid and whenever at least
``fracfem._progress.STEP_SECONDS`` (1 s) passed since the previous INFO line,
DEBUG otherwise, so a run of 1,000 fast steps writes a handful of INFO lines.
The solvers of the single steps log their summaries at DEBUG; each new
factorisation of M/τ + A is an INFO line.
"""
from __future__ import annotations

import inspect
import logging
import math
import numbers
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import solvers
from ._progress import STEP_SECONDS, Ticker, inner_solves
from .assembly import load_vector
from .krylov import ShiftedOperator, pcg
from .laplace import SOLVER_TOL, Discretisation
from .preconditioners import multilevel_preconditioner

__all__ = [
    "mass_matrix",
    "Source",
    "time_grid",
    "Stepper",
    "initial_projection",
    "TimeStep",
    "time_steps",
    "solve_parabolic",
]

TAU_RTOL = 1e-9  # time steps within this relative distance share one factorisation

logger = logging.getLogger(__name__)


# ------------------------------------------------------------------ small checks


def _is_real(x) -> bool:
    return isinstance(x, numbers.Real) and not isinstance(x, (bool, np.bool_))


def _positive(name, x) -> float:
    if not _is_real(x) or not np.isfinite(x) or not x > 0:
        raise ValueError(f"{name}={x!r} must be a finite number > 0")
    return float(x)


def _positive_int(name, x) -> int:
    if not isinstance(x, numbers.Integral) or isinstance(x, (bool, np.bool_)) or x < 1:
        raise ValueError(f"{name}={x!r} must be an integer >= 1")
    return int(x)


# ------------------------------------------------------------------ mass matrix


def mass_matrix(mesh) -> sp.csr_matrix:
    """P1 mass matrix M_ij = ∫ φ_i φ_j over all nodes (scikit-fem), csr."""
    from skfem import Basis, BilinearForm, ElementTriP1, asm

    @BilinearForm
    def mass(u, v, _):
        return u * v

    return asm(mass, Basis(mesh, ElementTriP1(), intorder=2)).tocsr()


# ------------------------------------------------------------------ the load


class Source:
    """The load f of the parabolic problem: number, f(x) or f(x, t).

    Parameters
    ----------
    f : number, callable f(x) or callable f(x, t) (x of shape (2, ...), t float)
    f_time : None (read the signature: two required positional parameters mean
        f(x, t)), True (f(x, t)) or False (f(x))
    """

    def __init__(self, f, f_time: bool | None = None):
        if f_time is not None and not isinstance(f_time, (bool, np.bool_)):
            raise ValueError(f"f_time={f_time!r} must be None, True or False")
        if isinstance(f, Source):
            self.f, self.time_dependent = f.f, f.time_dependent
            return
        if _is_real(f):
            if not np.isfinite(f):
                raise ValueError(f"f={f!r} must be finite")
            if f_time:
                raise ValueError("f_time=True needs a callable f(x, t), got a number")
            self.f, self.time_dependent = float(f), False
            return
        if not callable(f):
            raise ValueError(f"f must be a number, a callable f(x) or a callable "
                             f"f(x, t); got {type(f).__name__}")
        if f_time is None:
            f_time = self._arity(f) == 2
        self.f, self.time_dependent = f, bool(f_time)

    @staticmethod
    def _arity(f) -> int:
        try:
            sig = inspect.signature(f)
        except (TypeError, ValueError) as err:
            raise ValueError("cannot read the signature of f; pass f_time=True for "
                             "f(x, t) or f_time=False for f(x)") from err
        required = [p for p in sig.parameters.values()
                    if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)
                    and p.default is p.empty]
        if len(required) not in (1, 2):
            raise ValueError(f"f must take (x) or (x, t); its signature {sig} has "
                             f"{len(required)} required positional parameters "
                             "(pass f_time= to say which)")
        return len(required)

    def at(self, t: float):
        """f(·, t) as a number or a callable of x."""
        if not self.time_dependent:
            return self.f
        f = self.f
        return lambda x: f(x, t)

    def mean(self, t0: float, t1: float, n: int):
        """f̄ = (1/(t1 − t0)) ∫_{t0}^{t1} f(·, t) dt by an n-point Gauss rule in t."""
        if not self.time_dependent:
            return self.f
        tg, wg = _gauss(t0, t1, n)
        f = self.f
        return lambda x: sum(w * np.asarray(f(x, t), dtype=float)
                             for t, w in zip(tg, wg))

    @property
    def is_zero(self) -> bool:
        return not callable(self.f) and self.f == 0.0


def _gauss(t0, t1, n):
    """Points and weights (summing to 1) of the n-point Gauss rule on [t0, t1]."""
    x, w = np.polynomial.legendre.leggauss(n)
    return t0 + 0.5 * (x + 1.0) * (t1 - t0), 0.5 * w


# ------------------------------------------------------------------ time grids


def time_grid(times=None, *, T=None, tau=None, t0: float = 0.0) -> np.ndarray:
    """The time points t_0 < t_1 < … < t_M.

    Either ``times`` (any strictly increasing finite array of ≥ 2 points) or
    ``T`` > 0 and ``tau`` > 0: then M = ⌈T/τ⌉ (up to round-off 1e−9) uniform steps
    of length T/M ≤ τ on [t0, t0 + T].
    """
    if times is not None:
        if T is not None or tau is not None:
            raise ValueError("give either times or (T, tau), not both")
        times = np.asarray(times, dtype=float)
        if times.ndim != 1 or times.size < 2:
            raise ValueError(f"times must be a 1-D array of at least 2 time points; "
                             f"got shape {times.shape}")
        if not np.all(np.isfinite(times)):
            raise ValueError("times must be finite")
        if np.any(np.diff(times) <= 0):
            k = int(np.flatnonzero(np.diff(times) <= 0)[0])
            raise ValueError(f"times must be strictly increasing; times[{k + 1}] = "
                             f"{times[k + 1]!r} <= times[{k}] = {times[k]!r}")
        return times
    if T is None or tau is None:
        raise ValueError("give times, or both T (final time) and tau (time step)")
    T = _positive("T", T)
    tau = _positive("tau", tau)
    if not _is_real(t0) or not np.isfinite(t0):
        raise ValueError(f"t0={t0!r} must be a finite number")
    n = max(1, math.ceil(T / tau - 1e-9))
    return float(t0) + np.linspace(0.0, T, n + 1)


# ------------------------------------------------------------------ the stepper


def _held_bytes(obj, seen=None) -> int:
    """Bytes of the numpy arrays, sparse matrices and compressed operators in
    ``obj`` (through lists, tuples, dicts and the attributes of other objects),
    each counted once."""
    import scipy.sparse as sp

    from .compressed import CompressedOperator
    seen = set() if seen is None else seen
    if obj is None or id(obj) in seen or isinstance(obj, (str, bytes, int, float)):
        return 0
    seen.add(id(obj))
    if isinstance(obj, np.ndarray):
        return int(obj.nbytes) if obj.base is None or id(obj.base) not in seen else 0
    if isinstance(obj, CompressedOperator):
        return int(obj.nbytes)
    if sp.issparse(obj):
        return sum(int(getattr(obj, a).nbytes) for a in ("data", "indices", "indptr", "row",
                                                          "col", "offsets")
                   if isinstance(getattr(obj, a, None), np.ndarray))
    if isinstance(obj, dict):
        return sum(_held_bytes(v, seen) for v in obj.values())
    if isinstance(obj, (list, tuple)):
        return sum(_held_bytes(v, seen) for v in obj)
    if hasattr(obj, "__dict__"):
        return sum(_held_bytes(v, seen) for v in vars(obj).values())
    return 0


class Stepper:
    """DG(0) steps of one assembled problem, with the per-τ factorisations.

    Parameters
    ----------
    problem : :class:`fracfem.vi.MixedProblem` (any kind: obstacle, friction,
        thin_obstacle, thin_friction) or :class:`fracfem.laplace.Discretisation`
        (the unconstrained fractional heat equation)
    max_cached : number of distinct τ whose Cholesky factor (and Schur complement)
        are kept (least recently used dropped); each costs one dense n × n matrix.
        With a compressed operator (``discretise(..., operator='compressed')``)
        M/τ + A stays an operator with a multilevel preconditioner per τ, and
        every step is solved by warm-started Krylov iterations (PCG, or the
        PDAS / Uzawa of :mod:`fracfem.krylov_vi`): nothing dense is formed.
        PDAS given ``lam0`` = λ^{k−1} (the multiplier of ``u_prev``'s step) starts
        from that step's active sets (``pair_start``).

    Attributes
    ----------
    disc, cset (None if unconstrained), kind ('heat' if unconstrained), mesh (fine),
    coarse (None if unconstrained), free, M (free × free mass matrix, csr),
    timings (seconds: 'mass', 'factorisation', 'schur', 'eigenvalues',
    'load', 'solve'), n_factorisations.
    """

    def __init__(self, problem, *, max_cached: int = 4):
        from .vi import MixedProblem

        if isinstance(problem, Stepper):
            raise TypeError("problem is already a Stepper")
        if isinstance(problem, MixedProblem):
            self.problem, self.disc, self.cset = problem, problem.disc, problem.cset
            self.kind, self.coarse = problem.kind, problem.coarse
        elif isinstance(problem, Discretisation):
            self.problem, self.disc, self.cset = problem, problem, None
            self.kind, self.coarse = "heat", None
        else:
            raise TypeError(f"problem must be a vi.MixedProblem or a "
                            f"laplace.Discretisation, got {type(problem).__name__}")
        self.max_cached = _positive_int("max_cached", max_cached)
        t0 = time.perf_counter()
        self.mesh = self.disc.mesh
        self.free = np.asarray(self.disc.free)
        M_all = mass_matrix(self.mesh)
        self.M_rows = M_all[self.free]                 # free × all nodes
        self.M = self.M_rows[:, self.free].tocsr()     # free × free
        self._M_dense = None
        self._M_lu = None
        self._ops: OrderedDict = OrderedDict()
        self._loads: dict = {}
        self.n_factorisations = 0
        self.timings = dict(mass=time.perf_counter() - t0, factorisation=0.0, schur=0.0,
                            eigenvalues=0.0, load=0.0, solve=0.0, projection=0.0)

    @property
    def s(self) -> float:
        return self.disc.s

    @property
    def nbytes(self) -> int:
        """Bytes of the arrays it holds: the stiffness matrix or compressed
        operator, the coupling and mass matrices and the cached factorisations,
        Schur complements and preconditioners."""
        return _held_bytes([self.disc.A, getattr(self.cset, "B", None), self.M_rows, self.M,
                            self._M_dense, self._M_lu, list(self._ops.values())])

    @property
    def n_free(self) -> int:
        return len(self.free)

    # ---- operators

    def _key(self, tau):
        for key in self._ops:
            if abs(key - tau) <= TAU_RTOL * key:
                self._ops.move_to_end(key)
                return key
        return None

    def operator(self, tau: float) -> tuple[float, dict]:
        """(τ used, {'factor', 'schur', 'rho'}) for A_τ = M/τ + A, cached.

        Steps within a relative 1e−9 of a cached τ reuse it (and its τ in the
        right-hand side, so the step is consistent with its matrix).
        """
        tau = _positive("tau", tau)
        key = self._key(tau)
        if key is not None:
            return key, self._ops[key]
        if not self.disc.dense:
            return tau, self._compressed_operator(tau)
        if self._M_dense is None:
            self._M_dense = self.M.toarray()
        t0 = t_start = time.perf_counter()
        K = self.disc.A + self._M_dense / tau
        factor = solvers.cholesky_factor(K)
        del K
        self.timings["factorisation"] += time.perf_counter() - t0
        self.n_factorisations += 1
        op = {"factor": factor, "schur": None, "rho": None}
        if self.cset is not None:
            t0 = time.perf_counter()
            op["schur"] = solvers.schur_complement(factor, self.cset.B)
            self.timings["schur"] += time.perf_counter() - t0
        logger.info("Stepper: factorised M/τ + A for τ = %.4g: %d unknowns, %d multipliers "
                    "(Schur complement), %.2f s", tau, self.n_free,
                    0 if self.cset is None else self.cset.B.shape[1],
                    time.perf_counter() - t_start)
        self._ops[tau] = op
        while len(self._ops) > self.max_cached:
            self._ops.popitem(last=False)
        return tau, op

    def _compressed_operator(self, tau: float) -> dict:
        """M/τ + A as an operator with its multilevel preconditioner (cached)."""
        t0 = time.perf_counter()
        K = ShiftedOperator(self.disc.A, self.M, 1.0 / tau)
        op = {"K": K, "preconditioner": multilevel_preconditioner(self.mesh, K),
              "factor": None, "schur": None, "rho": None}
        self.timings["factorisation"] += time.perf_counter() - t0
        logger.info("Stepper: preconditioner of M/τ + A for τ = %.4g (%d unknowns), %.2f s",
                    tau, self.n_free, time.perf_counter() - t0)
        self.n_factorisations += 1
        self._ops[tau] = op
        while len(self._ops) > self.max_cached:
            self._ops.popitem(last=False)
        return op

    # ---- loads

    def load(self, source: Source, t0: float, t1: float, n_gauss: int = 3) -> np.ndarray:
        """f̄ = (1/τ)∫_{t0}^{t1} (f(t), φ_i) dt on the free nodes (Gauss in time)."""
        t_start = time.perf_counter()
        if source.is_zero:
            out = np.zeros(self.n_free)
        elif not source.time_dependent:
            # one cached vector for the last f(x) seen (kept alive, compared by identity)
            cached = self._loads.get("f")
            if cached is None or not (cached[0] is source.f or cached[0] == source.f):
                cached = (source.f, load_vector(self.mesh, source.f)[self.free])
                self._loads["f"] = cached
            out = cached[1]
        else:
            tg, wg = _gauss(t0, t1, n_gauss)
            out = sum(w * load_vector(self.mesh, source.at(t))[self.free]
                      for t, w in zip(tg, wg))
        self.timings["load"] += time.perf_counter() - t_start
        return out

    # ---- one step

    def step(self, u_prev: np.ndarray, tau: float, load: np.ndarray, *,
             solver: str = "pdas", lam0=None, solver_options: dict | None = None,
             guess=None):
        """One DG(0) step from u^{k−1} (free nodes): (u^k free, λ^k or None, info).

        ``guess`` (free nodes, default u^{k−1}) starts the iterative solvers of a
        compressed operator; it changes their iteration count, not the solution."""
        if guess is None:
            guess = u_prev
        elif np.shape(guess) != np.shape(u_prev):
            raise ValueError(f"guess must be a vector of shape {np.shape(u_prev)} (the free "
                             f"nodes); got shape {np.shape(guess)}")
        elif not np.all(np.isfinite(guess)):
            raise ValueError(f"guess must be finite; got {np.count_nonzero(~np.isfinite(guess))}"
                             " entries that are NaN or infinite")
        tau, op = self.operator(tau)
        rhs = self.M @ u_prev / tau + load
        t0 = time.perf_counter()
        with inner_solves():   # the solvers' summaries are DEBUG: time_steps reports
            u, lam, info = self._solve(op, tau, guess, rhs, solver, lam0, solver_options)
        seconds = time.perf_counter() - t0
        self.timings["solve"] += seconds
        info = dict(info)
        info["seconds_step"] = seconds
        info["tau_used"] = tau
        return u, lam, info

    def _solve(self, op, tau, guess, rhs, solver, lam0, solver_options):
        """(u^k, λ^k, solver info) of one step with the operator ``op`` of τ;
        ``guess`` starts the iterative solvers."""
        if self.cset is None and op["factor"] is None:
            # warm start from u^{k−1} (or its extrapolation): the step changes u by O(τ)
            u, info = pcg(op["K"], rhs, M=op["preconditioner"], x0=guess, tol=SOLVER_TOL)
            lam = None
        elif self.cset is None:
            u = la.cho_solve(op["factor"], rhs, check_finite=False)
            lam, info = None, {}
        elif op["factor"] is None:
            # inner Krylov solves with M/τ + A, warm-started from u^{k−1}
            opts = dict(solver_options or {})
            if lam0 is not None and "lam0" not in opts:
                opts["lam0"] = lam0
                if (solver == "pdas" and "u0" not in opts
                        and np.any(solvers._initial_multiplier(self.cset, lam0))):
                    # λ^{k−1} solved the last step and the guess (u^{k−1} or its linear
                    # predictor) is near u^k: their active sets start this step
                    opts.setdefault("pair_start", True)
            opts.setdefault("M", op["preconditioner"])
            opts.setdefault("u0", guess)
            run = {"pdas": solvers.pdas, "uzawa": solvers.uzawa}.get(solver)
            if run is None:
                raise ValueError(f"solver={solver!r} must be 'pdas' or 'uzawa'")
            u, lam, info = run(op["K"], self.cset.B, rhs, self.cset, **opts)
        else:
            opts = dict(solver_options or {})
            if lam0 is not None and "lam0" not in opts:
                opts["lam0"] = lam0
            if solver == "pdas":
                u, lam, info = solvers.pdas(None, self.cset.B, rhs, self.cset,
                                            factor=op["factor"], schur=op["schur"], **opts)
            elif solver == "uzawa":
                if op["rho"] is not None and "rho" not in opts:
                    opts["rho"] = op["rho"]
                u, lam, info = solvers.uzawa(None, self.cset.B, rhs, self.cset,
                                             factor=op["factor"], schur=op["schur"], **opts)
                if op["rho"] is None and "rho" not in (solver_options or {}):
                    op["rho"] = info["rho"]
                    self.timings["eigenvalues"] += info["seconds"]["eigenvalues"]
            else:
                raise ValueError(f"solver={solver!r} must be 'pdas' or 'uzawa'")
        return u, lam, info

    # ---- projection

    def project(self, u0, *, order: int = 6) -> np.ndarray:
        """P_h u₀ on the free nodes (see :func:`initial_projection`)."""
        t0 = time.perf_counter()
        nv = self.mesh.p.shape[1]
        if _is_real(u0) or callable(u0):
            if _is_real(u0) and not np.isfinite(u0):
                raise ValueError(f"u0={u0!r} must be finite")
            try:
                b = load_vector(self.mesh, u0, order=order)[self.free]
            except ValueError as err:
                raise ValueError(f"u0 must be finite at the quadrature points ({err})") \
                    from err
        else:
            arr = np.asarray(u0, dtype=float)
            if arr.shape == (nv,):
                full = arr
            elif arr.shape == (self.n_free,):
                full = np.zeros(nv)
                full[self.free] = arr
            else:
                raise ValueError(f"u0 must be a number, a callable u0(x) or nodal values "
                                 f"of shape ({nv},) (all fine nodes) or ({self.n_free},) "
                                 f"(free nodes); got shape {arr.shape}")
            if not np.all(np.isfinite(full)):
                raise ValueError("u0 must be finite (it has non-finite nodal values)")
            b = self.M_rows @ full
        if not np.all(np.isfinite(b)):
            raise ValueError("u0 must be finite (non-finite values at quadrature points)")
        if self._M_lu is None:
            self._M_lu = spla.splu(self.M.tocsc())
        u = self._M_lu.solve(b)
        self.timings["projection"] += time.perf_counter() - t0
        return u


def _as_stepper(problem) -> Stepper:
    return problem if isinstance(problem, Stepper) else Stepper(problem)


def initial_projection(problem, u0, *, order: int = 6) -> np.ndarray:
    """P_h u₀: the L² projection of u₀ onto V_h (zero on ∂Ω_h), over all fine nodes.

    DG(0) sees u₀ only through the jump term ⟨u^{0,+} − u₀, v⟩, v ∈ V_h, i.e.
    through (u₀, φ_i) for the free nodes i, so starting from u₀ and from P_h u₀
    are the same.  ``u0``: number, callable u0(x) (x of shape (2, ...); integrals
    by a triangle rule of ``order``) or nodal values of a P1 function on the fine
    mesh (all nodes, or free nodes with zero boundary values; exact).
    ``problem``: MixedProblem, Discretisation or :class:`Stepper`.
    """
    st = _as_stepper(problem)
    return st.disc.extend(st.project(u0, order=order))


# ------------------------------------------------------------------ stepping


@dataclass
class TimeStep:
    """One time step of DG(0): u^k on (t_{k−1}, t_k].

    k = 0 is the initial state: t = t_0, tau = 0, u = P_h u₀, lam = None.
    """

    k: int
    t: float                     # t_k
    tau: float                   # t_k − t_{k−1} (0 for k = 0)
    u: np.ndarray                # u^k over all fine nodes (zero on ∂Ω_h)
    lam: np.ndarray | None       # λ^k per multiplier (None if unconstrained or k = 0)
    info: dict = field(default_factory=dict)  # solver info; 'seconds_step', 'tau_used'


def _check_solver(solver):
    if solver not in ("pdas", "uzawa"):
        raise ValueError(f"solver={solver!r} must be 'pdas' or 'uzawa'")


def time_steps(problem, u0, times=None, *, T=None, tau=None, t0: float = 0.0,
               f=0.0, f_time: bool | None = None, solver: str = "pdas",
               solver_options: dict | None = None, time_quadrature: int = 3,
               projection_order: int = 6, warm_start: bool = True
               ) -> Iterator[TimeStep]:
    """DG(0) time stepping of Problem 6.11 as a generator of :class:`TimeStep`.

    Parameters
    ----------
    problem : MixedProblem (obstacle, friction, thin_obstacle, thin_friction),
        Discretisation (unconstrained) or :class:`Stepper` (reuses its cached
        factorisations; pass one to share them between calls)
    u0 : initial value (number, callable u0(x), or nodal array; projected, see
        :func:`initial_projection`)
    times / T, tau, t0 : the time grid (:func:`time_grid`)
    f, f_time : the load (module docstring; default f = 0)
    solver : 'pdas' or 'uzawa' per step (constrained problems)
    solver_options : keywords of the solver (tol, maxiter, …)
    time_quadrature : Gauss points in time for f̄_k (time-dependent f)
    warm_start : start each step's solver from λ^{k−1} and, where it iterates
        (a compressed operator), from u^{k−1} + τ_k (u^{k−1} − u^{k−2})/τ_{k−1}

    Yields
    ------
    TimeStep k = 0 (P_h u₀), then k = 1 … M.  Usage::

        for step in time_steps(prob, 2.0, T=1.0, tau=0.05):
            record(step.t, step.u, step.lam, step.info)
    """
    _check_solver(solver)
    _positive_int("time_quadrature", time_quadrature)
    grid = time_grid(times, T=T, tau=tau, t0=t0)
    source = Source(f, f_time)
    st = _as_stepper(problem)
    clock = Ticker(STEP_SECONDS)
    n_steps = len(grid) - 1
    logger.debug("DG(0) time stepping (%s): %d steps on [%g, %g], %d unknowns", st.kind,
                 n_steps, grid[0], grid[-1], st.n_free)
    u = st.project(u0, order=projection_order)
    yield TimeStep(0, float(grid[0]), 0.0, st.disc.extend(u), None,
                   {"seconds_projection": st.timings["projection"]})
    lam = None
    u_before = None     # u^{k−2}: with u^{k−1} the linear predictor of u^k
    for k in range(1, len(grid)):
        a, b = float(grid[k - 1]), float(grid[k])
        load = st.load(source, a, b, time_quadrature)
        guess = None
        if warm_start and u_before is not None:
            # u^{k−1} + τ_k (u^{k−1} − u^{k−2})/τ_{k−1}: the iterative solvers start
            # O(τ²) from u^k instead of O(τ) (the solution is the same)
            guess = u + (b - a) / (a - float(grid[k - 2])) * (u - u_before)
        u_new, lam, info = st.step(u, b - a, load, solver=solver,
                                   lam0=lam if warm_start else None,
                                   solver_options=solver_options, guess=guess)
        # at k = 2, u^{k−2} is the projection of u₀ (no step's solution): measured, the
        # predictor from it still saves iterations (Example 5, 481 DOFs: 544 against 550)
        u_before, u = u, u_new
        logger.log(logging.INFO if k == n_steps or clock.due() else logging.DEBUG,
                   "DG(0) step %d/%d: t = %.6g, %d DOFs, solver iterations: %s, %.3f s "
                   "(elapsed %.1f s)", k, n_steps, b, st.n_free,
                   info.get("iterations", "none (Cholesky)"),
                   info["seconds_step"], clock.elapsed)
        yield TimeStep(k, b, b - a, st.disc.extend(u), lam, info)


def solve_parabolic(problem, u0, times=None, **kwargs) -> list[TimeStep]:
    """All steps of :func:`time_steps` as a list (k = 0 first)."""
    return list(time_steps(problem, u0, times, **kwargs))
