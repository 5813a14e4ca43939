"""Numba kernels of the compressed operator; plain-array signatures only.

Far element pairs of the dense assembly use the Taylor-corrected centroid
rule (:func:`fracfem._kernels.far_pairs`, level 0): every term is the kernel
k(D) = |D|^(−2−2s), its gradient or its Hessian at D = c_T − c_T', times
moments of T and T'.  Here k(x − y) is interpolated on tensor Chebyshev grids
of the bounding boxes of element clusters (an H²-matrix with nested bases):
k(x − y) ≈ Σ_αβ L^σ_α(x) k(ξ_α − ζ_β) L^τ_β(y).  Sources and targets are
functionals c0·L + c1·∇L + c2:∇²L of the basis at element centroids, so the
Taylor terms are represented exactly up to the interpolation error.

Near element pairs (inadmissible leaf blocks) are computed with exactly the
rules of the dense assembly (:func:`fracfem._kernels.near_pairs`, beside the
dense kernels whose pair rule it calls) and added into a node-level CSR
pattern, whose helpers are here.
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange



# ---------------------------------------------------------------- Chebyshev


@njit(cache=True)
def cheb_basis_1d(xi, z, out):  # pragma: no cover
    """Lagrange basis of the Chebyshev points z (m,) of the first kind at
    xi ∈ [−1, 1]: out[0, i] = ℓ_i, out[1, i] = ℓ_i', out[2, i] = ℓ_i''.

    ℓ_i = 1/m + (2/m) Σ_{k≥1} T_k(z_i) T_k(xi) (discrete orthogonality).
    """
    m = z.shape[0]
    T = np.empty(m)
    dT = np.empty(m)
    d2T = np.empty(m)
    T[0] = 1.0
    dT[0] = 0.0
    d2T[0] = 0.0
    if m > 1:
        T[1] = xi
        dT[1] = 1.0
        d2T[1] = 0.0
    for k in range(1, m - 1):
        T[k + 1] = 2.0 * xi * T[k] - T[k - 1]
        dT[k + 1] = 2.0 * T[k] + 2.0 * xi * dT[k] - dT[k - 1]
        d2T[k + 1] = 4.0 * dT[k] + 2.0 * xi * d2T[k] - d2T[k - 1]
    for i in range(m):
        zi = z[i]
        tkm1 = 1.0
        tk = zi
        v = 1.0
        d1 = 0.0
        d2 = 0.0
        for k in range(1, m):
            v += 2.0 * tk * T[k]
            d1 += 2.0 * tk * dT[k]
            d2 += 2.0 * tk * d2T[k]
            tn = 2.0 * zi * tk - tkm1
            tkm1 = tk
            tk = tn
        out[0, i] = v / m
        out[1, i] = d1 / m
        out[2, i] = d2 / m


@njit(cache=True)
def _basis_2d(x, y, box, z, bx, by, L):  # pragma: no cover
    """Tensor basis (value, ∂x, ∂y, ∂xx, ∂xy, ∂yy) at (x, y) in box
    (cx, cy, hx, hy): L (6, m*m), index α = i*m + j (i along x)."""
    m = z.shape[0]
    cheb_basis_1d((x - box[0]) / box[2], z, bx)
    cheb_basis_1d((y - box[1]) / box[3], z, by)
    ix = 1.0 / box[2]
    iy = 1.0 / box[3]
    for i in range(m):
        for j in range(m):
            a = i * m + j
            L[0, a] = bx[0, i] * by[0, j]
            L[1, a] = bx[1, i] * by[0, j] * ix
            L[2, a] = bx[0, i] * by[1, j] * iy
            L[3, a] = bx[2, i] * by[0, j] * ix * ix
            L[4, a] = bx[1, i] * by[1, j] * ix * iy
            L[5, a] = bx[0, i] * by[2, j] * iy * iy


@njit(cache=True)
def _transfer_1d(parent, child, dim, z, E):  # pragma: no cover
    """E[g, k] = ℓ^parent_k(child node g) along one dimension (m, m)."""
    m = z.shape[0]
    buf = np.empty((3, m))
    for g in range(m):
        x = child[dim] + child[dim + 2] * z[g]
        cheb_basis_1d((x - parent[dim]) / parent[dim + 2], z, buf)
        for k in range(m):
            E[g, k] = buf[0, k]


@njit(cache=True, parallel=True)
def transfers(boxes, parent, z):  # pragma: no cover
    """1D transfer matrices of every cluster to its parent (nc, 2, m, m);
    the root's are unused."""
    nc = boxes.shape[0]
    m = z.shape[0]
    E = np.zeros((nc, 2, m, m))
    for c in prange(nc):
        p = parent[c]
        if p < 0:
            continue
        _transfer_1d(boxes[p], boxes[c], 0, z, E[c, 0])
        _transfer_1d(boxes[p], boxes[c], 1, z, E[c, 1])
    return E


