"""Multilevel preconditioner for the fractional stiffness operator.

An additive multilevel (BPX-type) preconditioner on auxiliary uniform grids:

    B r = r / diag(A) + w Σ_l P_l (P_lᵀ r) / a(ψ_l, ψ_l),

P_l the interpolation at the free nodes of the mesh of the bilinear hats ψ of
a square grid of spacing H_l, each multiplied by the ramp min(1, dist(x, ∂Ω)/H_l),
w = ``coarse_weight`` (by default growing with the order).  The ramp puts every
coarse function in H̃^s(Ω): a hat merely cut off at ∂Ω jumps there, and for
s > 1/2 the energy of that jump grows like h^(1−2s) as the mesh is refined; the
jump alone made the condition number grow like h^(1−2s) (by √2 per uniform
refinement at s = 3/4).  Hats centred outside Ω take part too (ramped), so that
every level covers Ω up to ∂Ω.  Only hats the mesh resolves (every element at
the free nodes in their support has diameter ≤ H_l) are used.

The energies follow from one measured value per level, the central hat's
a(ψ_c, ψ_c), carried to the other hats by the interpolation estimate
a(ψ, ψ) ∼ ‖ψ‖^(2−2σ) |ψ|_1^(2σ) (P1 mass and Laplace matrices of the mesh):
it sees the shape of a ramped hat and, unlike sums of diagonal entries, not
the mesh size, so graded and anisotropic meshes get the weights of uniform
ones.  σ, the order of the operator on the grid scales, is measured from the
energies of the central hats of the two coarsest levels, E(H) ∝ H^(2−2σ)
(σ = s for the fractional Laplacian, less for M/τ + A at coarse scales).

The diagonal term handles the finest scales and local refinement, the grids
the smooth part: no mesh hierarchy is needed, so it serves uniform, graded
and adaptive meshes alike.
"""
from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .assembly import _boundary_edges, mesh_arrays

log = logging.getLogger(__name__)

__all__ = ["MultilevelPreconditioner", "multilevel_preconditioner"]
# the weight of the grid levels against the diagonal, w = 0.15 + 0.2 σ: at small σ
# the diagonal nearly suffices (Jacobi alone takes 14–18 PCG iterations at
# s = 0.25) and the overlapping grids mainly raise the largest eigenvalue.
# PCG iterations to 1e-10 on disk_uniform(6), disk_graded(0.14),
# disk_graded_aniso(0.025): s = 0.25, w = 0.2 / 0.25 / 0.35: 16 / 17 / 20,
# 16 / 17 / –, 19 / 20 / –; s = 0.75, w = 0.25 / 0.3 / 0.35 / 0.5: 20 / 19 / 19 / 19,
# 19 / 18 / 18 / 20, 30 / 30 / 31 / 34
COARSE_WEIGHT = (0.15, 0.2)
COARSEST = 1      # the coarsest grid: spacing half the bounding box
NEAREST_EDGES = 8  # boundary edges (by midpoint) searched for dist(x, ∂Ω)
# hats of which the ramp leaves less L² mass than this fraction of the central
# hat's are left out: slivers at ∂Ω, nodal functions in effect, whose energy the
# estimate misses (measured, s = 0.75: with them the largest eigenvalue of BA grows
# from 1.66 to 1.84 / 2.03 / 2.15 on disk_uniform(5 / 6 / 7); without them it
# stays 1.66; fractions 0.005–0.02 alike, 0.05 and more lower the smallest)
MIN_MASS = 0.01


class MultilevelPreconditioner:
    """Callable r ↦ B r; ``levels`` lists (H, number of hats, energy of the
    central hat), ``order`` the measured σ of the energies."""

    def __init__(self, inv_diag, prolongations, energies, levels, order=np.nan):
        self._inv_diag = inv_diag
        self._P = prolongations
        self._inv_e = [1.0 / e for e in energies]
        self.levels = levels
        self.order = order

    def __call__(self, r: np.ndarray) -> np.ndarray:
        z = self._inv_diag * r
        for P, ie in zip(self._P, self._inv_e):
            z += P @ (ie * (P.T @ r))
        return z

    def congruence_diagonal(self, B) -> np.ndarray:
        """diag(Bᵀ B_M B) for a sparse B (n × m), B_M this preconditioner; cheap
        (sparse products), and a stand-in for diag(BᵀA⁻¹B)."""
        B = sp.csc_matrix(B)
        out = np.asarray(B.multiply(B).T @ self._inv_diag).ravel()
        for P, ie in zip(self._P, self._inv_e):
            PB = sp.csc_matrix(P.T @ B)
            out += np.asarray(PB.multiply(PB).T @ ie).ravel()
        return out


