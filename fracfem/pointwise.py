"""Pointwise values of the integral fractional Laplacian of a P1 function.

For u_h a continuous P1 function on the mesh (nodal vector over all nodes),
extended by zero outside the mesh polygon Ω, and x a point strictly inside
an element,

    (−Δ)^s u_h(x) = c_{2,s} P.V.∫_{R²} (u_h(x) − u_h(y)) |x − y|^(−2−2s) dy.

These values enter the residual r_h = f − (−Δ)^s u_h of the a posteriori
indicators (paper, Section 7 and Remark 7.1).

Method (fast kernel)
--------------------
The brief's element-by-element polar formula — exact integrals in the
radial variable r = |y − x| over each element T', Gauss in the angle —
is, by the divergence theorem in polar coordinates, a sum of line integrals
over the element boundaries.  Summed over all elements, the contributions of
the two sides of an interior edge combine into the jump of the normal
derivative, and the whole sum collapses to the Riesz potential of the
distribution −Δ(u_h 1_Ω) (the identity (−Δ)^s = I_{2−2s}(−Δ), valid for
compactly supported u_h, 0 < s < 1):

    (−Δ)^s u_h(x) = c/(2s) [ Σ_e J_e ∫_e G(|x−y|) dℓ(y)
                             + Σ_{e ⊂ ∂Ω} d_e(x) ∫_e u_h(y) |x−y|^(−2−2s) dℓ(y) ],

    G(r) = (r^(−2s) − ℓ₀^(−2s)) / (2s),   c = c_{2,s},

with J_e = ∂_{n₁}u_h|_{T₁} + ∂_{n₂}u_h|_{T₂} the jump of the normal derivative
across e (outward normals n₁, n₂ of the two elements; ∂_n u_h|_T alone on a
boundary edge, where u_h jumps to 0), and d_e(x) = (y − x)·n_e the distance
of x to the line of the boundary edge e (n_e the outward normal of Ω).  The
constant −ℓ₀^(−2s) in G is harmless because Σ_e J_e |e| = ∫ −Δu_h = 0; it
keeps the formula uniform as s → 0 (ℓ₀ is the diameter of the bounding
box).  The double-layer term vanishes when u_h = 0 on ∂Ω (the usual case);
for u_h ≡ 1 it reproduces c κ(x), κ(x) = ∫_{Ωᶜ}|x−y|^(−2−2s) dy.  The
constant c/(2s) = 1/γ(2−2s)·2s follows from the Riesz constant
γ(α) = π 2^α Γ(α/2)/Γ(1 − α/2) with α = 2 − 2s.

So one value costs one smooth line integral per mesh edge (O(N_E) per
point instead of O(N_T) element integrals plus κ): near edges
(|x − m_e| < near·|e|) use the substitution t = d sinh v along the edge,
which makes the integrand analytic in a strip of fixed width however close
x is to e (x strictly inside an element is never on an edge), farther
edges Gauss rules with 8 and 4 points and, beyond 6 edge lengths, the
midpoint rule with its analytic second-order correction (see
:class:`PointwiseOptions`; the defaults give relative errors ≲ 1e-6 of
max|(−Δ)^s u_h|, the tests compare against the raised options and against
the reference).  Cost: O(N_points × N_edges), about 20 ns (s = 1/2) to
40 ns (other s) per point–edge pair and thread.

Compressed path
---------------
``method="compressed"`` (and ``"auto"`` on large meshes) computes the same
sums in about linear time: point–edge pairs closer than the farthest
distance class (6 edge lengths by default) and a margin from the cluster
boxes keep the rules above, the others — where the dense path takes the
corrected midpoint rule (single layer) or 4 Gauss points (double layer) —
are summed through cluster trees of points and of those rules' points with
tensor Chebyshev interpolation of the kernels (the H² machinery of
:mod:`fracfem.compressed`), so that the two paths differ by the
interpolation error, which follows ``tol`` (:func:`_riesz_compressed`).

Reference
---------
The tests compare against an independent, slow implementation of the
brief's element-wise polar formula (``tests/pointwise_reference.py``,
outside the package).

s ≥ 1/2
-------
(−Δ)^s u_h behaves like J_e dist(x, e)^(1−2s) near an interior edge e with
J_e ≠ 0 (like J_e log dist for s = 1/2): this is real (u_h has kinks), the
values at interior points are finite and computed accurately (the sinh rule
resolves the near-singularity), but for s ≥ 3/4 the function is not in
L²(Ω): a fixed triangle rule then computes a rule-dependent number (in
effect the L² norm of r_h sampled at distances ≥ δ h from the edges, δ the
smallest barycentric coordinate of the rule), which does not converge as
the order rises (it grows as the rule's points approach the edges; e.g.
s = 0.75 on disk_uniform(3): 1.18, 1.21, 1.37, 2.29 for orders 2, 4, 6, 8).
For 1/2 ≤ s < 3/4 it is in L² but the quadrature converges slowly; for
s < 1/2 it is Hölder continuous.  For s > 1/2 it is in L^p exactly for
p < 1/(2s − 1) (the paper's L^p remark after Lemma 5.22); a reliable
L^p or L² evaluation needs rules graded toward the edges, which
:func:`fractional_laplacian_at` supports (any points inside elements).
"""
from __future__ import annotations