@njit(cache=True)
def _grid(box, z, X):  # pragma: no cover
    m = z.shape[0]
    for i in range(m):
        for j in range(m):
            X[i * m + j, 0] = box[0] + box[2] * z[i]
            X[i * m + j, 1] = box[1] + box[3] * z[j]


@njit(cache=True, parallel=True)
def coupling_matrices(tboxes, sboxes, far_rows, far_cols, z, expo, comp,
                      logl0=0.0):  # pragma: no cover
    """K[b, α, β] = |r|^(2·expo), r = ζ^τ_β − ξ^σ_α, of every admissible block
    b = (σ, τ), σ a target cluster (tboxes), τ a source cluster (sboxes);
    with comp = 0 or 1 the kernel is r_comp |r|^(2·expo) instead, with
    comp = 2 it is (|r|^(2·expo) − ℓ₀^(2·expo))/(−2·expo), ℓ₀ = exp(logl0),
    computed without cancellation (bounded as expo → 0)."""
    l0p = np.exp(2.0 * expo * logl0) / (-2.0 * expo)
    nb = far_rows.shape[0]
    m = z.shape[0]
    p = m * m
    K = np.empty((nb, p, p))
    for b in prange(nb):
        X = np.empty((p, 2))
        Y = np.empty((p, 2))
        _grid(tboxes[far_rows[b]], z, X)
        _grid(sboxes[far_cols[b]], z, Y)
        for a in range(p):
            for c in range(p):
                dx = Y[c, 0] - X[a, 0]
                dy = Y[c, 1] - X[a, 1]
                if comp == 2:
                    K[b, a, c] = l0p * np.expm1(expo * (np.log(dx * dx + dy * dy)
                                                        - 2.0 * logl0))
                    continue
                v = (dx * dx + dy * dy) ** expo
                if comp == 0:
                    v *= dx
                elif comp == 1:
                    v *= dy
                K[b, a, c] = v
    return K


@njit(cache=True)
def _apply_1d_pair(Ex, Ey, w, out, transpose, m):  # pragma: no cover
    """out += (Ex ⊗ Ey) w (or its transpose), w and out of length m*m."""
    tmp = np.zeros((m, m))
    if transpose:
        # out[k, l] += Σ_gh Ex[g, k] Ey[h, l] w[g, h]
        for g in range(m):
            for l in range(m):
                acc = 0.0
                for h in range(m):
                    acc += Ey[h, l] * w[g * m + h]
                tmp[g, l] = acc
        for k in range(m):
            for l in range(m):
                acc = 0.0
                for g in range(m):
                    acc += Ex[g, k] * tmp[g, l]
                out[k * m + l] += acc
    else:
        # out[g, h] += Σ_kl Ex[g, k] Ey[h, l] w[k, l]
        for k in range(m):
            for h in range(m):
                acc = 0.0
                for l in range(m):
                    acc += Ey[h, l] * w[k * m + l]
                tmp[k, h] = acc
        for g in range(m):
            for h in range(m):
                acc = 0.0
                for k in range(m):
                    acc += Ex[g, k] * tmp[k, h]
                out[g * m + h] += acc


