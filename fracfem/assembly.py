"""P1 Galerkin matrix of the integral fractional Laplacian on triangle meshes.

a(u, v) = (c/2) ∫∫_{Ω×Ω} (u(x)−u(y))(v(x)−v(y)) |x−y|^(−2−2s) dx dy
          + c ∫_Ω u v κ,     κ(x) = ∫_{Ωᶜ} |x−y|^(−2−2s) dy,

with c = c_{2,s} and Ω the polygon of the mesh (DESIGN.md, "Bilinear form").
Element pairs are classified once (identical / common edge / common vertex /
separated); touching pairs use the relative-coordinate rules of
:mod:`fracfem.quadrature`, separated pairs product Gauss rules whose order
falls with distance, and κ is integrated with rules graded toward ∂Ω.
"""
from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
import scipy.sparse as sp
from scipy.special import gamma, roots_jacobi

from . import _aniso_kernels, _kernels, memory
from .exact import c2s, check_s
from .meshes import check_mesh
from .quadrature import (coincident_rule, edge_rule, gauss01, radial_factor,
                         triangle_rule, vertex_rule)

log = logging.getLogger(__name__)

__all__ = [
    "QuadratureOptions",
    "stiffness_matrix",
    "load_vector",
    "energy",
    "touching_pairs",
    "close_separated_pairs",
    "close_pair_corrections",
    "exterior_kernel",
    "mesh_arrays",
    "dense_bytes",
]


@dataclass(frozen=True)
class QuadratureOptions:
    """Quadrature orders of the assembly.

    coincident, edge, vertex: Gauss points per face direction of the
    singular rules; far_orders: triangle-rule degrees of separated pairs from
    the farthest to the nearest class, far_thresholds: the separation ratios
    |c_T − c_T'| / max diam at which the classes start (one fewer);
    far_orders[0] = 0 selects the Taylor-corrected centroid rule (one
    kernel evaluation per pair, error O((h/d)³)) for the farthest class;
    kappa_order: triangle-rule degree for κ away from ∂Ω; kappa_layers and
    kappa_gauss: geometric layers and Gauss points per layer toward ∂Ω.

    Touching pairs whose relative-coordinate faces come closer to the
    singularity than ``thin_closeness`` times the pair's longest edge
    (:func:`fracfem._aniso_kernels.pair_closeness`; thin triangles side by
    side, closeness ~ 1/aspect ratio; shape-regular meshes ≥ 0.24) are
    integrated by the graded face rules of :mod:`fracfem._aniso_kernels`
    instead: ``thin_gauss`` Gauss points per panel, panels growing by
    ``thin_ratio`` away from the points nearest to the singularity.  Their
    accuracy does not depend on the aspect ratio.
    """

    coincident: int = 10
    edge: int = 6
    vertex: int = 5
    far_orders: tuple = (0, 2, 4, 8)
    far_thresholds: tuple = (8.0, 4.0, 2.0)
    kappa_order: int = 8
    kappa_layers: int = 6
    kappa_gauss: int = 4
    thin_closeness: float = 0.3
    thin_gauss: int = 5
    thin_ratio: float = 2.0

    def __post_init__(self):
        for name in ("coincident", "edge", "vertex", "kappa_order", "kappa_layers",
                     "kappa_gauss", "thin_gauss"):
            val = getattr(self, name)
            if not isinstance(val, (int, np.integer)) or val < 1:
                raise ValueError(f"QuadratureOptions.{name}={val!r} must be an integer >= 1")
        if self.thin_gauss > 32:
            raise ValueError(f"QuadratureOptions.thin_gauss={self.thin_gauss!r} must be <= 32")
        if not 0.0 <= self.thin_closeness <= 1.0:
            raise ValueError(f"QuadratureOptions.thin_closeness={self.thin_closeness!r} must be "
                             "in [0, 1] (0: never use the graded rules of thin pairs)")
        if not 1.0 < self.thin_ratio <= 8.0:
            raise ValueError(f"QuadratureOptions.thin_ratio={self.thin_ratio!r} must be in (1, 8]")
        if len(self.far_orders) < 1 or any(not 0 <= o <= 12 for o in self.far_orders):
            raise ValueError(f"QuadratureOptions.far_orders={self.far_orders!r} must be "
                             "one or more triangle-rule degrees in [0, 12] (0: Taylor rule)")
        if 0 in self.far_orders[1:]:
            raise ValueError("QuadratureOptions.far_orders: only the first (farthest) "
                             "class may use the Taylor rule (order 0)")
        if len(self.far_thresholds) != len(self.far_orders) - 1:
            raise ValueError(f"QuadratureOptions.far_thresholds={self.far_thresholds!r} must "
                             f"have len(far_orders) - 1 = {len(self.far_orders) - 1} entries")
        if any(not r > 0 for r in self.far_thresholds) or list(self.far_thresholds) != sorted(
                self.far_thresholds, reverse=True):
            raise ValueError(f"QuadratureOptions.far_thresholds={self.far_thresholds!r} must "
                             "be positive and decreasing (farthest class first)")

    def raised(self, keep_taylor: bool = False) -> "QuadratureOptions":
        """Every order raised: for quadrature-convergence checks.

        keep_taylor: keep the Taylor rule (far_orders[0] = 0) for the farthest class, which
        then starts at twice its separation ratio, as every other class does: the compressed
        operator needs it there (its far field is the Taylor rule's kernel expansion).  By
        default the farthest class gets a Gauss rule too.
        """
        if not isinstance(keep_taylor, (bool, np.bool_)):
            raise ValueError(f"keep_taylor={keep_taylor!r} must be True or False")
        orders = tuple(min(max(2 * o, 2), 12) for o in self.far_orders)
        if keep_taylor and self.far_orders[0] == 0:
            orders = (0,) + orders[1:]
        return replace(
            self,
            coincident=2 * self.coincident,
            edge=self.edge + 4,
            vertex=self.vertex + 3,
            far_orders=orders,
            far_thresholds=tuple(2.0 * r for r in self.far_thresholds),
            kappa_order=min(2 * self.kappa_order, 19),
            kappa_layers=2 * self.kappa_layers,
            kappa_gauss=self.kappa_gauss + 4,
            thin_closeness=min(2.0 * self.thin_closeness, 1.0),
            thin_gauss=min(self.thin_gauss + 3, 32),
            thin_ratio=1.0 + 0.5 * (self.thin_ratio - 1.0),
        )