import logging
import numbers
import time
from dataclasses import dataclass, replace

import numpy as np

from . import _pointwise_kernels as _pk
from .assembly import mesh_arrays
from .compressed import (DEFAULT_TOL, block_tree, chebyshev_order, cluster_tree, far_values,
                         near_lists, square_around)
from .exact import c2s, check_s
from .quadrature import gauss01, triangle_rule

__all__ = [
    "PointwiseOptions",
    "fractional_laplacian_at",
    "fractional_laplacian_qp",
    "normal_derivative_jumps",
    "METHODS",
]

log = logging.getLogger(__name__)

_INSIDE = 1e-12   # points must have all barycentric coordinates above this

METHODS = ("dense", "compressed", "auto")
# "auto": the compressed path from this many point–edge pairs on, about 1,000
# nodes with the order-4 rule (benchmarks/pointwise.md, loaded 2-core machine:
# the compressed path is 0.55-1.0× as fast as the dense one at 5e6-1e7 pairs
# (disk_uniform(4)), 0.75× for 1,000 points on disk_uniform(6) (2.5e7 pairs,
# building the source tree dominates), 1.4-2.8× from 7.6e7 pairs on)
AUTO_PAIRS = 4e7
# cluster trees of the compressed path: points per target leaf, sources per
# source leaf; admissibility max(diam) ≤ ETA·dist and interpolation order
# chebyshev_order(tol) + 1 (measured on disk_uniform(6), random P1 u_h, s = 0.1:
# eta 1 and order 7 at tol = 1e-8 leave 1.2e-6 of max|values|, eta 0.5 and
# order 8 1e-8 at about the same cost: the near field dominates)
TARGET_LEAF = 32
SOURCE_LEAF = 16
ETA = 0.5