@njit(cache=True, parallel=True)
def leaf_moments(src, cent, perm, leaves, cl_start, cl_end, boxes, z, W):  # pragma: no cover
    """W[leaf, r, β] = Σ_{T in leaf} src[T, r] · (L_β, ∇L_β, ∇²L_β)(c_T),
    src (Nt, nrhs, 6) = (c0, c1x, c1y, c2xx, c2xy, c2yy); the Hessian
    contraction counts the mixed entry twice (c2 a symmetric matrix)."""
    m = z.shape[0]
    p = m * m
    nrhs = src.shape[1]
    for li in prange(leaves.shape[0]):
        c = leaves[li]
        bx = np.empty((3, m))
        by = np.empty((3, m))
        L = np.empty((6, p))
        for r in range(nrhs):
            for a in range(p):
                W[c, r, a] = 0.0
        for k in range(cl_start[c], cl_end[c]):
            T = perm[k]
            _basis_2d(cent[T, 0], cent[T, 1], boxes[c], z, bx, by, L)
            for r in range(nrhs):
                s0 = src[T, r, 0]
                s1 = src[T, r, 1]
                s2 = src[T, r, 2]
                s3 = src[T, r, 3]
                s4 = 2.0 * src[T, r, 4]
                s5 = src[T, r, 5]
                for a in range(p):
                    W[c, r, a] += (s0 * L[0, a] + s1 * L[1, a] + s2 * L[2, a]
                                   + s3 * L[3, a] + s4 * L[4, a] + s5 * L[5, a])


@njit(cache=True)
def upward(W, E, level_nodes, level_ptr, child0, child1, m):  # pragma: no cover
    """W[parent] = Σ_children E_childᵀ W[child], deepest level first.

    Serial: O(m³) per cluster is far less than a parallel region's barrier
    costs on a loaded machine (one per level)."""
    nrhs = W.shape[1]
    p = m * m
    nlev = level_ptr.shape[0] - 1
    for lev in range(nlev - 1, -1, -1):
        for ii in range(level_ptr[lev], level_ptr[lev + 1]):
            c = level_nodes[ii]
            a = child0[c]
            if a < 0:
                continue
            b = child1[c]
            for r in range(nrhs):
                for k in range(p):
                    W[c, r, k] = 0.0
                _apply_1d_pair(E[a, 0], E[a, 1], W[a, r], W[c, r], True, m)
                _apply_1d_pair(E[b, 0], E[b, 1], W[b, r], W[c, r], True, m)


@njit(cache=True, parallel=True)
def couple_grouped(W, K, grp_ptr, blk_rows, blk_cols, nc, nchunks):  # pragma: no cover
    """G[σ] = Σ_{admissible (σ, τ)} K_b W[τ] with the blocks grouped by their
    coupling matrix (grp_ptr[g]:grp_ptr[g+1] use K[g]): the W[τ] of a group
    are gathered and multiplied by K[g] in one matrix product (BLAS).
    Returns per-chunk sums (nchunks, nc, nrhs, p)."""
    nrhs = W.shape[1]
    p = W.shape[2]
    ng = grp_ptr.shape[0] - 1
    G = np.zeros((nchunks, nc, nrhs, p))
    most = 1
    for g in range(ng):
        most = max(most, grp_ptr[g + 1] - grp_ptr[g])
    for c in prange(nchunks):
        buf = np.empty((most * nrhs, p))
        for g in range(c, ng, nchunks):
            q0 = grp_ptr[g]
            nb = grp_ptr[g + 1] - q0
            for q in range(nb):
                tau = blk_cols[q0 + q]
                for r in range(nrhs):
                    for k in range(p):
                        buf[q * nrhs + r, k] = W[tau, r, k]
            R = np.dot(buf[:nb * nrhs], K[g].T)
            for q in range(nb):
                sig = blk_rows[q0 + q]
                for r in range(nrhs):
                    for a in range(p):
                        G[c, sig, r, a] += R[q * nrhs + r, a]
    return G


@njit(cache=True)
def downward(G, E, level_nodes, level_ptr, child0, child1, m):  # pragma: no cover
    """G[child] += E_child G[parent], top level first."""
    nrhs = G.shape[1]
    nlev = level_ptr.shape[0] - 1
    for lev in range(nlev):
        for ii in range(level_ptr[lev], level_ptr[lev + 1]):
            c = level_nodes[ii]
            a = child0[c]
            if a < 0:
                continue
            b = child1[c]
            for r in range(nrhs):
                _apply_1d_pair(E[a, 0], E[a, 1], G[c, r], G[a, r], False, m)
                _apply_1d_pair(E[b, 0], E[b, 1], G[c, r], G[b, r], False, m)


