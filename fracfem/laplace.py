"""The unconstrained problem a(u, v) = (f, v): Example 1 and fractional heat."""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from ._progress import solver_level
from .assembly import (QuadratureOptions, _check_dense_memory, dense_bytes, load_vector,
                       stiffness_matrix)
from .compressed import DEFAULT_TOL, stiffness_operator
from .krylov import pcg
from .memory import check_dense, memory_limit
from .exact import check_s
from .opcache import dense_free_block
from .meshes import validates
from .preconditioners import multilevel_preconditioner
from .solvers import cho_factor, cho_factor_bytes

OPERATORS = ("dense", "compressed", "auto")
# "auto": dense up to this many free nodes (and if it fits), compressed above.  At one
# thread (benchmarks/auto-operator.md) dense is the faster up to 2,017 free nodes
# (dense/compressed 0.63-0.94), compressed from 3,273 on (1.45-2.37), the anisotropic
# graded mesh of 3,626 nodes aside (0.98): the switch lies in between, and placed
# anywhere there it costs a single solve at most 6 %.
AUTO_DENSE_NODES = 2000
SOLVER_TOL = 1e-10        # relative PCG residual of solve_laplace

__all__ = ["Discretisation", "discretise", "solve_laplace"]

logger = logging.getLogger(__name__)


@dataclass
class Discretisation:
    """Free-node stiffness matrix and load of one mesh, with phase timings."""

    mesh: object
    s: float
    free: np.ndarray
    A: object                      # a(φ_i, φ_j), i, j free: array or CompressedOperator
    b: np.ndarray                  # (f, φ_i), i free
    timings: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)

    @property
    def dense(self) -> bool:
        """True when A is a dense array (else a compressed operator)."""
        return isinstance(self.A, np.ndarray)

    def extend(self, u_free: np.ndarray) -> np.ndarray:
        """Nodal vector over all nodes, zero on the boundary."""
        u = np.zeros(self.mesh.p.shape[1])
        u[self.free] = u_free
        return u


def _dense_fits(mesh) -> bool:
    import numba
    lim = memory_limit()[0]
    need = dense_bytes(mesh.p.shape[1], mesh.t.shape[1], numba.get_num_threads())
    return lim is None or need < 0.5 * lim


def _check_reusable(stiffness, mesh, s, free):
    """Refuse a Discretisation made for another mesh or s than the one it is reused for."""
    if not isinstance(stiffness, Discretisation):
        raise ValueError(f"stiffness={type(stiffness).__name__} must be a Discretisation "
                         "(the result of discretise for this mesh and s)")
    if float(stiffness.s) != float(s):
        raise ValueError(f"stiffness was assembled for s={stiffness.s:g}, not s={float(s):g}")
    same = (stiffness.mesh is mesh
            or (stiffness.mesh.p.shape == mesh.p.shape and stiffness.mesh.t.shape == mesh.t.shape
                and np.array_equal(stiffness.mesh.p, mesh.p)
                and np.array_equal(stiffness.mesh.t, mesh.t)))
    if not same or not np.array_equal(stiffness.free, free):
        raise ValueError(f"stiffness was assembled on another mesh ({stiffness.mesh.p.shape[1]} "
                         f"nodes) than this one ({mesh.p.shape[1]} nodes)")


