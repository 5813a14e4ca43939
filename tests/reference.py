"""Slow, plain NumPy references for the numba kernels of :mod:`fracfem.assembly`.

Everything here loops over element pairs in Python and is meant for tiny
meshes (a few dozen triangles) in the tests.  The code is written from the
mathematical definitions, not from the kernels:

* touching pairs are found by comparing node sets pair by pair;
* the relative-coordinate data of a singular pair (the matrix M with
  x − y = M z and the matrix A with φ_a(x) − φ_a(y) = (Aᵀ z)_a) are obtained
  by *evaluating* the affine parametrisations of the two triangles at z = 0
  and z = e_i, not from tables;
* separated pairs use the product rule on the physical triangles, or the
  second-order Taylor expansion of the kernel written out term by term with
  second moments computed by quadrature;
* κ(x) = ∫_{Ωᶜ}|x − y|^(−2−2s) dy is integrated as
  (1/2s) Σ_e ∫_e (y − x)·n |y − x|^(−2−2s) ds by composite Gauss–Legendre
  rules along each edge, geometrically graded toward the foot of the
  perpendicular, and ∫_T φ_a φ_b κ by tensor Gauss rules in collapsed
  coordinates graded toward the boundary nodes of T.

Conventions shared with the assembly (they define which numbers are
compared, not how they are computed): p is (Nv, 2), t is (Nt, 3); local
nodes of a common-edge pair are (P, Q, R, R') with P, Q the shared nodes in
the order in which they appear in the lower-numbered triangle T, R the third
node of T and R' that of T'; of a common-vertex pair (P, Q, R, Q', R') with
(Q, R) and (Q', R') in the local order of T and T'.  Separated pairs are
classified by |c_T − c_T'| / max(diam T, diam T') exactly as documented in
:class:`fracfem.assembly.QuadratureOptions`.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial.legendre import leggauss

from fracfem.assembly import QuadratureOptions
from fracfem.exact import c2s, check_s
from fracfem.quadrature import (coincident_rule, edge_rule, radial_factor,
                                triangle_rule, vertex_rule)

__all__ = [
    "classify_pairs",
    "singular_pairs_reference",
    "far_pair_reference",
    "taylor_pair_reference",
    "far_matrix_reference",
    "singular_matrix_reference",
    "boundary_edges_reference",
    "kappa_reference",
    "kappa_mass_reference",
    "stiffness_matrix_reference",
]

# local node layout of the two triangles of a pair (positions in `nodes`)
_LAYOUT = {"coincident": ((0, 1, 2), (0, 1, 2)),
           "edge": ((0, 1, 2), (0, 1, 3)),
           "vertex": ((0, 1, 2), (0, 3, 4))}
_RULES = {"coincident": coincident_rule, "edge": edge_rule, "vertex": vertex_rule}


def _gauss01(n):
    x, w = leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def _area2(P):
    """Twice the (unsigned) area of the triangle with vertex rows P (3, 2)."""
    e1, e2 = P[1] - P[0], P[2] - P[0]
    return abs(e1[0] * e2[1] - e1[1] * e2[0])


def _gradients(P):
    """Gradients (3, 2) of the barycentric coordinates of triangle P."""
    T = np.column_stack([P[1] - P[0], P[2] - P[0]])
    G = np.linalg.inv(T)            # rows: ∇λ1, ∇λ2
    return np.vstack([-G[0] - G[1], G[0], G[1]])


# --------------------------------------------------------------------------
# pair classification


def classify_pairs(t):
    """(edge_nodes, vertex_nodes, separated) by comparing node sets pairwise.

    edge_nodes (ne, 4) rows (P, Q, R, R'); vertex_nodes (nv, 5) rows
    (P, Q, R, Q', R'); separated: list of (T, T') with T < T'.
    """
    t = np.asarray(t)
    edges, verts, sep = [], [], []
    for T in range(len(t)):
        a = [int(v) for v in t[T]]
        for T2 in range(T + 1, len(t)):
            b = [int(v) for v in t[T2]]
            shared = [v for v in a if v in b]
            if len(shared) == 2:
                R = [v for v in a if v not in b][0]
                R2 = [v for v in b if v not in a][0]
                edges.append(shared + [R, R2])
            elif len(shared) == 1:
                verts.append(shared + [v for v in a if v not in b]
                             + [v for v in b if v not in a])
            elif len(shared) == 0:
                sep.append((T, T2))
            else:
                raise ValueError(f"triangles {T} and {T2} have the same nodes")
    return (np.array(edges, dtype=np.int64).reshape(-1, 4),
            np.array(verts, dtype=np.int64).reshape(-1, 5), sep)


# --------------------------------------------------------------------------
# singular pairs


def _relative_coordinates(Pts, kind):
    """M (2, d) and A (d, d+1) with x − y = M z, φ_a(x) − φ_a(y) = (Aᵀz)_a.

    Pts (d+1, 2) are the local nodes of the pair.  x = F_T(x̂),
    y = F_T'(ŷ) with F the affine maps from τ̂ in the local orders of
    _LAYOUT and (x̂, ŷ) given by z (and a free variable, set to 0):
    coincident x̂ = ŷ + z, ŷ = 0; edge x̂ = (z₁, z₂), ŷ = (0, z₃);
    vertex x̂ = (z₁, z₂), ŷ = (z₃, z₄).
    """
    lt, lt2 = _LAYOUT[kind]
    d = len(Pts) - 1

    def hats(xh, layout):
        """Values of the d+1 local hat functions at F(x̂) on the triangle."""
        v = np.zeros(d + 1)
        lam = (1.0 - xh[0] - xh[1], xh[0], xh[1])
        for j, a in enumerate(layout):
            v[a] += lam[j]
        return v

    def ref_points(z):
        if kind == "coincident":
            return z[:2], np.zeros(2)
        if kind == "edge":
            return z[:2], np.array([0.0, z[2]])
        return z[:2], z[2:]

    def diff(z):
        xh, yh = ref_points(z)
        PT, PT2 = Pts[list(lt)], Pts[list(lt2)]
        x = PT[0] + xh[0] * (PT[1] - PT[0]) + xh[1] * (PT[2] - PT[0])
        y = PT2[0] + yh[0] * (PT2[1] - PT2[0]) + yh[1] * (PT2[2] - PT2[0])
        return x - y, hats(xh, lt) - hats(yh, lt2)

    g0, h0 = diff(np.zeros(d))
    M = np.empty((2, d))
    A = np.empty((d, d + 1))
    for i in range(d):
        gi, hi = diff(np.eye(d)[i])
        M[:, i] = gi - g0
        A[i] = hi - h0
    return M, A


def singular_pairs_reference(p, nodes, kind, n, s):
    """Local matrices ∫_T∫_T'(φ_a(x)−φ_a(y))(φ_b(x)−φ_b(y))|x−y|^(−2−2s)
    (without c_{2,s}) of touching pairs by the rule ``kind`` with n points
    per face direction, computed pair by pair; shape (len(nodes), d+1, d+1).
    """
    p = np.asarray(p, dtype=float)
    nodes = np.asarray(nodes)
    zq, wq = _RULES[kind](n)
    B = radial_factor(kind, s)
    lt, lt2 = _LAYOUT[kind]
    out = np.empty((len(nodes), nodes.shape[1], nodes.shape[1]))
    for k, row in enumerate(nodes):
        Pts = p[row]
        M, A = _relative_coordinates(Pts, kind)
        r = zq @ M.T                                       # x − y at the points
        Z = np.einsum("q,qi,qj->ij", wq * _kernel(r, s), zq, zq)
        jac = _area2(Pts[list(lt)]) * _area2(Pts[list(lt2)])   # 4|T||T'|
        out[k] = B * jac * (A.T @ Z @ A)
    return out


def singular_matrix_reference(p, t, s, quadrature):
    """Σ over identical (×½) and touching (×1) pairs, without c_{2,s}."""
    p, t = np.asarray(p, dtype=float), np.asarray(t)
    A = np.zeros((len(p), len(p)))
    edges, verts, _ = classify_pairs(t)
    for kind, nodes, n, fac in (("coincident", t, quadrature.coincident, 0.5),
                                ("edge", edges, quadrature.edge, 1.0),
                                ("vertex", verts, quadrature.vertex, 1.0)):
        if len(nodes) == 0:
            continue
        loc = singular_pairs_reference(p, nodes, kind, n, s)
        for row, L in zip(nodes, loc):
            A[np.ix_(row, row)] += fac * L
    return A


# --------------------------------------------------------------------------
# separated pairs


def _kernel(z, s):
    return np.sum(z * z, axis=-1) ** (-1.0 - s)


def far_pair_reference(pT, pT2, order, s):
    """6 × 6 matrix of ∫_T∫_T'(u(x)−u(y))(v(x)−v(y))|x−y|^(−2−2s) over the
    nodes (T's three, then T''s three), by triangle_rule(order) on both."""
    pT, pT2 = np.asarray(pT, dtype=float), np.asarray(pT2, dtype=float)
    X, W = triangle_rule(order)
    lam = np.column_stack([1.0 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
    x, wx = lam @ pT, W * _area2(pT)
    y, wy = lam @ pT2, W * _area2(pT2)
    nq = len(W)
    # U[q, r] = (φ_a(x_q) − φ_a(y_r))_a over the six nodes
    U = np.concatenate([np.broadcast_to(lam[:, None, :], (nq, nq, 3)),
                        -np.broadcast_to(lam[None, :, :], (nq, nq, 3))], axis=2)
    K = wx[:, None] * wy[None, :] * _kernel(x[:, None, :] - y[None, :, :], s)
    return np.einsum("qr,qra,qrb->ab", K, U, U)


def _second_moment(P):
    """(|T|, centroid, ∫_T (x−c)(x−c)ᵀ dx) with a degree-2 exact rule."""
    X, W = triangle_rule(2)
    lam = np.column_stack([1.0 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])
    x = lam @ P
    w = W * _area2(P)
    area = w.sum()
    c = (w[:, None] * x).sum(0) / area
    v = x - c
    return area, c, np.einsum("q,qi,qj->ij", w, v, v)


def taylor_pair_reference(pT, pT2, s):
    """6 × 6 Taylor-corrected centroid rule for a separated pair.

    With x = c + ξ, y = c' + η, D = c − c' and u linear on each triangle,
    u(x) − u(y) = δ_u + g_u·ξ − g'_u·η (δ_u = u(c) − u(c'), g_u, g'_u the
    gradients of u on T, T'), and k(D + ξ − η) ≈ k + ∇k·(ξ−η)
    + ½(ξ−η)ᵀ∇²k(ξ−η).  Keeping all terms of total degree ≤ 2 in (ξ, η)
    and using ∫ξ = ∫η = 0, ∫ξξᵀ = I_T, ∫ηηᵀ = I_T':
      δ_uδ_v (|T||T'|k + ½|T'| tr(∇²k I_T) + ½|T| tr(∇²k I_T'))
      + δ_u (|T'| g_vᵀI_T∇k + |T| g'_vᵀI_T'∇k) + (u ↔ v)
      + k (|T'| g_uᵀI_T g_v + |T| g'_uᵀI_T' g'_v).
    """
    pT, pT2 = np.asarray(pT, dtype=float), np.asarray(pT2, dtype=float)
    a1, c1, I1 = _second_moment(pT)
    a2, c2, I2 = _second_moment(pT2)
    D = c1 - c2
    r2 = D @ D
    alpha = -2.0 - 2.0 * s
    k = r2 ** (alpha / 2)
    gk = alpha * r2 ** (alpha / 2 - 1) * D
    Hk = alpha * r2 ** (alpha / 2 - 1) * (np.eye(2) + (alpha - 2) * np.outer(D, D) / r2)
    # per local basis function a: δ_a, gradient on T, gradient on T'
    delta = np.array([1, 1, 1, -1, -1, -1]) / 3.0
    g1 = np.vstack([_gradients(pT), np.zeros((3, 2))])
    g2 = np.vstack([np.zeros((3, 2)), _gradients(pT2)])
    C0 = a1 * a2 * k + 0.5 * a2 * np.trace(Hk @ I1) + 0.5 * a1 * np.trace(Hk @ I2)
    lin = a2 * g1 @ (I1 @ gk) + a1 * g2 @ (I2 @ gk)                # (6,)
    return (C0 * np.outer(delta, delta)
            + np.outer(delta, lin) + np.outer(lin, delta)
            + k * (a2 * g1 @ I1 @ g1.T + a1 * g2 @ I2 @ g2.T))


def _far_level(pT, pT2, thresholds):
    """Index of the far-field class of a pair (0 = farthest): the first L
    with |c_T − c_T'| >= thresholds[L] · max(diam T, diam T').

    Structured meshes have many pairs with a ratio exactly equal to a
    threshold; the test is written as |D|² >= thr² hm², the form the kernel
    uses, so that such ties fall on the same side of the threshold.
    """
    def diam(P):
        return max(np.linalg.norm(P[i] - P[j]) for i, j in ((0, 1), (1, 2), (2, 0)))
    D = pT.mean(0) - pT2.mean(0)
    r2 = D[0] * D[0] + D[1] * D[1]
    hm = max(diam(pT), diam(pT2))
    for L, thr in enumerate(thresholds):
        if r2 >= thr * thr * hm * hm:
            return L
    return len(thresholds)


def far_matrix_reference(p, t, s, orders, thresholds):
    """Σ over separated pairs T < T' of their 6 × 6 matrices (without c_{2,s});
    order 0 is the Taylor-corrected centroid rule."""
    p, t = np.asarray(p, dtype=float), np.asarray(t)
    A = np.zeros((len(p), len(p)))
    for T, T2 in classify_pairs(t)[2]:
        pT, pT2 = p[t[T]], p[t[T2]]
        order = orders[_far_level(pT, pT2, thresholds)]
        if order == 0:
            loc = taylor_pair_reference(pT, pT2, s)
        else:
            loc = far_pair_reference(pT, pT2, order, s)
        idx = np.concatenate([t[T], t[T2]])
        A[np.ix_(idx, idx)] += loc
    return A


# --------------------------------------------------------------------------
# exterior kernel κ


def boundary_edges_reference(p, t):
    """Boundary edges (m, 4) = (x0, y0, x1, y1), Ω to the left, and the
    boundary nodes."""
    p, t = np.asarray(p, dtype=float), np.asarray(t)
    count, third = {}, {}
    for tri in t:
        for i in range(3):
            a, b, c = int(tri[i]), int(tri[(i + 1) % 3]), int(tri[(i + 2) % 3])
            key = (min(a, b), max(a, b))
            count[key] = count.get(key, 0) + 1
            third[key] = c
    rows, bnodes = [], set()
    for (a, b), cnt in count.items():
        if cnt != 1:
            continue
        c = third[(a, b)]
        e, f = p[b] - p[a], p[c] - p[a]
        if e[0] * f[1] - e[1] * f[0] < 0:
            a, b = b, a
        rows.append(np.concatenate([p[a], p[b]]))
        bnodes.update((a, b))
    return np.array(rows), np.array(sorted(bnodes), dtype=np.int64)


def _line_integral(lo, hi, d, s, gx, gw):
    """∫_lo^hi (d² + t²)^(−1−s) dt for arrays 0 ≤ lo ≤ hi, d ≠ 0: composite
    Gauss on [lo, max(lo,|d|)] and on [m 4^k, m 4^(k+1)], m = max(lo, |d|)."""
    ad = np.abs(d)
    total = np.zeros_like(lo)

    def gauss(a, b, mask):
        a, b = a[mask], b[mask]
        tq = a[:, None] + (b - a)[:, None] * gx[None, :]
        f = (ad[mask][:, None] ** 2 + tq ** 2) ** (-1.0 - s)
        total[mask] += (b - a) * (f @ gw)

    start = np.maximum(lo, ad)
    first = lo < np.minimum(hi, ad)
    if first.any():
        gauss(lo, np.minimum(hi, ad), first)
    k = 0
    while True:
        a = start * 4.0 ** k
        mask = a < hi
        if not mask.any():
            break
        gauss(a, np.minimum(hi, 4.0 * a), mask)
        k += 1
    return total


def kappa_reference(x, edges, s, n=20):
    """κ(x) = (1/2s) Σ_e ∫_e (y−x)·n_e |y−x|^(−2−2s) ds for points x (N, 2)
    strictly inside the polygon with edges (m, 4) (Ω on the left).

    On each edge, with t the arc length from the foot of the perpendicular
    and d = (y − x)·n, the integrand is d (d² + t²)^(−1−s); it is integrated
    by n-point Gauss rules on pieces graded geometrically (ratio 4) from
    t = 0 at the scale |d|, so the accuracy is uniform in the distance.
    """
    x = np.atleast_2d(np.asarray(x, dtype=float))
    gx, gw = _gauss01(n)
    out = np.zeros(len(x))
    for e in np.asarray(edges, dtype=float):
        a, b = e[:2], e[2:]
        L = np.linalg.norm(b - a)
        tan = (b - a) / L
        nrm = np.array([tan[1], -tan[0]])      # outward for Ω on the left
        d = (a - x) @ nrm
        t1 = (a - x) @ tan
        t2 = (b - x) @ tan
        ok = d != 0.0                      # on the edge's line: integrand 0
        d, t1, t2 = d[ok], t1[ok], t2[ok]
        # split [t1, t2] at t = 0 into pieces [lo, hi] of |t|
        cross = (t1 < 0.0) & (t2 > 0.0)
        lo = np.where(cross, 0.0, np.minimum(np.abs(t1), np.abs(t2)))
        hi = np.where(cross, -t1, np.maximum(np.abs(t1), np.abs(t2)))
        val = _line_integral(lo, hi, d, s, gx, gw)
        if cross.any():
            z = np.zeros(cross.sum())
            val[cross] += _line_integral(z, t2[cross], d[cross], s, gx, gw)
        out[ok] += d * val
    return out / (2.0 * s)


def _graded(n, layers, sigma, toward):
    """Composite Gauss rule on [0, 1] graded geometrically toward 0, 1 or
    both ('both')."""
    g, w = _gauss01(n)
    br = np.concatenate([[0.0], sigma ** np.arange(layers, -1, -1.0)])
    pts = np.concatenate([a + (b - a) * g for a, b in zip(br[:-1], br[1:])])
    wts = np.concatenate([(b - a) * w for a, b in zip(br[:-1], br[1:])])
    if toward == 0:
        return pts, wts
    if toward == 1:
        return 1.0 - pts[::-1], wts[::-1]
    half = 0.5 * pts
    return np.concatenate([half, 1.0 - half[::-1]]), np.concatenate([0.5 * wts, 0.5 * wts[::-1]])


def _collapsed(rho, wrho, th, wth):
    """Barycentric points (apex, B, C) and weights (sum 1/2) of the collapsed
    map x = A + ρ((1−θ)B + θC − A)."""
    R, TH = np.meshgrid(rho, th, indexing="ij")
    W = np.outer(wrho, wth) * R
    lam = np.column_stack([(1 - R).ravel(), (R * (1 - TH)).ravel(), (R * TH).ravel()])
    return lam, W.ravel()


def kappa_mass_reference(p, t, s, *, n=6, layers=12, theta_layers=4, sigma=0.25,
                         n_interior=10, n_edge=12):
    """∫_T φ_a φ_b κ (Nt, 3, 3) for every element with a free node (zero for
    elements with all nodes on ∂Ω), κ by :func:`kappa_reference`.

    Elements without boundary nodes: each of the 4 children of T by a
    collapsed n_interior² Gauss rule.  One boundary node B: collapsed map
    with apex B, graded toward B.  Two boundary nodes: apex at the free node,
    graded toward the opposite side and toward both of its ends.
    """
    p, t = np.asarray(p, dtype=float), np.asarray(t)
    edges, bnodes = boundary_edges_reference(p, t)
    onb = np.isin(t, bnodes)
    out = np.zeros((len(t), 3, 3))
    # interior: 4 children (barycentric corner sets) × collapsed Gauss rule
    g, w = _gauss01(n_interior)
    lam_c, w_c = _collapsed(g, w, g, w)
    mids = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1],
                     [0, .5, .5], [.5, 0, .5], [.5, .5, 0]])
    children = [(0, 5, 4), (5, 1, 3), (4, 3, 2), (3, 4, 5)]
    lam_int = np.vstack([lam_c @ mids[list(ch)] for ch in children])
    w_int = np.concatenate([w_c / 4.0] * 4)
    r0, wr0 = _graded(n, layers, sigma, 0)
    r1, wr1 = _graded(n, layers, sigma, 1)
    tu, wtu = _gauss01(2 * n)
    tb, wtb = _graded(n, theta_layers, sigma, "both")
    for T in range(len(t)):
        nb = int(onb[T].sum())
        if nb == 3:
            continue
        if nb == 0:
            lam, wq = lam_int, w_int
        else:
            if nb == 1:
                apex = int(np.flatnonzero(onb[T])[0])
                col, wq = _collapsed(r0, wr0, tu, wtu)
            else:
                apex = int(np.flatnonzero(~onb[T])[0])
                col, wq = _collapsed(r1, wr1, tb, wtb)
            lam = np.empty_like(col)
            lam[:, [(apex + j) % 3 for j in range(3)]] = col
        P = p[t[T]]
        kap = kappa_reference(lam @ P, edges, s, n=n_edge)
        out[T] = np.einsum("q,qa,qb->ab", wq * kap * _area2(P), lam, lam)
    return out


# --------------------------------------------------------------------------
# full matrix


def stiffness_matrix_reference(mesh, s, quadrature=None, *, parts=False, **kappa_opts):
    """a(φ_i, φ_j) by Python loops over all element pairs (see module doc).

    Boundary rows/columns are NaN as in :func:`fracfem.assembly.stiffness_matrix`.
    With parts=True returns the dict {'singular', 'far', 'kappa'} of the three
    contributions (each already multiplied by c_{2,s}, no NaN).
    """
    s = check_s(s)
    quad = quadrature or QuadratureOptions()
    p = np.asarray(mesh.p, dtype=float).T
    t = np.asarray(mesh.t, dtype=np.int64).T
    c = c2s(s)
    res = {"singular": c * singular_matrix_reference(p, t, s, quad),
           "far": c * far_matrix_reference(p, t, s, quad.far_orders, quad.far_thresholds)}
    K = kappa_mass_reference(p, t, s, **kappa_opts)
    Akap = np.zeros((len(p), len(p)))
    for T in range(len(t)):
        Akap[np.ix_(t[T], t[T])] += K[T]
    res["kappa"] = c * Akap
    if parts:
        return res
    A = res["singular"] + res["far"] + res["kappa"]
    _, bnodes = boundary_edges_reference(p, t)
    A[bnodes, :] = np.nan
    A[:, bnodes] = np.nan
    return A


# --------------------------------------------------------------------------
# thin (anisotropic) element pairs
#
# Written independently of fracfem._aniso_kernels: integrals over a triangle
# near a point are done in collapsed coordinates about the point of the
# triangle nearest to it, geometrically graded down to a fraction of the
# distance (no polar coordinates about the singularity, no arc-length rules);
# the outer variables of the relative-coordinate faces by scipy's adaptive
# Gauss–Kronrod rules.


def _nearest_on_segment(x, a, b):
    d = b - a
    t = np.clip((x - a) @ d / (d @ d), 0.0, 1.0)
    return a + t * d


def _nearest_on_triangle(x, V):
    """Point of the triangle V (3, 2) nearest to x (x outside V)."""
    cands = [_nearest_on_segment(x, V[i], V[(i + 1) % 3]) for i in range(3)]
    return min(cands, key=lambda y: np.sum((y - x) ** 2))


def _graded_layers(n, small, sigma):
    """Composite Gauss rule on [0, 1] graded geometrically toward 0 down to
    panels of width below ``small``."""
    g, w = _gauss01(n)
    layers = max(int(np.ceil(np.log(1.0 / max(small, 1e-300)) / np.log(1 / sigma))), 1)
    br = np.concatenate([[0.0], sigma ** np.arange(layers, -1, -1.0)])
    return (np.concatenate([a + (b - a) * g for a, b in zip(br[:-1], br[1:])]),
            np.concatenate([(b - a) * w for a, b in zip(br[:-1], br[1:])]))


def _graded_triangle_rule(V, y0, dist, n=10, sigma=0.25, extra=4):
    """Points (m, 2) and weights covering the triangle V in collapsed
    coordinates about its point y0: per edge BC two sub-triangles (y0, F, B),
    (y0, F, C) with F the point of BC nearest to y0; radial variable graded
    toward y0 down to sigma^extra · dist, the variable along BC graded toward
    F down to sigma^extra · (distance of y0 from BC) / |FB|."""
    pts, wts = [], []
    for i in range(3):
        B0, C0 = V[i], V[(i + 1) % 3]
        F = _nearest_on_segment(y0, B0, C0)
        hgt = np.linalg.norm(F - y0)
        for B in (B0, C0):
            lb = np.linalg.norm(B - F)
            area2 = abs((F[0] - y0[0]) * (B[1] - y0[1]) - (B[0] - y0[0]) * (F[1] - y0[1]))
            if lb == 0.0 or area2 <= 1e-15 * lb * lb:
                continue
            size = max(hgt, np.linalg.norm(B - y0))
            rho, wr = _graded_layers(n, sigma ** extra * dist / size, sigma)
            th, wt = _graded_layers(n, sigma ** extra * max(hgt, dist) / lb, sigma)
            R, TH = np.meshgrid(rho, th, indexing="ij")
            Y = y0 + R.ravel()[:, None] * ((1 - TH.ravel())[:, None] * F
                                           + TH.ravel()[:, None] * B - y0)
            pts.append(Y)
            wts.append((np.outer(wr, wt) * R).ravel() * area2)
    return np.vstack(pts), np.concatenate(wts)


def triangle_moments_reference(V, s, n=8):
    """(K0, K1x, K1y, K2xx, K2xy, K2yy) of ∫_V (1, η, ηηᵀ)|η|^(−2−2s) dη for
    a triangle V (3, 2) not containing 0, by collapsed coordinates graded
    toward the point of V nearest to 0."""
    V = np.asarray(V, dtype=float)
    y0 = _nearest_on_triangle(np.zeros(2), V)
    Y, W = _graded_triangle_rule(V, y0, np.linalg.norm(y0), n=n)
    k = W * np.sum(Y * Y, axis=1) ** (-1.0 - s)
    return np.array([k.sum(), k @ Y[:, 0], k @ Y[:, 1], k @ Y[:, 0] ** 2,
                     k @ (Y[:, 0] * Y[:, 1]), k @ Y[:, 1] ** 2])


def _quad_split(f, cuts, epsrel=1e-9):
    """∫_0^1 f (array-valued) by scipy quad_vec on [0, 1] split at cuts."""
    from scipy.integrate import quad_vec

    br = np.unique(np.clip(np.concatenate([[0.0, 1.0], cuts]), 0.0, 1.0))
    return sum(quad_vec(f, a, b, epsrel=epsrel, epsabs=0.0)[0]
               for a, b in zip(br[:-1], br[1:]) if b > a)


def _nearest_params(p0, v, pts):
    """Parameters t of p0 + t v nearest to each point (for breakpoints)."""
    return np.array([(q - p0) @ v / (v @ v) for q in pts])


def _face_polar(M, w0, ia, sa, ib, sb, G, eta0, s, n=8):
    """∫_τ̂ w wᵀ |Mw|^(−2−2s) da db over a face w = w0 + a sa e_ia + b sb e_ib
    with image η0 + G τ̂, by the change of variables to η and
    triangle_moments_reference (d × d)."""
    d = len(w0)
    Gi = np.linalg.inv(G)
    C = np.zeros((d, 2))
    C[ia], C[ib] = sa * Gi[0], sb * Gi[1]
    c = w0 - C @ eta0
    K = triangle_moments_reference(np.array([eta0, eta0 + G[:, 0], eta0 + G[:, 1]]), s, n=n)
    K1 = K[1:3]
    K2 = np.array([[K[3], K[4]], [K[4], K[5]]])
    return (np.outer(c, c) * K[0] + np.outer(c, C @ K1) + np.outer(C @ K1, c)
            + C @ K2 @ C.T) / abs(np.linalg.det(G))


def thin_face_integral_reference(M, kind, s, epsrel=1e-9, n=8):
    """Z = ∫_faces w wᵀ |Mw|^(−2−2s) dσ of the relative-coordinate rule
    ``kind`` (faces and weights as in fracfem.quadrature) for the pair matrix
    M (2, d), by adaptive quadrature (relative tolerance epsrel) and
    triangle_moments_reference (n points per panel)."""
    M = np.asarray(M, dtype=float)
    kern = lambda eta: np.sum(eta * eta, axis=-1) ** (-1.0 - s)   # noqa: E731
    if kind == "coincident":
        hv = np.array([[1.0, 0], [0, 1], [-1, 1], [-1, 0], [0, -1], [1, -1]])
        Z = np.zeros((2, 2))
        for i in range(6):
            a, e = hv[i], hv[(i + 1) % 6] - hv[i]
            f = lambda u: np.outer(a + u * e, a + u * e) * kern(M @ (a + u * e))  # noqa: E731
            Z += 0.5 * _quad_split(f, _nearest_params(-M @ a, M @ e, [np.zeros(2)]))
        return Z
    if kind == "edge":
        Z = np.zeros((3, 3))
        for w0, eU, eV in (((1.0, 0, 0), (-1.0, 1, 0), (0, 0, 1.0)),
                           ((-1.0, 0, 0), (1.0, 0, 1), (0, 1.0, 0))):
            w0, eU, eV = map(np.array, (w0, eU, eV))

            def inner(U):
                c = w0 + U * eU
                f = lambda V: np.outer(c + V * eV, c + V * eV) * kern(M @ (c + V * eV))  # noqa: E731
                return _quad_split(f, _nearest_params(-M @ c, M @ eV, [np.zeros(2)]), epsrel)
            Z += _quad_split(inner, _nearest_params(-M @ w0, -M @ eU,
                                                    [np.zeros(2), M @ eV]), epsrel)
        G = M[:, :2]
        Z += _face_polar(M, np.array([0, 0, 1.0]), 0, 1.0, 1, 1.0, G, M[:, 2], s, n=n)
        G = np.column_stack([-M[:, 0], M[:, 2]])
        Z += _face_polar(M, np.array([0, 1.0, 0]), 0, -1.0, 2, 1.0, G, M[:, 1], s, n=n)
        return Z
    Z = np.zeros((4, 4))
    for k0, k1, f0, f1 in ((0, 1, 2, 3), (2, 3, 0, 1)):
        G = M[:, [f0, f1]]

        def half(t):
            w0 = np.zeros(4)
            w0[k0], w0[k1] = 1 - t, t
            return _face_polar(M, w0, f0, 1.0, f1, 1.0, G, (1 - t) * M[:, k0] + t * M[:, k1],
                               s, n=n)
        Z += _quad_split(half, _nearest_params(-M[:, k0], M[:, k0] - M[:, k1],
                                               [np.zeros(2), G[:, 0], G[:, 1]]), epsrel)
    return Z


def thin_pairs_reference(p, nodes, kind, s, **opts):
    """Local matrices of touching pairs (like singular_pairs_reference, without
    c_{2,s}) with the faces integrated by thin_face_integral_reference."""
    p = np.asarray(p, dtype=float)
    B = radial_factor(kind, s)
    lt, lt2 = _LAYOUT[kind]
    out = []
    for row in np.asarray(nodes):
        Pts = p[row]
        M, A = _relative_coordinates(Pts, kind)
        Z = thin_face_integral_reference(M, kind, s, **opts)
        jac = _area2(Pts[list(lt)]) * _area2(Pts[list(lt2)])
        out.append(B * jac * (A.T @ Z @ A))
    return np.array(out)


def separated_pair_reference(pT, pT2, s, n=6, extra=3):
    """6 × 6 matrix ∫_T∫_T'(φ_a(x)−φ_a(y))(φ_b(x)−φ_b(y))|x−y|^(−2−2s) of a
    separated pair (nodes of T, then of T') for T, T' close compared to their
    size: both triangles by collapsed coordinates graded toward their
    mutually nearest points (x-rule toward the point of T nearest to T', then
    for each x the y-rule toward the point of T' nearest to x)."""
    pT, pT2 = np.asarray(pT, dtype=float), np.asarray(pT2, dtype=float)
    # point of T nearest to T': nearest over T's edges to T''s vertices and vice versa
    best = (np.inf, None)
    for i in range(3):
        for j in range(3):
            y = _nearest_on_segment(pT2[j], pT[i], pT[(i + 1) % 3])
            best = min(best, (np.sum((y - pT2[j]) ** 2), tuple(y)), key=lambda z: z[0])
            x = _nearest_on_segment(pT[i], pT2[j], pT2[(j + 1) % 3])
            best = min(best, (np.sum((x - pT[i]) ** 2), tuple(pT[i])), key=lambda z: z[0])
    x0, gap = np.array(best[1]), np.sqrt(best[0])
    X, WX = _graded_triangle_rule(pT, x0, gap, n=n, extra=extra)
    GT, GT2 = _gradients(pT), _gradients(pT2)
    out = np.zeros((6, 6))
    for x, wx in zip(X, WX):
        y0 = _nearest_on_triangle(x, pT2)
        Y, WY = _graded_triangle_rule(pT2, y0, np.linalg.norm(y0 - x), n=n, extra=extra)
        lamx = 1.0 / 3.0 + GT @ (x - pT.mean(0))
        lamy = 1.0 / 3.0 + (Y - pT2.mean(0)) @ GT2.T
        U = np.column_stack([np.broadcast_to(lamx, (len(Y), 3)), -lamy])
        k = wx * WY * np.sum((Y - x) ** 2, axis=1) ** (-1.0 - s)
        out += (U * k[:, None]).T @ U
    return out


def kappa_mass_thin_reference(p, t, T, s, panels=2000, n=6):
    """∫_T φ_a φ_b κ (3, 3) for one (thin) element T by brute force: slices
    parallel to its longest edge, `panels` uniform Gauss panels along it and
    panels graded toward both ends across, κ by kappa_reference (boundary of
    the whole mesh)."""
    p, t = np.asarray(p, dtype=float), np.asarray(t)
    edges, _ = boundary_edges_reference(p, t)
    P = p[t[T]]
    L = [np.linalg.norm(P[(i + 1) % 3] - P[i]) for i in range(3)]
    i = int(np.argmax(L))
    A, B, C = P[i], P[(i + 1) % 3], P[(i + 2) % 3]
    g, w = _gauss01(n)
    br = np.linspace(0, 1, panels + 1)
    u = np.concatenate([a + (b - a) * g for a, b in zip(br[:-1], br[1:])])
    wu = np.concatenate([(b - a) * w for a, b in zip(br[:-1], br[1:])])
    v, wv = _graded(n, 14, 0.25, "both")       # κ ~ dist^(−2s) toward ∂Ω across
    # x = (1−v)(A + u(B−A)) + v C, |dx| = 2|T| (1 − v) du dv
    U, V = np.meshgrid(u, v, indexing="ij")
    X = (1 - V.ravel())[:, None] * (A + U.ravel()[:, None] * (B - A)) + V.ravel()[:, None] * C
    W = np.outer(wu, wv).ravel() * (1 - V.ravel()) * _area2(P)
    kap = kappa_reference(X, edges, s)
    lam = 1.0 / 3.0 + (X - P.mean(0)) @ _gradients(P).T
    return np.einsum("q,qa,qb->ab", W * kap, lam, lam)