@njit(cache=True, parallel=True)
def leaf_evaluate(G, cent, perm, leaves, cl_start, cl_end, boxes, z, out,
                  nder=6):  # pragma: no cover
    """out[T, r, :] = (g, ∂x g, ∂y g, ∂xx g, ∂xy g, ∂yy g)(c_T) of the local
    expansion g = Σ_α G[leaf, r, α] L_α (the first ``nder`` of them)."""
    m = z.shape[0]
    p = m * m
    nrhs = G.shape[1]
    for li in prange(leaves.shape[0]):
        c = leaves[li]
        bx = np.empty((3, m))
        by = np.empty((3, m))
        L = np.empty((6, p))
        for k in range(cl_start[c], cl_end[c]):
            T = perm[k]
            _basis_2d(cent[T, 0], cent[T, 1], boxes[c], z, bx, by, L)
            for r in range(nrhs):
                for d in range(nder):
                    acc = 0.0
                    for a in range(p):
                        acc += G[c, r, a] * L[d, a]
                    out[T, r, d] = acc


@njit(cache=True)
def _leaf_free_nodes(t, perm, a, b, node_index):  # pragma: no cover
    """Sorted free-node numbers (``node_index``, −1 skipped) of the elements
    perm[a:b]."""
    buf = np.empty(3 * (b - a), dtype=np.int64)
    q = 0
    for k in range(a, b):
        for j in range(3):
            v = node_index[t[perm[k], j]]
            if v >= 0:
                buf[q] = v
                q += 1
    return np.unique(buf[:q])


@njit(cache=True, parallel=True)
def leaf_source_matrix(t, perm, leaves, cl_start, cl_end, boxes, z, cent, area, mom,
                       grad, node_index):  # pragma: no cover
    """CSR arrays (indptr, indices, data) of the matrix M taking the free-node
    values x to the leaf moments of :meth:`CompressedOperator.far_matvec`:
    row (ℓ·2 + r)·p + α of leaf number ℓ holds W[leaves[ℓ], r, α] =
    Σ_T Σ_j M_(T, j) x_(t[T, j]), with, at the centroid of T,

    * r = 0: (|T|/3) L_α (the value sources |T|/3 Σ_j x_j);
    * r = 1: (I∇λ_j)·∇L_α + (I : ∇²L_α)/6 (I the second moments of T).

    Columns are ``node_index`` of the nodes (−1: not free, skipped); the
    2p rows of a leaf share one sorted column list.  The same functionals as
    :func:`leaf_moments` applied to the sources made from x, summed in
    another order."""
    m = z.shape[0]
    p = m * m
    nl = leaves.shape[0]
    count = np.zeros(nl, dtype=np.int64)
    for li in prange(nl):
        c = leaves[li]
        u = _leaf_free_nodes(t, perm, cl_start[c], cl_end[c], node_index)
        count[li] = u.shape[0]
    off = np.zeros(nl + 1, dtype=np.int64)
    for li in range(nl):
        off[li + 1] = off[li] + 2 * p * count[li]
    indptr = np.empty(nl * 2 * p + 1, dtype=np.int64)
    indptr[nl * 2 * p] = off[nl]
    indices = np.empty(off[nl], dtype=np.int64)
    data = np.zeros(off[nl], dtype=np.float64)
    for li in prange(nl):
        c = leaves[li]
        u = _leaf_free_nodes(t, perm, cl_start[c], cl_end[c], node_index)
        nu = u.shape[0]
        for row in range(2 * p):
            r0 = off[li] + row * nu
            indptr[li * 2 * p + row] = r0
            for i in range(nu):
                indices[r0 + i] = u[i]
        bx = np.empty((3, m))
        by = np.empty((3, m))
        L = np.empty((6, p))
        for k in range(cl_start[c], cl_end[c]):
            T = perm[k]
            _basis_2d(cent[T, 0], cent[T, 1], boxes[c], z, bx, by, L)
            a3 = area[T] / 3.0
            m0 = mom[T, 0]
            m1 = mom[T, 1]
            m2 = mom[T, 2]
            for j in range(3):
                v = node_index[t[T, j]]
                if v < 0:
                    continue
                col = np.searchsorted(u, v)
                g0 = grad[T, j, 0]
                g1 = grad[T, j, 1]
                w1 = m0 * g0 + m1 * g1
                w2 = m1 * g0 + m2 * g1
                base0 = off[li] + col
                base1 = off[li] + p * nu + col
                for a in range(p):
                    data[base0 + a * nu] += a3 * L[0, a]
                    data[base1 + a * nu] += (w1 * L[1, a] + w2 * L[2, a]
                                             + (m0 * L[3, a] + 2.0 * m1 * L[4, a]
                                                + m2 * L[5, a]) / 6.0)
    return indptr, indices, data


