"""P1 functions between non-matching meshes: point location and interpolation.

Used to compare a solution with a reference on another mesh (errors of the
parabolic examples) and to carry u_h from one time slab's mesh to the next.
A P1 function is extended by zero outside its mesh (its polygon is inside the
unit disk and the functions vanish on its boundary, so this is the natural
extension of V_h ⊂ H^s_0).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from .assembly import mesh_arrays
from .meshes import validates

__all__ = ["locate", "interpolation_matrix", "interpolate", "interpolate_at", "transfer",
           "energy_distance",
           "pieces_on", "space_time_distance", "SpaceTimeReference", "SlabwiseReference",
           "ReferenceFamily", "extrapolated_distance"]


def _element_maps(mesh):
    """Vertex 0 and the inverse Jacobian of every element (affine P1 maps)."""
    p, t = mesh_arrays(mesh)
    p0 = p[t[:, 0]]
    J = np.stack([p[t[:, 1]] - p0, p[t[:, 2]] - p0], axis=2)       # (Nt, 2, 2)
    return p0, np.linalg.inv(J), t


def _barycentric(p0, Jinv, el, x):
    """Barycentric coordinates (N, 3) of points x (N, 2) in elements el (N,)."""
    xi = np.einsum("nij,nj->ni", Jinv[el], x - p0[el])
    return np.column_stack([1.0 - xi[:, 0] - xi[:, 1], xi[:, 0], xi[:, 1]])


@validates("mesh")
def locate(mesh, points, *, tol: float = 1e-10, candidates: int = 12):
    """Element containing each point, and its barycentric coordinates.

    ``points`` (2, N).  A KD-tree of the element centroids proposes the nearest
    ``candidates`` elements; points not found among them are searched in all
    elements (in blocks).  Returns (elements (N,) int, −1 for points outside the
    mesh polygon (barycentric coordinates ≥ −tol count as inside), barycentric
    coordinates (N, 3), 0 where outside).
    """
    x = np.asarray(points, dtype=float)
    if x.ndim != 2 or x.shape[0] != 2 or not np.all(np.isfinite(x)):
        raise ValueError(f"points must be a finite array of shape (2, N), got {x.shape}")
    x = x.T
    p0, Jinv, t = _element_maps(mesh)
    p, _ = mesh_arrays(mesh)
    nt, n = len(t), len(x)
    el = np.full(n, -1, dtype=np.int64)
    bary = np.zeros((n, 3))
    k = min(candidates, nt)
    _, cand = cKDTree(p[t].mean(axis=1)).query(x, k)
    cand = cand.reshape(n, k)
    best = np.full(n, -np.inf)
    for j in range(k):
        b = _barycentric(p0, Jinv, cand[:, j], x)
        m = b.min(axis=1)
        better = (m > best) & (best < -tol)          # keep the first containing one
        el = np.where(better, cand[:, j], el)
        bary[better] = b[better]
        best = np.where(better, m, best)
    missing = np.flatnonzero(best < -tol)
    block = max(1, 2_000_000 // nt)                                # bounded memory
    for start in range(0, missing.size, block):
        idx = missing[start:start + block]
        xs = x[idx]                                                # (B, 2)
        xi = np.einsum("tij,btj->bti", Jinv, xs[:, None, :] - p0[None])
        b = np.concatenate([1.0 - xi.sum(axis=2, keepdims=True), xi], axis=2)
        m = b.min(axis=2)                                          # (B, Nt)
        arg = m.argmax(axis=1)
        bary[idx] = b[np.arange(len(idx)), arg]
        el[idx] = arg
        best[idx] = m[np.arange(len(idx)), arg]
    outside = best < -tol
    el[outside] = -1
    bary[outside] = 0.0
    return el, bary


@validates("mesh")
def interpolation_matrix(mesh, points) -> sp.csr_matrix:
    """Sparse E with (E u)_j = u_h(x_j): P1 evaluation (0 outside the mesh)."""
    elem, bary = locate(mesh, points)
    n = len(elem)
    inside = elem >= 0
    rows = np.repeat(np.flatnonzero(inside), 3)
    cols = np.asarray(mesh.t)[:, elem[inside]].T.ravel()
    return sp.csr_matrix((bary[inside].ravel(), (rows, cols)),
                         shape=(n, mesh.p.shape[1]))


@validates("mesh")
def interpolate_at(mesh, u, points, **kwargs) -> np.ndarray:
    """Values at ``points`` (2, N) of the P1 function u (nodal, all nodes of
    ``mesh``), extended by 0 outside the mesh polygon."""
    u = np.asarray(u, dtype=float)
    if u.shape != (mesh.p.shape[1],):
        raise ValueError(f"u must have one value per node of mesh ({mesh.p.shape[1]},), "
                         f"got {u.shape}")
    el, bary = locate(mesh, points, **kwargs)
    t = np.asarray(mesh.t.T, dtype=np.int64)
    vals = np.einsum("nk,nk->n", bary, u[t[np.maximum(el, 0)]])
    return np.where(el >= 0, vals, 0.0)


@validates("mesh_from", "mesh_to")
def transfer(mesh_from, u_from, mesh_to) -> np.ndarray:
    """Nodal interpolation of a P1 function onto another mesh: the values at the
    nodes of ``mesh_to`` (0 outside the old polygon and on ∂Ω of the new mesh)."""
    if mesh_to is mesh_from:
        return np.array(u_from, dtype=float)
    u = interpolate_at(mesh_from, u_from, mesh_to.p)
    u[mesh_to.boundary_nodes()] = 0.0
    return u


@validates("mesh_from", "mesh_to")
def interpolate(mesh_from, u, mesh_to) -> np.ndarray:
    """Nodal interpolant on mesh_to of the P1 function u on mesh_from."""
    u = np.asarray(u, dtype=float)
    if u.shape != (mesh_from.p.shape[1],):
        raise ValueError(f"u must have one value per node of mesh_from "
                         f"({mesh_from.p.shape[1]},), got {u.shape}")
    return interpolation_matrix(mesh_from, mesh_to.p) @ u


def energy_distance(mesh, u, reference) -> float:
    """‖I u − u_ref‖_a: the energy-norm distance of the P1 function u on ``mesh`` to a
    reference, ``reference`` = (Discretisation of the reference mesh, u_ref over all its
    nodes); I u is the nodal interpolant on the reference mesh (0 outside ``mesh``), the
    norm the reference's free-node matrix (dense or compressed).  Exact when the
    reference mesh refines ``mesh`` on the same polygon (then I u = u); the disk's
    refinements (:func:`fracfem.refine_disk`) move new boundary nodes onto the circle,
    where I u differs from u in the elements along the boundary."""
    disc, u_ref = reference
    u_ref = np.asarray(u_ref, dtype=float)
    if u_ref.shape != (disc.mesh.p.shape[1],):
        raise ValueError(f"u_ref must have one value per node of the reference mesh "
                         f"({disc.mesh.p.shape[1]},), got {u_ref.shape}")
    d = (interpolate(mesh, u, disc.mesh) - u_ref)[disc.free]
    return float(np.sqrt(max(float(d @ np.asarray(disc.A @ d, dtype=float)), 0.0)))


def _contiguous(name, pcs):
    """Check that pieces (t0, t1, mesh, u) follow one another in time; their time edges."""
    if not pcs:
        raise ValueError(f"{name} is empty")
    for k in range(len(pcs) - 1):
        if not np.isclose(pcs[k][1], pcs[k + 1][0], rtol=0, atol=1e-12 * abs(pcs[-1][1])):
            raise ValueError(f"{name} are not contiguous in time: piece {k} ends at "
                             f"{pcs[k][1]}, piece {k + 1} starts at {pcs[k + 1][0]}")
    return np.array([pcs[0][0]] + [pc[1] for pc in pcs], dtype=float)


# singular values of one mesh's snapshots (its pieces' nodal vectors) below this
# fraction of the largest are dropped before the reference's matrix is applied: each
# piece then moves by at most that fraction of the largest snapshot, 10⁴ times above
# round-off; on the parabolic runs the distances move by < 1e-9 relative (tests)
RANK_RTOL = 1e-12


class _Span:
    """Snapshots (columns of X) as Q C, Q orthonormal (singular values ≥ rtol × the
    largest), with Y = A I Q: then A I x_i ≈ Y c_i for every snapshot x_i."""

    def __init__(self, X, interp, apply, rtol):
        Q, sv, Vt = np.linalg.svd(X, full_matrices=False)
        r = max(1, int(np.count_nonzero(sv > rtol * sv[0]))) if sv.size and sv[0] > 0 else 0
        self.C = sv[:r, None] * Vt[:r]
        # one product with the block of r columns: a compressed operator reads its
        # near field once for a block, a dense matrix multiplies matrices
        self.Y = apply(np.asarray(interp @ Q[:, :r])) if r \
            else np.zeros((interp.shape[0], 0))

    def product(self, col):
        return self.Y @ self.C[:, col]


class SpaceTimeReference:
    """A reference function, piecewise constant in time on one mesh, to measure
    many functions against: ``distance(pieces)`` is ‖I u − u_ref‖_{L²(0,T; a)}.

    ``reference``: list of (t0, t1, mesh, u) on one mesh (u on all its nodes);
    ``A_ref``: the free-node matrix of that mesh (an array, a sparse matrix or a
    LinearOperator: ``@`` of a vector and of a block of columns); ``free_ref``: its
    free nodes.  On each interval of the union of the two time grids
    e = I u_i − u_ref,j and A e = A I u_i − A u_ref,j, so the matrix
    is needed for the reference's pieces (kept for later distances) and for the
    pieces of u, not on every interval.  It is applied to a basis of each mesh's
    pieces rather than to every piece: the nodal vectors of the pieces on one mesh
    (one time slab; the reference's own) are expanded in their leading singular
    vectors, those with singular value above ``rank_rtol`` (default
    :data:`RANK_RTOL`) times the largest; the solution varies smoothly in time, so a
    run with many small time steps needs far fewer products than it has pieces.
    ``rank_rtol=0`` keeps every direction (at most one product per piece).
    ``matvecs`` counts the products.
    """

    def __init__(self, reference, A_ref, free_ref, *, rank_rtol: float = RANK_RTOL):
        self.edges = _contiguous("reference", reference)
        self.mesh = reference[0][2]
        if any(pc[2] is not self.mesh for pc in reference):
            raise ValueError("the reference pieces must all live on one mesh")
        if not (np.isfinite(rank_rtol) and 0.0 <= rank_rtol < 1.0):
            raise ValueError(f"rank_rtol={rank_rtol!r} must be in [0, 1)")
        self.rank_rtol = float(rank_rtol)
        self.A, self.free = A_ref, np.asarray(free_ref)
        self.values = [np.asarray(pc[3], dtype=float)[self.free] for pc in reference]
        self._span = None
        self.matvecs = 0

    def _A_ref(self, j):
        if self._span is None:
            eye = sp.identity(len(self.free), format="csr")
            self._span = _Span(np.column_stack(self.values), eye, self._apply,
                               self.rank_rtol)
        return self._span.product(j)

    def _apply(self, x):
        """A x for a vector, or for each column of a block (counted as one product each)."""
        self.matvecs += 1 if x.ndim == 1 else x.shape[1]
        y = np.asarray(self.A @ x, dtype=float)
        if y.shape != x.shape:
            raise ValueError(f"A_ref @ x gave shape {y.shape} for x of shape {x.shape}: "
                             "A_ref must map (n,) to (n,) and (n, k) to (n, k)")
        return y

    def distance(self, pieces) -> float:
        """‖I u − u_ref‖_{L²(0,T; a)}: u is interpolated onto the reference mesh
        (nodal interpolation, zero outside its mesh); the time integral is exact
        on the union of both time grids, which must cover the same interval."""
        return float(_distances(pieces, [self])[0])


class SlabwiseReference:
    """A reference whose space mesh changes in time (an Algorithm C pass: one mesh per
    time slab), to measure other functions against: ``distance(pieces)`` is
    (Σ_slabs ‖I_j u − u_ref‖²_{L²(slab j; a_j)})^{1/2}, on each slab u interpolated
    onto that slab's mesh and measured in its a-norm.

    ``reference``: pieces (t0, t1, mesh, u) contiguous in time; consecutive pieces on
    one mesh (the same object) form a slab.  ``operator(mesh)`` returns that mesh's
    free-node matrix and free nodes, (A, free).  Only one slab's matrix is held at a
    time: ``distances(runs)`` measures several functions slab by slab, calling
    ``operator`` once per slab (``operator_calls``).  With one mesh throughout this is
    :class:`SpaceTimeReference`."""

    def __init__(self, reference, operator, *, rank_rtol: float = RANK_RTOL):
        self.edges = _contiguous("reference", reference)
        if not (np.isfinite(rank_rtol) and 0.0 <= rank_rtol < 1.0):
            raise ValueError(f"rank_rtol={rank_rtol!r} must be in [0, 1)")
        self.slabs: list = []
        for pc in reference:
            if self.slabs and self.slabs[-1][-1][2] is pc[2]:
                self.slabs[-1].append(pc)
            else:
                self.slabs.append([pc])
        self.operator, self.rank_rtol = operator, float(rank_rtol)
        self.operator_calls = 0

    def distances(self, runs) -> np.ndarray:
        """The distance of each run (a list of pieces covering the reference's time
        interval) to the reference."""
        tol = 1e-12 * max(abs(self.edges[-1]), 1e-300)
        for pieces in runs:
            ta = _contiguous("pieces", pieces)
            if abs(ta[0] - self.edges[0]) > tol or abs(ta[-1] - self.edges[-1]) > tol:
                raise ValueError(f"time intervals differ: [{ta[0]}, {ta[-1]}] vs "
                                 f"[{self.edges[0]}, {self.edges[-1]}]")
        total = np.zeros(len(runs))
        for slab in self.slabs:
            A, free = self.operator(slab[0][2])
            self.operator_calls += 1
            ref = SpaceTimeReference(slab, A, free, rank_rtol=self.rank_rtol)
            a, b = ref.edges[0], ref.edges[-1]
            for k, pieces in enumerate(runs):
                # u's pieces that overlap (a, b), cut there; the first starts at a and the
                # last ends at b exactly, whatever the rounding of u's own time edges
                within = [[max(t0, a), min(t1, b), mesh, u] for t0, t1, mesh, u in pieces
                          if min(t1, b) > max(t0, a)]
                within[0][0], within[-1][1] = a, b
                total[k] += float(_distances([tuple(w) for w in within], [ref])[0]) ** 2
            del A, free, ref
        return np.sqrt(total)

    def distance(self, pieces) -> float:
        """(Σ_slabs ‖I_j u − u_ref‖²_{L²(slab j; a_j)})^{1/2}; u must cover the
        reference's time interval."""
        return float(self.distances([pieces])[0])


def _distances(pieces, references) -> np.ndarray:
    """‖I u − u_k‖ for every reference u_k of ``references`` (SpaceTimeReference objects
    on one mesh with one matrix): one pass over the union of all time grids, A I u of
    each piece of u formed once for all of them."""
    first = references[0]
    ta = _contiguous("pieces", pieces)
    tol = 1e-12 * max([abs(ta[-1])] + [abs(r.edges[-1]) for r in references] + [1e-300])
    for r in references:
        tb = r.edges
        if abs(ta[0] - tb[0]) > tol or abs(ta[-1] - tb[-1]) > tol:
            raise ValueError(f"time intervals differ: [{ta[0]}, {ta[-1]}] vs "
                             f"[{tb[0]}, {tb[-1]}]")
    # the pieces of each mesh, in time order (a slab's mesh, or a run's only one)
    groups: dict = {}
    for i, pc in enumerate(pieces):
        groups.setdefault(id(pc[2]), []).append(i)
    current: dict = {}

    def piece(i):                  # (I u_i, A I u_i) on the reference's free nodes
        key = id(pieces[i][2])
        if current.get("key") != key:   # a new mesh: its pieces' basis
            idx = groups[key]
            mesh = pieces[i][2]
            interp = (sp.eye(mesh.p.shape[1], format="csr") if _same_mesh(mesh, first.mesh)
                      else interpolation_matrix(mesh, first.mesh.p))[first.free]
            X = np.column_stack([np.asarray(pieces[k][3], dtype=float) for k in idx])
            current.clear()
            current.update(key=key, interp=interp,
                           col={k: c for c, k in enumerate(idx)},
                           span=_Span(X, interp, first._apply, first.rank_rtol))
        v = current["interp"] @ np.asarray(pieces[i][3], dtype=float)
        return v, current["span"].product(current["col"][i])

    grid = ta
    for r in references:
        grid = np.union1d(grid, r.edges)
    grid = grid[np.concatenate([[True], np.diff(grid) > 1e-12 * max(1.0, abs(grid[-1]))])]
    total = np.zeros(len(references))
    last = (None, None)
    last_ref = [(None, None)] * len(references)
    for a, b in zip(grid[:-1], grid[1:]):
        mid = 0.5 * (a + b)
        i = int(np.clip(np.searchsorted(ta, mid) - 1, 0, len(pieces) - 1))
        if last[0] != i:
            last = (i, piece(i))
        v, Av = last[1]
        for k, r in enumerate(references):
            j = int(np.clip(np.searchsorted(r.edges, mid) - 1, 0, len(r.values) - 1))
            if last_ref[k][0] != j:    # Y c_j once per reference piece, not per interval
                last_ref[k] = (j, r._A_ref(j))
            total[k] += (b - a) * float((v - r.values[j]) @ (Av - last_ref[k][1]))
    return np.sqrt(np.maximum(total, 0.0))


def pieces_on(pieces, mesh) -> list:
    """Pieces (t0, t1, m, u) as pieces on ``mesh``: each u nodally interpolated onto it
    (zero outside m; one interpolation matrix per distinct m), u as it is where m is
    ``mesh``."""
    maps: dict = {}
    moved = []
    for t0, t1, m, u in pieces:
        u = np.asarray(u, dtype=float)
        if m is not mesh:
            if id(m) not in maps:
                maps[id(m)] = interpolation_matrix(m, mesh.p)
            u = maps[id(m)] @ u
        moved.append((t0, t1, mesh, u))
    return moved


class ReferenceFamily:
    """Runs u₁, …, u_K of one family converging to the unknown u (coarsest first), to
    measure another function's distance to u rather than to the finest run.

    ``members``: K ≥ 3 lists of pieces (t0, t1, mesh, u), each list on one mesh;
    ``A_ref``, ``free_ref``: the free-node matrix and free nodes of the finest member's
    mesh, in whose a-norm every distance is taken (the coarser members are interpolated
    onto it).  ``steps`` holds the distances d_k = ‖u_k − u_{k+1}‖ of consecutive
    members, ``distances(pieces)`` those of a function to every member, and
    ``error(pieces)`` the extrapolated distance to u (:func:`extrapolated_distance`)."""

    def __init__(self, members, A_ref, free_ref, *, rank_rtol: float = RANK_RTOL):
        if len(members) < 3:
            raise ValueError(f"a reference family needs at least 3 members, got "
                             f"{len(members)}")
        fine = members[-1][0][2]
        on_fine = []
        self.meshes = []               # the space meshes of each member
        for pcs in members:
            self.meshes.append(list({id(pc[2]): pc[2] for pc in pcs}.values()))
            _contiguous("member", pcs)
            on_fine.append(pieces_on(pcs, fine))
        self.references = [SpaceTimeReference(pcs, A_ref, free_ref, rank_rtol=rank_rtol)
                           for pcs in on_fine]
        self.steps = np.array([self.references[k + 1].distance(on_fine[k])
                               for k in range(len(on_fine) - 1)])

    @property
    def matvecs(self) -> int:
        return sum(r.matvecs for r in self.references)

    def distances(self, pieces) -> np.ndarray:
        """‖I u − u_k‖ for every member u_k (coarsest first), in one pass."""
        return _distances(pieces, self.references)

    def shared_members(self, pieces) -> list:
        """The members with a space mesh of a piece of u (equal nodes and triangles)."""
        own = list({id(pc[2]): pc[2] for pc in pieces}.values())
        return [k for k, ms in enumerate(self.meshes)
                if any(_same_mesh(a, b) for a in own for b in ms)]

    def error(self, pieces, *, leave_out_shared: bool = True) -> dict:
        """The distances to the members and :func:`extrapolated_distance` of them.  With
        ``leave_out_shared``, a member on the space mesh of a piece of u is left out of
        the extrapolation (``left_out``): u's error shares that member's space error, so
        its angle with it is not that with the others'."""
        d = self.distances(pieces)
        shared = self.shared_members(pieces) if leave_out_shared else []
        return {"distances": d, "left_out": shared,
                **extrapolated_distance(d, self.steps, exclude=shared)}


def _same_mesh(a, b) -> bool:
    """The same nodes (in the same order) and the same triangles, in any order and with
    their vertices in any order (skfem's MeshTri sorts each triangle's vertices; a mesh
    made by refinement need not)."""
    if a is b:
        return True
    if a.p.shape != b.p.shape or a.t.shape != b.t.shape or not np.array_equal(a.p, b.p):
        return False
    if np.array_equal(a.t, b.t):
        return True
    ta, tb = np.sort(a.t, axis=0), np.sort(b.t, axis=0)
    return bool(np.array_equal(ta[:, np.lexsort(ta)], tb[:, np.lexsort(tb)]))


def _extrapolate_squares(nodes, squares) -> float:
    """The value at x = 0 of the parabola through (x_k, e_k²) (three points)."""
    total = 0.0
    for k in range(len(nodes)):
        w = np.prod([nodes[j] / (nodes[j] - nodes[k]) for j in range(len(nodes)) if j != k])
        total += w * squares[k]
    return float(total)


def extrapolated_distance(distances, steps, exclude=()) -> dict:
    """The distance ‖v − u‖ of a function v to the limit u of a family u₁, …, u_K, from
    its distances e_k = ‖v − u_k‖ to the members and the family's steps
    d_k = ‖u_k − u_{k+1}‖ (coarsest first; K ≥ 3).

    e_k² = ‖v − u‖² − 2⟨v − u, u_k − u⟩ + ‖u_k − u‖².  If the members' errors decrease
    geometrically, ‖u_k − u‖ = κ x_k with x_k = d_k (the finest: x_K = d_{K−1}²/d_{K−2}),
    and v's error keeps its angle with theirs, e_k² is a parabola in x_k: its value at
    x = 0 through the three finest members is the estimate.  The model needs no
    alignment of the members' errors with one another, only that the family be
    asymptotic.  ``uncertainty`` is the change from the estimate through the three
    members before, as a family's last step measures its finest member's error, and no
    less than the correction to the distance to the finest member (K ≥ 4; NaN for K = 3,
    infinite if the estimate before fails).  Members in ``exclude`` (indices) are left out: the three finest and
    the three before of those that remain.  Returns {'error', 'uncertainty', 'ratio'}
    (ratio: the family's last d_{K−1}/d_{K−2}); an extrapolated e² ≤ 0 gives error NaN,
    fewer than three members left give NaN for both."""
    e = np.asarray(distances, dtype=float)
    d = np.asarray(steps, dtype=float)
    K = e.size
    if K < 3 or d.size != K - 1:
        raise ValueError(f"need distances to K >= 3 members and K - 1 steps, got "
                         f"{e.size} distances and {d.size} steps")
    if not (np.all(np.isfinite(d)) and np.all(d > 0) and np.all(np.isfinite(e))):
        raise ValueError(f"distances {e} and steps {d} must be finite, steps positive")
    ratios = d[1:] / d[:-1]
    if not np.all(ratios < 1.0):
        raise RuntimeError(f"the family does not converge: steps {d} (ratios {ratios})")
    x = np.append(d, d[-1] ** 2 / d[-2])
    kept = [k for k in range(K) if k not in set(int(j) for j in exclude)]

    def estimate(idx):
        if len(idx) < 3:
            return float("nan")
        sq = _extrapolate_squares(x[idx], e[idx] ** 2)
        return float(np.sqrt(sq)) if sq > 0 else float("nan")

    err = estimate(kept[-3:])
    # the change from the estimate before, and no less than the correction it makes to
    # the distance to the finest member left in (a correction is not trusted beyond its size)
    if len(kept) >= 4:
        before = estimate(kept[-4:-1])
        # an estimate before that fails (e² ≤ 0) leaves the model unconfirmed: unbounded
        unc = (max(abs(err - before), abs(err - e[kept[-1]])) if np.isfinite(before)
               else float("inf"))
    else:
        unc = float("nan")
    return {"error": err, "uncertainty": unc, "ratio": float(ratios[-1])}


def space_time_distance(pieces, reference, A_ref, free_ref) -> float:
    """‖I u − u_ref‖_{L²(0,T; a)} for functions piecewise constant in time
    (one distance; :class:`SpaceTimeReference` measures many against one reference).

    ``pieces`` and ``reference`` are lists of (t0, t1, mesh, u): on (t0, t1] the
    function is the P1 function u (all nodes) on mesh.  u is interpolated onto
    the reference mesh of each reference piece (nodal interpolation, zero
    outside its mesh); the a-norm is the reference's free-node matrix A_ref, all
    reference pieces sharing one mesh.  The time integral is exact on the union
    of both time grids, which must cover the same interval.
    """
    return SpaceTimeReference(reference, A_ref, free_ref).distance(pieces)