def mesh_arrays(mesh, name: str = "mesh") -> tuple[np.ndarray, np.ndarray]:
    """(p (Nv, 2) float64, t (Nt, 3) int64) of a scikit-fem mesh, checked once.

    The check is :func:`fracfem.meshes.check_mesh` (duplicate or unused nodes,
    zero-area triangles, non-finite coordinates, shapes); it is skipped inside a
    :func:`fracfem.meshes.validated` block for this mesh.  ``name`` names the mesh
    in error messages.
    """
    check_mesh(mesh, name)
    p = np.ascontiguousarray(np.asarray(mesh.p, dtype=np.float64).T)
    t = np.ascontiguousarray(np.asarray(mesh.t, dtype=np.int64).T)
    return p, t


def touching_pairs(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ordered local nodes of common-edge (P,Q,R,R') and common-vertex
    (P,Q,R,Q',R') element pairs, each unordered pair once."""
    nt = len(t)
    nv = int(t.max()) + 1
    inc = sp.csr_matrix((np.ones(3 * nt), (np.repeat(np.arange(nt), 3), t.ravel())),
                        shape=(nt, nv))
    shared = sp.triu(inc @ inc.T, k=1).tocoo()
    T1, T2, nsh = shared.row, shared.col, shared.data.astype(int)
    a, b = t[T1], t[T2]
    in_b = (a[:, :, None] == b[:, None, :]).any(2)     # nodes of T1 also in T2
    in_a = (b[:, :, None] == a[:, None, :]).any(2)
    e = nsh == 2
    # common edge: P, Q shared (in T1's order), R the rest of T1, R' of T2
    ae, be = a[e], b[e]
    shared_e = ae[in_b[e]].reshape(-1, 2)
    R = ae[~in_b[e]]
    Rp = be[~in_a[e]]
    edge_nodes = np.column_stack([shared_e, R, Rp])
    v = nsh == 1
    av, bv = a[v], b[v]
    P = av[in_b[v]]
    QR = av[~in_b[v]].reshape(-1, 2)
    QRp = bv[~in_a[v]].reshape(-1, 2)
    vertex_nodes = np.column_stack([P, QR, QRp])
    return edge_nodes.astype(np.int64), vertex_nodes.astype(np.int64)


# local nodal values → relative-coordinate coefficients (quadrature.py)
_AMAT = {
    "coincident": np.array([[-1.0, 1, 0], [-1, 0, 1]]),
    "edge": np.array([[-1.0, 1, 0, 0], [-1, 0, 1, 0], [1, 0, 0, -1]]),
    "vertex": np.array([[-1.0, 1, 0, 0, 0], [-1, 0, 1, 0, 0],
                        [1, 0, 0, -1, 0], [1, 0, 0, 0, -1]]),
}
_SIGNS = {"coincident": np.array([1.0, 1.0]), "edge": np.array([1.0, 1, -1]),
          "vertex": np.array([1.0, 1, -1, -1])}
_SECOND = {"coincident": np.array([0, 1, 2]), "edge": np.array([0, 1, 3]),
           "vertex": np.array([0, 3, 4])}


_KIND = {"coincident": 0, "edge": 1, "vertex": 2}
DEGENERATE_GAP = 1e-12   # relative closeness/gap below which a pair is a mesh defect


def _singular_local(p, nodes, kind, n, s, quad=None):
    """Local matrices (len(nodes), d+1, d+1) of touching pairs of one kind,
    without c_{2,s}: the fixed rule with n points per face direction, or
    the graded rules of thin pairs (``quad``, default QuadratureOptions())."""
    quad = quad or QuadratureOptions()
    rule = {"coincident": coincident_rule, "edge": edge_rule, "vertex": vertex_rule}[kind]
    out = np.empty((len(nodes), nodes.shape[1], nodes.shape[1]))
    if not len(nodes):
        return out
    nodes = np.ascontiguousarray(nodes, dtype=np.int64)
    thin = np.zeros(len(nodes), dtype=bool)
    if quad.thin_closeness > 0:
        closeness = _aniso_kernels.pair_closeness(p, nodes, _KIND[kind])
        bad = np.flatnonzero(~(closeness > DEGENERATE_GAP))
        if bad.size:
            raise ValueError(f"{kind} element pair with nodes {nodes[bad[0]].tolist()} is "
                             "degenerate (its triangles overlap or have zero area); "
                             "check the mesh (fracfem.meshes.validate_mesh)")
        thin = closeness < quad.thin_closeness
    regular = np.flatnonzero(~thin)
    if regular.size:
        zq, wq = rule(n)
        sub = nodes if regular.size == len(nodes) else nodes[regular]
        loc = np.empty((len(sub), nodes.shape[1], nodes.shape[1]))
        _kernels.singular_pairs(p, sub, _SECOND[kind], _SIGNS[kind],
                                np.ascontiguousarray(zq), wq, _AMAT[kind], s, loc)
        out[regular] = loc
    if thin.any():
        gx, gw = gauss01(quad.thin_gauss)
        loc = np.empty((int(thin.sum()), nodes.shape[1], nodes.shape[1]))
        _aniso_kernels.thin_singular_pairs(p, nodes[thin], _SECOND[kind], _SIGNS[kind],
                                           _KIND[kind], _AMAT[kind], s, gx, gw,
                                           float(quad.thin_ratio), loc)
        out[thin] = loc
        log.debug("%d of %d %s pairs by the graded rules of thin pairs",
                  int(thin.sum()), len(nodes), kind)
    return out * radial_factor(kind, s)


def close_separated_pairs(p, t, quad, geometry=None):
    """Separated element pairs (m, 2), T < T', closer than ``quad.thin_closeness``
    times the longer diameter, that :func:`fracfem._kernels.far_pairs` puts in
    a product Gauss class (not the Taylor class); their gaps relative to that
    diameter.  Empty when ``thin_closeness`` is 0."""
    from scipy.spatial import cKDTree

    empty = np.zeros((0, 2), dtype=np.int64)
    if quad.thin_closeness <= 0 or len(t) < 2:
        return empty, np.zeros(0)
    area2, cent, diam = _element_geometry(p, t) if geometry is None else geometry
    # gap < c·hmax needs |c_T − c_T'| < (c + 4/3)·hmax: search from the larger element
    tree = cKDTree(cent)
    lists = tree.query_ball_point(cent, r=(quad.thin_closeness + 4.0 / 3.0) * diam)
    cnt = np.fromiter((len(x) for x in lists), dtype=np.int64, count=len(lists))
    i = np.repeat(np.arange(len(t)), cnt)
    j = np.concatenate(lists).astype(np.int64) if cnt.sum() else np.zeros(0, dtype=np.int64)
    # each pair once, from its larger element (which finds it)
    keep = (diam[i] > diam[j]) | ((diam[i] == diam[j]) & (i < j))
    i, j = i[keep], j[keep]
    pairs = np.column_stack([np.minimum(i, j), np.maximum(i, j)])
    a, b = t[pairs[:, 0]], t[pairs[:, 1]]
    pairs = pairs[~(a[:, :, None] == b[:, None, :]).any(axis=(1, 2))]
    if not len(pairs):
        return empty, np.zeros(0)
    hm = np.maximum(diam[pairs[:, 0]], diam[pairs[:, 1]])
    gap = _aniso_kernels.triangle_gaps(p, t, np.ascontiguousarray(pairs)) / hm
    bad = np.flatnonzero(~(gap > DEGENERATE_GAP))
    if bad.size:
        T1, T2 = pairs[bad[0]]
        raise ValueError(f"triangles {T1} and {T2} touch without sharing a node (a crack "
                         "or a duplicate node); check the mesh (fracfem.meshes.validate_mesh)")
    d2 = np.sum((cent[pairs[:, 0]] - cent[pairs[:, 1]]) ** 2, axis=1)
    sel = gap < quad.thin_closeness
    if quad.far_orders[0] == 0 and len(quad.far_thresholds):
        # not the Taylor level: the negation of pair_level's test, with its rounding
        R = float(quad.far_thresholds[0])
        sel &= ~(d2 >= R * R * hm * hm)
    return np.ascontiguousarray(pairs[sel]), gap[sel]


def close_pair_corrections(p, t, s, quad, geometry=None):
    """(pairs (m, 2), local (m, 6, 6)) to add, times c_{2,s}, to the matrix of
    :func:`fracfem._kernels.far_pairs`: for the separated pairs of
    :func:`close_separated_pairs`, the graded rule of thin pairs
    (:func:`fracfem._aniso_kernels.separated_blocks`) minus the product Gauss
    rule that far_pairs used.  Local order: the nodes of T, then of T'."""
    pairs, _ = close_separated_pairs(p, t, quad, geometry)
    loc = np.zeros((len(pairs), 6, 6))
    if not len(pairs):
        return pairs, loc
    area2, cent, diam = _element_geometry(p, t) if geometry is None else geometry
    gx, gw = gauss01(quad.thin_gauss)
    _aniso_kernels.separated_blocks(p, t, pairs, s, gx, gw, float(quad.thin_ratio), loc)
    # the product rules of far_pairs, only the Gauss levels
    qx, qw, lam, offs = _far_rules(p, t, quad.far_orders, area2)
    std = np.empty_like(loc)
    _kernels.far_rule_blocks(t, pairs, cent, diam, qx, qw, lam, offs,
                             np.asarray(quad.far_thresholds, dtype=np.float64), s, std)
    log.debug("%d close separated pairs by the graded rules of thin pairs", len(pairs))
    return pairs, loc - std


def _element_geometry(p, t):
    """Twice the areas, centroids (Nt, 2) and diameters (longest edge) of the elements."""
    area2 = np.abs(_cross2(p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]))
    cent = np.ascontiguousarray(p[t].mean(axis=1))
    diam = np.max([np.linalg.norm(p[t[:, i]] - p[t[:, j]], axis=1)
                   for i, j in ((0, 1), (1, 2), (2, 0))], axis=0)
    return area2, cent, diam


def _far_rules(p, t, orders, area2=None):
    """Physical points (Nt, nq, 2), weights (Nt, nq), barycentrics, offsets."""
    rules = [triangle_rule(max(o, 1)) for o in orders]   # order 0: Taylor level, centroid
    most = max(len(W) for _, W in rules)
    if most > _kernels.MAX_RULE_POINTS:  # the kernels' work arrays, before any (Nt, nq) array
        raise ValueError(f"far-field rules are limited to {_kernels.MAX_RULE_POINTS} points per "
                         f"triangle; far_orders {list(orders)} ask for {most}")
    pts, wts, lams, offs = [], [], [], [0]
    if area2 is None:
        area2 = _element_geometry(p, t)[0]
    for X, W in rules:
        lam = np.column_stack([1.0 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
        pts.append(np.einsum("qk,tkd->tqd", lam, p[t]))
        wts.append(area2[:, None] * W[None, :])
        lams.append(lam)
        offs.append(offs[-1] + len(W))
    return (np.ascontiguousarray(np.concatenate(pts, axis=1)),
            np.ascontiguousarray(np.concatenate(wts, axis=1)),
            np.ascontiguousarray(np.vstack(lams)), np.array(offs, dtype=np.int64))


def _cross2(a, b):
    """z-component of the cross product of 2D vectors (..., 2)."""
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _element_moments(p, t):
    """Areas, second moments (Ixx, Ixy, Iyy) about the centroid, ∇λ_a."""
    v = p[t] - p[t].mean(axis=1, keepdims=True)
    e1, e2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    area = 0.5 * np.abs(det)
    mom = (area / 12.0)[:, None] * np.column_stack([
        np.sum(v[:, :, 0] ** 2, 1), np.sum(v[:, :, 0] * v[:, :, 1], 1),
        np.sum(v[:, :, 1] ** 2, 1)])
    # ∇λ for λ1 = ((x−p0)×e2)/det, λ2 = (e1×(x−p0))/det, λ0 = 1 − λ1 − λ2
    g1 = np.column_stack([e2[:, 1], -e2[:, 0]]) / det[:, None]
    g2 = np.column_stack([-e1[:, 1], e1[:, 0]]) / det[:, None]
    grad = np.stack([-g1 - g2, g1, g2], axis=1)
    return area, np.ascontiguousarray(mom), np.ascontiguousarray(grad)


def _boundary_edges(p, t):
    """Boundary edges (m, 4) oriented counter-clockwise around the polygon."""
    edges = np.sort(np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]]), axis=1)
    third = np.concatenate([t[:, 2], t[:, 0], t[:, 1]])
    uniq, idx, cnt = np.unique(edges, axis=0, return_index=True, return_counts=True)
    b = cnt == 1
    e, r = uniq[b], third[idx[b]]
    a0, a1, c = p[e[:, 0]], p[e[:, 1]], p[r]
    # Ω (the third vertex) must lie to the left of a0 → a1
    left = _cross2(a1 - a0, c - a0) > 0
    e = np.where(left[:, None], e, e[:, ::-1])
    return np.column_stack([p[e[:, 0]], p[e[:, 1]]]), np.unique(e)