@njit(cache=True)
def _row_chunks(indptr, nchunks):  # pragma: no cover
    """Row bounds (nchunks + 1,) of CSR row ranges holding about equal numbers
    of entries."""
    n = indptr.shape[0] - 1
    nnz = indptr[n]
    bounds = np.empty(nchunks + 1, dtype=np.int64)
    for c in range(nchunks + 1):
        bounds[c] = np.searchsorted(indptr, (nnz * c) // nchunks)
    bounds[0] = 0
    bounds[nchunks] = n
    return bounds


@njit(cache=True, parallel=True)
def csr_matvec(indptr, indices, data, x, nchunks):  # pragma: no cover
    """y = A x for A in CSR arrays, rows split into ``nchunks`` ranges of
    about equal numbers of entries, one per thread (scipy's product runs on
    one thread)."""
    y = np.empty(indptr.shape[0] - 1)
    bounds = _row_chunks(indptr, nchunks)
    for c in prange(nchunks):
        for i in range(bounds[c], bounds[c + 1]):
            acc = 0.0
            for k in range(indptr[i], indptr[i + 1]):
                acc += data[k] * x[indices[k]]
            y[i] = acc
    return y


@njit(cache=True, parallel=True)
def csr_rmatvec(indptr, indices, data, g, ncols, nchunks):  # pragma: no cover
    """y = Aᵀ g for A in CSR arrays (ncols columns): row ranges of about equal
    numbers of entries, one per thread, each scattering into its own y."""
    bounds = _row_chunks(indptr, nchunks)
    Y = np.zeros((nchunks, ncols))
    for c in prange(nchunks):
        for i in range(bounds[c], bounds[c + 1]):
            gi = g[i]
            if gi == 0.0:
                continue
            for k in range(indptr[i], indptr[i + 1]):
                Y[c, indices[k]] += data[k] * gi
    y = np.zeros(ncols)
    for c in range(nchunks):
        for j in range(ncols):
            y[j] += Y[c, j]
    return y


@njit(cache=True, parallel=True)
def csr_block_product(indptr, indices, data, B, ncols, transpose,
                      nchunks):  # pragma: no cover
    """A B, or Aᵀ B with ``transpose``, for A in CSR arrays (ncols columns) and a block
    B (rows, k) C-ordered: :func:`csr_matvec` and :func:`csr_rmatvec` with k
    right-hand sides, each entry of A read once for all of them (the product is bound
    by reading A).  Row ranges of about equal numbers of entries, one per thread; A B
    writes each row once, Aᵀ B scatters into the thread's own sums."""
    k = B.shape[1]
    n = indptr.shape[0] - 1
    bounds = _row_chunks(indptr, nchunks)
    # Aᵀ B: each thread its own sums; a factor, as numba's parallel loop does not type
    # ``c if transpose else 0`` as an index (measured: TypingError)
    per_thread = 1 if transpose else 0
    Y = np.zeros((nchunks if transpose else 1, ncols if transpose else n, k))
    for c in prange(nchunks):
        own = c * per_thread
        for i in range(bounds[c], bounds[c + 1]):
            for q in range(indptr[i], indptr[i + 1]):
                a = data[q]
                j = indices[q]
                if transpose:
                    for r in range(k):
                        Y[own, j, r] += a * B[i, r]
                else:
                    for r in range(k):
                        Y[own, i, r] += a * B[j, r]
    for c in range(1, Y.shape[0]):
        for j in range(Y.shape[1]):
            for r in range(k):
                Y[0, j, r] += Y[c, j, r]
    return Y[0]


# ---------------------------------------------------------------- near field


@njit(cache=True)
def _csr_position(indptr, indices, i, j):  # pragma: no cover
    """Position of entry (i, j) in a CSR pattern with sorted indices that holds it
    (not checked: on a pattern without (i, j) it is the first entry of row i
    past column j, or the row's last entry, or indptr[i] when row i is empty:
    the next row's first, or nnz past the last row)."""
    lo = indptr[i]
    hi = indptr[i + 1] - 1
    while lo < hi:
        mid = (lo + hi) >> 1
        if indices[mid] < j:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True)