@dataclass(frozen=True)
class PointwiseOptions:
    """Quadrature of the edge integrals of :func:`fractional_laplacian_at`.

    near: edges with |x − m_e| < near·|e| use the sinh substitution, with
    Gauss rules of ``near_points`` points on pieces of length ≤ ``piece`` in
    the substituted variable; ratios: distance ratios |x − m_e|/|e| at which
    the Gauss levels with ``points[1:]`` points start (``points[0]`` from
    ``near`` on); boundary_ratios / boundary_points: the same for the
    double-layer integrals over ∂Ω (used only if u_h ≠ 0 on ∂Ω).
    """

    near: float = 1.0
    piece: float = 2.0
    near_points: int = 8
    ratios: tuple = (2.5, 6.0)
    points: tuple = (8, 4, 0)
    boundary_ratios: tuple = (4.0,)
    boundary_points: tuple = (8, 4)

    def __post_init__(self):
        if not (self.near > 0 and self.piece > 0 and self.near_points >= 1):
            raise ValueError(f"invalid PointwiseOptions {self}")
        for r, n, name in ((self.ratios, self.points, "ratios/points"),
                           (self.boundary_ratios, self.boundary_points,
                            "boundary_ratios/boundary_points")):
            if len(n) != len(r) + 1 or min(n) < 0 or list(r) != sorted(r):
                raise ValueError(f"PointwiseOptions: {name} must be increasing "
                                 f"ratios and one more point count ≥ 0, got {r}, {n}")
        if min(self.boundary_points) < 1 or min(self.points[:-1]) < 1:
            raise ValueError("PointwiseOptions: only the farthest single-layer level "
                             "may have 0 points (midpoint rule with correction)")

    def raised(self) -> "PointwiseOptions":
        """Every order raised: for quadrature-convergence checks."""
        return replace(self, near=2.0 * self.near, piece=0.5 * self.piece,
                       near_points=2 * self.near_points,
                       ratios=tuple(2.0 * r for r in self.ratios),
                       points=tuple(max(2 * n, 2) for n in self.points),
                       boundary_ratios=tuple(2.0 * r for r in self.boundary_ratios),
                       boundary_points=tuple(2 * n for n in self.boundary_points))


def _check_u(u, nv, batch=False):
    """u (nv,), or with ``batch`` also (nv, K) (K ≥ 1 functions, one per column)."""
    u = np.asarray(u, dtype=np.float64)
    if not (u.shape == (nv,) or (batch and u.ndim == 2 and u.shape[0] == nv
                                 and u.shape[1] >= 1)):
        allowed = f"({nv},) or ({nv}, K)" if batch else f"({nv},)"
        raise ValueError(f"u must have shape {allowed} (one value per mesh node), "
                         f"got {u.shape}")
    if not np.all(np.isfinite(u)):
        bad = np.flatnonzero(~np.all(np.isfinite(u.reshape(nv, -1)), axis=1))
        raise ValueError(f"u has non-finite values at nodes {bad[:5].tolist()}")
    return np.ascontiguousarray(u)


def _gradients(p, t, U):
    """Element gradients (Nt, 2, K) of the P1 functions U (Nv, K) and signed 2|T|."""
    v = p[t]
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    du1, du2 = U[t[:, 1]] - U[t[:, 0]], U[t[:, 2]] - U[t[:, 0]]          # (Nt, K)
    g = np.stack([du1 * e2[:, 1, None] - du2 * e1[:, 1, None],
                  e1[:, 0, None] * du2 - e2[:, 0, None] * du1], axis=1)
    return g / det[:, None, None], det


def normal_derivative_jumps(mesh, u):
    """Edges and jumps of the normal derivative of the P1 function u.

    Returns (edges (m, 2) node pairs, J (m,), boundary (m,) bool) with
    J_e = Σ_{T ∋ e} ∇u_T·n_T (outward normals), so that −Δ(u 1_Ω) restricted
    to u = 0 on ∂Ω is Σ_e J_e δ_e; on a boundary edge J_e = ∇u_T·n_T.
    """
    p, t = mesh_arrays(mesh)
    u = _check_u(u, len(p))
    return _jumps(p, t, u)[:3]


