"""Numba kernels of the nonlocal assembly; plain-array signatures only.

Every kernel has a slow NumPy twin in the test suite (``tests/reference.py``,
outside the package); the tests compare the two.  All kernels are compiled
with ``cache=True`` because every Snakemake job is a fresh process.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

#: Most points of one far-field rule: the size of the kernels' per-thread work
#: arrays W (MAX_RULE_POINTS²) and V (3 × MAX_RULE_POINTS), which are indexed
#: without bounds checks.
MAX_RULE_POINTS = 64


@njit(cache=True, inline="always")
def _check_rule_sizes(offsets):  # pragma: no cover
    """Refuse rules (offsets[L]:offsets[L+1]) longer than the work arrays."""
    if np.max(offsets[1:] - offsets[:-1]) > MAX_RULE_POINTS:
        raise ValueError("a far-field rule is longer than the work arrays (MAX_RULE_POINTS)")


@njit(cache=True, parallel=True)
def singular_pairs(p, nodes, tp, signs, zq, wq, amat, s, out):  # pragma: no cover
    """Local matrices of touching element pairs in relative coordinates.

    p (Nv, 2) coordinates; nodes (n, d+1) local nodes of each pair, node 0
    the common vertex (P), columns of M are signs[j] (p[nodes[j+1]] − p[P]);
    tp (3,) local indices of the second triangle; zq (nq, d), wq (nq,) the
    face rule; amat (d, d+1) maps local nodal values to z-coefficients;
    out (n, d+1, d+1) receives ∫∫ (φ_a(x)−φ_a(y))(φ_b(x)−φ_b(y))|x−y|^(−2−2s)
    without the radial factor and the constant c_{2,s}.
    """
    n = nodes.shape[0]
    d = zq.shape[1]
    nq = zq.shape[0]
    expo = -1.0 - s
    for k in prange(n):
        P = nodes[k, 0]
        M = np.empty((2, d))
        for j in range(d):
            q = nodes[k, j + 1]
            M[0, j] = signs[j] * (p[q, 0] - p[P, 0])
            M[1, j] = signs[j] * (p[q, 1] - p[P, 1])
        # 2|T| and 2|T'|
        a0, a1, a2 = nodes[k, 0], nodes[k, 1], nodes[k, 2]
        det1 = abs((p[a1, 0] - p[a0, 0]) * (p[a2, 1] - p[a0, 1])
                   - (p[a2, 0] - p[a0, 0]) * (p[a1, 1] - p[a0, 1]))
        b0, b1, b2 = nodes[k, tp[0]], nodes[k, tp[1]], nodes[k, tp[2]]
        det2 = abs((p[b1, 0] - p[b0, 0]) * (p[b2, 1] - p[b0, 1])
                   - (p[b2, 0] - p[b0, 0]) * (p[b1, 1] - p[b0, 1]))
        Z = np.zeros((d, d))
        for i in range(nq):
            x0 = 0.0
            x1 = 0.0
            for j in range(d):
                x0 += M[0, j] * zq[i, j]
                x1 += M[1, j] * zq[i, j]
            kern = wq[i] * (x0 * x0 + x1 * x1) ** expo
            for a in range(d):
                za = kern * zq[i, a]
                for b in range(a, d):
                    Z[a, b] += za * zq[i, b]
        for a in range(d):
            for b in range(a):
                Z[a, b] = Z[b, a]
        scale = det1 * det2
        nl = d + 1
        for a in range(nl):
            for b in range(nl):
                acc = 0.0
                for i in range(d):
                    for j in range(d):
                        acc += amat[i, a] * Z[i, j] * amat[j, b]
                out[k, a, b] = scale * acc


@njit(cache=True, inline="always")
def pair_level(T, T2, cent, diam, thresholds, nlev):  # pragma: no cover
    """(level, dx, dy, r2) of the separated pair (T, T2): dx, dy, r2 from
    c_T − c_T', and the first level L whose ratio threshold[L] the separation
    |c_T − c_T'| / max(diam_T, diam_T') reaches (the last, most accurate
    level when it reaches none)."""
    dx = cent[T, 0] - cent[T2, 0]
    dy = cent[T, 1] - cent[T2, 1]
    hm = max(diam[T], diam[T2])
    r2 = dx * dx + dy * dy
    lev = nlev - 1
    for L in range(nlev - 1):
        if r2 >= thresholds[L] * thresholds[L] * hm * hm:
            lev = L
            break
    return lev, dx, dy, r2


@njit(cache=True, inline="always")
def separated_pair(T, T2, lev, dx, dy, r2, area, mom, grad, qx, qw, lam, offsets,
                   taylor, expo, alpha, D, c, W, V, X):  # pragma: no cover
    """One separated pair (T, T2) at level ``lev`` (:func:`pair_level`): X[a, b]
    ← what it adds to entry (t[T, a], t[T2, b]) of the one-sided part, and its
    sums into the rows T, T2 of chunk c of D, as :func:`far_pairs`
    describes; W (MAX_RULE_POINTS, MAX_RULE_POINTS) and V (3, MAX_RULE_POINTS)
    are work arrays."""
    q0 = offsets[lev]
    nq = offsets[lev + 1] - q0
    if taylor and lev == 0:
        # second-order Taylor-corrected centroid rule: expand k
        # about d = c_T − c_T' with the elements' second moments
        # I_T, one kernel evaluation.  Error O((h/d)^3) in the
        # quadratic form of smooth u; single entries O(h/d) to
        # O((h/d)^2) (dropped third-moment terms).
        k = r2 ** expo
        kr = alpha * k / r2
        gx = kr * dx
        gy = kr * dy
        hxx = kr * (1.0 + (alpha - 2.0) * dx * dx / r2)
        hxy = kr * (alpha - 2.0) * dx * dy / r2
        hyy = kr * (1.0 + (alpha - 2.0) * dy * dy / r2)
        A1 = area[T]
        A2 = area[T2]
        tr1 = hxx * mom[T, 0] + 2.0 * hxy * mom[T, 1] + hyy * mom[T, 2]
        tr2 = hxx * mom[T2, 0] + 2.0 * hxy * mom[T2, 1] + hyy * mom[T2, 2]
        C0 = A1 * A2 * k + 0.5 * (A2 * tr1 + A1 * tr2)
        a1x = A2 * (mom[T, 0] * gx + mom[T, 1] * gy)
        a1y = A2 * (mom[T, 1] * gx + mom[T, 2] * gy)
        a2x = A1 * (mom[T2, 0] * gx + mom[T2, 1] * gy)
        a2y = A1 * (mom[T2, 1] * gx + mom[T2, 2] * gy)
        D[c, T, 0] += C0
        D[c, T2, 0] += C0
        D[c, T, 1] += a1x
        D[c, T, 2] += a1y
        D[c, T2, 1] -= a2x
        D[c, T2, 2] -= a2y
        D[c, T, 3] += k * A2
        D[c, T2, 3] += k * A1
        for a in range(3):
            pa = (a1x * grad[T, a, 0] + a1y * grad[T, a, 1]) / 3.0
            for b in range(3):
                pb = (a2x * grad[T2, b, 0] + a2y * grad[T2, b, 1]) / 3.0
                X[a, b] = -(C0 / 9.0 - pb + pa)
        return
    # W_qr = w_q w_r k(x_q − y_r)
    for q in range(nq):
        xq0 = qx[T, q0 + q, 0]
        xq1 = qx[T, q0 + q, 1]
        wqq = qw[T, q0 + q]
        for r in range(nq):
            ex = xq0 - qx[T2, q0 + r, 0]
            ey = xq1 - qx[T2, q0 + r, 1]
            W[q, r] = wqq * qw[T2, q0 + r] * (ex * ex + ey * ey) ** expo
    for q in range(nq):
        sq = 0.0
        sr = 0.0
        for r in range(nq):
            sq += W[q, r]
            sr += W[r, q]
        D[c, T, 4 + q0 + q] += sq
        D[c, T2, 4 + q0 + q] += sr
    # off-diagonal block: −Σ W_qr λ_a(x_q) λ_b(y_r)
    for a in range(3):
        for r in range(nq):
            acc = 0.0
            for q in range(nq):
                acc += lam[q0 + q, a] * W[q, r]
            V[a, r] = acc
    for a in range(3):
        for b in range(3):
            acc = 0.0
            for r in range(nq):
                acc += V[a, r] * lam[q0 + r, b]
            X[a, b] = -acc


@njit(cache=True, parallel=True)
def far_pairs(A, t, cent, diam, area, mom, grad, qx, qw, lam, offsets, thresholds,
              taylor, s, order, class_ptr, nchunks):  # pragma: no cover
    """All non-touching element pairs with product Gauss rules, added to A.

    The rule of a pair is chosen from its separation ratio
    |c_T − c_T'| / max(diam_T, diam_T'): level L (points
    offsets[L]:offsets[L+1] of qx, qw, lam) is the first with
    ratio >= thresholds[L]; the last level is the most accurate.
    If ``taylor`` is true, level 0 is the Taylor-corrected centroid rule (area,
    second moments mom = (Ixx, Ixy, Iyy) about the centroid, gradients of
    the barycentric coordinates grad (nt, 3, 2)).

    Adds the one-sided off-diagonal part X to A (nv, nv): pair (T, T') with
    T < T' adds to the entries (t[T, a], t[T', b]), the rows of T's nodes;
    A + Aᵀ (:func:`add_transpose_inplace`) then gives the symmetric part.  The
    elements come in classes order[class_ptr[k]:class_ptr[k+1]] (ascending),
    no two elements of a class sharing a node (:func:`fracfem.assembly.element_classes`),
    taken one after the other; ``nchunks`` threads share each class, so no two
    threads write one row of A at a time, and every entry receives its terms in
    the same order whatever ``nchunks``.  Returns D (nchunks, nt, nq_total + 4):
    per quadrature point q of T, Σ_r W_qr, from which the diagonal blocks
    Σ_q D_q λ_a(x_q) λ_b(x_q) follow; for the Taylor level D[:, :, 0:4] hold
    ΣC0, Σα (2) and Σ k|T'| instead (see assembly.py).  D is per thread: a pair
    writes the rows of both its elements there.
    """
    nt = t.shape[0]
    nlev = offsets.shape[0] - 1
    nqt = offsets[nlev]
    expo = -1.0 - s
    alpha = -2.0 - 2.0 * s
    _check_rule_sizes(offsets)
    if nchunks < 1:
        raise ValueError("nchunks must be positive")
    D = np.zeros((nchunks, nt, nqt + 4))
    W_all = np.empty((nchunks, MAX_RULE_POINTS, MAX_RULE_POINTS))
    V_all = np.empty((nchunks, 3, MAX_RULE_POINTS))
    X_all = np.empty((nchunks, 3, 3))
    for k in range(class_ptr.shape[0] - 1):
        lo = class_ptr[k]
        hi = class_ptr[k + 1]
        for c in prange(nchunks):
            W = W_all[c]
            V = V_all[c]
            Xl = X_all[c]
            for idx in range(lo + c, hi, nchunks):
                T = order[idx]
                i0, i1, i2 = t[T, 0], t[T, 1], t[T, 2]
                for T2 in range(T + 1, nt):
                    j0, j1, j2 = t[T2, 0], t[T2, 1], t[T2, 2]
                    if (i0 == j0 or i0 == j1 or i0 == j2 or i1 == j0 or i1 == j1
                            or i1 == j2 or i2 == j0 or i2 == j1 or i2 == j2):
                        continue
                    lev, dx, dy, r2 = pair_level(T, T2, cent, diam, thresholds, nlev)
                    separated_pair(T, T2, lev, dx, dy, r2, area, mom, grad, qx, qw, lam,
                                   offsets, taylor, expo, alpha, D, c, W, V, Xl)
                    for a in range(3):
                        ia = t[T, a]
                        for b in range(3):
                            A[ia, t[T2, b]] += Xl[a, b]
    return D


@njit(cache=True, parallel=True)
def add_transpose_inplace(A, nchunks):  # pragma: no cover
    """A ← A + Aᵀ in place, in 64 × 64 tiles: the tile pair (I, J), I ≤ J, is
    summed and written by one thread alone (interleaved rows of tiles per thread,
    as the work per row of tiles falls with I)."""
    n = A.shape[0]
    nb = (n + 63) // 64
    for c in prange(nchunks):
        for I in range(c, nb, nchunks):
            i0 = I * 64
            i1 = min(n, i0 + 64)
            for J in range(I, nb):
                j0 = J * 64
                j1 = min(n, j0 + 64)
                for i in range(i0, i1):
                    for j in range(max(j0, i) if I == J else j0, j1):
                        v = A[i, j] + A[j, i]
                        A[i, j] = v
                        A[j, i] = v


@njit(cache=True, parallel=True)
def near_pairs(t, perm, cl_start, cl_end, near_ptr, near_rows, near_cols, cent, diam,
               area, mom, grad, qx, qw, lam, offsets, thresholds, taylor, s,
               indptr, indices, nv, row_order, colour_ptr, nchunks,
               data):  # pragma: no cover
    """Separated element pairs of the near blocks with the dense assembly's
    rules (:func:`fracfem._kernels.far_pairs`); touching pairs are skipped.

    Near blocks sorted by row cluster σ (near_ptr[i]:near_ptr[i+1] are the
    blocks of row near_rows[i]).  Each unordered pair once: blocks with σ < τ
    whole, σ = τ for T < T'.  The one-sided part X of a pair (T, T') goes to
    entry (t[T, a], t[T', b]) of the CSR data, found through a column →
    position map of the three rows of T (the pattern holds nodes(σ) × nodes(τ)
    of every near block); add the transpose with
    :func:`fracfem._h2_kernels.symmetrize_csr_inplace`.

    The row clusters come in classes, row_order[colour_ptr[k]:colour_ptr[k+1]]
    (indices into near_rows), taken one after the other; ``nchunks`` threads
    share each class.  ``data`` (allocated by the caller, so that it can shrink
    it in place) is either one array of zeros of shape (1, nnz), written by
    every thread, which is race-free when no two row clusters of a class share
    a node (:func:`fracfem._h2_kernels.greedy_colouring`), or per-thread copies (nchunks, nnz) to
    be summed, for any classes.  Race-free only because every entry
    nodes(σ) × nodes(τ) is in the pattern: a missing one would be written
    through a stale position, possibly into another thread's row.  Returns D
    (nchunks, nt, nq_total + 4) as in far_pairs: per chunk, since it gathers
    on the elements of both clusters.
    """
    nt = t.shape[0]
    nlev = offsets.shape[0] - 1
    nqt = offsets[nlev]
    expo = -1.0 - s
    alpha = -2.0 - 2.0 * s
    if nchunks < 1 or (data.shape[0] != 1 and data.shape[0] != nchunks):
        raise ValueError("nchunks must be positive and data have one row or one per chunk")
    copy_stride = 0 if data.shape[0] == 1 else 1   # shared array, or one per chunk
    _check_rule_sizes(offsets)
    D = np.zeros((nchunks, nt, nqt + 4))
    W_all = np.empty((nchunks, MAX_RULE_POINTS, MAX_RULE_POINTS))
    V_all = np.empty((nchunks, 3, MAX_RULE_POINTS))
    X_all = np.empty((nchunks, 3, 3))
    pos_all = np.zeros((nchunks, 3, nv), dtype=np.int64)
    for col in range(colour_ptr.shape[0] - 1):
        lo_c = colour_ptr[col]
        hi_c = colour_ptr[col + 1]
        for c in prange(nchunks):
            W = W_all[c]
            V = V_all[c]
            X = X_all[c]
            pos = pos_all[c]
            dc = np.int64(c) * copy_stride
            for oi in range(lo_c + c, hi_c, nchunks):
                ri = row_order[oi]
                sig = near_rows[ri]
                for k1 in range(cl_start[sig], cl_end[sig]):
                    T = perm[k1]
                    i0, i1, i2 = t[T, 0], t[T, 1], t[T, 2]
                    for a in range(3):
                        ia = t[T, a]
                        for kk in range(indptr[ia], indptr[ia + 1]):
                            pos[a, indices[kk]] = kk
                    for bb in range(near_ptr[ri], near_ptr[ri + 1]):
                        tau = near_cols[bb]
                        if sig > tau:
                            continue
                        k2s = cl_start[tau]
                        if sig == tau:
                            k2s = k1 + 1
                        for k2 in range(k2s, cl_end[tau]):
                            T2 = perm[k2]
                            j0, j1, j2 = t[T2, 0], t[T2, 1], t[T2, 2]
                            if (i0 == j0 or i0 == j1 or i0 == j2 or i1 == j0 or i1 == j1
                                    or i1 == j2 or i2 == j0 or i2 == j1 or i2 == j2):
                                continue
                            lev, dx, dy, r2 = pair_level(T, T2, cent, diam, thresholds,
                                                         nlev)
                            separated_pair(T, T2, lev, dx, dy, r2, area, mom, grad, qx, qw,
                                           lam, offsets, taylor, expo, alpha, D, c, W, V, X)
                            for a in range(3):
                                for b in range(3):
                                    data[dc, pos[a, t[T2, b]]] += X[a, b]
    return D


@njit(cache=True, parallel=True)
def far_rule_blocks(t, pairs, cent, diam, qx, qw, lam, offsets, thresholds, s, out):  # pragma: no cover
    """6 × 6 matrices that :func:`fracfem._kernels.far_pairs` assembles for the
    separated pairs (m, 2) with its product Gauss levels (same level choice;
    pairs of the Taylor level must not be passed)."""
    nlev = offsets.shape[0] - 1
    expo = -1.0 - s
    for k in prange(pairs.shape[0]):
        T, T2 = pairs[k, 0], pairs[k, 1]
        lev = pair_level(T, T2, cent, diam, thresholds, nlev)[0]
        q0 = offsets[lev]
        nq = offsets[lev + 1] - q0
        for a in range(6):
            for b in range(6):
                out[k, a, b] = 0.0
        for qq in range(nq):
            for r in range(nq):
                ex = qx[T, q0 + qq, 0] - qx[T2, q0 + r, 0]
                ey = qx[T, q0 + qq, 1] - qx[T2, q0 + r, 1]
                W = qw[T, q0 + qq] * qw[T2, q0 + r] * (ex * ex + ey * ey) ** expo
                for a in range(3):
                    la = lam[q0 + qq, a]
                    ma = lam[q0 + r, a]
                    for b in range(3):
                        out[k, a, b] += W * la * lam[q0 + qq, b]
                        out[k, 3 + a, 3 + b] += W * ma * lam[q0 + r, b]
                        out[k, a, 3 + b] -= W * la * lam[q0 + r, b]
        for a in range(3):
            for b in range(3):
                out[k, 3 + b, a] = out[k, a, 3 + b]


@njit(cache=True)
def scatter_local(A, nodes, local, factor):  # pragma: no cover
    """A[nodes[k, a], nodes[k, b]] += factor * local[k, a, b]."""
    n, m = nodes.shape
    for k in range(n):
        for a in range(m):
            ia = nodes[k, a]
            for b in range(m):
                A[ia, nodes[k, b]] += factor * local[k, a, b]


@njit(cache=True, parallel=True)
def kernel_floor(cent, s, nchunks):  # pragma: no cover
    """Σ over unordered element pairs of |c_T − c_T'|^(−2−2s): the cost floor.

    The pairs :func:`far_pairs` visits (interleaved elements per chunk here), one
    kernel evaluation per pair and no matrix writes.
    """
    nt = cent.shape[0]
    expo = -1.0 - s
    partial = np.zeros(nchunks)
    for c in prange(nchunks):
        acc = 0.0
        for T in range(c, nt, nchunks):
            for T2 in range(T + 1, nt):
                dx = cent[T, 0] - cent[T2, 0]
                dy = cent[T, 1] - cent[T2, 1]
                acc += (dx * dx + dy * dy) ** expo
        partial[c] = acc
    return partial.sum()


@njit(cache=True)
def _cos_power_integral(phi, s2, gl_x, gl_w, gj_x, gj_w, full):  # pragma: no cover
    """∫₀^φ cos^(2s) θ dθ for φ in [−π/2, π/2] (s2 = 2s).

    Gauss–Legendre on [0, φ] where cos is bounded below; near π/2 the
    identity ∫₀^φ = ∫₀^(π/2) − ∫₀^(π/2−φ) sin^(2s) and a Gauss–Jacobi rule
    for the weight v^(2s) (sin ψ/ψ is analytic) keep full accuracy.
    """
    sgn = 1.0
    if phi < 0.0:
        sgn = -1.0
        phi = -phi
    if phi <= 0.25 * np.pi:
        acc = 0.0
        for i in range(gl_x.shape[0]):
            acc += gl_w[i] * np.cos(phi * gl_x[i]) ** s2
        return sgn * phi * acc
    u = 0.5 * np.pi - phi
    acc = 0.0
    if u > 0.0:
        for i in range(gj_x.shape[0]):
            psi = u * gj_x[i]
            acc += gj_w[i] * (np.sin(psi) / psi) ** s2
        acc *= u ** (s2 + 1.0)
    return sgn * (full - acc)


@njit(cache=True, parallel=True)
def exterior_kappa(x, edges, s, gl_x, gl_w, gj_x, gj_w, full, far_x, far_w, far2_x):  # pragma: no cover
    """κ(x) = ∫_{Ωᶜ} |x − y|^(−2−2s) dy for points x inside a polygon.

    By the divergence theorem κ(x) = (1/2s) Σ_e ∫_e (y−x)·n_e |y−x|^(−2−2s),
    n_e the outward normal; per edge this is sign(d)|d|^(−2s)[F(φ₂) − F(φ₁)]
    with F(φ) = ∫₀^φ cos^(2s), d the signed distance to the edge's line and
    φ the angles of the edge's ends seen from the foot of the perpendicular.
    Valid for any (also non-convex) polygon; edges (m, 4) = (x0, y0, x1, y1)
    oriented counter-clockwise around Ω.
    """
    n = x.shape[0]
    m = edges.shape[0]
    s2 = 2.0 * s
    out = np.empty(n)
    for i in prange(n):
        acc = 0.0
        for e in range(m):
            ax = edges[e, 0] - x[i, 0]
            ay = edges[e, 1] - x[i, 1]
            bx = edges[e, 2] - x[i, 0]
            by = edges[e, 3] - x[i, 1]
            tx = edges[e, 2] - edges[e, 0]
            ty = edges[e, 3] - edges[e, 1]
            ln = np.sqrt(tx * tx + ty * ty)
            tx /= ln
            ty /= ln
            d = ax * ty - ay * tx          # (y − x)·n, n = (ty, −tx) outward
            if d == 0.0:
                continue
            ad = abs(d)
            t1 = ax * tx + ay * ty
            t2 = bx * tx + by * ty
            mx = 0.5 * (ax + bx)
            my = 0.5 * (ay + by)
            dm2 = mx * mx + my * my
            if dm2 > 16.0 * ln * ln:
                # distant edge: smooth integrand; Gauss in t, 4 points up to
                # 12 edge lengths away, 2 beyond (relative error < 1e-5)
                part = 0.0
                if dm2 > 144.0 * ln * ln:
                    for g in range(2):
                        tg = t1 + (t2 - t1) * far2_x[g]
                        part += 0.5 * (d * d + tg * tg) ** (-1.0 - s)
                else:
                    for g in range(4):
                        tg = t1 + (t2 - t1) * far_x[g]
                        part += far_w[g] * (d * d + tg * tg) ** (-1.0 - s)
                acc += d * (t2 - t1) * part
                continue
            f2 = _cos_power_integral(np.arctan(t2 / ad), s2, gl_x, gl_w, gj_x, gj_w, full)
            f1 = _cos_power_integral(np.arctan(t1 / ad), s2, gl_x, gl_w, gj_x, gj_w, full)
            acc += np.sign(d) * ad ** (-s2) * (f2 - f1)
        out[i] = acc / s2
    return out