def _grid_prolongation(x, origin, H, n):
    """Bilinear hats of the grid (spacing H, n × n nodes) at points x, only
    the columns of hats that are nonzero at some point; their grid indices."""
    g = (x - origin) / H
    i0 = np.clip(np.floor(g).astype(np.int64), 0, n - 2)
    f = g - i0
    rows, cols, vals = [], [], []
    for di in (0, 1):
        for dj in (0, 1):
            w = (f[:, 0] if di else 1 - f[:, 0]) * (f[:, 1] if dj else 1 - f[:, 1])
            ii, jj = i0[:, 0] + di, i0[:, 1] + dj
            keep = w > 0
            rows.append(np.flatnonzero(keep))
            cols.append(ii[keep] * n + jj[keep])
            vals.append(w[keep])
    rows, cols, vals = map(np.concatenate, (rows, cols, vals))
    used, cols = np.unique(cols, return_inverse=True)
    return sp.csr_matrix((vals, (rows, cols.reshape(-1))), shape=(len(x), len(used))), used


def multilevel_preconditioner(mesh, op, *, coarsest: int = COARSEST,
                              coarse_weight: float | None = None) -> MultilevelPreconditioner:
    """Preconditioner for ``op`` (free nodes in ``mesh.interior_nodes()``
    order; anything with ``@`` and ``diagonal()``).

    coarsest: the coarsest grid has spacing (bounding box)/2**coarsest, an
    integer in [1, 20]; coarse_weight damps the grid levels against the
    diagonal (the supports of the hats of successive levels overlap), in (0, 1];
    default 0.15 + 0.2 σ, σ the measured order.
    """
    if coarse_weight is not None and not (np.isfinite(coarse_weight)
                                          and 0.0 < coarse_weight <= 1.0):
        raise ValueError(f"coarse_weight={coarse_weight!r} must be in (0, 1]")
    if not (isinstance(coarsest, (int, np.integer)) and 1 <= coarsest <= 20):
        raise ValueError(f"coarsest={coarsest!r} must be an integer in [1, 20]")
    p, t = mesh_arrays(mesh)
    free = np.asarray(mesh.interior_nodes(), dtype=np.int64)
    if op.shape != (len(free), len(free)):
        raise ValueError(f"op has shape {op.shape}, the mesh has {len(free)} free nodes")
    d = np.asarray(op.diagonal(), dtype=np.float64)
    if not np.all(np.isfinite(d) & (d > 0)):
        raise ValueError("the operator's diagonal must be finite and positive")
    x = p[free]
    # local mesh size at a point: largest diameter of the elements at the
    # nearest free node (nodal maximum)
    e = p[t]
    diam = np.max([np.linalg.norm(e[:, i] - e[:, j], axis=1)
                   for i, j in ((0, 1), (1, 2), (2, 0))], axis=0)
    hnode = np.zeros(len(p))
    np.maximum.at(hnode, t.ravel(), np.repeat(diam, 3))
    edges, _ = _boundary_edges(p, t)
    dist = _boundary_distance(x, edges)
    mass, stiff = _p1_matrices(p, t, free)
    lo, hi = p.min(0), p.max(0)
    size = float((hi - lo).max())
    hmin = float(diam.min())
    Ps, shapes, central, levels = [], [], [], []
    level = coarsest
    while size / 2 ** level >= hmin:
        H = size / 2 ** level
        n = 2 ** level + 1
        P, used = _grid_prolongation(x, lo, H, n)
        # a hat the mesh does not resolve would act like a nodal function
        keep = np.flatnonzero(_column_max(P, hnode[free]) <= H)
        P, used = P[:, keep].tocsr(), used[keep]
        if P.shape[1]:
            ramped = (sp.diags(np.minimum(1.0, dist / H)) @ P).tocsr()
            # the central hat: untouched by the ramp if any is, nearest the centre
            whole = np.asarray(ramped.sum(0)).ravel() >= (1 - 1e-12) * np.asarray(P.sum(0)).ravel()
            g = lo + H * np.column_stack([used // n, used % n])
            rank = np.linalg.norm(g - 0.5 * (lo + hi), axis=1) + np.where(whole, 0.0, 4 * size)
            c = int(np.argmin(rank))
            psi = ramped[:, c].toarray().ravel()
            energy = float(psi @ (op @ psi))
            mq, kq = _column_quadratic(ramped, mass), _column_quadratic(ramped, stiff)
            ok = mq >= MIN_MASS * mq[c]
            central.append((int(np.sum(ok[:c])), energy, bool(whole[c])))
            Ps.append(ramped[:, ok].tocsr())
            shapes.append((mq[ok], kq[ok]))
            levels.append((H, Ps[-1].shape[1], energy))
        level += 1
    sigma = _measured_order([lv[0] for lv in levels], central)
    if coarse_weight is None:
        coarse_weight = COARSE_WEIGHT[0] + COARSE_WEIGHT[1] * sigma
    energies = []
    for (m, k), (c, energy, _) in zip(shapes, central):
        q = m ** (1.0 - sigma) * k ** sigma
        energies.append(energy * q / q[c] / coarse_weight)
    log.info("multilevel preconditioner: %d grid levels, %d hats, order %.3f", len(Ps),
             sum(P.shape[1] for P in Ps), sigma)
    return MultilevelPreconditioner(1.0 / d, Ps, energies, levels, sigma)


def _measured_order(H: list, central: list) -> float:
    """σ of E(H) ∝ H^(2−2σ) from the central hats of the two coarsest levels
    that the ramp leaves whole (the best resolved on any mesh; E is the
    energy of the hat); 1/2 when there are no two such levels."""
    whole = [i for i, (_, _, w) in enumerate(central) if w]
    if len(whole) < 2:
        return 0.5
    i, j = whole[0], whole[1]
    sigma = 1.0 - 0.5 * np.log(central[i][1] / central[j][1]) / np.log(H[i] / H[j])
    return float(np.clip(sigma, 0.0, 1.0))


def _p1_matrices(p: np.ndarray, t: np.ndarray, free: np.ndarray):
    """P1 mass and Laplace matrices on the free nodes (csr)."""
    e = p[t]
    d1, d2 = e[:, 1] - e[:, 0], e[:, 2] - e[:, 0]
    det = d1[:, 0] * d2[:, 1] - d1[:, 1] * d2[:, 0]
    area = 0.5 * np.abs(det)
    # gradients of the barycentric coordinates
    g = np.empty((len(t), 3, 2))
    g[:, 1] = np.column_stack([d2[:, 1], -d2[:, 0]]) / det[:, None]
    g[:, 2] = np.column_stack([-d1[:, 1], d1[:, 0]]) / det[:, None]
    g[:, 0] = -g[:, 1] - g[:, 2]
    K = area[:, None, None] * np.einsum("tad,tbd->tab", g, g)
    M = area[:, None, None] / 12.0 * (np.ones((3, 3)) + np.eye(3))
    rows = np.repeat(t, 3, axis=1).ravel()
    cols = np.tile(t, (1, 3)).ravel()
    nv = len(p)
    out = []
    for loc in (M, K):
        A = sp.csr_matrix((loc.ravel(), (rows, cols)), shape=(nv, nv))
        out.append(A[free][:, free].tocsr())
    return out


def _column_quadratic(P: sp.csr_matrix, A: sp.csr_matrix) -> np.ndarray:
    """diag(Pᵀ A P), one value per column."""
    return np.asarray(P.multiply(A @ P).sum(0)).ravel()


def _boundary_distance(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """Distance from points x (n, 2) to the boundary segments (m, 4), searched
    among the NEAREST_EDGES segments with the nearest midpoints."""
    a, b = edges[:, :2], edges[:, 2:]
    k = min(NEAREST_EDGES, len(edges))
    _, idx = cKDTree(0.5 * (a + b)).query(x, k=k)
    idx = idx.reshape(len(x), k)
    aa, ab = a[idx], (b - a)[idx]
    tt = np.clip(np.sum((x[:, None] - aa) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.linalg.norm(x[:, None] - (aa + tt[..., None] * ab), axis=-1).min(axis=1)


def _column_max(P: sp.csr_matrix, values: np.ndarray) -> np.ndarray:
    """Largest value of the rows in each column's support."""
    C = P.tocsc()
    out = np.zeros(C.shape[1])
    counts = np.diff(C.indptr)
    nz = counts > 0
    out[nz] = np.maximum.reduceat(values[C.indices], C.indptr[:-1][nz])
    return out
