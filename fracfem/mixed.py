"""Mixed formulation of obstacle and friction problems (Section 5.3).

The displacement u_h is P1 on the fine mesh T_h = T_H.refined(), the Lagrange
multiplier λ_H is piecewise constant on the coarse mesh T_H (H = 2h, Lemma 5.17),
or on coarse edges of a curve Γ̃ for the thin problems.  In the nodal basis
Problem 5.15 reads

    A u + B λ = f,    (μ − λ)ᵀ (Bᵀ u − g) ≤ 0  for all μ ∈ Λ_H,

with B_ij = ∫ φ_i μ_j and g_j = ⟨μ_j, w⟩.  Every Λ_H of Remark 5.16 is a box
{lower ≤ λ ≤ upper} in the coefficients of λ_H, so the constraint sets below share
one interface (``lower``, ``upper``, ``g``, ``project``, ``contains``, ``kind``)
that the solvers in :mod:`fracfem.solvers` use without knowing which problem it is.

Conventions
-----------
* ``coarse`` and ``fine`` are :class:`skfem.MeshTri` with ``fine = coarse.refined()``:
  the coarse nodes are the first fine nodes (same indices) and the parent of fine
  element ``e`` is ``e % coarse.nelements``.
* Coupling matrices have one row per fine node; the solvers need the rows of the
  free (interior) nodes only, ``B[free]``.
* If new boundary nodes were moved onto a curved boundary after refinement, μ_j is
  the indicator of the union of the four children of T_j (which is what the fine
  mesh resolves), and all integrals here are over the fine elements.
"""

from __future__ import annotations

import logging
import numbers
from dataclasses import dataclass, field
from typing import Callable, ClassVar

import numpy as np
import scipy.sparse as sp

from .meshes import triangle_areas

logger = logging.getLogger(__name__)

__all__ = [
    "coupling_matrix",
    "edge_coupling_matrix",
    "edges_on_curve",
    "friction_bound",
    "obstacle_from_function",
    "Obstacle",
    "Friction",
    "ThinObstacle",
    "ThinFriction",
]


# --------------------------------------------------------------------------- meshes


def _check_nested(coarse, fine) -> None:
    """Raise ValueError unless ``fine`` looks like ``coarse.refined()``."""
    if fine.nelements != 4 * coarse.nelements:
        raise ValueError(
            "fine must be the uniform refinement of coarse (fine.nelements == "
            f"4 * coarse.nelements); got fine.nelements = {fine.nelements}, "
            f"coarse.nelements = {coarse.nelements}")
    if fine.nvertices < coarse.nvertices or not np.allclose(
            fine.p[:, :coarse.nvertices], coarse.p, rtol=0.0, atol=1e-12):
        raise ValueError("fine must keep the coarse nodes first with the same "
                         "indices (as skfem's refined() does)")


def _parents(coarse, fine):
    """Coarse parent of every fine element (skfem numbering: e mod n_coarse)."""
    return np.arange(fine.nelements) % coarse.nelements


def coupling_matrix(coarse, fine) -> sp.csr_matrix:
    """Coupling matrix B_ij = ∫ φ_i μ_j of P1 on ``fine`` and P0 on ``coarse``.

    Closed form: each fine triangle adds area/3 to each of its three vertices in
    the column of its parent (Section 5.3, H = 2h).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (fine.nvertices, coarse.nelements)
    """
    _check_nested(coarse, fine)
    third = triangle_areas(fine.p, fine.t) / 3.0
    rows = fine.t.ravel()
    cols = np.tile(_parents(coarse, fine), 3)
    data = np.tile(third, 3)
    return sp.csr_matrix((data, (rows, cols)),
                         shape=(fine.nvertices, coarse.nelements))


def _edge_keys(a, b, n):
    """Order-independent integer key of the node pairs (a, b)."""
    return np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)


def _check_edges(coarse, edges):
    """Validate that ``edges`` (2, m) are distinct edges of the coarse mesh."""
    edges = np.asarray(edges)
    if edges.ndim != 2 or edges.shape[0] != 2 or edges.shape[1] == 0:
        raise ValueError(f"edges must be a non-empty int array of shape (2, m); "
                         f"got shape {edges.shape}")
    if not np.issubdtype(edges.dtype, np.integer):
        raise ValueError(f"edges must be an integer array; got dtype {edges.dtype}")
    if edges.min() < 0 or edges.max() >= coarse.nvertices:
        raise ValueError(f"edges must index coarse nodes 0..{coarse.nvertices - 1}; "
                         f"got range [{edges.min()}, {edges.max()}]")
    n = coarse.nvertices
    keys = _edge_keys(edges[0], edges[1], n)
    known = _edge_keys(coarse.facets[0], coarse.facets[1], n)
    bad = np.flatnonzero(~np.isin(keys, known))
    if bad.size:
        a, b = edges[:, bad[0]]
        raise ValueError(
            f"Γ̃ is not made of coarse mesh edges: pair ({a},{b}) (column {bad[0]}) "
            f"is not an edge of the coarse mesh ({bad.size} such pairs)")
    if np.unique(keys).size != keys.size:
        raise ValueError("edges must not repeat a coarse edge")
    return edges.astype(np.int64)