def _distance_to_edges(x, edges):
    """Distance from points x (n, 2) to the nearest of the segments (m, 4).

    Many segments: a segment at distance D has its midpoint within D + ℓ/2,
    so only segments whose midpoints lie within d_mid + ℓ_max of x (d_mid
    the distance to the nearest midpoint) can be nearest; those candidates,
    from a k-d tree, are measured exactly (the same result as
    :func:`_distance_to_edges_all`, in O(n log m) instead of O(nm))."""
    if len(edges) <= 64 or len(x) <= 64:
        return _distance_to_edges_all(x, edges)
    from scipy.spatial import cKDTree

    a, b = edges[:, :2], edges[:, 2:]
    mid = 0.5 * (a + b)
    lmax = float(np.linalg.norm(b - a, axis=1).max())
    tree = cKDTree(mid)
    dm, _ = tree.query(x)
    lists = tree.query_ball_point(x, dm * (1.0 + 1e-12) + lmax)
    cnt = np.fromiter((len(c) for c in lists), dtype=np.int64, count=len(lists))
    cand = np.fromiter((k for c in lists for k in c), dtype=np.int64, count=int(cnt.sum()))
    owner = np.repeat(np.arange(len(x)), cnt)
    d = _segment_distance(x[owner], a[cand], b[cand])
    out = np.full(len(x), np.inf)
    np.minimum.at(out, owner, d)
    return out


