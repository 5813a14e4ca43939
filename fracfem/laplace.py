"""The unconstrained problem a(u, v) = (f, v): Example 1 and fractional heat."""
from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg as sla

from .assembly import QuadratureOptions, load_vector, stiffness_matrix
from .memory import check_dense
from .meshes import validates

__all__ = ["Discretisation", "discretise", "solve_laplace"]


@dataclass
class Discretisation:
    """Free-node stiffness matrix and load of one mesh, with phase timings."""

    mesh: object
    s: float
    free: np.ndarray
    A: np.ndarray                  # a(φ_i, φ_j), i, j free
    b: np.ndarray                  # (f, φ_i), i free
    timings: dict = field(default_factory=dict)

    def extend(self, u_free: np.ndarray) -> np.ndarray:
        """Nodal vector over all nodes, zero on the boundary."""
        u = np.zeros(self.mesh.p.shape[1])
        u[self.free] = u_free
        return u


@validates("mesh")
def discretise(mesh, s: float, f=1.0, *, quadrature: QuadratureOptions | None = None,
               load_order: int = 6) -> Discretisation:
    """Assemble the free-node matrix and load vector of (−Δ)^s u = f.

    The mesh is checked once (:func:`fracfem.meshes.validate_mesh`); a problem whose
    dense matrix does not fit into memory is refused before assembly
    (:func:`fracfem.assembly.stiffness_matrix`, limit ``$FRACFEM_MEMORY_LIMIT``).
    """
    tim: dict = {}
    A = stiffness_matrix(mesh, s, quadrature=quadrature, timings=tim)
    free = mesh.interior_nodes()
    Af = np.ascontiguousarray(A[np.ix_(free, free)])
    del A
    b = load_vector(mesh, f, order=load_order)[free]
    return Discretisation(mesh, float(s), free, Af, b, {"assembly": tim["total"]})


def solve_laplace(disc: Discretisation) -> np.ndarray:
    """u_h on the free nodes by a Cholesky factorisation; timing in disc.timings."""
    t0 = time.perf_counter()
    n = len(disc.A)
    check_dense(8.0 * n * n, what=f"the Cholesky factor of the {n} × {n} free-node matrix",
                advice="use a coarser mesh")
    try:
        factor = sla.cho_factor(disc.A, lower=True, check_finite=True)
    except np.linalg.LinAlgError as err:
        raise ValueError(f"the free-node matrix is not positive definite ({err}); "
                         "is the mesh valid and s in (0, 1)?") from err
    u = sla.cho_solve(factor, disc.b)
    disc.timings["solve"] = time.perf_counter() - t0
    return u