def _midpoint_nodes(fine, edges):
    """Fine node splitting each coarse edge: the unique common fine neighbour."""
    nv = fine.nvertices
    i, j = fine.facets
    adjacency = sp.csr_matrix((np.ones(2 * i.size), (np.r_[i, j], np.r_[j, i])),
                              shape=(nv, nv))
    common = adjacency[edges[0]].multiply(adjacency[edges[1]]).tocsr()
    counts = np.diff(common.indptr)
    if np.any(counts != 1):
        k = int(np.flatnonzero(counts != 1)[0])
        raise ValueError(f"coarse edge ({edges[0, k]},{edges[1, k]}) has no unique "
                         "midpoint in fine; is fine = coarse.refined()?")
    return common.indices.astype(np.int64)


def edge_coupling_matrix(coarse, fine, edges) -> sp.csr_matrix:
    """Coupling matrix B_ie = ∫_e φ_i ds of P1 on ``fine`` and P0 on coarse edges.

    Exact for P1: each of the two fine sub-edges of a coarse edge adds half its
    length to each of its two endpoints.

    Parameters
    ----------
    edges : int array, shape (2, m)
        Coarse node index pairs, one coarse edge of Γ̃ per column
        (the multiplier μ_e of Remark 5.16 (ii), (iv)).

    Returns
    -------
    scipy.sparse.csr_matrix, shape (fine.nvertices, m)
    """
    _check_nested(coarse, fine)
    edges = _check_edges(coarse, edges)
    mid = _midpoint_nodes(fine, edges)
    cols = np.arange(edges.shape[1])
    rows, data = [], []
    for end in edges:
        half = 0.5 * np.linalg.norm(fine.p[:, end] - fine.p[:, mid], axis=0)
        rows += [end, mid]
        data += [half, half]
    return sp.csr_matrix((np.concatenate(data), (np.concatenate(rows), np.tile(cols, 4))),
                         shape=(fine.nvertices, edges.shape[1]))


def edges_on_curve(coarse, on_curve: Callable) -> np.ndarray:
    """Coarse edges whose endpoints and midpoint all satisfy ``on_curve``.

    Parameters
    ----------
    on_curve : callable
        ``on_curve(x) -> bool array`` for points ``x`` of shape (2, N).

    Returns
    -------
    int array, shape (2, m): the edges of Γ̃, as used by :func:`edge_coupling_matrix`.
    """
    a, b = coarse.facets
    pa, pb = coarse.p[:, a], coarse.p[:, b]
    keep = (np.asarray(on_curve(pa), bool) & np.asarray(on_curve(pb), bool)
            & np.asarray(on_curve(0.5 * (pa + pb)), bool))
    return np.vstack((a[keep], b[keep])).astype(np.int64)


# ------------------------------------------------------------------ argument checks


def _check_s_thin(s) -> float:
    """Thin problems need the trace theorem: s ∈ (1/2, 1)."""
    ok = isinstance(s, numbers.Real) and not isinstance(s, (bool, np.bool_))
    if not ok or not np.isfinite(s) or not 0.5 < s < 1.0:
        raise ValueError("thin obstacle/friction problems need the fractional order "
                         f"s in the open interval (1/2, 1) (trace on Γ̃); got s = {s!r}")
    return float(s)


def _as_csr(B):
    """B as a 2-D csr matrix."""
    B = sp.csr_matrix(B)
    if B.ndim != 2:
        raise ValueError(f"B must be a 2-D matrix; got shape {B.shape}")
    return B


def _check_vector(name, v, n) -> np.ndarray:
    """A finite float vector of length ``n`` (scalars broadcast)."""
    v = np.asarray(v, dtype=float)
    if v.ndim == 0:
        v = np.full(n, float(v))
    if v.shape != (n,):
        raise ValueError(f"{name} must have shape ({n},); got {v.shape}")
    if not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be finite; got {np.count_nonzero(~np.isfinite(v))} "
                         "non-finite entries")
    return v