def _distance_to_edges_all(x, edges):
    """Distance from points x (n, 2) to the nearest of the segments (m, 4),
    every point against every segment: the reference of :func:`_distance_to_edges`."""
    a, b = edges[None, :, :2], edges[None, :, 2:]
    out = np.full(len(x), np.inf)
    for i0 in range(0, len(x), 4096):
        out[i0:i0 + 4096] = _segment_distance(x[i0:i0 + 4096, None, :], a, b).min(axis=1)
    return out


def _segment_distance(x, a, b):
    """Distance from x to the segments [a, b] (broadcast arrays, last axis 2)."""
    ab = b - a
    tt = np.clip(np.sum((x - a) * ab, -1) / np.sum(ab * ab, -1), 0.0, 1.0)
    return np.linalg.norm(x - (a + tt[..., None] * ab), axis=-1)


def exterior_kernel(x: np.ndarray, edges: np.ndarray, s: float) -> np.ndarray:
    """κ(x) = ∫_{Ωᶜ}|x−y|^(−2−2s) dy at points x (n, 2) inside the polygon
    with counter-clockwise boundary edges (m, 4)."""
    s = check_s(s)
    gl_x, gl_w = gauss01(8)
    gj_t, gj_w = roots_jacobi(8, 0.0, 2.0 * s)        # weight (1+t)^(2s)
    gj_x = 0.5 * (gj_t + 1.0)
    gj_w = gj_w / 2.0 ** (2.0 * s + 1.0)               # weight v^(2s) on [0, 1]
    full = 0.5 * np.sqrt(np.pi) * gamma(s + 0.5) / gamma(s + 1.0)
    return _kernels.exterior_kappa(np.ascontiguousarray(x, dtype=np.float64),
                                   np.ascontiguousarray(edges, dtype=np.float64),
                                   s, gl_x, gl_w, gj_x, gj_w, full, *gauss01(4),
                                   gauss01(2)[0])


