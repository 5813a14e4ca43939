"""Numba kernels of :mod:`fracfem.pointwise`; plain-array signatures only.

The pointwise values of (−Δ)^s u_h are computed as Riesz potentials of the
distribution −Δ(u_h 1_Ω), which for a P1 function is a sum of line measures
on the mesh edges (see :mod:`fracfem.pointwise`).  The kernels below
integrate, for every evaluation point x and every mesh edge e = [a, b],

    single layer  S_e(x) = ∫_e G(|x − y|) dℓ(y),
                  G(r) = (r^(−2s) − ℓ₀^(−2s)) / (2s)   (continuous as s → 0),
    double layer  D_e(x) = d_e(x) ∫_e u(y) |x − y|^(−2−2s) dℓ(y),
                  d_e(x) = (y − x)·n_e, n_e the outward normal of Ω,

with u linear along e.  Edges near x (|x − m_e| < near·|e|, m_e the
midpoint) are integrated after the substitution t = |d| sinh v (t the
position along the line of e measured from the foot of the perpendicular
from x, d the distance of x to that line): the integrand becomes analytic
in the strip |Im v| < π/2 whatever d, so Gauss–Legendre on pieces of
length ≤ ``piece`` in v converges geometrically, also for x very close to
e.  Farther edges use Gauss–Legendre rules in t with fewer points as the
distance ratio grows and, farthest, the midpoint rule with its analytic
second-order correction.

All kernels are compiled with ``cache=True`` (every Snakemake job is a
fresh process) and are parallel over evaluation points.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True)
def _g_kernel(r2, s, logl0, l0p):  # pragma: no cover
    """G(r) = (r^(−2s) − ℓ₀^(−2s))/(2s) from r², log ℓ₀ and l0p = ℓ₀^(−2s)/(2s)."""
    return l0p * np.expm1(-s * (np.log(r2) - 2.0 * logl0))


@njit(cache=True)
def _single_near(x0, x1, ax, ay, bx, by, s, logl0, l0p, gx, gw, piece):  # pragma: no cover
    """∫_[a,b] G(|x − y|) dℓ(y) by the sinh substitution (x not on [a, b])."""
    tx = bx - ax
    ty = by - ay
    ln = np.sqrt(tx * tx + ty * ty)
    tx /= ln
    ty /= ln
    px = ax - x0
    py = ay - x1
    t1 = px * tx + py * ty              # a relative to the foot point
    t2 = t1 + ln                        # b
    d = abs(px * ty - py * tx)          # distance of x to the line of e
    ng = gx.shape[0]
    acc = 0.0
    if d > 1e-13 * ln:
        v1 = np.arcsinh(t1 / d)
        v2 = np.arcsinh(t2 / d)
        npc = max(1, int(np.ceil((v2 - v1) / piece)))
        hv = (v2 - v1) / npc
        d2 = d * d
        for k in range(npc):
            va = v1 + k * hv
            part = 0.0
            for g in range(ng):
                ch = np.cosh(va + hv * gx[g])
                part += gw[g] * ch * _g_kernel(d2 * ch * ch, s, logl0, l0p)
            acc += part
        return acc * hv * d
    # x on the line of e, outside the segment: t = ±exp(w), w = log |t|
    lo = min(abs(t1), abs(t2))
    hi = max(abs(t1), abs(t2))
    w1 = np.log(lo)
    w2 = np.log(hi)
    npc = max(1, int(np.ceil((w2 - w1) / piece)))
    hw = (w2 - w1) / npc
    for k in range(npc):
        wa = w1 + k * hw
        part = 0.0
        for g in range(ng):
            tt = np.exp(wa + hw * gx[g])
            part += gw[g] * tt * _g_kernel(tt * tt, s, logl0, l0p)
        acc += part
    return acc * hw


@njit(cache=True)
def _double_near(x0, x1, ax, ay, bx, by, s, gx, gw, piece):  # pragma: no cover
    """(w_a, w_b) with d_e ∫_[a,b] u(y) |x − y|^(−2−2s) dℓ(y) = w_a u_a + w_b u_b for
    u linear from u_a to u_b, by the sinh substitution; d_e = (a − x)·n with n
    the right-hand normal of a → b."""
    tx = bx - ax
    ty = by - ay
    ln = np.sqrt(tx * tx + ty * ty)
    tx /= ln
    ty /= ln
    px = ax - x0
    py = ay - x1
    t1 = px * tx + py * ty
    d = px * ty - py * tx               # signed: (a − x)·(ty, −tx)
    ad = abs(d)
    if ad <= 1e-13 * ln:
        return 0.0, 0.0
    v1 = np.arcsinh(t1 / ad)
    v2 = np.arcsinh((t1 + ln) / ad)
    npc = max(1, int(np.ceil((v2 - v1) / piece)))
    hv = (v2 - v1) / npc
    ng = gx.shape[0]
    acc_a = 0.0
    acc_b = 0.0
    for k in range(npc):
        va = v1 + k * hv
        for g in range(ng):
            v = va + hv * gx[g]
            xi = (ad * np.sinh(v) - t1) / ln      # position along e in [0, 1]
            w = gw[g] * np.cosh(v) ** (-1.0 - 2.0 * s)
            acc_a += w * (1.0 - xi)
            acc_b += w * xi
    # d ∫ u (d² + t²)^(−1−s) dt, dt = |d| cosh v dv
    c = np.sign(d) * ad ** (-2.0 * s) * hv
    return c * acc_a, c * acc_b


@njit(cache=True, inline="always")
def _level(q, rat2):  # pragma: no cover
    """Index of the Gauss level of distance ratio² q (levels start at rat2)."""
    lev = 0
    while lev < rat2.shape[0] and q >= rat2[lev]:
        lev += 1
    return lev


@njit(cache=True, inline="always")
def single_weight(x0, x1, edata, e, s, logl0, l0s, near2, rat2, gl_x, gl_w, gl_off, nx, nw,
                piece):  # pragma: no cover
    """∫_e G(|x − y|) dℓ(y) / |e| by the rule of edge e's distance class
    (l0s = ℓ₀^(−2s), logl0 = log ℓ₀); the edge's term is J_e |e| times this."""
    s2 = 2.0 * s
    mx = edata[e, 4] - x0
    my = edata[e, 5] - x1
    r2 = mx * mx + my * my
    q = r2 * edata[e, 6]
    if q < near2:
        return edata[e, 6] ** 0.5 * _single_near(
            x0, x1, edata[e, 0], edata[e, 1], edata[e, 2], edata[e, 3],
            s, logl0, l0s / s2, nx, nw, piece)
    lev = _level(q, rat2)
    tx = edata[e, 2] - edata[e, 0]
    ty = edata[e, 3] - edata[e, 1]
    half = s == 0.5
    if gl_off[lev + 1] == gl_off[lev]:
        # midpoint rule with its second-order correction:
        # ∫ f = |e| f(0) + |e|³/24 f''(0), f(t) = G(|m_e − x + t τ|),
        # f'' = ρ^(−2s−2) ((2s+2)(z·τ)²/ρ² − 1)
        if half:
            rp = 1.0 / np.sqrt(r2)                 # ρ^(−2s)
        else:
            rp = np.exp(-s * np.log(r2))
        pz = mx * tx + my * ty
        f2 = rp / r2 * ((s2 + 2.0) * pz * pz * edata[e, 6] / r2 - 1.0)
        return (rp - l0s) / s2 + f2 / (24.0 * edata[e, 6])
    part = 0.0
    wsum = 0.0
    for g in range(gl_off[lev], gl_off[lev + 1]):
        yx = edata[e, 0] + gl_x[g] * tx - x0
        yy = edata[e, 1] + gl_x[g] * ty - x1
        if half:
            part += gl_w[g] / np.sqrt(yx * yx + yy * yy)
        else:
            part += gl_w[g] * np.exp(-s * np.log(yx * yx + yy * yy))
        wsum += gl_w[g]
    return (part - wsum * l0s) / s2


