"""The free-node stiffness operator in compressed (H²-matrix) form.

The operator equals the dense :func:`fracfem.stiffness_matrix` restricted to
the free nodes up to the compression error, which follows ``tol``:

* element clusters: a binary tree over element centroids (bisection of the
  longest side of the bounding box at the median);
* a block (σ, τ) is admissible when the centroid boxes satisfy
  dist ≥ max(max(diam σ, diam τ)/eta, R·h_max(σ ∪ τ)), R the separation ratio
  from which the dense assembly uses its Taylor-corrected centroid rule
  (``QuadratureOptions.far_thresholds[0]``): every pair of an admissible block
  is then integrated by that rule, whose terms are k, ∇k and ∇²k at centroid
  differences times element moments;
* admissible blocks: k(x − y) interpolated on tensor Chebyshev grids of order
  m per direction on both boxes, with nested bases (1D transfer matrices);
* near blocks (inadmissible leaves): the element pairs with exactly the rules
  of the dense assembly, in a node-level sparse matrix, together with the
  touching pairs, κ and the far-field diagonal terms (the u(x)v(x) parts of
  every far pair, summed over the far field with the same H² passes).
"""
from __future__ import annotations

import logging
import math
import time

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla

from . import _h2_kernels as hk
from . import _kernels
from .assembly import (QuadratureOptions, _boundary_edges, _element_geometry,
                       close_pair_corrections,
                       _element_moments, _far_rules, _kappa_local, _singular_local,
                       mesh_arrays, touching_pairs)
from .exact import c2s, check_s

log = logging.getLogger(__name__)

__all__ = ["CompressedOperator", "stiffness_operator", "chebyshev_order"]

DEFAULT_TOL = 1e-8
DEFAULT_ETA = 1.0
DEFAULT_LEAF = 24


def chebyshev_order(tol: float) -> int:
    """Interpolation order per direction for a relative tolerance ``tol``."""
    tol = float(tol)
    if not (np.isfinite(tol) and 1e-14 <= tol < 1.0):
        raise ValueError(f"tol={tol!r} must be a number in [1e-14, 1)")
    # measured (tests/test_compressed.py, benchmarks/bench_compressed.py): the
    # relative matvec error falls by about 10 per order at eta = 1 and is below
    # 10^(1 - m) on the disk, square and L-shape for s in [0.1, 0.9]
    return int(min(14, max(3, math.ceil(-math.log10(tol) - 1e-9) - 1)))


def chebyshev_points(m: int) -> np.ndarray:
    """The m Chebyshev points of the first kind on [−1, 1]."""
    return np.cos((2.0 * np.arange(m) + 1.0) * np.pi / (2.0 * m))


# ---------------------------------------------------------------- trees


def cluster_tree(cent: np.ndarray, diam: np.ndarray, leaf_size: int,
                 root: tuple | None = None) -> dict:
    """Binary cluster tree of the element centroids on dyadic boxes.

    The root is a square around all centroids; a cluster's box is halved
    along its longer side (x first) until it holds at most ``leaf_size``
    elements, empty halves being skipped.  Every box is a dyadic rectangle
    (dx, dy, ix, iy): side L/2^dx by L/2^dy at integer position (ix, iy), so
    the coupling matrices of far blocks depend only on a few integers.
    ``root`` = (lower-left corner, side) shares one root square between the
    trees of sources and targets.  Built by :func:`fracfem._h2_kernels.split_tree`;
    :func:`cluster_tree_reference` is its plain-Python reference.
    """
    cent = np.ascontiguousarray(cent, dtype=np.float64)
    if root is None:
        root = square_around(cent)
    lo0, L = np.asarray(root[0], dtype=np.float64), float(root[1])
    (perm, start, end, parent, level, c0, c1, dyadic, tlo, thi,
     hmax) = hk.split_tree(cent, np.ascontiguousarray(diam, dtype=np.float64),
                           int(leaf_size), float(lo0[0]), float(lo0[1]), L)
    return _tree_dict(perm, start, end, parent, level, c0, c1, dyadic, tlo, thi, hmax,
                      lo0, L)


def _tree_dict(perm, start, end, parent, level, c0, c1, dyadic, tlo, thi, hmax, lo0, L):
    side = L / 2.0 ** dyadic[:, :2]
    blo = lo0 + dyadic[:, 2:] * side
    boxes = np.column_stack([blo + 0.5 * side, 0.5 * side])
    order = np.argsort(level, kind="stable")
    level_ptr = np.searchsorted(level[order], np.arange(level.max() + 2)).astype(np.int64)
    return dict(perm=perm, start=start, end=end, parent=parent, child0=c0, child1=c1,
                lo=blo, hi=blo + side, tlo=tlo, thi=thi, dyadic=dyadic,
                boxes=np.ascontiguousarray(boxes), hmax=hmax,
                level_nodes=order.astype(np.int64), level_ptr=level_ptr)


def cluster_tree_reference(cent: np.ndarray, diam: np.ndarray, leaf_size: int,
                           root: tuple | None = None) -> dict:
    """The tree of :func:`cluster_tree` (same arguments, same output), built
    cluster by cluster in plain Python: the reference of its numba kernel."""
    nt = len(cent)
    perm = np.arange(nt, dtype=np.int64)
    if root is None:
        root = square_around(cent)
    lo0, L = np.asarray(root[0], dtype=np.float64), float(root[1])
    start, end, parent, level, c0, c1, box = [0], [nt], [-1], [0], [], [], [[0, 0, 0, 0]]
    i = 0
    while i < len(start):
        a, b = start[i], end[i]
        c0.append(-1)
        c1.append(-1)
        if b - a > leaf_size:
            idx = perm[a:b]
            dx, dy, ix, iy = box[i]
            nl = 0
            while dx < 60 and dy < 60:      # no boxes below 2^-60 of the root
                dim = 0 if dx <= dy else 1
                if dim == 0:
                    mid = lo0[0] + (2 * ix + 1) * L / 2.0 ** (dx + 1)
                else:
                    mid = lo0[1] + (2 * iy + 1) * L / 2.0 ** (dy + 1)
                left = cent[idx, dim] < mid
                nl = int(left.sum())
                halves = [[dx + 1, dy, 2 * ix, iy], [dx + 1, dy, 2 * ix + 1, iy]] if dim == 0 \
                    else [[dx, dy + 1, ix, 2 * iy], [dx, dy + 1, ix, 2 * iy + 1]]
                if 0 < nl < len(idx):
                    break
                dx, dy, ix, iy = halves[0] if nl else halves[1]
            box[i] = [dx, dy, ix, iy]
            if not 0 < nl < len(idx):       # coincident centroids: keep as a leaf
                i += 1
                continue
            perm[a:b] = np.concatenate([idx[left], idx[~left]])
            for lo, hi, bx in ((a, a + nl, halves[0]), (a + nl, b, halves[1])):
                start.append(lo)
                end.append(hi)
                parent.append(i)
                level.append(level[i] + 1)
                box.append(bx)
            c0[i], c1[i] = len(start) - 2, len(start) - 1
        i += 1
    start = np.array(start, dtype=np.int64)
    end = np.array(end, dtype=np.int64)
    dyadic = np.array(box, dtype=np.int64)
    nc = len(start)
    # tight bounding boxes and largest element diameter of every cluster
    tlo = np.empty((nc, 2))
    thi = np.empty((nc, 2))
    hmax = np.empty(nc)
    for k in range(nc):
        idx = perm[start[k]:end[k]]
        pts = cent[idx]
        tlo[k], thi[k] = pts.min(0), pts.max(0)
        hmax[k] = diam[idx].max()
    return _tree_dict(perm, start, end, np.array(parent, dtype=np.int64),
                      np.array(level, dtype=np.int64), np.array(c0, dtype=np.int64),
                      np.array(c1, dtype=np.int64), dyadic, tlo, thi, hmax, lo0, L)