def _graded_collapsed_rule(layers, ngauss, toward_apex, theta_layers=0):
    """Barycentric points (apex, B, C) and weights on τ̂, geometrically graded
    in the radial variable ρ toward the apex (ρ=0) or the opposite edge, and
    with theta_layers > 0 in the angle toward both ends (B and C)."""
    sigma = 0.25
    breaks = np.concatenate([[0.0], sigma ** np.arange(layers, -1, -1.0)])
    g, wg = gauss01(ngauss)
    rho = np.concatenate([a + (b - a) * g for a, b in zip(breaks[:-1], breaks[1:])])
    wrho = np.concatenate([(b - a) * wg for a, b in zip(breaks[:-1], breaks[1:])])
    if not toward_apex:
        rho, wrho = 1.0 - rho[::-1], wrho[::-1]
    if theta_layers:
        br = 0.5 * np.concatenate([[0.0], sigma ** np.arange(theta_layers, -1, -1.0)])
        h = np.concatenate([a + (b - a) * g for a, b in zip(br[:-1], br[1:])])
        wh = np.concatenate([(b - a) * wg for a, b in zip(br[:-1], br[1:])])
        th, wth = np.concatenate([h, 1.0 - h[::-1]]), np.concatenate([wh, wh[::-1]])
    else:
        th, wth = gauss01(2 * ngauss)
    R, TH = np.meshgrid(rho, th, indexing="ij")
    W = np.outer(wrho, wth) * R
    bary = np.column_stack([(1 - R).ravel(), (R * (1 - TH)).ravel(), (R * TH).ravel()])
    return bary, W.ravel()


KAPPA_CHUNK = 1 << 20   # points per κ evaluation in :func:`_kappa_local`