@njit(cache=True, inline="always")
def double_weights(x0, x1, ba, bb, e, s, near2, brat2, bgl_x, bgl_w, bgl_off, nx, nw,
                   piece):  # pragma: no cover
    """(w_a, w_b): d_e(x) ∫_e u(y)|x − y|^(−2−2s) dℓ(y) = w_a u_a + w_b u_b for
    boundary edge e, u linear between its end values, by the rule of its
    distance class."""
    ax = ba[e, 0]
    ay = ba[e, 1]
    tx = bb[e, 0] - ax
    ty = bb[e, 1] - ay
    l2 = tx * tx + ty * ty
    mx = ax + 0.5 * tx - x0
    my = ay + 0.5 * ty - x1
    q = (mx * mx + my * my) / l2
    if q < near2:
        return _double_near(x0, x1, ax, ay, bb[e, 0], bb[e, 1], s, nx, nw, piece)
    lev = _level(q, brat2)
    ln = np.sqrt(l2)
    d = ((ax - x0) * ty - (ay - x1) * tx) / ln
    ex = -1.0 - s
    pa = 0.0
    pb = 0.0
    for g in range(bgl_off[lev], bgl_off[lev + 1]):
        yx = ax + bgl_x[g] * tx - x0
        yy = ay + bgl_x[g] * ty - x1
        w = bgl_w[g] * (yx * yx + yy * yy) ** ex
        pa += w * (1.0 - bgl_x[g])
        pb += w * bgl_x[g]
    return d * ln * pa, d * ln * pb