def _jumps(p, t, u):
    """As :func:`normal_derivative_jumps`, J (m,) or (m, K) for u (Nv,) or (Nv, K),
    and the boundary edges oriented with Ω on the left."""
    g, det = _gradients(p, t, u.reshape(len(p), -1))
    sgn = np.sign(det)[:, None]
    nodes, flux = [], []
    for k in range(3):
        a, b = t[:, (k + 1) % 3], t[:, (k + 2) % 3]
        tv = p[b] - p[a]
        # right-hand normal (ty, −tx) is outward for a counter-clockwise T
        flux.append(sgn * (g[:, 0] * tv[:, 1, None] - g[:, 1] * tv[:, 0, None]))  # ∂_n u |e|
        nodes.append(np.column_stack([a, b]))
    nodes, flux = np.vstack(nodes), np.concatenate(flux)
    # orient every local edge with Ω (its element) on the left
    ccw = np.tile(det > 0, 3)
    oriented = np.where(ccw[:, None], nodes, nodes[:, ::-1])
    key = np.sort(nodes, axis=1)
    uniq, first, inv, cnt = np.unique(key, axis=0, return_index=True,
                                      return_inverse=True, return_counts=True)
    inv = inv.ravel()
    lengths = np.linalg.norm(p[uniq[:, 1]] - p[uniq[:, 0]], axis=1)
    J = np.column_stack([np.bincount(inv, weights=flux[:, r], minlength=len(uniq))
                         for r in range(flux.shape[1])]) / lengths[:, None]
    boundary = cnt == 1
    return uniq, (J if u.ndim == 2 else J[:, 0]), boundary, oriented[first[boundary]]


def _rules(ratios, points):
    xs, ws, off = [], [], [0]
    for n in points:
        x, w = gauss01(int(n)) if n > 0 else (np.empty(0), np.empty(0))
        xs.append(x)
        ws.append(w)
        off.append(off[-1] + len(x))
    return (np.asarray(ratios, dtype=np.float64), np.concatenate(xs),
            np.concatenate(ws), np.array(off, dtype=np.int64))


def _check_points(p, t, points, elements):
    x = np.asarray(points, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != 2:
        raise ValueError(f"points must have shape (N, 2), got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("points contain non-finite coordinates")
    el = np.asarray(elements)
    if el.shape != (len(x),) or (el.size and not np.issubdtype(el.dtype, np.integer)):
        raise ValueError(f"elements must be an integer array of shape ({len(x)},), "
                         f"got dtype {el.dtype} and shape {el.shape}")
    if el.size and (el.min() < 0 or el.max() >= len(t)):
        raise ValueError(f"elements must index the {len(t)} mesh elements")
    v = p[t[el]]
    e1, e2, r = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0], x - v[:, 0]
    det = e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0]
    l1 = (r[:, 0] * e2[:, 1] - r[:, 1] * e2[:, 0]) / det
    l2 = (e1[:, 0] * r[:, 1] - e1[:, 1] * r[:, 0]) / det
    lmin = np.minimum(np.minimum(l1, l2), 1.0 - l1 - l2)
    bad = np.flatnonzero(~(lmin > _INSIDE))
    if bad.size:
        raise ValueError(
            f"{bad.size} point(s) are not strictly inside their elements, e.g. "
            f"point {bad[0]} {x[bad[0]].tolist()} in element {el[bad[0]]} "
            f"(smallest barycentric coordinate {lmin[bad[0]]:.3e}); (−Δ)^s u_h is "
            f"evaluated only off the mesh edges")
    return np.ascontiguousarray(x), el


def check_method(method, tol):
    """``method`` and ``tol`` of the evaluation, checked."""
    if not isinstance(method, str) or method not in METHODS:
        raise ValueError(f"method={method!r} must be one of {METHODS}")
    if (isinstance(tol, bool) or not isinstance(tol, numbers.Real)
            or not (1e-14 <= float(tol) < 1.0)):
        raise ValueError(f"tol={tol!r} must be a number in [1e-14, 1) (relative "
                         f"accuracy of the compressed far field)")
    return method, float(tol)