def _csr_add(indptr, indices, data, i, j, v):  # pragma: no cover
    """data[(i, j)] += v; raises when the pattern has no entry (i, j)."""
    k = _csr_position(indptr, indices, i, j)
    if k >= indptr[i + 1] or indices[k] != j:
        raise IndexError("entry outside the near-field pattern")
    data[k] += v


@njit(cache=True)
def greedy_colouring(indptr, indices):  # pragma: no cover
    """Colours of the vertices of a graph (CSR adjacency, self-loops allowed),
    smallest first in vertex order: no two neighbours share one."""
    n = indptr.shape[0] - 1
    colour = np.full(n, -1, dtype=np.int64)
    seen = np.full(n + 1, -1, dtype=np.int64)
    for v in range(n):
        for k in range(indptr[v], indptr[v + 1]):
            cu = colour[indices[k]]
            if cu >= 0:
                seen[cu] = v
        cv = 0
        while seen[cv] == v:
            cv += 1
        colour[v] = cv
    return colour


@njit(cache=True, parallel=True)
def symmetrize_csr(indptr, indices, data):  # pragma: no cover
    """S + Sᵀ on a symmetric pattern with sorted indices, into a new array
    (the reference of :func:`symmetrize_csr_inplace`, which the assembly uses)."""
    n = indptr.shape[0] - 1
    out = np.empty_like(data)
    for i in prange(n):
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            out[k] = data[k] + data[_csr_position(indptr, indices, j, i)]
    return out


@njit(cache=True, parallel=True)
def symmetrize_csr_inplace(indptr, indices, data):  # pragma: no cover
    """data ← S + Sᵀ in place, on a symmetric pattern with sorted indices
    (:func:`symmetrize_csr` without its second array).  The entry (i, j) of
    the upper triangle is summed with (j, i) and written to both by row i's
    iteration alone: no other row reads or writes (j, i) of a j > i."""
    n = indptr.shape[0] - 1
    for i in prange(n):
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j < i:
                continue
            if j == i:
                data[k] = 2.0 * data[k]
                continue
            kt = _csr_position(indptr, indices, j, i)
            v = data[k] + data[kt]
            data[k] = v
            data[kt] = v


@njit(cache=True)
def scatter_csr(indptr, indices, data, nodes, local, factor):  # pragma: no cover
    """data[(nodes[k, a], nodes[k, b])] += factor * local[k, a, b]."""
    n, m = nodes.shape
    for k in range(n):
        for a in range(m):
            for b in range(m):
                _csr_add(indptr, indices, data, nodes[k, a], nodes[k, b],
                         factor * local[k, a, b])


# ---------------------------------------------------------------- κ


@njit(cache=True)
def _clenshaw(c, y):  # pragma: no cover
    """Σ_k c[k] T_k(4y − 1): a Chebyshev series on y ∈ [0, 1/2]."""
    xi = 4.0 * y - 1.0
    b1 = 0.0
    b2 = 0.0
    for k in range(c.shape[0] - 1, 0, -1):
        b0 = 2.0 * xi * b1 - b2 + c[k]
        b2 = b1
        b1 = b0
    return xi * b1 - b2 + c[0]


@njit(cache=True)
def _cos_power_difference(t1, t2, ad, s2, ca, cb, full):  # pragma: no cover
    """F(φ₂) − F(φ₁), F(φ) = ∫₀^φ cos^(2s), φ_i = arctan(t_i/ad), by the
    Chebyshev series of :func:`fracfem.compressed.cos_power_series`: with
    v = sin φ and c = cos φ, F = v·Q(v²) for v² ≤ 1/2, else
    sign(v)(F(π/2) − c^(2s+1) R(c²)).  No arctan, one power at most; two ends
    on the same side of the foot near π/2 subtract the c-terms directly."""
    r1 = np.hypot(ad, t1)
    r2 = np.hypot(ad, t2)
    v1 = t1 / r1
    v2 = t2 / r2
    c1 = ad / r1
    c2 = ad / r2
    g1 = 0.0
    g2 = 0.0
    b1 = v1 * v1 > 0.5
    b2 = v2 * v2 > 0.5
    if b1:
        g1 = c1 ** (s2 + 1.0) * _clenshaw(cb, c1 * c1)
    if b2:
        g2 = c2 ** (s2 + 1.0) * _clenshaw(cb, c2 * c2)
    if b1 and b2 and (v1 > 0.0) == (v2 > 0.0):
        return (g1 - g2) if v1 > 0.0 else (g2 - g1)
    f1 = (full - g1 if v1 > 0.0 else g1 - full) if b1 else v1 * _clenshaw(ca, v1 * v1)
    f2 = (full - g2 if v2 > 0.0 else g2 - full) if b2 else v2 * _clenshaw(ca, v2 * v2)
    return f2 - f1