@njit(cache=True, parallel=True)
def riesz_edges(x, edata, coef, ba, bb, bu, s, logl0, near, ratios, gl_x, gl_w, gl_off,
                bratios, bgl_x, bgl_w, bgl_off, nx, nw, piece, out):  # pragma: no cover
    """Σ_e J_e S_e(x_i) + Σ_boundary D_e(x_i) for every point x_i and every
    right-hand side r (the kernel values are computed once for all of them).

    x (n, 2) points (never on an edge); edata (m, 7) per edge: ends a, b
    (4 columns), midpoint (2), 1/|e|²; coef (m, K): J_e |e| of right-hand
    side r in column r, J_e the jump of the normal derivative; ba, bb (mb, 2)
    boundary edges oriented with Ω on the left, bu (mb, 2, K) the values of u
    at their ends; logl0 = log ℓ₀; near: sinh rule where |x − m_e| < near |e|;
    ratios (L,) increasing distance ratios at which the Gauss levels 1..L
    start (level 0 from ``near``), gl_x/gl_w concatenated Gauss rules on
    [0, 1] of levels 0..L with offsets gl_off (L+2,); bratios, bgl_x, bgl_w,
    bgl_off the same for the boundary (double layer) edges; nx, nw the Gauss
    rule on [0, 1] of the sinh pieces of length ≤ piece.  A single-layer
    level without Gauss points (gl_off[l] == gl_off[l+1]) means the midpoint
    rule with its analytic second-order correction (one kernel evaluation per
    edge).  out (n, K) receives the sums, without the factor c_{2,s}/(2s).
    """
    n = x.shape[0]
    nr = coef.shape[1]
    near2 = near * near
    rat2 = ratios * ratios
    brat2 = bratios * bratios
    l0s = np.exp(-2.0 * s * logl0)
    for i in prange(n):
        acc = np.zeros(nr)
        for e in range(edata.shape[0]):
            w = single_weight(x[i, 0], x[i, 1], edata, e, s, logl0, l0s, near2, rat2, gl_x,
                              gl_w, gl_off, nx, nw, piece)
            for r in range(nr):
                acc[r] += coef[e, r] * w
        for e in range(ba.shape[0]):
            wa, wb = double_weights(x[i, 0], x[i, 1], ba, bb, e, s, near2, brat2, bgl_x,
                                    bgl_w, bgl_off, nx, nw, piece)
            for r in range(nr):
                acc[r] += wa * bu[e, 0, r] + wb * bu[e, 1, r]
        for r in range(nr):
            out[i, r] = acc[r]