def fractional_laplacian_at(mesh, u, points, elements, s, *,
                            options: PointwiseOptions | None = None,
                            method: str = "auto", tol: float = DEFAULT_TOL) -> np.ndarray:
    """(−Δ)^s u_h at points strictly inside mesh elements.

    Parameters
    ----------
    mesh : skfem.MeshTri of the polygon Ω (either triangle orientation)
    u : (Nv,) nodal values over all mesh nodes; u_h is extended by zero
        outside Ω (normally u = 0 on ∂Ω; nonzero boundary values are allowed
        and mean a jump of u_h across ∂Ω — then the values blow up like
        dist(x, ∂Ω)^(−2s) towards ∂Ω).  Or (Nv, K): K functions at once, e.g.
        the time steps of one mesh; the kernel values, trees and near-field
        rules are then computed once for all of them (the cost grows far more
        slowly than K), and the result is (N, K), column r that of u[:, r]
        alone (to round-off where every column has the same edges with J_e ≠ 0,
        else — other source trees — to the compressed path's tolerance).
    points : (N, 2) coordinates (rows are points; note scikit-fem's (2, N)
        convention is *not* accepted, pass ``x.T``)
    elements : (N,) index of the element containing each point; every point
        must be strictly inside it (barycentric coordinates > 1e-12), because
        for s ≥ 1/2 the values are infinite on edges where ∇u_h jumps
    s : order in (0, 1)
    options : quadrature of the edge integrals, default :class:`PointwiseOptions`
    method : "dense" (every point against every edge, O(N·N_E)), "compressed"
        (near edges by the same rules, far edges through cluster trees and
        Chebyshev interpolation, about linear in N + N_E; see
        :func:`_riesz_compressed`) or "auto" (compressed from
        ``AUTO_PAIRS`` point–edge pairs on, where it is the faster)
    tol : relative accuracy of the compressed far field, in [1e-14, 1)

    Returns
    -------
    (N,) values of (−Δ)^s u_h, including the constant c_{2,s} ((N, K) for u
    of shape (Nv, K)).
    """
    s = check_s(s)
    method, tol = check_method(method, tol)
    opt = options or PointwiseOptions()
    p, t = mesh_arrays(mesh)
    u = _check_u(u, len(p), batch=True)
    x, _ = _check_points(p, t, points, elements)
    U = u.reshape(len(p), -1)                          # (Nv, K)
    out = np.zeros((len(x), U.shape[1]))
    if len(x):
        edges, J, boundary, bnodes = _jumps(p, t, U)
        keep = np.any(J != 0.0, axis=1)
        a, b = p[edges[keep, 0]], p[edges[keep, 1]]
        l2 = np.sum((b - a) ** 2, axis=1)
        edata = np.ascontiguousarray(np.column_stack([a, b, 0.5 * (a + b), 1.0 / l2]))
        coef = np.ascontiguousarray(J[keep] * np.sqrt(l2)[:, None])       # J_e |e|
        bu = U[bnodes]                                                  # (mb, 2, K)
        bkeep = np.any(bu != 0.0, axis=(1, 2))
        ba = np.ascontiguousarray(p[bnodes[bkeep, 0]])
        bb = np.ascontiguousarray(p[bnodes[bkeep, 1]])
        bu = np.ascontiguousarray(bu[bkeep])
        ell0 = float(np.linalg.norm(np.ptp(p, axis=0)))
        if method == "auto":
            pairs = float(len(x)) * (len(edata) + len(ba))
            method = "compressed" if pairs >= AUTO_PAIRS else "dense"
        if method == "dense":
            _pk.riesz_edges(x, *_kernel_args(edata, coef, ba, bb, bu, s, ell0, opt), out)
        else:
            _riesz_compressed(x, edata, coef, ba, bb, bu, s, ell0, opt, tol, out)
        out *= c2s(s) / (2.0 * s)
        if not np.all(np.isfinite(out)):
            raise FloatingPointError("non-finite values of (−Δ)^s u_h; are the points "
                                     "too close to an edge?")
    return out if u.ndim == 2 else out[:, 0]


def _kernel_args(edata, coef, ba, bb, bu, s, ell0, opt):
    """The arguments after x of :func:`fracfem._pointwise_kernels.riesz_edges`."""
    ratios, gx, gw, goff = _rules(opt.ratios, opt.points)
    bratios, bgx, bgw, bgoff = _rules(opt.boundary_ratios, opt.boundary_points)
    nx, nw = gauss01(int(opt.near_points))
    return (edata, coef, ba, bb, bu, s, np.log(ell0), float(opt.near), ratios, gx, gw, goff,
            bratios, bgx, bgw, bgoff, nx, nw, float(opt.piece))