def _check_friction_bound(F, n) -> np.ndarray:
    """F ≥ 0, finite, one value per multiplier (scalars broadcast)."""
    F = np.asarray(F, dtype=float)
    if F.ndim == 0:
        F = np.full(n, float(F))
    if F.shape != (n,):
        raise ValueError(f"friction bound F must have shape ({n},); got {F.shape}")
    bad = ~np.isfinite(F)
    if np.any(bad):
        raise ValueError(f"friction bound F must be finite and >= 0; got "
                         f"{np.count_nonzero(bad)} non-finite entries")
    if np.any(F < 0):
        raise ValueError(f"friction bound F must be >= 0; got min(F) = {F.min()!r}")
    return F


# ------------------------------------------------------------------ constraint sets


class _BoxSet:
    """Common interface of the sets Λ_H = {lower ≤ λ ≤ upper} of Remark 5.16."""

    kind: ClassVar[str] = ""

    @property
    def n_multipliers(self) -> int:
        """Number of multiplier coefficients (columns of B)."""
        return self.B.shape[1]

    def project(self, lam) -> np.ndarray:
        """Orthogonal (Euclidean) projection P_Λ onto Λ_H; exact, componentwise."""
        return np.clip(np.asarray(lam, dtype=float), self.lower, self.upper)

    def contains(self, lam, tol: float = 0.0) -> bool:
        """Whether λ ∈ Λ_H up to the absolute tolerance ``tol``."""
        lam = np.asarray(lam, dtype=float)
        return bool(np.all(lam >= self.lower - tol) and np.all(lam <= self.upper + tol))


class _SignSet(_BoxSet):
    """Λ_H = {λ ≤ 0} with w given nodally (g = Bᵀw) or as g directly."""

    def _set_g(self, w, w_name):
        self.B = _as_csr(self.B)
        if (w is None) == (self.g is None):
            raise ValueError(f"give exactly one of {w_name} (nodal values) and g "
                             "(the vector ⟨μ_j, w⟩)")
        if w is not None:
            w = _check_vector(w_name, w, self.B.shape[0])
            self.g = self.B.T @ w
        self.g = _check_vector("g", self.g, self.n_multipliers)

    @property
    def lower(self):
        return np.full(self.n_multipliers, -np.inf)

    @property
    def upper(self):
        return np.zeros(self.n_multipliers)


@dataclass(eq=False)
class Obstacle(_SignSet):
    """Obstacle set, Remark 5.16 (i): Λ_H = {λ_H ≤ 0}, w = χ.

    Parameters
    ----------
    B : sparse matrix, shape (n, m)
        Coupling matrix (rows of the nodes ``chi`` refers to).
    chi : array (n,), optional
        Nodal values of χ_h on the rows of B; then g = Bᵀχ = ∫_{T_j} χ_h.  For that
        integral to be exact pass the full B and all fine nodes; with the free rows
        only, χ_h is taken as zero on ∂Ω.
    g : array (m,), optional
        g_j = ⟨μ_j, χ⟩ directly (see :func:`obstacle_from_function`).
    """

    B: sp.csr_matrix
    chi: np.ndarray | None = None  # χ_h nodal
    g: np.ndarray | None = None  # ⟨μ_j, χ⟩
    kind: ClassVar[str] = "obstacle"

    def __post_init__(self):
        self._set_g(self.chi, "chi")


@dataclass(eq=False)
class ThinObstacle(_SignSet):
    """Thin obstacle (Signorini) set, Remark 5.16 (ii): Λ_H = {λ_H ≤ 0} on Γ̃, w = g.

    Parameters
    ----------
    B : sparse matrix, shape (n, m)
        Edge coupling matrix (:func:`edge_coupling_matrix`).
    height : array (n,), optional
        Nodal values of the obstacle height g on the rows of B (only the nodes on
        Γ̃ matter); then ``g = Bᵀ height`` = ∫_e g_h ds.
    g : array (m,), optional
        ⟨μ_e, g⟩ directly.
    s : float
        Fractional order; must lie in (1/2, 1) (trace theorem).
    """

    B: sp.csr_matrix
    height: np.ndarray | None = None  # obstacle height g on Γ̃, nodal
    g: np.ndarray | None = None  # ⟨μ_e, g⟩
    s: float = field(kw_only=True)
    kind: ClassVar[str] = "thin_obstacle"

    def __post_init__(self):
        self.s = _check_s_thin(self.s)
        self._set_g(self.height, "height")