@njit(cache=True)
def _edge_term(x0, x1, edges, e, g, s, ca, cb, full, far_x, far_w,
               far2_x):  # pragma: no cover
    """Share of Gauss point g (0 or 1) of edge e in 2s·κ(x), by the rule of
    :func:`fracfem._kernels.exterior_kappa`: its own term where that kernel
    uses the two-point rule, else the whole edge's contribution on g = 0 and
    nothing on g = 1 (the edge's integral computed once)."""
    s2 = 2.0 * s
    ax = edges[e, 0] - x0
    ay = edges[e, 1] - x1
    bx = edges[e, 2] - x0
    by = edges[e, 3] - x1
    tx = edges[e, 2] - edges[e, 0]
    ty = edges[e, 3] - edges[e, 1]
    ln = np.sqrt(tx * tx + ty * ty)
    tx /= ln
    ty /= ln
    d = ax * ty - ay * tx
    if d == 0.0:
        return 0.0
    ad = abs(d)
    t1 = ax * tx + ay * ty
    t2 = bx * tx + by * ty
    mx = 0.5 * (ax + bx)
    my = 0.5 * (ay + by)
    dm2 = mx * mx + my * my
    if dm2 > 144.0 * ln * ln:
        tg = t1 + (t2 - t1) * far2_x[g]
        return d * (t2 - t1) * 0.5 * (d * d + tg * tg) ** (-1.0 - s)
    if g == 1:
        return 0.0
    if dm2 > 16.0 * ln * ln:
        part = 0.0
        for q in range(far_x.shape[0]):
            tq = t1 + (t2 - t1) * far_x[q]
            part += far_w[q] * (d * d + tq * tq) ** (-1.0 - s)
        return d * (t2 - t1) * part
    return np.sign(d) * ad ** (-s2) * _cos_power_difference(t1, t2, ad, s2, ca, cb, full)


@njit(cache=True, parallel=True)
def kappa_near(x, tperm, tstart, near_ptr, near_rows, near_cols, tend, sperm, sstart, send,
               src_edge, src_g, edges, s, ca, cb, full, far_x, far_w,
               far2_x, out):  # pragma: no cover
    """out[i] += κ share of the near blocks of the target leaf of x_i (no
    races: every target point lies in one leaf)."""
    s2 = 2.0 * s
    for ri in prange(near_rows.shape[0]):
        tl = near_rows[ri]
        for k in range(tstart[tl], tend[tl]):
            i = tperm[k]
            acc = 0.0
            for bb in range(near_ptr[ri], near_ptr[ri + 1]):
                sl = near_cols[bb]
                for kk in range(sstart[sl], send[sl]):
                    j = sperm[kk]
                    acc += _edge_term(x[i, 0], x[i, 1], edges, src_edge[j], src_g[j], s,
                                      ca, cb, full, far_x, far_w, far2_x)
            out[i] += acc / s2


# ---------------------------------------------------------------- trees