def _sources(a, b, n):
    """Far-field sources of the edges [a, b]: the n Gauss points of each
    edge (the midpoint if n = 0), as (points, edge index, point index,
    weight on [0, 1])."""
    x, w = gauss01(n) if n > 0 else (np.array([0.5]), np.array([1.0]))
    k, ne = len(x), len(a)
    pts = (a[None] + x[:, None, None] * (b - a)[None]).reshape(-1, 2)
    return (np.ascontiguousarray(pts), np.tile(np.arange(ne, dtype=np.int64), k),
            np.repeat(np.arange(k, dtype=np.int64), ne), np.repeat(w, ne))


def _riesz_compressed(x, edata, coef, ba, bb, bu, s, ell0, opt, tol, out):
    """The sum of :func:`fracfem._pointwise_kernels.riesz_edges` with the far
    field compressed.

    Targets are the points x, in one cluster tree (:func:`fracfem.compressed.
    cluster_tree`, dyadic boxes of a square around points and mesh).  Each
    layer has a tree of sources, the points of the rule that the dense path
    uses for the edges in the farthest distance class: for the single layer
    (default) the edge midpoints, each with the functional
    J_e|e| (δ + |e|²/24 ∂²_τ) of the corrected midpoint rule; for the double
    layer the Gauss points y_g of the boundary edges with the weights
    w_g u(y_g) (b − a)^⊥, one H² pass per component of the kernel
    (y − x)|y − x|^(−2−2s).  A block is admissible when its boxes are
    separated (:func:`fracfem.compressed.block_tree`) and every pair in it is
    in the farthest class (distance ratio from the sources' boxes); there
    the kernel — G itself for the single layer, with its constant, so that
    the sum stays well conditioned as s → 0 — is interpolated on tensor
    Chebyshev grids of order ``chebyshev_order(tol) + 1`` with admissibility
    ``ETA``.  Near blocks are summed pair by pair with the rules of the dense
    path (:func:`fracfem._pointwise_kernels.riesz_near`), so the two paths
    differ by the interpolation error only.
    """
    t0 = time.perf_counter()
    m = min(chebyshev_order(tol) + 1, 14)
    # a single class beyond `near` is two with the same rule, both from `near`
    # on: the kernels then always find the start of the farthest class
    if not opt.ratios:
        opt = replace(opt, ratios=(opt.near,), points=2 * tuple(opt.points))
    if not opt.boundary_ratios:
        opt = replace(opt, boundary_ratios=(opt.near,),
                      boundary_points=2 * tuple(opt.boundary_points))
    args = _kernel_args(edata, coef, ba, bb, bu, s, ell0, opt)
    logl0 = args[6]
    nr = coef.shape[1]
    root = square_around(x, edata[:, :2], edata[:, 2:4], ba, bb)
    tt = cluster_tree(x, np.zeros(len(x)), TARGET_LEAF, root)
    layers = []
    if len(edata):
        a, b = edata[:, :2], edata[:, 2:4]
        n = int(opt.points[-1])
        pts, sedge, sg, w = _sources(a, b, n)
        src = np.zeros((1, len(pts), nr, 6))
        src[0, :, :, 0] = coef[sedge] * w[:, None]
        if n == 0:      # |e|²/24 τ τᵀ: the second-order term of the midpoint rule
            tv = b - a
            src[0, :, :, 3:6] = (coef / 24.0)[:, :, None] * np.column_stack(
                [tv[:, 0] ** 2, tv[:, 0] * tv[:, 1], tv[:, 1] ** 2])[:, None, :]
        # the farthest class starts at this distance ratio from the midpoint
        ratio = max(opt.ratios[-1], opt.near) + (0.5 if n else 0.0)
        layers.append((0, pts, sedge, sg, max(n, 1), np.sqrt(1.0 / edata[sedge, 6]), ratio,
                       src, (2,), -s))
    if len(ba):
        n = int(opt.boundary_points[-1])
        pts, sedge, sg, w = _sources(ba, bb, n)
        tv = (bb - ba)[sedge]
        xg = gauss01(n)[0][sg]
        wu = w[:, None] * (bu[sedge, 0] + xg[:, None] * (bu[sedge, 1] - bu[sedge, 0]))
        src = np.zeros((2, len(pts), nr, 6))
        src[0, :, :, 0] = wu * tv[:, 1, None]
        src[1, :, :, 0] = -wu * tv[:, 0, None]
        ratio = max(opt.boundary_ratios[-1], opt.near) + 0.5
        layers.append((1, pts, sedge, sg, n, np.linalg.norm(tv, axis=1), ratio, src,
                       (0, 1), -1.0 - s))
    tim = dict(trees=time.perf_counter() - t0, far=0.0, near=0.0)
    for layer, pts, sedge, sg, nsrc, ln, ratio, src, comps, expo in layers:
        t1 = time.perf_counter()
        ts = cluster_tree(pts, ln, SOURCE_LEAF, root)
        far, near = block_tree(tt, ts, ETA, ratio)
        t2 = time.perf_counter()
        out += far_values(tt, ts, far, x, pts, m, expo, src, comps, logl0)
        t3 = time.perf_counter()
        rows, ptr, cols = near_lists(near)
        # one row of edge data per source, in source-tree order
        rowof = sedge[ts["perm"]]
        edge_args = list(args[:5])
        if layer == 0:
            edge_args[0:2] = [np.ascontiguousarray(v[rowof]) for v in (edata, coef)]
        else:
            edge_args[2:5] = [np.ascontiguousarray(v[rowof]) for v in (ba, bb, bu)]
        _pk.riesz_near(x, tt["perm"], tt["start"], tt["end"], rows, ptr, cols, ts["start"],
                       ts["end"], np.ascontiguousarray(sg[ts["perm"]]), nsrc, layer,
                       *edge_args, *args[5:], out)
        tim["trees"] += t2 - t1
        tim["far"] += t3 - t2
        tim["near"] += time.perf_counter() - t3
        log.info("pointwise %s layer: %d points, %d sources, %d far / %d near blocks",
                 ("single", "double")[layer], len(x), len(pts), len(far), len(near))
    log.info("pointwise compressed, order %d: trees %.2f s, far field %.2f s, "
             "near field %.2f s", m, tim["trees"], tim["far"], tim["near"])
    return tim