def _kappa_local(p, t, boundary_nodes, edges, s, quad, geometry=None, kappa=None):
    """∫_T φ_a φ_b κ for every element (Nt, 3, 3); zero for elements whose
    three nodes are all on ∂Ω (they carry no free node).  ``kappa``: x ↦ κ(x)
    (default :func:`exterior_kernel` with the mesh's boundary)."""
    nt = len(t)
    onb = np.isin(t, boundary_nodes)
    nb = onb.sum(1)
    area2, cent, diam = _element_geometry(p, t) if geometry is None else geometry
    out = np.zeros((nt, 3, 3))
    # away from ∂Ω κ is smooth on the scale of the distance: a lower order
    # suffices where that distance exceeds four element diameters
    far = np.zeros(nt, dtype=bool)
    near = np.zeros(nt, dtype=bool)
    inner = np.flatnonzero(nb == 0)
    if inner.size:
        far[inner] = _distance_to_edges(cent[inner], edges) > 4.0 * diam[inner]
        # thin elements much closer to ∂Ω than long: κ varies along them on the
        # scale of that distance near the corners of the polygon
        cand = inner[~far[inner]]
        if quad.thin_closeness > 0 and cand.size:
            dv = _distance_to_edges(p[t[cand]].reshape(-1, 2), edges).reshape(-1, 3).min(1)
            near[cand[dv < quad.thin_closeness * diam[cand]]] = True
    if near.any():
        # about 100 to 250 points per element: chunks of elements bound the memory
        nel = np.flatnonzero(near)
        step = max(1, KAPPA_CHUNK // 256)
        for i0 in range(0, len(nel), step):
            ch = nel[i0:i0 + step]
            out[ch] = _kappa_near_boundary(p, t, ch, boundary_nodes, edges, s, quad, diam,
                                           kappa)
    groups = []
    for order, sel in ((quad.kappa_order, (nb == 0) & ~far & ~near),
                       (max(quad.kappa_order // 2, 2), far)):
        X, W = triangle_rule(order)
        lam_int = np.column_stack([1 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
        groups.append((np.flatnonzero(sel), None, lam_int, W))
    # thin elements at ∂Ω: κ varies along them near the corners of the polygon
    # on the scale of the distance, so the angle is graded toward both ends too
    thin = diam ** 2 > area2 / max(quad.thin_closeness, 1e-300) if quad.thin_closeness > 0 \
        else np.zeros(nt, dtype=bool)
    tl = quad.kappa_layers + 1
    for rule_thin in (False, True):
        vrule = _graded_collapsed_rule(quad.kappa_layers, quad.kappa_gauss, True,
                                       tl if rule_thin else 0)
        erule = _graded_collapsed_rule(quad.kappa_layers, quad.kappa_gauss, False,
                                       tl if rule_thin else 0)
        sel = thin if rule_thin else ~thin
        for k in range(3):
            # one boundary vertex (local k): apex there, graded toward it
            els = np.flatnonzero((nb == 1) & onb[:, k] & sel)
            groups.append((els, k, *vrule))
            # two boundary vertices: apex at the free vertex k, graded toward ∂Ω
            els = np.flatnonzero((nb == 2) & ~onb[:, k] & sel)
            groups.append((els, k, *erule))
    for els, apex, bary, w in groups:
        if els.size == 0:
            continue
        if apex is None:
            lam = bary
        else:  # columns (apex, apex+1, apex+2) → local order
            order = [(apex + j) % 3 for j in range(3)]
            lam = np.empty_like(bary)
            lam[:, order] = bary
        # chunks of at most KAPPA_CHUNK points bound the memory of the κ
        # evaluation (its trees and work arrays) at any mesh size
        step = max(1, KAPPA_CHUNK // len(w))
        for i0 in range(0, len(els), step):
            ch = els[i0:i0 + step]
            pts = np.einsum("qk,tkd->tqd", lam, p[t[ch]]).reshape(-1, 2)
            kap = (exterior_kernel(pts, edges, s) if kappa is None else kappa(pts)) \
                .reshape(len(ch), -1)
            wk = kap * (w[None, :] * area2[ch, None])
            out[ch] = np.einsum("tq,qa,qb->tab", wk, lam, lam)
    return out


def _kappa_near_boundary(p, t, els, boundary_nodes, edges, s, quad, diam, kappa=None):
    """∫_T φ_a φ_b κ (len(els), 3, 3) for interior elements close to ∂Ω
    compared to their length, by the graded rules of
    :func:`fracfem._aniso_kernels.near_boundary_rules` (toward the points
    nearest to the corners of the polygon within reach)."""
    from scipy.spatial import cKDTree

    bxy = p[boundary_nodes]
    cent = p[t[els]].mean(axis=1)
    lists = cKDTree(bxy).query_ball_point(cent, r=1.5 * diam[els])
    ptr = np.concatenate([[0], np.cumsum([len(x) for x in lists])]).astype(np.int64)
    bv = bxy[np.fromiter((k for x in lists for k in x), dtype=np.int64, count=int(ptr[-1]))]
    gx, gw = gauss01(quad.thin_gauss)
    x, w, offs = _aniso_kernels.near_boundary_rules(p, t, els, bv.reshape(-1, 2), ptr, gx, gw,
                                                     float(quad.thin_ratio))
    kap = exterior_kernel(x, edges, s) if kappa is None else kappa(x)
    owner = np.repeat(np.arange(len(els)), np.diff(offs))
    P = p[t[els]]
    e1, e2 = P[:, 1] - P[:, 0], P[:, 2] - P[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    d = x - P[owner, 0]
    l1 = (d[:, 0] * e2[owner, 1] - d[:, 1] * e2[owner, 0]) / det[owner]
    l2 = (e1[owner, 0] * d[:, 1] - e1[owner, 1] * d[:, 0]) / det[owner]
    lam = np.column_stack([1.0 - l1 - l2, l1, l2])
    wk = w * kap
    out = np.zeros((len(els), 3, 3))
    for a in range(3):
        for b in range(a, 3):
            out[:, a, b] = np.bincount(owner, weights=wk * lam[:, a] * lam[:, b],
                                       minlength=len(els))
            out[:, b, a] = out[:, a, b]
    return out


def dense_bytes(nv: int, nt: int, nchunks: int, quad: QuadratureOptions | None = None) -> float:
    """Peak bytes of :func:`stiffness_matrix`: the N × N matrix, into which the far field
    is assembled in place (:func:`fracfem._kernels.far_pairs`), and O(Nt) work arrays,
    some per chunk."""
    quad = quad or QuadratureOptions()
    nq = sum(len(triangle_rule(max(o, 1))[1]) for o in quad.far_orders)
    # per element: far-field sums D per chunk, rule points and weights (built twice),
    # and a generous 4 KiB for the singular local blocks, the κ rules and the classes
    per_element = 8.0 * (nchunks * (nq + 4) + 6 * nq) + 4096.0
    return 8.0 * nv * nv + per_element * nt


def _check_dense_memory(nv, nt, nchunks, quad, limit):
    """Refuse a stiffness matrix that does not fit, before allocating it."""
    advice = "use a coarser mesh"
    avail, _ = memory.memory_limit(limit)
    if avail is not None:
        linear = dense_bytes(nv, nt, nchunks, quad) - 8.0 * nv * nv
        fit = int(np.sqrt(max(avail - linear, 0.0) / 8.0))
        if fit >= 3:
            advice += f" (about N = {fit} nodes fit)"
    advice += (", or the compressed operator (fracfem.stiffness_operator, or "
               "discretise(..., operator='compressed'))")
    memory.check_dense(dense_bytes(nv, nt, nchunks, quad),
                       what=f"the dense stiffness matrix for N = {nv} nodes "
                            f"({nt} triangles, nchunks={nchunks})",
                       advice=advice, limit=limit)


def element_classes(t: np.ndarray, nv: int) -> tuple[np.ndarray, np.ndarray]:
    """Classes of elements no two of which share a node: (order, ptr), class k the
    elements order[ptr[k]:ptr[k+1]], ascending.  Greedy colouring of the elements in
    index order (:func:`fracfem._h2_kernels.greedy_colouring`), so at most
    3 (d − 1) + 1 classes, d the most elements at one node."""
    from ._h2_kernels import greedy_colouring
    nt = len(t)
    inc = sp.csr_matrix((np.ones(3 * nt), t.ravel(), np.arange(0, 3 * nt + 1, 3)),
                        shape=(nt, nv))
    adj = (inc @ inc.T).tocsr()
    adj.sort_indices()
    colour = greedy_colouring(adj.indptr.astype(np.int64), adj.indices.astype(np.int64))
    order = np.argsort(colour, kind="stable").astype(np.int64)
    ptr = np.concatenate([[0], np.cumsum(np.bincount(colour))]).astype(np.int64)
    return order, ptr


def far_field_into(A, p, t, s, quad, geometry, moments, nchunks):
    """Add the far field of every separated pair (without c_{2,s}) to A in place:
    the off-diagonal part symmetrised, the diagonal blocks from the per-element sums
    (:func:`fracfem._kernels.far_pairs`).  A must hold nothing else yet: A + Aᵀ is
    taken in place."""
    orders = quad.far_orders
    area2, cent, diam = geometry
    area, mom, grad = moments
    qx, qw, lam, offs = _far_rules(p, t, orders, area2)
    order, ptr = element_classes(t, len(p))
    D = _kernels.far_pairs(A, t, cent, diam, area, mom, grad, qx, qw, lam, offs,
                           np.asarray(quad.far_thresholds, dtype=np.float64),
                           orders[0] == 0, s, order, ptr, nchunks)
    _kernels.add_transpose_inplace(A, nchunks)
    D = D.sum(axis=0)
    # diagonal blocks of the Gauss levels: Σ_q D_q λ_a(x_q) λ_b(x_q)
    E = np.einsum("tq,qa,qb->tab", D[:, 4:], lam, lam)
    # ... and of the Taylor level: ΣC0/9 + (α·∇λ_a + α·∇λ_b)/3 + Σk|T'| ∇λ_aᵀ I_T ∇λ_b
    if orders[0] == 0:
        al = np.einsum("td,tad->ta", D[:, 1:3], grad) / 3.0
        Imat = np.stack([mom[:, [0, 1]], mom[:, [1, 2]]], axis=1)
        E += (D[:, 0, None, None] / 9.0 + al[:, :, None] + al[:, None, :]
              + D[:, 3, None, None] * np.einsum("tad,tde,tbe->tab", grad, Imat, grad))
    _kernels.scatter_local(A, t, E, 1.0)


def stiffness_matrix(mesh, s: float, *, quadrature: QuadratureOptions | None = None,
                     timings: dict | None = None, nchunks: int | None = None,
                     memory_limit=None) -> np.ndarray:
    """Dense matrix a(φ_i, φ_j) over all mesh nodes.

    Rows and columns of boundary nodes are NaN: homogeneous Dirichlet data
    never needs them, and for s ≥ 1/2 the couplings of boundary nodes are
    infinite (κ ~ dist(x, ∂Ω)^(−2s)).  Restrict to interior nodes,
    ``A[np.ix_(free, free)]``; that block is symmetric positive definite.

    Parameters
    ----------
    mesh : skfem.MeshTri of a polygon (any triangulated polygon)
    s : fractional order in (0, 1)
    quadrature : orders, default :class:`QuadratureOptions`
    timings : if given, filled with seconds per phase
    nchunks : threads of the far-field loop (default: numba threads); they share A (each
        takes elements of one class at a time, no two of which share a node: no two threads
        write one row), so the peak is one N × N matrix whatever their number
    memory_limit : bytes the dense path may use (number, or a string like '2G');
        default ``$FRACFEM_MEMORY_LIMIT``, else the memory available now.  A problem
        needing more (:func:`dense_bytes`) raises
        :class:`fracfem.memory.DenseMemoryError` (a MemoryError and a ValueError)
        before anything large is allocated.
    """
    s = check_s(s)
    quad = quadrature or QuadratureOptions()
    p, t = mesh_arrays(mesh)
    nv = len(p)
    if nchunks is None:
        import numba
        nchunks = numba.get_num_threads()
    if not isinstance(nchunks, (int, np.integer)) or isinstance(nchunks, bool) or nchunks < 1:
        raise ValueError(f"nchunks={nchunks!r} must be an integer >= 1")
    nchunks = int(nchunks)
    _check_dense_memory(nv, len(t), nchunks, quad, memory_limit)
    c = c2s(s)
    tim = {} if timings is None else timings
    t0 = time.perf_counter()

    edges, bnodes = _boundary_edges(p, t)
    edge_nodes, vertex_nodes = touching_pairs(t)
    geometry = _element_geometry(p, t)
    # the far field first, into A itself (no copy per thread), then the rest added
    A = np.zeros((nv, nv))
    far_field_into(A, p, t, s, quad, geometry, _element_moments(p, t), nchunks)
    A *= c
    tim["far"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    # identical pairs: (c/2) Σ_T I_TT; touching pairs: c Σ_{T<T'} I_TT'
    loc = _singular_local(p, t, "coincident", quad.coincident, s, quad)
    _kernels.scatter_local(A, t, loc, 0.5 * c)
    loc = _singular_local(p, edge_nodes, "edge", quad.edge, s, quad)
    _kernels.scatter_local(A, edge_nodes, loc, c)
    loc = _singular_local(p, vertex_nodes, "vertex", quad.vertex, s, quad)
    _kernels.scatter_local(A, vertex_nodes, loc, c)
    tim["singular"] = time.perf_counter() - t1

    t3 = time.perf_counter()
    pairs, corr = close_pair_corrections(p, t, s, quad, geometry)
    if len(pairs):
        _kernels.scatter_local(A, np.ascontiguousarray(np.hstack([t[pairs[:, 0]], t[pairs[:, 1]]])),
                               corr, c)
    tim["close"] = time.perf_counter() - t3

    t2 = time.perf_counter()
    K = _kappa_local(p, t, bnodes, edges, s, quad, geometry)
    _kernels.scatter_local(A, t, K, c)
    tim["exterior"] = time.perf_counter() - t2

    A[bnodes, :] = np.nan
    A[:, bnodes] = np.nan
    tim["total"] = time.perf_counter() - t0
    log.info("assembled %d x %d matrix (s=%g) in %.2f s", nv, nv, s, tim["total"])
    return A


def load_vector(mesh, f, *, order: int = 6) -> np.ndarray:
    """b_i = ∫ f φ_i over all nodes; f a callable of x (2, ...) or a number."""
    p, t = mesh_arrays(mesh)
    X, W = triangle_rule(order)
    lam = np.column_stack([1 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
    x = np.einsum("qk,tkd->dtq", lam, p[t])
    fx = np.broadcast_to(np.asarray(f(x) if callable(f) else f, dtype=float), x.shape[1:])
    if not np.all(np.isfinite(fx)):
        raise ValueError("f returned non-finite values at quadrature points")
    area2 = _element_geometry(p, t)[0]
    loc = np.einsum("tq,q,qa->ta", fx, W, lam) * area2[:, None]
    return np.bincount(t.ravel(), weights=loc.ravel(), minlength=len(p))


def energy(A: np.ndarray, b: np.ndarray, u: np.ndarray) -> float:
    """E(u) = ½ a(u, u) − (f, u) on the free nodes."""
    return 0.5 * float(u @ (A @ u)) - float(b @ u)