@validates("mesh")
def discretise(mesh, s: float, f=1.0, *, quadrature: QuadratureOptions | None = None,
               load_order: int = 6, operator: str = "dense",
               tol: float = DEFAULT_TOL, stiffness=None) -> Discretisation:
    """Assemble the free-node matrix and load vector of (−Δ)^s u = f.

    operator: "dense" (an array; refused before assembly when it does not fit,
    limit ``$FRACFEM_MEMORY_LIMIT``), "compressed"
    (:func:`fracfem.compressed.stiffness_operator` with accuracy ``tol``) or
    "auto" (dense up to ``AUTO_DENSE_NODES`` = 2,000 free nodes when it fits, else
    compressed).
    The mesh is checked once (:func:`fracfem.meshes.validate_mesh`).
    stiffness: a Discretisation of this mesh and s made before (other data f): its
    operator is reused instead of assembled, and only the load is computed.
    With an operator cache (:mod:`fracfem.opcache`: :func:`fracfem.operator_cache` or
    ``$FRACFEM_OPERATOR_CACHE``) a dense matrix assembled before with the same mesh, s,
    quadrature and code is read back instead (``info['cache']``: 'hit' or 'miss'); its
    ``timings['assembly']`` stays the seconds of the assembly.
    """
    s = check_s(s)
    if quadrature is not None and not isinstance(quadrature, QuadratureOptions):
        raise ValueError(f"quadrature={quadrature!r} must be a fracfem.QuadratureOptions "
                         "or None (the default orders)")
    if operator not in OPERATORS:
        raise ValueError(f"operator={operator!r} must be one of {OPERATORS}")
    free = mesh.interior_nodes()
    if stiffness is not None:
        _check_reusable(stiffness, mesh, s, free)
        b = load_vector(mesh, f, order=load_order)[free]
        return Discretisation(mesh, float(s), free, stiffness.A, b, {"assembly": 0.0},
                              {**stiffness.info, "reused": True})
    if operator == "auto":
        operator = "dense" if len(free) <= AUTO_DENSE_NODES and _dense_fits(mesh) \
            else "compressed"
    tim: dict = {}
    if operator == "dense":
        def assemble():
            A = stiffness_matrix(mesh, s, quadrature=quadrature, timings=tim)
            return A, tim
        import numba
        quad = quadrature or QuadratureOptions()
        # refused as assembly would refuse it, also when the cache holds it
        _check_dense_memory(mesh.p.shape[1], mesh.t.shape[1], numba.get_num_threads(), quad,
                            None)
        Af, tim, cached = dense_free_block(mesh, s, free, quad, assemble)
        info = {"operator": "dense", **cached}
    else:
        Af = stiffness_operator(mesh, s, tol=tol, quadrature=quadrature)
        tim = Af.info["timings"]
        info = {"operator": "compressed", "tol": tol, "order": Af.info["order"],
                "nbytes": Af.nbytes}
    b = load_vector(mesh, f, order=load_order)[free]
    timings = {"assembly": tim["total"]}
    if "load" in tim:                      # read back from the operator cache
        timings["operator_load"] = tim["load"]
    return Discretisation(mesh, float(s), free, Af, b, timings, info)


def solve_laplace(disc: Discretisation, *, tol: float = SOLVER_TOL,
                  maxiter: int = 2000) -> np.ndarray:
    """u_h on the free nodes: Cholesky for a dense A, else PCG with the
    multilevel preconditioner (iterations and the condition estimate of the
    preconditioned operator in disc.info); timing in disc.timings."""
    if not disc.dense:
        t0 = time.perf_counter()
        M = multilevel_preconditioner(disc.mesh, disc.A)
        disc.timings["preconditioner"] = time.perf_counter() - t0
        u, stats = pcg(disc.A, disc.b, M=M, tol=tol, maxiter=maxiter)
        disc.timings["solve"] = time.perf_counter() - t0
        disc.info.update(iterations=stats["iterations"], residual=stats["residual"],
                         condition=stats["condition"])
        return u
    t0 = time.perf_counter()
    n = len(disc.A)
    check_dense(cho_factor_bytes(n),
                what=f"the Cholesky factor of the {n} × {n} free-node matrix",
                advice="use a coarser mesh")
    try:
        factor = cho_factor(disc.A, check_finite=True)
    except np.linalg.LinAlgError as err:
        raise ValueError(f"the free-node matrix is not positive definite ({err}); "
                         "is the mesh valid and s in (0, 1)?") from err
    u = sla.cho_solve(factor, disc.b)
    disc.timings["solve"] = time.perf_counter() - t0
    logger.log(solver_level(), "solve_laplace: Cholesky solve, %d unknowns, %.2f s", n,
               disc.timings["solve"])
    return u