def quadrature_points(mesh, order: int):
    """Physical points (Nt, nq, 2), weights (Nt, nq) and barycentrics (nq, 3)
    of ``triangle_rule(order)`` on every element (weights sum to the areas)."""
    p, t = mesh_arrays(mesh)
    X, W = triangle_rule(order)
    lam = np.column_stack([1.0 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
    pts = np.einsum("qk,tkd->tqd", lam, p[t])
    e1, e2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    area2 = np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    return pts, area2[:, None] * W[None, :], lam


def fractional_laplacian_qp(mesh, u, s, order: int, *,
                            options: PointwiseOptions | None = None,
                            method: str = "auto", tol: float = DEFAULT_TOL):
    """(−Δ)^s u_h at the points of ``triangle_rule(order)`` of every element.

    Returns (values (Nt, nq), points (Nt, nq, 2), weights (Nt, nq)); the
    weights are physical (Σ_q weights[T, q] = |T|), so that
    Σ weights·values·φ approximates ∫_Ω (−Δ)^s u_h φ.  ``u`` (Nv,) or (Nv, K)
    (then values (Nt, nq, K)), ``options``, ``method`` and ``tol`` as in
    :func:`fractional_laplacian_at`.
    """
    s = check_s(s)
    check_method(method, tol)
    pts, wts, _ = quadrature_points(mesh, order)
    nt, nq = wts.shape
    el = np.repeat(np.arange(nt), nq)
    vals = fractional_laplacian_at(mesh, u, pts.reshape(-1, 2), el, s, options=options,
                                   method=method, tol=tol)
    return vals.reshape((nt, nq) + vals.shape[1:]), pts, wts