class _BoxFriction(_BoxSet):
    """Λ_H = {|λ| ≤ F}, w = 0."""

    def _setup(self):
        self.B = _as_csr(self.B)
        self.F = _check_friction_bound(self.F, self.n_multipliers)

    @property
    def g(self):
        return np.zeros(self.n_multipliers)  # w = 0

    @property
    def lower(self):
        return -self.F

    @property
    def upper(self):
        return self.F


@dataclass(eq=False)
class Friction(_BoxFriction):
    """Interior friction set, Remark 5.16 (iii): Λ_H = {|λ_H| ≤ F}, w = 0.

    Parameters
    ----------
    B : sparse matrix, shape (n, m)
    F : array (m,) or float
        F_j ≥ 0 on coarse element j (0 outside the friction subdomain S,
        see :func:`friction_bound`).
    """

    B: sp.csr_matrix
    F: np.ndarray  # friction bound F_j
    kind: ClassVar[str] = "friction"

    def __post_init__(self):
        self._setup()


@dataclass(eq=False)
class ThinFriction(_BoxFriction):
    """Thin friction set on Γ̃, Remark 5.16 (iv): Λ_H = {|λ_H| ≤ F}, w = 0.

    Parameters
    ----------
    B : sparse matrix, shape (n, m)
        Edge coupling matrix (:func:`edge_coupling_matrix`).
    F : array (m,) or float
        F_e ≥ 0 per coarse edge of Γ̃.
    s : float
        Fractional order; must lie in (1/2, 1) (trace theorem).
    """

    B: sp.csr_matrix
    F: np.ndarray  # friction bound F_e
    s: float = field(kw_only=True)
    kind: ClassVar[str] = "thin_friction"

    def __post_init__(self):
        self.s = _check_s_thin(self.s)
        self._setup()


# ------------------------------------------------------------------- data helpers


def friction_bound(coarse, F: float, subdomain: Callable | None = None) -> np.ndarray:
    """Per-element friction bound F_j = F · 1_S(centroid of T_j).

    Parameters
    ----------
    F : float
        Friction coefficient, finite and ≥ 0.
    subdomain : callable, optional
        ``subdomain(x) -> bool array`` for points of shape (2, N); default S = Ω.
    """
    F = _check_friction_bound(F, 1)[0]
    values = np.full(coarse.nelements, F)
    if subdomain is not None:
        centroids = coarse.p[:, coarse.t].mean(axis=1)
        values[~np.asarray(subdomain(centroids), bool)] = 0.0
    return values


def _element_integrals(fine, func, intorder):
    """∫_e func over every fine element, by skfem quadrature of order ``intorder``."""
    from skfem import Basis, ElementTriP0, LinearForm, asm

    basis = Basis(fine, ElementTriP0(), intorder=intorder)
    form = LinearForm(lambda v, w: func(w.x) * v)
    return asm(form, basis)


def obstacle_from_function(coarse, fine, chi: Callable, free=None, *,
                           intorder: int = 6) -> Obstacle:
    """Obstacle set for a function χ, with g_j = ∫_{T_j} χ by quadrature.

    Checks the paper's assumption χ ≤ 0 in Ωᶜ on the boundary nodes of ``fine``.

    Parameters
    ----------
    chi : callable
        ``chi(x)`` for points ``x`` of shape (2, ...), vectorised.
    free : int array, optional
        Free fine nodes (default ``fine.interior_nodes()``); the returned set holds
        ``B = coupling_matrix(coarse, fine)[free]``, the B the solvers take.
    intorder : int
        Quadrature order on the fine elements (≥ 4).
    """
    if not isinstance(intorder, numbers.Integral) or intorder < 4:
        raise ValueError(f"intorder must be an integer >= 4; got {intorder!r}")
    boundary = fine.boundary_nodes()
    chi_boundary = np.asarray(chi(fine.p[:, boundary]), dtype=float)
    top = float(np.max(chi_boundary))
    if not np.isfinite(top) or top > 1e-12 * max(1.0, np.max(np.abs(chi_boundary))):
        raise ValueError(f"the obstacle χ must be <= 0 on the boundary of Ω (χ <= 0 in "
                         f"Ωᶜ); got max χ = {top!r} on the boundary nodes")
    free = fine.interior_nodes() if free is None else np.asarray(free)
    B = coupling_matrix(coarse, fine)[free]
    per_fine = _element_integrals(fine, chi, intorder)
    g = np.bincount(_parents(coarse, fine), weights=per_fine,
                    minlength=coarse.nelements)  # ⟨μ_j, χ⟩
    logger.debug("obstacle: g from order-%d quadrature on %d fine elements",
                 intorder, fine.nelements)
    return Obstacle(B, g=g)
