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

_MAXBP = 8          # breakpoints of an outer rule (3 vertices + 2 ends, merged)


@njit(cache=True)
def _radial(R2, s):  # pragma: no cover
    """(G0/R², G1/R³, G2/R⁴) for the radial antiderivatives
    G0 = −R^(−2s)/(2s), G1 = (R^(1−2s) − 1)/(1−2s), G2 = R^(2−2s)/(2−2s)."""
    lnR = 0.5 * np.log(R2)
    p = np.exp(-2.0 * s * lnR)                 # R^(−2s)
    e = 1.0 - 2.0 * s
    x = e * lnR
    if abs(x) < 1e-8:
        G1 = lnR * (1.0 + 0.5 * x)
    else:
        G1 = np.expm1(x) / e
    R = np.sqrt(R2)
    return -p / (2.0 * s) / R2, G1 / (R2 * R), p / ((2.0 - 2.0 * s) * R2)


@njit(cache=True)
def _tri_moments(v, s, gx, gw, q, K):  # pragma: no cover
    """K = (K0, K1x, K1y, K2xx, K2xy, K2yy) of ∫_Π (1, η, ηηᵀ)|η|^(−2−2s) dη
    for the triangle Π with vertices v (3, 2), 0 outside Π.

    Polar coordinates about 0: Σ_edges d_e ∫ G(R) … /R² dτ with τ the arc
    length from the foot of the perpendicular (signed distance d_e along the
    outward normal); the constants of the antiderivatives cancel because 0
    lies outside Π.  Coordinates are scaled by the largest |v| first.
    """
    for i in range(6):
        K[i] = 0.0
    L = 0.0
    for i in range(3):
        L = max(L, np.sqrt(v[i, 0] ** 2 + v[i, 1] ** 2))
    ax, ay = v[0, 0] / L, v[0, 1] / L
    bx, by = v[1, 0] / L, v[1, 1] / L
    cx, cy = v[2, 0] / L, v[2, 1] / L
    if (bx - ax) * (cy - ay) - (cx - ax) * (by - ay) < 0.0:   # make it CCW
        bx, by, cx, cy = cx, cy, bx, by
    ng = gx.shape[0]
    for e in range(3):
        if e == 0:
            x0, y0, x1, y1 = ax, ay, bx, by
        elif e == 1:
            x0, y0, x1, y1 = bx, by, cx, cy
        else:
            x0, y0, x1, y1 = cx, cy, ax, ay
        ln = np.sqrt((x1 - x0) ** 2 + (y1 - y0) ** 2)
        tx, ty = (x1 - x0) / ln, (y1 - y0) / ln
        nx, ny = ty, -tx                        # outward for CCW
        d = x0 * nx + y0 * ny
        if d == 0.0:
            continue
        ta = x0 * tx + y0 * ty
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
                    wt = abs(h) * gw[g] * d
                    f0, f1, f2 = _radial(d * d + tau * tau, s)
                    ex = d * nx + tau * tx
                    ey = d * ny + tau * ty
                    K[0] += wt * f0
                    K[1] += wt * f1 * ex
                    K[2] += wt * f1 * ey
                    K[3] += wt * f2 * ex * ex
                    K[4] += wt * f2 * ex * ey
                    K[5] += wt * f2 * ey * ey
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
    bp = np.sort(bp[:nb])
    # merge breakpoints closer than 1e-12
    keep = np.empty(nb)
    nk = 0
    for i in range(nb):
        if nk == 0 or bp[i] - keep[nk - 1] > 1e-12:
            keep[nk] = bp[i]
            nk += 1
    keep[nk - 1] = 1.0
    sc = np.empty(nk)
    for i in range(nk):
        t = keep[i]
        sc[i] = _dist_to_set(p0x + t * vx, p0y + t * vy, cv, nc) / vn
    ng = gx.shape[0]
    # upper bound of panels: each side log_q(len/scale) + 2
    npan = 0
    for i in range(nk - 1):
        half = 0.5 * (keep[i + 1] - keep[i])
        for e in (sc[i], sc[i + 1]):
            r = half / max(e, 1e-300)
            npan += 2 + (int(np.log(r) / np.log(q)) + 1 if r > 1.0 else 0)
    T = np.empty(npan * ng)
    W = np.empty(npan * ng)
    n = 0
    for i in range(nk - 1):
        lo, hi = keep[i], keep[i + 1]
        mid = 0.5 * (lo + hi)
        for side in range(2):
            if side == 0:
                a, end, sgn, w = lo, mid, 1.0, sc[i]
            else:
                a, end, sgn, w = hi, mid, -1.0, sc[i + 1]
            while sgn * (end - a) > 0.0:
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