@njit(cache=True)
def split_tree(cent, diam, leaf_size, lo0x, lo0y, L):  # pragma: no cover
    """The cluster tree of :func:`fracfem.compressed.cluster_tree`, built in
    one pass: returns perm, start, end, parent, level, child0, child1, the
    dyadic boxes (nc, 4), the tight boxes tlo, thi (nc, 2) and hmax (nc,).

    A cluster's box is halved along its longer side (x first), empty halves
    skipped; the split is a stable partition (left half first).  Boxes are
    not refined beyond 2^-60 of the root: such a cluster (coincident
    centroids, up to rounding) stays a leaf."""
    nt = cent.shape[0]
    cap = 2 * nt + 1
    perm = np.arange(nt)
    start = np.empty(cap, dtype=np.int64)
    end = np.empty(cap, dtype=np.int64)
    parent = np.empty(cap, dtype=np.int64)
    level = np.empty(cap, dtype=np.int64)
    c0 = np.full(cap, -1, dtype=np.int64)
    c1 = np.full(cap, -1, dtype=np.int64)
    box = np.zeros((cap, 4), dtype=np.int64)
    buf = np.empty(nt, dtype=np.int64)
    start[0] = 0
    end[0] = nt
    parent[0] = -1
    level[0] = 0
    n = 1
    i = 0
    while i < n:
        a = start[i]
        b = end[i]
        if b - a > leaf_size:
            dx, dy, ix, iy = box[i, 0], box[i, 1], box[i, 2], box[i, 3]
            nl = 0
            dim = 0
            ok = False
            while dx < 60 and dy < 60:
                dim = 0 if dx <= dy else 1
                if dim == 0:
                    mid = lo0x + (2 * ix + 1) * L / 2.0 ** (dx + 1)
                else:
                    mid = lo0y + (2 * iy + 1) * L / 2.0 ** (dy + 1)
                nl = 0
                for k in range(a, b):
                    if cent[perm[k], dim] < mid:
                        nl += 1
                if 0 < nl < b - a:
                    ok = True
                    break
                if dim == 0:
                    dx += 1
                    ix = 2 * ix + (0 if nl else 1)
                else:
                    dy += 1
                    iy = 2 * iy + (0 if nl else 1)
            box[i, 0], box[i, 1], box[i, 2], box[i, 3] = dx, dy, ix, iy
            if ok:
                nlft = 0
                nr = 0
                for k in range(a, b):
                    e = perm[k]
                    if cent[e, dim] < mid:
                        perm[a + nlft] = e
                        nlft += 1
                    else:
                        buf[nr] = e
                        nr += 1
                for k in range(nr):
                    perm[a + nlft + k] = buf[k]
                for h in range(2):
                    start[n] = a if h == 0 else a + nl
                    end[n] = a + nl if h == 0 else b
                    parent[n] = i
                    level[n] = level[i] + 1
                    if dim == 0:
                        box[n, 0], box[n, 1], box[n, 2], box[n, 3] = dx + 1, dy, 2 * ix + h, iy
                    else:
                        box[n, 0], box[n, 1], box[n, 2], box[n, 3] = dx, dy + 1, ix, 2 * iy + h
                    n += 1
                c0[i] = n - 2
                c1[i] = n - 1
        i += 1
    tlo = np.empty((n, 2))
    thi = np.empty((n, 2))
    hmax = np.empty(n)
    for k in range(n - 1, -1, -1):      # children are created after their parent
        if c0[k] < 0:
            tlo[k, 0] = np.inf
            tlo[k, 1] = np.inf
            thi[k, 0] = -np.inf
            thi[k, 1] = -np.inf
            hmax[k] = -np.inf
            for j in range(start[k], end[k]):
                e = perm[j]
                for d in range(2):
                    tlo[k, d] = min(tlo[k, d], cent[e, d])
                    thi[k, d] = max(thi[k, d], cent[e, d])
                hmax[k] = max(hmax[k], diam[e])
        else:
            for d in range(2):
                tlo[k, d] = min(tlo[c0[k], d], tlo[c1[k], d])
                thi[k, d] = max(thi[c0[k], d], thi[c1[k], d])
            hmax[k] = max(hmax[c0[k]], hmax[c1[k]])
    return (perm, start[:n].copy(), end[:n].copy(), parent[:n].copy(), level[:n].copy(),
            c0[:n].copy(), c1[:n].copy(), box[:n].copy(), tlo, thi, hmax)


@njit(cache=True)
def restrict_csr_inplace(indptr, indices, data, new_index):  # pragma: no cover
    """Keep the rows and columns i with new_index[i] ≥ 0 (an increasing
    numbering), compacting indices and data in place; returns the new indptr
    and the number of entries kept (the first nnz of indices and data)."""
    nrow = 0
    for i in range(new_index.shape[0]):
        if new_index[i] >= 0:
            nrow += 1
    ptr = np.zeros(nrow + 1, dtype=np.int64)
    w = 0
    r = 0
    for i in range(indptr.shape[0] - 1):
        if new_index[i] < 0:
            continue
        for k in range(indptr[i], indptr[i + 1]):
            j = new_index[indices[k]]
            if j >= 0:
                indices[w] = j
                data[w] = data[k]
                w += 1
        r += 1
        ptr[r] = w
    return ptr, w