@njit(cache=True, parallel=True)
def riesz_near(x, tperm, tstart, tend, rows, ptr, cols, sstart, send, src_g, nsrc, layer,
               edata, coef, ba, bb, bu, s, logl0, near, ratios, gl_x, gl_w, gl_off, bratios,
               bgl_x, bgl_w, bgl_off, nx, nw, piece, out):  # pragma: no cover
    """out[i, r] += the near-block share of one layer at x_i for right-hand
    side r (layer 0: single layer over ``edata, coef``, 1: double layer over
    ``ba, bb, bu``; arguments as in :func:`riesz_edges`).

    The sources of the far field are the points of each edge's rule of the
    farthest distance class, ``nsrc`` per edge (one midpoint where that rule
    is the corrected midpoint rule).  Here the edge arrays hold one row per
    source in the order of the source tree (source k: point src_g[k] of the
    edge in row k; the sources of cluster τ are rows sstart[τ]:send[τ]).  A
    pair (x, source) of a near block adds the source's own term where the
    edge is in the farthest class for x (as it would in a far block) and
    1/nsrc of the edge's whole term, by the rule of its class, otherwise:
    the sum over all blocks is then the sum of :func:`riesz_edges`.  Target
    clusters (rows) in parallel: every point lies in one leaf, so no two
    threads write the same entry.
    """
    nr = out.shape[1]
    near2 = near * near
    rat2 = ratios * ratios
    brat2 = bratios * bratios
    far2 = max(rat2[rat2.shape[0] - 1], near2)      # the farthest class starts here
    bfar2 = max(brat2[brat2.shape[0] - 1], near2)
    goff = gl_off[rat2.shape[0]]
    bgoff = bgl_off[brat2.shape[0]]
    s2 = 2.0 * s
    l0s = np.exp(-s2 * logl0)
    ex = -1.0 - s
    for ri in prange(rows.shape[0]):
        tl = rows[ri]
        acc = np.empty(nr)
        for k in range(tstart[tl], tend[tl]):
            i = tperm[k]
            x0 = x[i, 0]
            x1 = x[i, 1]
            for r in range(nr):
                acc[r] = 0.0
            for bi in range(ptr[ri], ptr[ri + 1]):
                for e in range(sstart[cols[bi]], send[cols[bi]]):
                    if layer == 0:
                        if nsrc > 1:
                            mx = edata[e, 4] - x0
                            my = edata[e, 5] - x1
                            if (mx * mx + my * my) * edata[e, 6] >= far2:
                                g = goff + src_g[e]
                                yx = edata[e, 0] + gl_x[g] * (edata[e, 2] - edata[e, 0]) - x0
                                yy = edata[e, 1] + gl_x[g] * (edata[e, 3] - edata[e, 1]) - x1
                                w = gl_w[g] * (np.exp(-s * np.log(yx * yx + yy * yy))
                                               - l0s) / s2
                                for r in range(nr):
                                    acc[r] += coef[e, r] * w
                                continue
                        w = single_weight(x0, x1, edata, e, s, logl0, l0s, near2, rat2,
                                          gl_x, gl_w, gl_off, nx, nw, piece) / nsrc
                        for r in range(nr):
                            acc[r] += coef[e, r] * w
                    else:
                        tx = bb[e, 0] - ba[e, 0]
                        ty = bb[e, 1] - ba[e, 1]
                        mx = ba[e, 0] + 0.5 * tx - x0
                        my = ba[e, 1] + 0.5 * ty - x1
                        if mx * mx + my * my >= bfar2 * (tx * tx + ty * ty):
                            g = bgoff + src_g[e]
                            yx = ba[e, 0] + bgl_x[g] * tx - x0
                            yy = ba[e, 1] + bgl_x[g] * ty - x1
                            w = bgl_w[g] * (yx * ty - yy * tx) * (yx * yx + yy * yy) ** ex
                            xg = bgl_x[g]
                            for r in range(nr):
                                acc[r] += w * (bu[e, 0, r] + xg * (bu[e, 1, r] - bu[e, 0, r]))
                            continue
                        wa, wb = double_weights(x0, x1, ba, bb, e, s, near2, brat2, bgl_x,
                                                bgl_w, bgl_off, nx, nw, piece)
                        for r in range(nr):
                            acc[r] += (wa * bu[e, 0, r] + wb * bu[e, 1, r]) / nsrc
            for r in range(nr):
                out[i, r] += acc[r]
