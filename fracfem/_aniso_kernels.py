"""Numba kernels for touching pairs of thin (anisotropic) triangles.

The relative-coordinate rules of :mod:`fracfem.quadrature` integrate the
point singularity z = 0 exactly in the radial variable; what is left are
face integrals Z = ∫_faces w wᵀ |Mw|^(−2−2s) dσ(w).  For thin triangles
|Mw| is small on part of a face (a ridge of relative width ~ 1/aspect) and
fixed Gauss rules fail.  Here the same faces are integrated by rules adapted
to the geometry of each pair:

* a 1D integral along w(u) = c + u e is split at the parameter nearest to
  the complex zeros u* ± iδ of |Mw(u)|² and done by Gauss panels that grow
  geometrically (ratio q) from there, the first as wide as its distance to
  the zeros;
* a 2D face that M maps one-to-one onto a triangle Π ⊂ R² (the triangle
  faces of the edge rule, the slices of the vertex rule) is written in polar
  coordinates about η = Mw = 0: the radial integrals of r^(−1−2s)(1, r, r²)
  are exact and the angular one runs along the edges of Π in arc length,
  graded toward the foot of the perpendicular from 0;
* the remaining outer variable (segment × segment faces of the edge rule,
  the two halves of the vertex rule) gets a composite graded rule with
  breakpoints where the moving point passes closest to the vertices of the
  fixed segment or triangle.

Every rule is exact in the limit of small panels; accuracy is set by the
Gauss points per panel (``gx``, ``gw`` on [0, 1]) and the ratio ``q``.
Output conventions are those of :func:`fracfem._kernels.singular_pairs`.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

_MAXBP = 8          # breakpoints of an outer rule (3 vertices + 2 ends)


@njit(cache=True)
def _ray_moments(r1, r2, s, gx, gw):  # pragma: no cover
    """(∫ r^(−1−2s), ∫ r^(−2s), ∫ r^(1−2s)) dr over [r1, r2], 0 < r1 ≤ r2:
    closed forms when r2 > 2 r1, else Gauss–Legendre (no cancellation)."""
    if r2 <= r1:
        return 0.0, 0.0, 0.0
    if r2 > 2.0 * r1:
        l1 = np.log(r1)
        l2 = np.log(r2)
        p1 = np.exp(-2.0 * s * l1)
        p2 = np.exp(-2.0 * s * l2)
        e = 1.0 - 2.0 * s
        x = e * (l2 - l1)
        if abs(x) < 1e-8:
            f1 = (l2 - l1) * (1.0 + 0.5 * x)
        else:
            f1 = np.expm1(x) / e
        return (p1 - p2) / (2.0 * s), r1 * p1 * f1, (r2 * r2 * p2 - r1 * r1 * p1) / (2.0 - 2.0 * s)
    h = r2 - r1
    i0 = 0.0
    i1 = 0.0
    i2 = 0.0
    rho = h / r1
    if rho < 0.02:       # 2-point Gauss: relative error ~ (rho/4)^4
        for g in range(2):
            r = r1 + h * (0.5 + (g - 0.5) * 0.5773502691896258)
            k = 0.5 * h * np.exp((-1.0 - 2.0 * s) * np.log(r))
            i0 += k
            i1 += k * r
            i2 += k * r * r
        return i0, i1, i2
    if rho < 0.3:        # 3-point Gauss: relative error ~ (rho/4)^6
        for g in range(3):
            x = 0.7745966692414834 * (g - 1)
            r = r1 + h * 0.5 * (1.0 + x)
            k = (0.4444444444444444 if g == 1 else 0.2777777777777778) * h \
                * np.exp((-1.0 - 2.0 * s) * np.log(r))
            i0 += k
            i1 += k * r
            i2 += k * r * r
        return i0, i1, i2
    for g in range(gx.shape[0]):
        r = r1 + h * gx[g]
        k = gw[g] * h * np.exp((-1.0 - 2.0 * s) * np.log(r))
        i0 += k
        i1 += k * r
        i2 += k * r * r
    return i0, i1, i2


@njit(cache=True)
def _tri_moments(v, s, gx, gw, q, K):  # pragma: no cover
    """K = (K0, K1x, K1y, K2xx, K2xy, K2yy) of ∫_Π (1, η, ηηᵀ)|η|^(−2−2s) dη
    for the triangle Π with vertices v (3, 2), 0 outside Π.

    Polar coordinates about 0.  Seen from 0, Π spans less than π; the ray
    through the middle vertex splits it into two sectors in which every ray
    enters through one edge and leaves through another.  The angle runs
    along the entry edge in arc length τ (dθ = |d| dτ / r1², d the distance
    of its line), graded toward the foot of the perpendicular from 0; the
    radial integral from entry r1 to exit r2 is exact or Gauss
    (:func:`_ray_moments`).  Coordinates are scaled by the largest |v|.
    """
    for i in range(6):
        K[i] = 0.0
    L = 0.0
    for i in range(3):
        L = max(L, np.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2))
    cx = (v[0, 0] + v[1, 0] + v[2, 0]) / (3.0 * L)
    cy = (v[0, 1] + v[1, 1] + v[2, 1]) / (3.0 * L)
    # vertices sorted by angle relative to the centroid direction (three
    # compares; no arrays: this runs once per outer point of every thin pair)
    a0 = np.arctan2(cx * v[0, 1] - cy * v[0, 0], cx * v[0, 0] + cy * v[0, 1])
    a1 = np.arctan2(cx * v[1, 1] - cy * v[1, 0], cx * v[1, 0] + cy * v[1, 1])
    a2 = np.arctan2(cx * v[2, 1] - cy * v[2, 0], cx * v[2, 0] + cy * v[2, 1])
    i0, i1, i2 = 0, 1, 2
    if a1 < a0:
        a0, a1, i0, i1 = a1, a0, i1, i0
    if a2 < a1:
        a1, a2, i1, i2 = a2, a1, i2, i1
        if a1 < a0:
            a0, a1, i0, i1 = a1, a0, i1, i0
    lo = (v[i0, 0] / L, v[i0, 1] / L)
    md = (v[i1, 0] / L, v[i1, 1] / L)
    hi = (v[i2, 0] / L, v[i2, 1] / L)
    # the ray through md meets the line (lo, hi) at X
    fx, fy = hi[0] - lo[0], hi[1] - lo[1]
    den = md[0] * fy - md[1] * fx
    num = lo[0] * fy - lo[1] * fx
    lam = num / den if den != 0.0 else np.inf       # X = lam · md
    mid_in_front = lam > 1.0
    Xx, Xy = lam * md[0], lam * md[1]
    ng = gx.shape[0]
    for sector in range(2):
        if sector == 0:
            a0x, a0y = lo[0], lo[1]
            if mid_in_front:     # enter through (lo, md), leave through (lo, hi)
                a1x, a1y = md[0], md[1]
                ox, oy, ux, uy = lo[0], lo[1], fx, fy
            else:                # enter through (lo, X), leave through (lo, md)
                a1x, a1y = Xx, Xy
                ox, oy, ux, uy = lo[0], lo[1], md[0] - lo[0], md[1] - lo[1]
        else:
            a1x, a1y = hi[0], hi[1]
            if mid_in_front:
                a0x, a0y = md[0], md[1]
                ox, oy, ux, uy = lo[0], lo[1], fx, fy
            else:
                a0x, a0y = Xx, Xy
                ox, oy, ux, uy = md[0], md[1], hi[0] - md[0], hi[1] - md[1]
        ln = np.sqrt((a1x - a0x) ** 2 + (a1y - a0y) ** 2)
        if not ln > 0.0:
            continue
        tx, ty = (a1x - a0x) / ln, (a1y - a0y) / ln
        nx, ny = ty, -tx
        d = a0x * nx + a0y * ny
        if d == 0.0:
            continue
        ad = abs(d)
        # exit line through o with normal m
        mx, my = uy, -ux
        om = ox * mx + oy * my
        ta = a0x * tx + a0y * ty
        tb = ta + ln
        tn = min(max(0.0, ta), tb)
        eps = np.sqrt(d * d + tn * tn)
        for side in range(2):
            if side == 0:
                a, end, sgn = tn, tb, 1.0
            else:
                a, end, sgn = tn, ta, -1.0
            w = eps
            while sgn * (end - a) > 0.0:
                rem = sgn * (end - a)
                b = end if rem <= w * (1.0 + 0.5 * q) else a + sgn * w
                h = b - a
                for g in range(ng):
                    tau = a + h * gx[g]
                    ex = d * nx + tau * tx
                    ey = d * ny + tau * ty
                    r1 = np.sqrt(ex * ex + ey * ey)
                    ex /= r1
                    ey /= r1
                    dm = ex * mx + ey * my
                    r2 = om / dm if dm != 0.0 else r1
                    i0, i1, i2 = _ray_moments(r1, max(r2, r1), s, gx, gw)
                    wt = abs(h) * gw[g] * ad / (r1 * r1)
                    K[0] += wt * i0
                    K[1] += wt * i1 * ex
                    K[2] += wt * i1 * ey
                    K[3] += wt * i2 * ex * ex
                    K[4] += wt * i2 * ex * ey
                    K[5] += wt * i2 * ey * ey
                a = b
                w *= q
    K[0] *= L ** (-2.0 * s)
    sc1 = L ** (1.0 - 2.0 * s)
    K[1] *= sc1
    K[2] *= sc1
    sc2 = L ** (2.0 - 2.0 * s)
    K[3] *= sc2
    K[4] *= sc2
    K[5] *= sc2


@njit(cache=True)
def _seg_moments(cx, cy, ex, ey, s, gx, gw, q, m):  # pragma: no cover
    """m_k = ∫_0^1 V^k |c + V e|^(−2−2s) dV, k = 0, 1, 2, graded toward the
    parameter nearest to the complex zeros of |c + V e|²."""
    ee = ex * ex + ey * ey
    vs = -(cx * ex + cy * ey) / ee
    vn = min(max(vs, 0.0), 1.0)
    px, py = cx + vn * ex, cy + vn * ey
    eps = np.sqrt((px * px + py * py) / ee)
    m[0] = 0.0
    m[1] = 0.0
    m[2] = 0.0
    expo = -1.0 - s
    ng = gx.shape[0]
    for side in range(2):
        if side == 0:
            a, end, sgn = vn, 1.0, 1.0
        else:
            a, end, sgn = vn, 0.0, -1.0
        w = eps
        while sgn * (end - a) > 0.0:
            rem = sgn * (end - a)
            b = end if rem <= w * (1.0 + 0.5 * q) else a + sgn * w
            h = b - a
            for g in range(ng):
                V = a + h * gx[g]
                X = cx + V * ex
                Y = cy + V * ey
                k = abs(h) * gw[g] * (X * X + Y * Y) ** expo
                m[0] += k
                m[1] += k * V
                m[2] += k * V * V
            a = b
            w *= q


@njit(cache=True)
def _point_segment(px, py, ax, ay, bx, by):  # pragma: no cover
    """Distance from p to the segment [a, b]."""
    dx, dy = bx - ax, by - ay
    dd = dx * dx + dy * dy
    t = 0.0 if dd == 0.0 else min(max(((px - ax) * dx + (py - ay) * dy) / dd, 0.0), 1.0)
    return np.sqrt((px - ax - t * dx) ** 2 + (py - ay - t * dy) ** 2)


@njit(cache=True)
def _dist_to_set(px, py, cv, nc):  # pragma: no cover
    """Distance from p to the segment (nc = 2) or triangle (nc = 3) with
    vertices cv, p outside it."""
    if nc == 2:
        return _point_segment(px, py, cv[0, 0], cv[0, 1], cv[1, 0], cv[1, 1])
    d = np.inf
    for i in range(3):
        j = (i + 1) % 3
        d = min(d, _point_segment(px, py, cv[i, 0], cv[i, 1], cv[j, 0], cv[j, 1]))
    return d


@njit(cache=True)
def _outer_rule(p0x, p0y, vx, vy, cv, nc, gx, gw, q):  # pragma: no cover
    """Composite graded Gauss rule on [0, 1] for a point p(t) = p0 + t v that
    moves past a fixed segment or triangle (vertices cv (nc, 2)).

    Breakpoints: t = 0, 1 and the parameters where p(t) passes closest to
    each vertex; at each, panels start at (distance from p to the set)/|v|
    and grow by q toward the neighbouring breakpoints (split halfway).
    """
    vv = vx * vx + vy * vy
    vn = np.sqrt(vv)
    bp = np.empty(_MAXBP)
    nb = 0
    bp[nb] = 0.0
    nb += 1
    bp[nb] = 1.0
    nb += 1
    for j in range(nc):
        t = ((cv[j, 0] - p0x) * vx + (cv[j, 1] - p0y) * vy) / vv
        if 0.0 < t < 1.0:
            bp[nb] = t
            nb += 1
    keep = _unique_sorted(bp, nb)
    sc = np.empty(keep.shape[0])
    for i in range(keep.shape[0]):
        t = keep[i]
        sc[i] = _dist_to_set(p0x + t * vx, p0y + t * vy, cv, nc) / vn
    return _composite(keep, sc, gx, gw, q)


@njit(cache=True)
def _add_polar_face(Z, d, wt, w0, ia, sa, ib, sb, G, eta0, s, gx, gw, q, K, tri):  # pragma: no cover
    """Z += wt ∫_τ̂ w wᵀ |Mw|^(−2−2s) for a face w = w0 + a·sa·e_ia + b·sb·e_ib
    whose image Mw = η0 + G (a, b) is a triangle (G (2, 2) invertible)."""
    det = G[0, 0] * G[1, 1] - G[0, 1] * G[1, 0]
    i00, i01 = G[1, 1] / det, -G[0, 1] / det
    i10, i11 = -G[1, 0] / det, G[0, 0] / det
    tri[0, 0], tri[0, 1] = eta0[0], eta0[1]
    tri[1, 0], tri[1, 1] = eta0[0] + G[0, 0], eta0[1] + G[1, 0]
    tri[2, 0], tri[2, 1] = eta0[0] + G[0, 1], eta0[1] + G[1, 1]
    _tri_moments(tri, s, gx, gw, q, K)
    # w = c + C η with C rows ia, ib = sa (G⁻¹)_0, sb (G⁻¹)_1, c = w0 − C η0
    C = np.zeros((d, 2))
    C[ia, 0] = sa * i00
    C[ia, 1] = sa * i01
    C[ib, 0] = sb * i10
    C[ib, 1] = sb * i11
    c = np.empty(d)
    for i in range(d):
        c[i] = w0[i] - C[i, 0] * eta0[0] - C[i, 1] * eta0[1]
    f = wt / abs(det)
    for i in range(d):
        ck1_i = C[i, 0] * K[1] + C[i, 1] * K[2]
        for j in range(d):
            ck1_j = C[j, 0] * K[1] + C[j, 1] * K[2]
            ck2 = (C[i, 0] * (K[3] * C[j, 0] + K[4] * C[j, 1])
                   + C[i, 1] * (K[4] * C[j, 0] + K[5] * C[j, 1]))
            Z[i, j] += f * (c[i] * c[j] * K[0] + c[i] * ck1_j + ck1_i * c[j] + ck2)


@njit(cache=True)
def _add_segment_face(Z, M, w0, eU, eV, s, gx, gw, q, m, cv):  # pragma: no cover
    """Z += ∫_0^1∫_0^1 w wᵀ |Mw|^(−2−2s) dV dU for w = w0 + U eU + V eV
    (segment × segment faces of the edge rule, d = 3)."""
    d = 3
    MU0 = M[0, 0] * eU[0] + M[0, 1] * eU[1] + M[0, 2] * eU[2]
    MU1 = M[1, 0] * eU[0] + M[1, 1] * eU[1] + M[1, 2] * eU[2]
    MV0 = M[0, 0] * eV[0] + M[0, 1] * eV[1] + M[0, 2] * eV[2]
    MV1 = M[1, 0] * eV[0] + M[1, 1] * eV[1] + M[1, 2] * eV[2]
    Mw00 = M[0, 0] * w0[0] + M[0, 1] * w0[1] + M[0, 2] * w0[2]
    Mw01 = M[1, 0] * w0[0] + M[1, 1] * w0[1] + M[1, 2] * w0[2]
    # p(U) = −M(w0 + U eU) moves past the fixed segment [0, M eV]
    cv[0, 0], cv[0, 1] = 0.0, 0.0
    cv[1, 0], cv[1, 1] = MV0, MV1
    T, W = _outer_rule(-Mw00, -Mw01, -MU0, -MU1, cv, 2, gx, gw, q)
    c = np.empty(d)
    for k in range(T.shape[0]):
        U = T[k]
        for i in range(d):
            c[i] = w0[i] + U * eU[i]
        _seg_moments(Mw00 + U * MU0, Mw01 + U * MU1, MV0, MV1, s, gx, gw, q, m)
        for i in range(d):
            for j in range(d):
                Z[i, j] += W[k] * (c[i] * c[j] * m[0] + (c[i] * eV[j] + eV[i] * c[j]) * m[1]
                                   + eV[i] * eV[j] * m[2])


@njit(cache=True)
def _z_coincident(M, s, gx, gw, q, Z):  # pragma: no cover
    """Face integral of the identical-triangle rule (hexagon z = x̂ − ŷ)."""
    hv = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 1.0],
                   [-1.0, 0.0], [0.0, -1.0], [1.0, -1.0]])
    m = np.empty(3)
    for i in range(2):
        for j in range(2):
            Z[i, j] = 0.0
    for e in range(6):
        a0, a1 = hv[e, 0], hv[e, 1]
        b0, b1 = hv[(e + 1) % 6, 0], hv[(e + 1) % 6, 1]
        e0, e1 = b0 - a0, b1 - a1
        cx = M[0, 0] * a0 + M[0, 1] * a1
        cy = M[1, 0] * a0 + M[1, 1] * a1
        ex = M[0, 0] * e0 + M[0, 1] * e1
        ey = M[1, 0] * e0 + M[1, 1] * e1
        _seg_moments(cx, cy, ex, ey, s, gx, gw, q, m)
        # w = a + u e; |a × b| = 1 for consecutive hexagon vertices; ½ of the rule
        Z[0, 0] += 0.5 * (a0 * a0 * m[0] + 2.0 * a0 * e0 * m[1] + e0 * e0 * m[2])
        Z[0, 1] += 0.5 * (a0 * a1 * m[0] + (a0 * e1 + e0 * a1) * m[1] + e0 * e1 * m[2])
        Z[1, 1] += 0.5 * (a1 * a1 * m[0] + 2.0 * a1 * e1 * m[1] + e1 * e1 * m[2])
    Z[1, 0] = Z[0, 1]


@njit(cache=True)
def _z_edge(M, s, gx, gw, q, Z):  # pragma: no cover
    """Face integral of the common-edge rule, z = (x̂₁ − ŷ₁, x̂₂, ŷ₂)."""
    d = 3
    for i in range(d):
        for j in range(d):
            Z[i, j] = 0.0
    K = np.empty(6)
    m = np.empty(3)
    tri = np.empty((3, 2))
    cv = np.empty((3, 2))
    G = np.empty((2, 2))
    eta0 = np.empty(2)
    # ρ = z₁ + z₂: w = (1 − U, U, V)
    _add_segment_face(Z, M, np.array([1.0, 0.0, 0.0]), np.array([-1.0, 1.0, 0.0]),
                      np.array([0.0, 0.0, 1.0]), s, gx, gw, q, m, cv)
    # ρ = z₃ − z₁: w = (U − 1, V, U)
    _add_segment_face(Z, M, np.array([-1.0, 0.0, 0.0]), np.array([1.0, 0.0, 1.0]),
                      np.array([0.0, 1.0, 0.0]), s, gx, gw, q, m, cv)
    # ρ = z₃: w = (a, b, 1)
    G[0, 0], G[1, 0], G[0, 1], G[1, 1] = M[0, 0], M[1, 0], M[0, 1], M[1, 1]
    eta0[0], eta0[1] = M[0, 2], M[1, 2]
    _add_polar_face(Z, d, 1.0, np.array([0.0, 0.0, 1.0]), 0, 1.0, 1, 1.0, G, eta0,
                    s, gx, gw, q, K, tri)
    # ρ = z₂: w = (−a, 1, b)
    G[0, 0], G[1, 0], G[0, 1], G[1, 1] = -M[0, 0], -M[1, 0], M[0, 2], M[1, 2]
    eta0[0], eta0[1] = M[0, 1], M[1, 1]
    _add_polar_face(Z, d, 1.0, np.array([0.0, 1.0, 0.0]), 0, -1.0, 2, 1.0, G, eta0,
                    s, gx, gw, q, K, tri)


@njit(cache=True)
def _z_vertex(M, s, gx, gw, q, Z):  # pragma: no cover
    """Face integral of the common-vertex rule, z = (x̂, ŷ): two halves
    x̂₁ + x̂₂ = 1 (x on the edge QR, y in T') and ŷ₁ + ŷ₂ = 1."""
    d = 4
    for i in range(d):
        for j in range(d):
            Z[i, j] = 0.0
    K = np.empty(6)
    tri = np.empty((3, 2))
    cv = np.empty((3, 2))
    G = np.empty((2, 2))
    eta0 = np.empty(2)
    w0 = np.zeros(4)
    for half in range(2):
        # moving pair of columns (k0, k1), fixed pair (f0, f1)
        k0, k1, f0, f1 = (0, 1, 2, 3) if half == 0 else (2, 3, 0, 1)
        G[0, 0], G[1, 0], G[0, 1], G[1, 1] = M[0, f0], M[1, f0], M[0, f1], M[1, f1]
        # p(t) = −η0(t) = −(M_k0 + t (M_k1 − M_k0)) against the triangle G τ̂
        cv[0, 0], cv[0, 1] = 0.0, 0.0
        cv[1, 0], cv[1, 1] = M[0, f0], M[1, f0]
        cv[2, 0], cv[2, 1] = M[0, f1], M[1, f1]
        T, W = _outer_rule(-M[0, k0], -M[1, k0], M[0, k0] - M[0, k1], M[1, k0] - M[1, k1],
                           cv, 3, gx, gw, q)
        for k in range(T.shape[0]):
            t = T[k]
            for i in range(4):
                w0[i] = 0.0
            w0[k0] = 1.0 - t
            w0[k1] = t
            eta0[0] = (1.0 - t) * M[0, k0] + t * M[0, k1]
            eta0[1] = (1.0 - t) * M[1, k0] + t * M[1, k1]
            _add_polar_face(Z, d, W[k], w0, f0, 1.0, f1, 1.0, G, eta0, s, gx, gw, q, K, tri)


@njit(cache=True, parallel=True)
def thin_singular_pairs(p, nodes, tp, signs, kind, amat, s, gx, gw, q, out):  # pragma: no cover
    """Local matrices of touching pairs like :func:`fracfem._kernels.singular_pairs`
    (same nodes, tp, signs, amat, out; without the radial factor and c_{2,s}),
    with the face integrals of :func:`_z_coincident` (kind 0), :func:`_z_edge`
    (1) or :func:`_z_vertex` (2)."""
    n = nodes.shape[0]
    d = amat.shape[0]
    for k in prange(n):
        P = nodes[k, 0]
        M = np.empty((2, d))
        for j in range(d):
            qn = nodes[k, j + 1]
            M[0, j] = signs[j] * (p[qn, 0] - p[P, 0])
            M[1, j] = signs[j] * (p[qn, 1] - p[P, 1])
        a0, a1, a2 = nodes[k, 0], nodes[k, 1], nodes[k, 2]
        det1 = abs((p[a1, 0] - p[a0, 0]) * (p[a2, 1] - p[a0, 1])
                   - (p[a2, 0] - p[a0, 0]) * (p[a1, 1] - p[a0, 1]))
        b0, b1, b2 = nodes[k, tp[0]], nodes[k, tp[1]], nodes[k, tp[2]]
        det2 = abs((p[b1, 0] - p[b0, 0]) * (p[b2, 1] - p[b0, 1])
                   - (p[b2, 0] - p[b0, 0]) * (p[b1, 1] - p[b0, 1]))
        Z = np.empty((d, d))
        if kind == 0:
            _z_coincident(M, s, gx, gw, q, Z)
        elif kind == 1:
            _z_edge(M, s, gx, gw, q, Z)
        else:
            _z_vertex(M, s, gx, gw, q, Z)
        scale = det1 * det2
        nl = d + 1
        for a in range(nl):
            for b in range(nl):
                acc = 0.0
                for i in range(d):
                    for j in range(d):
                        acc += amat[i, a] * Z[i, j] * amat[j, b]
                out[k, a, b] = scale * acc


@njit(cache=True)
def _seg_seg(ax, ay, bx, by, cx, cy, dx, dy):  # pragma: no cover
    """Distance between the disjoint segments [a, b] and [c, d]."""
    return min(_point_segment(ax, ay, cx, cy, dx, dy), _point_segment(bx, by, cx, cy, dx, dy),
               _point_segment(cx, cy, ax, ay, bx, by), _point_segment(dx, dy, ax, ay, bx, by))


@njit(cache=True)
def _seg_tri(ax, ay, bx, by, tri):  # pragma: no cover
    """Distance between the segment [a, b] and the disjoint triangle tri (3, 2)."""
    d = np.inf
    for i in range(3):
        j = (i + 1) % 3
        d = min(d, _seg_seg(ax, ay, bx, by, tri[i, 0], tri[i, 1], tri[j, 0], tri[j, 1]))
    return d


@njit(cache=True, parallel=True)
def pair_closeness(p, nodes, kind):  # pragma: no cover
    """How close the faces of the relative-coordinate rule come to the
    singularity, relative to the pair's size: (min over the faces of the
    distance of their images M·face from 0) / (longest edge of the pair).

    Equilateral pairs give about 0.4–0.9; a pair of thin triangles with
    aspect ratio a that lie side by side gives ~ 1/a.  nodes as in
    :func:`thin_singular_pairs`; kind 0 identical, 1 common edge, 2 common
    vertex."""
    n = nodes.shape[0]
    out = np.empty(n)
    tri = np.empty((3, 2))
    for k in prange(n):
        tri = np.empty((3, 2))
        P = p[nodes[k, 0]]
        Q = p[nodes[k, 1]]
        R = p[nodes[k, 2]]
        hmax = max(np.sqrt(((Q - P) ** 2).sum()), np.sqrt(((R - P) ** 2).sum()),
                   np.sqrt(((R - Q) ** 2).sum()))
        if kind == 0:
            # hexagon T − T: its edges lie at the heights of T from 0
            area2 = abs((Q[0] - P[0]) * (R[1] - P[1]) - (R[0] - P[0]) * (Q[1] - P[1]))
            out[k] = area2 / hmax / hmax
            continue
        if kind == 1:
            R2 = p[nodes[k, 3]]
            hmax = max(hmax, np.sqrt(((R2 - P) ** 2).sum()), np.sqrt(((R2 - Q) ** 2).sum()))
            # R' against T, R against T', [Q, R] against [P, R'], [P, R] against [Q, R']
            tri[0], tri[1], tri[2] = P, Q, R
            d = _dist_to_set(R2[0], R2[1], tri, 3)
            tri[2] = R2
            d = min(d, _dist_to_set(R[0], R[1], tri, 3))
            d = min(d, _seg_seg(Q[0], Q[1], R[0], R[1], P[0], P[1], R2[0], R2[1]))
            d = min(d, _seg_seg(P[0], P[1], R[0], R[1], Q[0], Q[1], R2[0], R2[1]))
        else:
            Q2 = p[nodes[k, 3]]
            R2 = p[nodes[k, 4]]
            hmax = max(hmax, np.sqrt(((Q2 - P) ** 2).sum()), np.sqrt(((R2 - P) ** 2).sum()),
                       np.sqrt(((R2 - Q2) ** 2).sum()))
            # edge QR of T against T', edge Q'R' of T' against T
            tri[0], tri[1], tri[2] = P, Q2, R2
            d = _seg_tri(Q[0], Q[1], R[0], R[1], tri)
            tri[1], tri[2] = Q, R
            d = min(d, _seg_tri(Q2[0], Q2[1], R2[0], R2[1], tri))
        out[k] = d / hmax
    return out


@njit(cache=True)
def _composite(bp, sc, gx, gw, q):  # pragma: no cover
    """Composite Gauss rule on [bp[0], bp[-1]] with breakpoints bp (sorted)
    and grading scales sc: on each side of a breakpoint the panels start at
    width sc and grow by q (each interval split halfway)."""
    # degenerate geometry (meshes that skipped validation) gives NaN or zero
    # scales: grade as finely as a double allows instead
    sc = sc.copy()
    for i in range(sc.shape[0]):
        if not sc[i] > 1e-15:
            sc[i] = 1e-15
    # an interior breakpoint whose panels would not be smaller than its
    # distance to both neighbours grades nothing: drop it
    keep = np.ones(bp.shape[0], dtype=np.bool_)
    for i in range(1, bp.shape[0] - 1):
        if sc[i] >= bp[i] - bp[i - 1] and sc[i] >= bp[i + 1] - bp[i]:
            keep[i] = False
    bp = bp[keep]
    sc = sc[keep]
    nk = bp.shape[0]
    ng = gx.shape[0]
    npan = 0
    for i in range(nk - 1):
        half = 0.5 * (bp[i + 1] - bp[i])
        for e in (sc[i], sc[i + 1]):
            r = half / e
            npan += 2 + (int(np.log(r) / np.log(q)) + 1 if r > 1.0 else 0)
    T = np.empty(npan * ng)
    W = np.empty(npan * ng)
    n = 0
    for i in range(nk - 1):
        lo, hi = bp[i], bp[i + 1]
        if not hi > lo:
            continue
        if sc[i] >= hi - lo and sc[i + 1] >= hi - lo:     # one panel suffices
            for g in range(ng):
                T[n] = lo + (hi - lo) * gx[g]
                W[n] = (hi - lo) * gw[g]
                n += 1
            continue
        mid = 0.5 * (lo + hi)
        for side in range(2):
            if side == 0:
                a, end, sgn, w = lo, mid, 1.0, sc[i]
            else:
                a, end, sgn, w = hi, mid, -1.0, sc[i + 1]
            while sgn * (end - a) > 0.0 and n + ng <= T.shape[0]:
                rem = sgn * (end - a)
                b = end if rem <= w * (1.0 + 0.5 * q) else a + sgn * w
                h = b - a
                for g in range(ng):
                    T[n] = a + h * gx[g]
                    W[n] = abs(h) * gw[g]
                    n += 1
                a = b
                w *= q
    return T[:n], W[:n]


@njit(cache=True)
def _unique_sorted(bp, nb):  # pragma: no cover
    """Sorted breakpoints in [0, 1] with 0 and 1, merged closer than 1e-12."""
    b = np.sort(bp[:nb])
    keep = np.empty(nb)
    nk = 0
    for i in range(nb):
        if nk == 0 or b[i] - keep[nk - 1] > 1e-12:
            keep[nk] = b[i]
            nk += 1
    keep[nk - 1] = 1.0
    return keep[:nk]


@njit(cache=True)
def _ray_breakpoints(X0, Y0, yx, yy, best, pts, npts):  # pragma: no cover
    """Sorted distinct parameters θ in [0, 1] of the segment Y0 + θ(yx, yy) where the
    ray from X0 passes through one of the points pts[:npts], or where the segment
    comes nearest to one of them (best = |(yx, yy)|²); 0 and 1 included."""
    cand = np.empty(2 + 2 * npts)
    cand[0], cand[1] = 0.0, 1.0
    nb = 2
    for j in range(npts):
        vx, vy = pts[j, 0] - X0[0], pts[j, 1] - X0[1]
        den = vx * yy - vy * yx
        if den != 0.0:
            th = ((Y0[0] - X0[0]) * vy - (Y0[1] - X0[1]) * vx) / den
            if 0.0 < th < 1.0:
                cand[nb] = th
                nb += 1
        th = ((pts[j, 0] - Y0[0]) * yx + (pts[j, 1] - Y0[1]) * yy) / best
        if 0.0 < th < 1.0:
            cand[nb] = th
            nb += 1
    return _unique_sorted(cand, nb)


@njit(cache=True)
def _separated_block(PT, PT2, s, gx, gw, q, out):  # pragma: no cover
    """6 × 6 matrix ∫_T∫_T'(φ_a(x)−φ_a(y))(φ_b(x)−φ_b(y))|x−y|^(−2−2s) of a
    separated pair (nodes of T, then of T'), for T, T' close compared to
    their size.

    x ∈ T in Duffy coordinates from the vertex opposite the shortest edge,
    both by composite rules graded toward the rays / points passing nearest
    to the vertices of T' (as in :func:`_outer_rule`); for each x the
    integral over T' in polar coordinates about x (:func:`_tri_moments`).
    """
    for a in range(6):
        for b in range(6):
            out[a, b] = 0.0
    # Duffy coordinates from the vertex X0 opposite the shortest edge Y0Y1:
    # x = X0 + ρ((1−θ)Y0 + θY1 − X0), dx = 2|T| ρ dρ dθ; for a thin triangle
    # the ray ends move along the short edge only
    best = np.inf
    i0 = 0
    for i in range(3):
        j = (i + 1) % 3
        ln = (PT[j, 0] - PT[i, 0]) ** 2 + (PT[j, 1] - PT[i, 1]) ** 2
        if ln < best:
            best = ln
            i0 = i
    Y0 = PT[i0]
    Y1 = PT[(i0 + 1) % 3]
    X0 = PT[(i0 + 2) % 3]
    yx, yy = Y1[0] - Y0[0], Y1[1] - Y0[1]
    ly = np.sqrt(best)
    det = abs((Y0[0] - X0[0]) * yy - (Y0[1] - X0[1]) * yx)      # 2|T|
    # θ breakpoints: rays through the vertices of T', ray ends nearest to them
    bps = _ray_breakpoints(X0, Y0, yx, yy, best, PT2, 3)
    scs = np.empty(bps.shape[0])
    for i in range(bps.shape[0]):
        ex, ey = Y0[0] + bps[i] * yx, Y0[1] + bps[i] * yy
        scs[i] = _seg_tri(X0[0], X0[1], ex, ey, PT2) / ly
    S, WS = _composite(bps, scs, gx, gw, q)
    # barycentric gradients of T (local order) and of T'
    g = np.empty((6, 2))
    for k, P in ((0, PT), (3, PT2)):
        e1x, e1y = P[1, 0] - P[0, 0], P[1, 1] - P[0, 1]
        e2x, e2y = P[2, 0] - P[0, 0], P[2, 1] - P[0, 1]
        dd = e1x * e2y - e1y * e2x
        g[k + 1, 0], g[k + 1, 1] = e2y / dd, -e2x / dd
        g[k + 2, 0], g[k + 2, 1] = -e1y / dd, e1x / dd
        g[k, 0] = -g[k + 1, 0] - g[k + 2, 0]
        g[k, 1] = -g[k + 1, 1] - g[k + 2, 1]
    K = np.empty(6)
    tri = np.empty((3, 2))
    u0 = np.empty(6)
    u1 = np.empty(6)
    u2 = np.empty(6)
    for ks in range(S.shape[0]):
        th = S[ks]
        sx0, sy0 = X0[0], X0[1]
        vx, vy = Y0[0] + th * yx - sx0, Y0[1] + th * yy - sy0
        Tt, Wt = _outer_rule(sx0, sy0, vx, vy, PT2, 3, gx, gw, q)
        for kt in range(Tt.shape[0]):
            x0 = sx0 + Tt[kt] * vx
            x1 = sy0 + Tt[kt] * vy
            jac = WS[ks] * Tt[kt] * det
            for j in range(3):
                tri[j, 0] = PT2[j, 0] - x0
                tri[j, 1] = PT2[j, 1] - x1
            _tri_moments(tri, s, gx, gw, q, K)
            # U(x, y) = u0 + U1 (y − x): λ_T(x) for T's nodes, −λ_T'(y) for T''s
            for a in range(3):
                u0[a] = 1.0 / 3.0 + g[a, 0] * (x0 - (PT[0, 0] + PT[1, 0] + PT[2, 0]) / 3.0) \
                    + g[a, 1] * (x1 - (PT[0, 1] + PT[1, 1] + PT[2, 1]) / 3.0)
                u0[3 + a] = -(1.0 / 3.0 + g[3 + a, 0] * (x0 - (PT2[0, 0] + PT2[1, 0] + PT2[2, 0]) / 3.0)
                              + g[3 + a, 1] * (x1 - (PT2[0, 1] + PT2[1, 1] + PT2[2, 1]) / 3.0))
                u1[a] = 0.0
                u2[a] = 0.0
                u1[3 + a] = -g[3 + a, 0]
                u2[3 + a] = -g[3 + a, 1]
            w = jac * Wt[kt]
            for a in range(6):
                ca = u1[a] * K[1] + u2[a] * K[2]
                for b in range(a, 6):
                    cb = u1[b] * K[1] + u2[b] * K[2]
                    k2 = (u1[a] * (K[3] * u1[b] + K[4] * u2[b])
                          + u2[a] * (K[4] * u1[b] + K[5] * u2[b]))
                    out[a, b] += w * (u0[a] * u0[b] * K[0] + u0[a] * cb + ca * u0[b] + k2)
    for a in range(6):
        for b in range(a):
            out[a, b] = out[b, a]


@njit(cache=True, parallel=True)
def separated_blocks(p, t, pairs, s, gx, gw, q, out):  # pragma: no cover
    """:func:`_separated_block` for element pairs (m, 2) → out (m, 6, 6).

    The outer (Duffy) variable runs over the smaller triangle of each pair
    and the polar integral over the larger one: both orders integrate the
    same function, and this one needs about a third fewer kernel values on
    graded meshes (thin layers next to wider ones)."""
    for k in prange(pairs.shape[0]):
        PT = np.empty((3, 2))
        PT2 = np.empty((3, 2))
        for i in range(3):
            for d in range(2):
                PT[i, d] = p[t[pairs[k, 0], i], d]
                PT2[i, d] = p[t[pairs[k, 1], i], d]
        if _area2(PT) <= _area2(PT2):
            _separated_block(PT, PT2, s, gx, gw, q, out[k])
        else:
            blk = np.empty((6, 6))
            _separated_block(PT2, PT, s, gx, gw, q, blk)
            for a in range(6):
                for b in range(6):
                    out[k, a, b] = blk[(a + 3) % 6, (b + 3) % 6]


@njit(cache=True)
def _area2(P):  # pragma: no cover
    """Twice the area of the triangle P (3, 2)."""
    return abs((P[1, 0] - P[0, 0]) * (P[2, 1] - P[0, 1]) - (P[1, 1] - P[0, 1]) * (P[2, 0] - P[0, 0]))


@njit(cache=True, parallel=True)
def triangle_gaps(p, t, pairs):  # pragma: no cover
    """Distance between the triangles of each pair (m, 2) (0 if they touch)."""
    m = pairs.shape[0]
    out = np.empty(m)
    for k in prange(m):
        T, T2 = pairs[k, 0], pairs[k, 1]
        d = np.inf
        for a in range(3):
            A = p[t[T, a]]
            B = p[t[T, (a + 1) % 3]]
            for b in range(3):
                C = p[t[T2, b]]
                D = p[t[T2, (b + 1) % 3]]
                d = min(d, _seg_seg(A[0], A[1], B[0], B[1], C[0], C[1], D[0], D[1]))
        out[k] = d
    return out


@njit(cache=True)
def _near_boundary_rule(PT, bv, nbv, gx, gw, q):  # pragma: no cover
    """Points (m, 2) and weights (summing to |T|) on a thin triangle T close to
    the boundary: Duffy coordinates from the vertex opposite the shortest edge,
    the ray parameter graded toward the points where it passes nearest to the
    boundary vertices bv[:nbv] (scales from the distances to them), the
    angle by Gauss panels graded the same way."""
    best = np.inf
    i0 = 0
    for i in range(3):
        j = (i + 1) % 3
        ln = (PT[j, 0] - PT[i, 0]) ** 2 + (PT[j, 1] - PT[i, 1]) ** 2
        if ln < best:
            best = ln
            i0 = i
    Y0 = PT[i0]
    Y1 = PT[(i0 + 1) % 3]
    X0 = PT[(i0 + 2) % 3]
    yx, yy = Y1[0] - Y0[0], Y1[1] - Y0[1]
    det = abs((Y0[0] - X0[0]) * yy - (Y0[1] - X0[1]) * yx)
    ly = np.sqrt(best)
    # θ: rays through / ends nearest to the boundary vertices
    bps = _ray_breakpoints(X0, Y0, yx, yy, best, bv, nbv)
    scs = np.empty(bps.shape[0])
    for i in range(bps.shape[0]):
        ex, ey = Y0[0] + bps[i] * yx, Y0[1] + bps[i] * yy
        dmin = np.inf
        for j in range(nbv):
            dmin = min(dmin, _point_segment(bv[j, 0], bv[j, 1], X0[0], X0[1], ex, ey))
        scs[i] = dmin / ly
    S, WS = _composite(bps, scs, gx, gw, q)
    pts = np.empty((0, 2))
    wts = np.empty(0)
    chunks_p = []
    chunks_w = []
    for ks in range(S.shape[0]):
        ex, ey = Y0[0] + S[ks] * yx - X0[0], Y0[1] + S[ks] * yy - X0[1]
        # ρ along the ray: breakpoints where it passes nearest to the boundary vertices
        cand2 = np.empty(2 + nbv)
        cand2[0], cand2[1] = 0.0, 1.0
        nb2 = 2
        ee = ex * ex + ey * ey
        for j in range(nbv):
            t = ((bv[j, 0] - X0[0]) * ex + (bv[j, 1] - X0[1]) * ey) / ee
            if 0.0 < t < 1.0:
                cand2[nb2] = t
                nb2 += 1
        b2 = _unique_sorted(cand2, nb2)
        s2 = np.empty(b2.shape[0])
        en = np.sqrt(ee)
        for i in range(b2.shape[0]):
            px, py = X0[0] + b2[i] * ex, X0[1] + b2[i] * ey
            dmin = np.inf
            for j in range(nbv):
                dmin = min(dmin, np.sqrt((bv[j, 0] - px) ** 2 + (bv[j, 1] - py) ** 2))
            s2[i] = dmin / en
        R, WR = _composite(b2, s2, gx, gw, q)
        P = np.empty((R.shape[0], 2))
        Wp = np.empty(R.shape[0])
        for k in range(R.shape[0]):
            P[k, 0] = X0[0] + R[k] * ex
            P[k, 1] = X0[1] + R[k] * ey
            Wp[k] = WS[ks] * WR[k] * R[k] * det
        chunks_p.append(P)
        chunks_w.append(Wp)
    n = 0
    for c in chunks_w:
        n += c.shape[0]
    pts = np.empty((n, 2))
    wts = np.empty(n)
    k = 0
    for c in range(len(chunks_w)):
        m = chunks_w[c].shape[0]
        pts[k:k + m] = chunks_p[c]
        wts[k:k + m] = chunks_w[c]
        k += m
    return pts, wts


def near_boundary_rules(p, t, els, bverts, bptr, gx, gw, q):
    """Quadrature points (m, 2), weights (m,) and element offsets (len(els)+1)
    of :func:`_near_boundary_rule` for the elements els, with the boundary
    vertices bverts[bptr[k]:bptr[k+1]] near element k."""
    P, W, offs = [], [], [0]
    for k, T in enumerate(els):
        x, w = _near_boundary_rule(np.ascontiguousarray(p[t[T]]),
                                   np.ascontiguousarray(bverts[bptr[k]:bptr[k + 1]]),
                                   bptr[k + 1] - bptr[k], gx, gw, q)
        P.append(x)
        W.append(w)
        offs.append(offs[-1] + len(w))
    return np.vstack(P), np.concatenate(W), np.array(offs)