def square_around(*points: np.ndarray) -> tuple[np.ndarray, float]:
    """Lower-left corner and side of a square holding all the points."""
    allp = np.vstack(points)
    lo = allp.min(0)
    return lo, float((allp.max(0) - lo).max()) * (1.0 + 1e-9) + 1e-300


def block_keys(da: np.ndarray, db: np.ndarray, far: np.ndarray) -> np.ndarray:
    """Integer key of each far block: both boxes' dyadic depths and the offset
    of τ from σ in units of the finer resolution (equal keys, equal K; the
    two trees share one root square)."""
    a, b = da[far[:, 0]], db[far[:, 1]]
    D = np.maximum(a[:, :2], b[:, :2])
    off = (b[:, 2:] << (D - b[:, :2])) - (a[:, 2:] << (D - a[:, :2]))
    return np.column_stack([a[:, :2], b[:, :2], off])


def _box_distance(alo, ahi, blo, bhi):
    gap = np.maximum(0.0, np.maximum(alo - bhi, blo - ahi))
    return np.sqrt(np.sum(gap * gap, axis=-1))


def block_tree(ta: dict, tb: dict, eta: float, ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """Admissible (far) and inadmissible leaf (near) blocks (σ of ta, τ of tb),
    as (n, 2) arrays; with ta = tb both orders of every pair are listed."""
    def side(tree):
        lo, hi = tree["lo"], tree["hi"]
        return (lo, hi, tree["tlo"], tree["thi"], tree["hmax"], tree["child0"],
                tree["child1"], np.sqrt(np.sum((hi - lo) ** 2, axis=1)))
    alo, ahi, atlo, athi, ahmax, ac0, ac1, adiam = side(ta)
    blo, bhi, btlo, bthi, bhmax, bc0, bc1, bdiam = side(tb)
    far, near = [], []
    a = np.array([0])
    b = np.array([0])
    while a.size:
        # interpolation needs separated boxes; the Taylor rule of the dense
        # assembly needs every centroid pair R·h apart
        adm = ((_box_distance(alo[a], ahi[a], blo[b], bhi[b])
                >= np.maximum(adiam[a], bdiam[b]) / eta)
               & (_box_distance(atlo[a], athi[a], btlo[b], bthi[b])
                  >= ratio * np.maximum(ahmax[a], bhmax[b])))
        far.append(np.column_stack([a[adm], b[adm]]))
        a, b = a[~adm], b[~adm]
        la, lb = ac0[a] < 0, bc0[b] < 0
        leaf = la & lb
        near.append(np.column_stack([a[leaf], b[leaf]]))
        # split every non-leaf side (both when both are clusters)
        na, nb_ = [], []
        a, b, la, lb = a[~leaf], b[~leaf], la[~leaf], lb[~leaf]
        ca = [np.where(la, a, ac0[a]), np.where(la, a, ac1[a])]
        cb = [np.where(lb, b, bc0[b]), np.where(lb, b, bc1[b])]
        for i, x in enumerate(ca):
            for j, y in enumerate(cb):
                keep = np.ones(len(a), dtype=bool)
                if i == 1:
                    keep &= ~la          # a leaf side has one "child": itself
                if j == 1:
                    keep &= ~lb
                na.append(x[keep])
                nb_.append(y[keep])
        a = np.concatenate(na) if na else np.array([], dtype=np.int64)
        b = np.concatenate(nb_) if nb_ else np.array([], dtype=np.int64)
    return (np.concatenate(far).astype(np.int64), np.concatenate(near).astype(np.int64))


# ---------------------------------------------------------------- κ

KAPPA_RATIO = 13.0   # the exterior kernel's two-point rule holds beyond 12 edge lengths
# leaves of κ's two trees (benchmarks/kappa.md), apart from the operator's: small source
# leaves (Gauss points on ∂Ω) make blocks admissible closer to ∂Ω, so fewer edges are summed
# directly; large target leaves make fewer blocks where the points are dense (the
# assembly's: hundreds per element at ∂Ω), though larger target boxes sum more directly
KAPPA_SOURCE_LEAF = 12
KAPPA_TARGET_LEAF = 192


def operator_kappa(edges: np.ndarray, s: float, order: int, eta: float, *,
                   source_leaf: int = KAPPA_SOURCE_LEAF,
                   target_leaf: int = KAPPA_TARGET_LEAF) -> "CompressedKappa":
    """κ as :func:`stiffness_operator` evaluates it for the exterior term, given the
    operator's Chebyshev ``order`` and ``eta``: κ comes from the far field alone away from
    ∂Ω, undiluted by the near field, so it takes one more order and half the eta (measured:
    relative error ≤ 1e-8 at order 7 with eta 0.5, ≤ 1e-9 at order 8)."""
    return CompressedKappa(edges, s, order=min(order + 1, 14), eta=0.5 * eta,
                           source_leaf=source_leaf, target_leaf=target_leaf)


def cos_power_series(s: float, degree: int = 24) -> tuple[np.ndarray, np.ndarray]:
    """Chebyshev coefficients (in 4y − 1, y ∈ [0, 1/2]) of
    Q(y) = ∫₀¹ (1 − y x²)^(s−1/2) dx and R(y) = ∫₀¹ z^(2s) (1 − y z²)^(−1/2) dz,
    so that ∫₀^φ cos^(2s) = v·Q(v²) (v = sin φ, v² ≤ 1/2) and
    ∫_φ^(π/2) cos^(2s) = c^(2s+1) R(c²) (c = cos φ, c² ≤ 1/2).  Both are
    analytic in a Bernstein ellipse of parameter 3 + √8 (singular at y = 1):
    degree 24 leaves an interpolation error near 1e-17.  Sampled by
    40-point Gauss–Legendre and Gauss–Jacobi rules (smooth integrands)."""
    from numpy.polynomial import chebyshev
    from scipy.special import roots_jacobi

    from .quadrature import gauss01
    gx, gw = gauss01(40)
    jt, jw = roots_jacobi(40, 0.0, 2.0 * s)          # weight (1 + t)^(2s) on [−1, 1]
    jx, jw = 0.5 * (jt + 1.0), jw / 2.0 ** (2.0 * s + 1.0)

    def q(xi):
        y = (np.atleast_1d(xi)[:, None] + 1.0) / 4.0
        return np.sum(gw * (1.0 - y * gx ** 2) ** (s - 0.5), axis=1)

    def r(xi):
        y = (np.atleast_1d(xi)[:, None] + 1.0) / 4.0
        return np.sum(jw * (1.0 - y * jx ** 2) ** -0.5, axis=1)

    return (np.ascontiguousarray(chebyshev.chebinterpolate(q, degree)),
            np.ascontiguousarray(chebyshev.chebinterpolate(r, degree)))


class CompressedKappa:
    """κ(x) = ∫_{Ωᶜ}|x − y|^(−2−2s) dy at many points, equal to
    :func:`fracfem.assembly.exterior_kernel` up to the compression error.

    2s·κ(x) is a sum over boundary edges; beyond 12 edge lengths the exterior
    kernel takes two Gauss points y per edge, each contributing
    (ℓ/2) n·(y − x) |y − x|^(−2−2s).  Those terms are summed by two H² passes,
    one per component of n (kernels (y − x)_d |y − x|^(−2−2s), sources the
    Gauss points with weights (ℓ/2) n_d), every other term directly.
    ``source_leaf``: Gauss points per leaf of the source tree; ``target_leaf``:
    points x per leaf of the target tree.
    """

    def __init__(self, edges: np.ndarray, s: float, *, order: int, eta: float,
                 source_leaf: int = KAPPA_SOURCE_LEAF, target_leaf: int = KAPPA_TARGET_LEAF):
        from scipy.special import gamma

        from .quadrature import gauss01
        for name, value in (("source_leaf", source_leaf), ("target_leaf", target_leaf)):
            if not (isinstance(value, (int, np.integer)) and not isinstance(value, bool)
                    and 1 <= value <= 4096):
                raise ValueError(f"{name}={value!r} must be an integer in [1, 4096]")
        self.edges = np.ascontiguousarray(edges, dtype=np.float64)
        self.s, self.order, self.eta = float(s), order, eta
        self.source_leaf, self.target_leaf = int(source_leaf), int(target_leaf)
        a, b = self.edges[:, :2], self.edges[:, 2:]
        g2 = gauss01(2)[0]
        self.points = np.vstack([a + g2[0] * (b - a), a + g2[1] * (b - a)])
        ne = len(edges)
        self.src_edge = np.concatenate([np.arange(ne), np.arange(ne)]).astype(np.int64)
        self.src_g = np.repeat(np.arange(2, dtype=np.int64), ne)
        ln = np.linalg.norm(b - a, axis=1)
        nrm = np.column_stack([b[:, 1] - a[:, 1], a[:, 0] - b[:, 0]]) / ln[:, None]
        src = np.zeros((2, 2 * ne, 1, 6))
        for d in range(2):
            src[d, :, 0, 0] = np.tile(0.5 * ln * nrm[:, d], 2)
        self.src = src
        self.ln = np.tile(ln, 2)
        self.rules = (*cos_power_series(s),
                      0.5 * np.sqrt(np.pi) * gamma(s + 0.5) / gamma(s + 1.0),
                      *gauss01(4), g2)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        x = np.ascontiguousarray(x, dtype=np.float64)
        root = square_around(x, self.points)
        tt = cluster_tree(x, np.zeros(len(x)), self.target_leaf, root)
        ts = cluster_tree(self.points, self.ln, self.source_leaf, root)
        far, near = block_tree(tt, ts, self.eta, KAPPA_RATIO)
        out = far_values(tt, ts, far, x, self.points, self.order, -1.0 - self.s, self.src,
                         comps=(0, 1))[:, 0] / (2.0 * self.s)
        rows, ptr, cols = near_lists(near)
        hk.kappa_near(x, tt["perm"], tt["start"], ptr, rows, cols, tt["end"], ts["perm"],
                      ts["start"], ts["end"], self.src_edge, self.src_g, self.edges, self.s,
                      *self.rules, out)
        return out


def near_lists(near: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Near blocks (n, 2) by row cluster: rows (r,), ptr (r + 1,) and cols, the
    blocks of rows[i] being (rows[i], cols[ptr[i]:ptr[i+1]])."""
    nr = near[np.lexsort((near[:, 1], near[:, 0]))]
    rows, ptr = np.unique(nr[:, 0], return_index=True)
    return (rows.astype(np.int64), np.append(ptr, len(nr)).astype(np.int64),
            np.ascontiguousarray(nr[:, 1], dtype=np.int64))


def far_values(tt: dict, ts: dict, far: np.ndarray, x: np.ndarray, points: np.ndarray,
               order: int, expo: float, src: np.ndarray, comps=(-1,),
               logl0: float = 0.0, batch_bytes: int | None = None) -> np.ndarray:
    """Σ over the admissible blocks (targets x of tt, sources ``points`` of ts)
    of Σ_j src[c, j] k_c(y_j − x_i), one kernel k_c per entry c of ``comps``
    (see :func:`fracfem._h2_kernels.coupling_matrices`) and src (len(comps),
    n_sources, nrhs, 6) source functionals (nrhs right-hand sides); returns
    (n_targets, nrhs) values.

    Used once, the coupling matrices are never all held: they are made for
    one kernel and one batch of block geometries at a time, at most
    ``batch_bytes`` (default ``FAR_BATCH_BYTES``) of them, and dropped after
    their products.  The sums are those of the stored path up to the order
    of summation (tested)."""
    out = np.zeros((len(x), src.shape[2]))
    if not len(far):
        return out
    batch_bytes = FAR_BATCH_BYTES if batch_bytes is None else int(batch_bytes)
    if batch_bytes < 1:
        raise ValueError(f"batch_bytes={batch_bytes!r} must be a positive number of bytes")
    z = chebyshev_points(order)
    f = _far_blocks(tt, ts, far, _tree_data(tt, x, z), _tree_data(ts, points, z), z, expo,
                    comps=comps, logl0=logl0, lazy=True)
    per = max(1, batch_bytes // (8 * len(z) ** 4))
    for c, comp in enumerate(comps):
        out += _far_pass(f, src[c], nder=1, lazy=(comp, per))[:, :, 0]
    return out


FAR_BATCH_BYTES = 128 * 2**20


# ---------------------------------------------------------------- operator


# a block of :meth:`CompressedOperator._matmat`: at most this many columns (the near field
# is read once for them; larger blocks were no faster in benchmarks/matvec.md), whose
# far-field work arrays take at most this many bytes
MATMAT_COLUMNS = 8
MATMAT_BYTES = 256 * 2**20


class CompressedOperator(spla.LinearOperator):
    """Free-node stiffness operator: ``op @ x``, ``op.diagonal()``, ``op.nbytes``."""

    def __init__(self, near: sp.csr_matrix, far: dict, free: np.ndarray, nv: int,
                 t: np.ndarray, info: dict, leaf_matrix: sp.csr_matrix | None = None):
        n = len(free)
        super().__init__(dtype=np.float64, shape=(n, n))
        self.near = near
        self._far = far
        self.free = free
        self._nv = nv
        self._t = t
        self.info = info
        self.leaf_matrix = leaf_matrix

    @property
    def nbytes(self) -> int:
        """Bytes held by the representation (sparse near field, H² data,
        leaf matrix)."""
        n = sum(_csr_bytes(a) for a in (self.near, self.leaf_matrix) if a is not None)
        return int(n + sum(v.nbytes for v in self._far.values()
                           if isinstance(v, np.ndarray))
                   + sum(v.nbytes for v in self._far["tgt"].values()
                         if isinstance(v, np.ndarray)))

    def diagonal(self) -> np.ndarray:
        """The diagonal: far blocks couple no node with itself, so only the
        far-field diagonal terms carry the compression error."""
        return self.near.diagonal()

    def far_matvec(self, x: np.ndarray) -> np.ndarray:
        """The admissible-block part alone (free nodes).

        With the leaf matrix M (:func:`leaf_matrix`) the leaf moments are
        W = M x and the result is −c Mᵀ(G₀ + G₁, G₀) of the leaf expansions
        G = (G₀, G₁): the evaluation functionals are those of the moments,
        the value sources' expansion taking every functional and the other
        one the value alone.  Without it, :meth:`far_matvec_reference`."""
        M = self.leaf_matrix
        if M is None:
            return self.far_matvec_reference(x)
        leaves = self._far["src"]["leaves"]
        p = self._far["z"].shape[0] ** 2
        G = self._leaf_expansions(_csr_matvec(M, x).reshape(len(leaves), 2, p))
        G1 = G[:, 1].copy()
        G[:, 1] = G[:, 0]
        G[:, 0] += G1
        return -self._far["c"] * _csr_rmatvec(M, G.reshape(-1))

    def _leaf_expansions(self, moments: np.ndarray) -> np.ndarray:
        """The leaf clusters' moments (leaves, nrhs, m²) through the cluster tree: upward,
        the coupling of the admissible blocks, downward; returns the leaf clusters'
        expansions, in the same layout (each of the nrhs rows on its own)."""
        f = self._far
        S, T, m = f["src"], f["tgt"], f["z"].shape[0]
        leaves = S["leaves"]
        W = np.zeros((len(S["boxes"]),) + moments.shape[1:])
        W[leaves] = moments
        hk.upward(W, S["E"], S["level_nodes"], S["level_ptr"], S["child0"], S["child1"], m)
        G = _couple(f, W, None, None)
        del W
        hk.downward(G, T["E"], T["level_nodes"], T["level_ptr"], T["child0"], T["child1"],
                    m)
        return G[leaves]

    def far_matvec_reference(self, x: np.ndarray) -> np.ndarray:
        """:meth:`far_matvec` through element sources and the leaf kernels
        (:func:`fracfem._h2_kernels.leaf_moments`, ``leaf_evaluate``), without
        the leaf matrix: its reference."""
        f = self._far
        xa = np.zeros(self._nv)
        xa[self.free] = x
        xe = xa[self._t]                                   # (Nt, 3)
        sx = xe.sum(1)
        gu = np.einsum("tad,ta->td", f["grad"], xe)         # ∇u_h on T
        mom = f["mom"]
        src = np.zeros((len(xe), 2, 6))
        src[:, 0, 0] = f["area"] / 3.0 * sx
        src[:, 1, 1] = mom[:, 0] * gu[:, 0] + mom[:, 1] * gu[:, 1]
        src[:, 1, 2] = mom[:, 1] * gu[:, 0] + mom[:, 2] * gu[:, 1]
        src[:, 1, 3:6] = mom * (sx / 6.0)[:, None]
        out = _far_pass(f, src)
        g1, g2 = out[:, 0], out[:, 1]
        # (1/6) M:∇²G1, (M∇λ_a)·∇G1
        mh = (mom[:, 0] * g1[:, 3] + 2.0 * mom[:, 1] * g1[:, 4] + mom[:, 2] * g1[:, 5]) / 6.0
        mg = np.column_stack([mom[:, 0] * g1[:, 1] + mom[:, 1] * g1[:, 2],
                              mom[:, 1] * g1[:, 1] + mom[:, 2] * g1[:, 2]])
        ye = (f["area"] / 3.0 * (g1[:, 0] + g2[:, 0]) + mh)[:, None] \
            + np.einsum("tad,td->ta", f["grad"], mg)
        ye *= -f["c"]
        y = np.bincount(self._t.ravel(), weights=ye.ravel(), minlength=self._nv)
        return y[self.free]

    def near_matvec(self, x: np.ndarray) -> np.ndarray:
        """The sparse near-field part alone, ``near @ x`` on all threads."""
        return _csr_matvec(self.near, x)

    def _matvec(self, x):
        x = np.asarray(x, dtype=np.float64).reshape(-1)
        return self.near_matvec(x) + self.far_matvec(x)

    def _matmat(self, X):
        """``op @ X`` for X (n, k): the near field and the leaf matrix read once for
        a block of columns, the far field's coupling one matrix product per group for
        all of them; the columns in blocks whose far-field work arrays take at most
        :data:`MATMAT_BYTES`.  Equal to k products ``op @ X[:, j]`` up to the order
        of summation."""
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2 or X.shape[0] != self.shape[1]:
            raise ValueError(f"X must have shape ({self.shape[1]}, k), got {X.shape}")
        k = X.shape[1]
        if k == 0 or self.leaf_matrix is None:
            return np.column_stack([self._matvec(X[:, j]) for j in range(k)]) if k \
                else np.zeros((self.shape[0], 0))
        block = self.matmat_block()
        out = np.empty((self.shape[0], k))
        for j0 in range(0, k, block):
            Xb = np.ascontiguousarray(X[:, j0:j0 + block])
            out[:, j0:j0 + block] = self._near_matmat(Xb) + self._far_matmat(Xb)
        return out

    def _rmatmat(self, X):
        return self._matmat(X)

    def matmat_block(self) -> int:
        """Columns per block of :meth:`_matmat`: its far-field work arrays within
        MATMAT_BYTES.  Per column: the clusters' expansions (2 × m² values each) in the
        moments, in every thread's sums of the coupling and in their total, and every
        thread's gathered moments of its largest group of blocks and their product."""
        import numba
        f = self._far
        p = f["z"].shape[0] ** 2
        nth = numba.get_num_threads()
        most = int(np.diff(f["grp_ptr"]).max(initial=1))
        per_column = 8 * 2 * p * (len(f["tgt"]["boxes"]) * (nth + 2) + 2 * nth * most)
        return int(max(1, min(MATMAT_COLUMNS, MATMAT_BYTES // max(per_column, 1))))

    def _near_matmat(self, X):
        import numba
        A = self.near
        return hk.csr_block_product(A.indptr, A.indices, A.data, X, A.shape[1], False,
                                    numba.get_num_threads())

    def _far_matmat(self, X):
        """:meth:`far_matvec` for the columns of X (n, k): column j's two expansions
        are rows 2j, 2j + 1 of the clusters' work arrays."""
        import numba
        M = self.leaf_matrix
        nl = len(self._far["src"]["leaves"])
        p = self._far["z"].shape[0] ** 2
        k = X.shape[1]
        nth = numba.get_num_threads()
        MX = hk.csr_block_product(M.indptr, M.indices, M.data, X, M.shape[1], False, nth)
        Gl = self._leaf_expansions(
            MX.reshape(nl, 2, p, k).transpose(0, 3, 1, 2).reshape(nl, 2 * k, p)
        ).reshape(nl, k, 2, p)
        del MX
        out = np.empty((nl, 2, p, k))          # (G₀ + G₁, G₀) as in far_matvec
        out[:, 0] = (Gl[:, :, 0] + Gl[:, :, 1]).transpose(0, 2, 1)
        out[:, 1] = Gl[:, :, 0].transpose(0, 2, 1)
        Y = hk.csr_block_product(M.indptr, M.indices, M.data, out.reshape(-1, k),
                                 M.shape[1], True, nth)
        return -self._far["c"] * Y

    def _rmatvec(self, x):
        return self._matvec(x)


def _csr_matvec(A: sp.csr_matrix, x: np.ndarray) -> np.ndarray:
    """A @ x on all threads (scipy's product runs on one)."""
    import numba
    return hk.csr_matvec(A.indptr, A.indices, A.data,
                         np.ascontiguousarray(x, dtype=np.float64), numba.get_num_threads())


def _csr_rmatvec(A: sp.csr_matrix, g: np.ndarray) -> np.ndarray:
    """Aᵀ @ g on all threads."""
    import numba
    return hk.csr_rmatvec(A.indptr, A.indices, A.data,
                          np.ascontiguousarray(g, dtype=np.float64), A.shape[1],
                          numba.get_num_threads())


def _csr_bytes(a: sp.csr_matrix) -> int:
    return int(a.data.nbytes + a.indices.nbytes + a.indptr.nbytes)


def leaf_matrix(far: dict, t: np.ndarray, free: np.ndarray, nv: int) -> sp.csr_matrix:
    """The sparse matrix M (2·p rows per leaf cluster, one column per free
    node) of the leaf moments of the far field (see
    :func:`fracfem._h2_kernels.leaf_source_matrix`); ``far`` is the H² data
    of :func:`stiffness_operator` with the element moments."""
    S = far["src"]
    p = len(far["z"]) ** 2
    node_index = np.full(nv, -1, dtype=np.int64)
    node_index[free] = np.arange(len(free))
    indptr, indices, data = hk.leaf_source_matrix(
        np.ascontiguousarray(t, dtype=np.int64), S["perm"], S["leaves"], S["start"],
        S["end"], S["boxes"], far["z"], S["cent"], far["area"], far["mom"], far["grad"],
        node_index)
    if len(data) < np.iinfo(np.int32).max and len(free) < np.iinfo(np.int32).max:
        indptr, indices = indptr.astype(np.int32), indices.astype(np.int32)
    M = sp.csr_matrix((data, indices, indptr), shape=(len(S["leaves"]) * 2 * p, len(free)),
                      copy=False)
    M.has_sorted_indices = True
    return M


def _tree_data(tree: dict, points: np.ndarray, z: np.ndarray) -> dict:
    """What the H² passes need of one cluster tree."""
    return dict(boxes=tree["boxes"], cent=points, perm=tree["perm"],
                leaves=np.flatnonzero(tree["child0"] < 0).astype(np.int64),
                start=tree["start"], end=tree["end"], child0=tree["child0"],
                child1=tree["child1"], level_nodes=tree["level_nodes"],
                level_ptr=tree["level_ptr"], E=hk.transfers(tree["boxes"], tree["parent"], z))


def _unique_rows(keys: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """First index and inverse of np.unique(keys, axis=0) for integer rows,
    through one mixed-radix int64 per row when the column ranges allow (the
    same lexicographic order, an order of magnitude faster)."""
    if not len(keys):
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    lo = keys.min(axis=0)
    span = keys.max(axis=0) - lo + 1
    if math.prod(int(r) for r in span) >= 2 ** 62:
        _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
        return first, inverse.reshape(-1)
    packed = np.zeros(len(keys), dtype=np.int64)
    for c in range(keys.shape[1]):
        packed = packed * span[c] + (keys[:, c] - lo[c])
    _, first, inverse = np.unique(packed, return_index=True, return_inverse=True)
    return first, inverse


def _far_blocks(tt: dict, ts: dict, far: np.ndarray, tdata: dict, sdata: dict,
                z: np.ndarray, expo: float, comps=(-1,), logl0: float = 0.0,
                lazy: bool = False) -> dict:
    """Admissible blocks grouped by target cluster, with one coupling matrix per
    block geometry for each kernel: |r|^(2·expo) (comp −1), r_comp |r|^(2·expo)
    (comp 0, 1) or (|r|^(2·expo) − ℓ₀^(2·expo))/(−2·expo) (comp 2, ℓ₀ = e^logl0);
    with several comps K is a list, one array per comp.  ``lazy``: no K; the
    first block of each geometry is kept (``first_rows``, ``first_cols``) so
    that :func:`_far_pass` makes the matrices batch by batch."""
    fr = far
    first, inverse = _unique_rows(block_keys(tt["dyadic"], ts["dyadic"], fr))
    # blocks grouped by coupling matrix
    inverse = inverse.reshape(-1)
    order = np.argsort(inverse, kind="stable")
    grp_ptr = np.searchsorted(inverse[order], np.arange(len(first) + 1)).astype(np.int64)
    out = dict(z=z, tgt=tdata, src=sdata, grp_ptr=grp_ptr, grp_rows=fr[order, 0].copy(),
               grp_cols=fr[order, 1].copy(), expo=expo, logl0=logl0,
               first_rows=fr[first, 0].copy(), first_cols=fr[first, 1].copy())
    if lazy:
        out["K"] = None
        return out
    K = [hk.coupling_matrices(tdata["boxes"], sdata["boxes"], out["first_rows"],
                              out["first_cols"], z, expo, comp, logl0) for comp in comps]
    out["K"] = K[0] if len(K) == 1 else K
    return out


_BLAS = None


def _blas_one_thread():
    """A context in which BLAS runs on one thread.

    :func:`fracfem._h2_kernels.couple_grouped` calls BLAS from each of its
    numba threads; a BLAS that threads every call on top of that oversubscribes
    the cores (``couple_s`` against ``couple_blas_threads_s`` in
    ``benchmarks/matvec.md``)."""
    global _BLAS
    if _BLAS is None:
        import scipy.linalg.cython_blas  # noqa: F401  (numba's np.dot calls this BLAS)
        from threadpoolctl import ThreadpoolController
        _BLAS = ThreadpoolController()
    return _BLAS.limit(limits=1, user_api="blas")


def _couple(f: dict, W: np.ndarray, K: np.ndarray | None, lazy) -> np.ndarray:
    """G[σ] = Σ_τ K_(σ,τ) W[τ] over the admissible blocks: with the stored K,
    or (``lazy`` = (comp, geometries per batch)) batch by batch."""
    with _blas_one_thread():
        return _couple_blocks(f, W, K, lazy)


def _couple_blocks(f: dict, W: np.ndarray, K: np.ndarray | None, lazy) -> np.ndarray:
    import numba
    nc, nth = len(f["tgt"]["boxes"]), numba.get_num_threads()
    ptr, rows, cols = f["grp_ptr"], f["grp_rows"], f["grp_cols"]
    if lazy is None:
        G = hk.couple_grouped(W, f["K"] if K is None else K, ptr, rows, cols, nc, nth)
        return G[0] if nth == 1 else G.sum(axis=0)
    comp, per = lazy
    G = np.zeros((nc, W.shape[1], W.shape[2]))
    for g0 in range(0, len(ptr) - 1, per):
        g1 = min(g0 + per, len(ptr) - 1)
        Kb = hk.coupling_matrices(f["tgt"]["boxes"], f["src"]["boxes"],
                                  f["first_rows"][g0:g1].copy(),
                                  f["first_cols"][g0:g1].copy(), f["z"], f["expo"], comp,
                                  f["logl0"])
        b0, b1 = ptr[g0], ptr[g1]
        G += hk.couple_grouped(W, Kb, ptr[g0:g1 + 1] - b0, rows[b0:b1], cols[b0:b1], nc,
                               nth).sum(axis=0)
        del Kb
    return G


def _far_pass(f: dict, src: np.ndarray, K: np.ndarray | None = None,
              nder: int = 6, lazy=None) -> np.ndarray:
    """Σ over admissible blocks of the kernel applied to source functionals
    (src (n_sources, nrhs, 6)); returns value, gradient and Hessian of the
    result at every target point (n_targets, nrhs, 6; only the first ``nder``
    of them computed, the others zero).  ``lazy`` as in :func:`_couple`."""
    S, T, z = f["src"], f["tgt"], f["z"]
    m = z.shape[0]
    nrhs = src.shape[1]
    W = np.zeros((len(S["boxes"]), nrhs, m * m))
    hk.leaf_moments(src, S["cent"], S["perm"], S["leaves"], S["start"], S["end"],
                    S["boxes"], z, W)
    hk.upward(W, S["E"], S["level_nodes"], S["level_ptr"], S["child0"], S["child1"], m)
    G = _couple(f, W, K, lazy)
    hk.downward(G, T["E"], T["level_nodes"], T["level_ptr"], T["child0"], T["child1"], m)
    out = np.zeros((len(T["cent"]), nrhs, 6))
    hk.leaf_evaluate(G, T["cent"], T["perm"], T["leaves"], T["start"], T["end"],
                     T["boxes"], z, out, nder)
    return out


def _leaf_nodes(tree: dict, t: np.ndarray, nv: int) -> sp.csr_matrix:
    """Cluster × node incidence (int8, ones) of the leaf clusters: row c holds
    the nodes of the elements of leaf c; the rows of other clusters are empty."""
    nc = len(tree["start"])
    perm = tree["perm"]
    owner = np.empty(len(t), dtype=np.int64)
    leaves = np.flatnonzero(tree["child0"] < 0)
    for c in leaves:
        owner[perm[tree["start"][c]:tree["end"][c]]] = c
    inc = sp.csr_matrix((np.ones(3 * len(t), dtype=np.int8),
                         (np.repeat(owner, 3), t.ravel())), shape=(nc, nv))
    inc.data[:] = 1
    inc.sum_duplicates()
    inc.data[:] = 1
    return inc


def _near_pattern(tree: dict, near: np.ndarray, t: np.ndarray, nv: int,
                  inc: sp.csr_matrix | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Node pairs of the near blocks (structure only): CSR ``indptr`` (int64)
    and sorted ``indices`` (int32 while the node numbers allow), both arrays of
    their own, so that :func:`_restrict_arrays` compacts them in place.
    ``inc``: the leaves' node incidence (:func:`_leaf_nodes`) if already built."""
    nc = len(tree["start"])
    inc = _leaf_nodes(tree, t, nv) if inc is None else inc
    nb = sp.csr_matrix((np.ones(len(near), dtype=np.int8), (near[:, 0], near[:, 1])),
                       shape=(nc, nc))
    pat = (inc.T.tocsr().astype(np.int32) @ (nb.astype(np.int32) @ inc.astype(np.int32)))
    pat = pat.tocsr()
    pat.sort_indices()
    indptr = pat.indptr.astype(np.int64)
    indices = np.array(pat.indices, dtype=np.int32 if nv < 2 ** 31 else np.int64)
    del pat
    return indptr, indices


def _row_classes(tree: dict, rows: np.ndarray, t: np.ndarray, nv: int,
                 inc: sp.csr_matrix | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Classes of the near blocks' row clusters ``rows`` (leaves, as in
    :func:`block_tree`) in which no two clusters have a node in common, for
    :func:`fracfem._kernels.near_pairs` to write the values of one class's rows
    from several threads into one array: (order, ptr), the classes being
    rows-indices order[ptr[k]:ptr[k+1]], each in increasing order.  ``inc``:
    the leaves' node incidence (:func:`_leaf_nodes`) if already built."""
    rows = np.asarray(rows, dtype=np.int64)
    if len(rows) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(1, dtype=np.int64)
    if np.any(tree["child0"][rows] >= 0):
        raise ValueError("near blocks' row clusters must be leaves (block_tree's)")
    inc = _leaf_nodes(tree, t, nv) if inc is None else inc
    R = inc[rows].astype(np.int32)
    G = (R @ R.T).tocsr()
    colour = hk.greedy_colouring(G.indptr.astype(np.int64), G.indices.astype(np.int64))
    order = np.argsort(colour, kind="stable")
    ptr = np.concatenate([[0], np.cumsum(np.bincount(colour))]).astype(np.int64)
    return order.astype(np.int64), ptr


def _restrict(A: sp.csr_matrix, free: np.ndarray) -> sp.csr_matrix:
    """A[free][:, free] for increasing ``free``, compacting A's arrays in place:
    no second copy of the values at the peak.  A is spent, and no other view
    of its arrays may exist (the values are shrunk in place)."""
    return _restrict_arrays(A.indptr, A.indices, A.data, free, A.shape[0],
                            A.has_sorted_indices)


def _restrict_arrays(indptr: np.ndarray, indices: np.ndarray, data: np.ndarray,
                     free: np.ndarray, n: int, sorted_indices: bool = True) -> sp.csr_matrix:
    """:func:`_restrict` of the CSR arrays of an n × n matrix (spent)."""
    if len(free) > 1 and not np.all(np.diff(free) > 0):
        A = sp.csr_matrix((data, indices, indptr), shape=(n, n))
        return A[free][:, free].tocsr()
    new_index = np.full(n, -1, dtype=np.int64)
    new_index[free] = np.arange(len(free))
    ptr, nnz = hk.restrict_csr_inplace(indptr, indices, data, new_index)
    arrays = []
    for a in (data, indices):
        if a.flags.owndata:
            a.resize(nnz, refcheck=False)   # shrinks in place: nbytes stays honest
        else:
            a = a[:nnz].copy()
        arrays.append(a)
    out = sp.csr_matrix((arrays[0], arrays[1], ptr), shape=(len(free), len(free)),
                        copy=False)
    out.has_sorted_indices = sorted_indices
    return out


def _near_field(p, t, tree, near, quad, s, geometry, moments, *,
                per_thread_copies: bool = False, nchunks: int | None = None):
    """Pattern and one-sided values S of the near blocks' separated pairs
    (:func:`fracfem._kernels.near_pairs`, unscaled, the transpose not yet
    added), their per-element far-field sums D and the rules' Lagrange values.

    The threads write into one array of values, taking the row clusters a
    class of :func:`_row_classes` at a time: the values' peak is their final
    size, 12 bytes per entry while nnz < 2^31, whatever the threads, and they
    do not depend on the threads.  D is per thread (8·(nq_total + 4) bytes per
    element each, where the values take 12 bytes per entry and an element has
    hundreds to thousands of them), as are the positions of three rows (24
    bytes per node each).
    ``per_thread_copies`` is its reference: every row cluster in one class,
    a private copy of the values per thread, summed in thread order
    ((8·threads + 4) bytes per entry at the peak).  ``nchunks``: how many
    parts the kernel's parallel loop has (default: numba's threads)."""
    import numba

    nv = len(p)
    area2, cent, diam = geometry
    area, mom, grad = moments
    inc = _leaf_nodes(tree, t, nv)          # built once, for the pattern and the classes
    indptr, indices = _near_pattern(tree, near, t, nv, inc)
    qx, qw, lam, offs = _far_rules(p, t, quad.far_orders, area2)
    nchunks = numba.get_num_threads() if nchunks is None else int(nchunks)
    if nchunks < 1:
        raise ValueError(f"nchunks={nchunks!r} must be at least 1")
    rows, ptr, cols = near_lists(near)
    if per_thread_copies:
        order = np.arange(len(rows), dtype=np.int64)
        cptr = np.array([0, len(rows)], dtype=np.int64)
        data = np.zeros((nchunks, len(indices)))
    else:
        order, cptr = _row_classes(tree, rows, t, nv, inc)
        data = np.zeros((1, len(indices)))
    del inc
    D = _kernels.near_pairs(t, tree["perm"], tree["start"], tree["end"], ptr, rows, cols,
                            cent, diam, area, mom, grad, qx, qw, lam, offs,
                            np.asarray(quad.far_thresholds, dtype=np.float64), True, s,
                            indptr, indices, nv, order, cptr, nchunks, data)
    del qx, qw
    for k in range(1, data.shape[0]):
        data[0] += data[k]
    data.resize(len(indices), refcheck=False)   # the first row, in place
    return indptr, indices, data, D, lam


def stiffness_operator(mesh, s: float, *, tol: float = DEFAULT_TOL,
                       quadrature: QuadratureOptions | None = None,
                       eta: float = DEFAULT_ETA, leaf_size: int = DEFAULT_LEAF,
                       order: int | None = None,
                       leaf_matrices: bool = True) -> CompressedOperator:
    """Compressed free-node stiffness operator (interior nodes in
    ``mesh.interior_nodes()`` order).

    Parameters
    ----------
    mesh : skfem.MeshTri of a polygon
    s : fractional order in (0, 1)
    tol : relative accuracy of the far-field interpolation, in [1e-14, 1)
    quadrature : the rules of the dense assembly it reproduces
    eta : admissibility max(diam) ≤ eta·dist, in (0, 4]
    leaf_size : elements per leaf cluster, in [4, 512] (the exterior term's κ
        has trees of its own: :func:`operator_kappa`)
    order : Chebyshev points per direction (overrides ``tol``), in [2, 14]
    leaf_matrices : hold the sparse matrix from free-node values to leaf
        moments (:func:`leaf_matrix`, about a fifth more memory) so that a
        product spends no time on the Chebyshev bases of the elements; False
        keeps :meth:`CompressedOperator.far_matvec_reference` as the product
    """
    s = check_s(s)
    m = chebyshev_order(tol) if order is None else int(order)
    if not 2 <= m <= 14:
        raise ValueError(f"order={order!r} must be an integer in [2, 14]")
    if not (np.isfinite(eta) and 0.0 < eta <= 4.0):
        raise ValueError(f"eta={eta!r} must be in (0, 4]")
    if not (isinstance(leaf_size, (int, np.integer)) and 4 <= leaf_size <= 512):
        raise ValueError(f"leaf_size={leaf_size!r} must be an integer in [4, 512]")
    quad = quadrature or QuadratureOptions()
    if quad.far_orders[0] != 0:
        raise ValueError("the compressed operator needs the Taylor rule for the farthest "
                         f"class: QuadratureOptions.far_orders[0] = 0, got {quad.far_orders!r}")
    p, t = mesh_arrays(mesh)
    nv, nt = len(p), len(t)
    c = c2s(s)
    tim = {}
    t0 = time.perf_counter()

    geometry = _element_geometry(p, t)
    _, cent, diam = geometry
    area, mom, grad = _element_moments(p, t)
    tree = cluster_tree(cent, diam, int(leaf_size))
    far, near = block_tree(tree, tree, float(eta), float(quad.far_thresholds[0]))
    tim["trees"] = time.perf_counter() - t0

    t1 = time.perf_counter()
    indptr, indices, data, D, lam = _near_field(p, t, tree, near, quad, s, geometry,
                                                (area, mom, grad))
    hk.symmetrize_csr_inplace(indptr, indices, data)
    data *= c
    D = D.sum(axis=0)
    tim["near"] = time.perf_counter() - t1

    t2 = time.perf_counter()
    edge_nodes, vertex_nodes = touching_pairs(t)
    for nodes, kind, n, fac in ((t, "coincident", quad.coincident, 0.5 * c),
                                (edge_nodes, "edge", quad.edge, c),
                                (vertex_nodes, "vertex", quad.vertex, c)):
        loc = _singular_local(p, nodes, kind, n, s, quad)
        hk.scatter_csr(indptr, indices, data, nodes, loc, fac)
    # close separated pairs of thin triangles: the graded rule's correction
    # (all of them lie in near blocks: their separation ratio is below R)
    pairs, corr = close_pair_corrections(p, t, s, quad, geometry)
    if len(pairs):
        hk.scatter_csr(indptr, indices, data,
                       np.ascontiguousarray(np.hstack([t[pairs[:, 0]], t[pairs[:, 1]]])),
                       corr, c)
    tim["singular"] = time.perf_counter() - t2

    t3 = time.perf_counter()
    z = chebyshev_points(m)
    td = _tree_data(tree, cent, z)
    fdata = _far_blocks(tree, tree, far, td, td, z, -1.0 - s)
    fdata.update(area=area, mom=mom, grad=grad, c=c)
    tim["coupling"] = time.perf_counter() - t3

    # far-field diagonal terms: sums over every far T' of the Taylor terms
    t4 = time.perf_counter()
    src = np.zeros((nt, 2, 6))
    src[:, 0, 0] = area
    src[:, 1, 3:6] = mom
    out = _far_pass(fdata, src)
    S0, S1, S2, S3 = out[:, 0, 0], out[:, 0, 1:3], out[:, 0, 3:6], out[:, 1, 0]
    MS2 = mom[:, 0] * S2[:, 0] + 2.0 * mom[:, 1] * S2[:, 1] + mom[:, 2] * S2[:, 2]
    D[:, 0] += area * S0 + 0.5 * MS2 + 0.5 * area * S3
    D[:, 1] += mom[:, 0] * S1[:, 0] + mom[:, 1] * S1[:, 1]
    D[:, 2] += mom[:, 1] * S1[:, 0] + mom[:, 2] * S1[:, 1]
    D[:, 3] += S0
    E = np.einsum("tq,qa,qb->tab", D[:, 4:], lam, lam)
    al = np.einsum("td,tad->ta", D[:, 1:3], grad) / 3.0
    Imat = np.stack([mom[:, [0, 1]], mom[:, [1, 2]]], axis=1)
    E += (D[:, 0, None, None] / 9.0 + al[:, :, None] + al[:, None, :]
          + D[:, 3, None, None] * np.einsum("tad,tde,tbe->tab", grad, Imat, grad))
    hk.scatter_csr(indptr, indices, data, t, E, c)
    tim["far_diagonal"] = time.perf_counter() - t4

    t5 = time.perf_counter()
    edges, bnodes = _boundary_edges(p, t)
    kappa = operator_kappa(edges, s, m, eta)
    Kloc = _kappa_local(p, t, bnodes, edges, s, quad, geometry, kappa=kappa)
    hk.scatter_csr(indptr, indices, data, t, Kloc, c)
    tim["exterior"] = time.perf_counter() - t5

    free = np.asarray(mesh.interior_nodes(), dtype=np.int64)
    Af = _restrict_arrays(indptr, indices, data, free, nv)   # compacted in place
    del indptr, indices, data
    tim["total"] = time.perf_counter() - t0
    t6 = time.perf_counter()
    M = leaf_matrix(fdata, t, free, nv) if leaf_matrices else None
    tim["leaf_matrix"] = time.perf_counter() - t6
    tim["total"] = time.perf_counter() - t0
    info = dict(order=m, tol=tol, eta=eta, leaf_size=leaf_size,
                kappa_leaves=(kappa.source_leaf, kappa.target_leaf), clusters=len(tree["start"]),
                far_blocks=len(far), coupling_matrices=len(fdata["K"]), near_blocks=len(near),
                near_nnz=Af.nnz, leaf_matrix_nnz=0 if M is None else M.nnz, timings=tim)
    log.info("compressed operator: %d free nodes, %d far / %d near blocks, order %d, "
             "%.1f MB, %.2f s", len(free), len(far), len(near), m,
             (Af.data.nbytes + fdata["K"].nbytes) / 2**20, tim["total"])
    return CompressedOperator(Af, fdata, free, nv, t, info, M)
