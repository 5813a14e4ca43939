"""The compressed operator against its reference, the dense matrix."""
import numpy as np
import pytest

from fracfem import disk_uniform, load_vector, lshape, square, stiffness_matrix
from fracfem.compressed import chebyshev_order, stiffness_operator
from fracfem.krylov import jacobi, pcg
from fracfem.solvers import ConvergenceError

MESHES = {"disk": lambda: disk_uniform(4), "square": lambda: square(16),
          "lshape": lambda: lshape(3)}


def _dense(mesh, s):
    free = mesh.interior_nodes()
    return stiffness_matrix(mesh, s)[np.ix_(free, free)]


@pytest.mark.parametrize("name", sorted(MESHES))
@pytest.mark.parametrize("s", [0.1, 0.5, 0.9])
def test_operator_matches_dense_matrix(name, s):
    mesh = MESHES[name]()
    A = _dense(mesh, s)
    # small leaves so that these small meshes have admissible blocks at all
    op = stiffness_operator(mesh, s, leaf_size=8)
    assert op.info["far_blocks"] > 0
    x = np.random.default_rng(1).standard_normal(A.shape[0])
    err = np.linalg.norm(op @ x - A @ x) / np.linalg.norm(A @ x)
    assert err <= 1e-6
    # the near field alone is far off: the far blocks carry real weight
    assert np.linalg.norm(op.near @ x - A @ x) / np.linalg.norm(A @ x) > 1e3 * err
    # far blocks couple no node with itself; the far-field diagonal terms
    # carry the compression error only
    np.testing.assert_allclose(op.diagonal(), np.diag(A), rtol=1e-7)


def test_compression_error_falls_with_tol():
    mesh = disk_uniform(4)
    A = _dense(mesh, 0.5)
    x = np.random.default_rng(2).standard_normal(A.shape[0])
    errs = []
    for tol in (1e-4, 1e-6, 1e-8, 1e-10):
        op = stiffness_operator(mesh, 0.5, tol=tol, leaf_size=8)
        errs.append(np.linalg.norm(op @ x - A @ x) / np.linalg.norm(A @ x))
    assert all(e <= tol for e, tol in zip(errs, (1e-4, 1e-6, 1e-8, 1e-10)))
    assert errs[0] > 30 * errs[-1]
    assert [chebyshev_order(t) for t in (1e-4, 1e-6, 1e-8, 1e-10)] == sorted(
        chebyshev_order(t) for t in (1e-4, 1e-6, 1e-8, 1e-10))


def test_operator_is_symmetric():
    op = stiffness_operator(square(16), 0.7, leaf_size=8, tol=1e-4)
    rng = np.random.default_rng(3)
    x, y = rng.standard_normal((2, op.shape[0]))
    assert abs(x @ (op @ y) - y @ (op @ x)) <= 1e-12 * abs(x @ (op @ y)) + 1e-14
    assert op.nbytes > op.near.data.nbytes


@pytest.mark.parametrize("s", [0.25, 0.75])
def test_energy_with_pcg_matches_dense_solve(s):
    mesh = disk_uniform(4)
    free = mesh.interior_nodes()
    A = _dense(mesh, s)
    b = load_vector(mesh, 1.0)[free]
    op = stiffness_operator(mesh, s, leaf_size=8)
    u, info = pcg(op, b, M=jacobi(op.diagonal()), tol=1e-12)
    ud = np.linalg.solve(A, b)
    assert abs(b @ u - b @ ud) <= 1e-8 * (b @ ud)
    assert info["iterations"] < 60


def test_bad_parameters_are_refused():
    mesh = square(4)
    with pytest.raises(ValueError, match=r"tol=0\.0"):
        stiffness_operator(mesh, 0.5, tol=0.0)
    with pytest.raises(ValueError, match=r"leaf_size=2 .*\[4, 512\]"):
        stiffness_operator(mesh, 0.5, leaf_size=2)
    with pytest.raises(ValueError, match=r"eta=-1"):
        stiffness_operator(mesh, 0.5, eta=-1.0)
    with pytest.raises(ValueError, match=r"\bs\b"):
        stiffness_operator(mesh, 1.5)


def test_pcg_reports_non_convergence_and_bad_input():
    op = stiffness_operator(square(8), 0.5)
    b = np.ones(op.shape[0])
    with pytest.raises(ConvergenceError, match="iterations = 2"):
        pcg(op, b, maxiter=2, tol=1e-12)
    with pytest.raises(ValueError, match="tol"):
        pcg(op, b, tol=2.0)
    with pytest.raises(ValueError, match="non-finite"):
        pcg(op, b * np.nan)


def test_dg0_steps_with_compressed_operator_match_dense():
    import fracfem as ff

    mesh = disk_uniform(4)
    runs = {}
    for op in ("dense", "compressed"):
        disc = ff.discretise(mesh, 0.5, 0.0, operator=op)
        runs[op] = list(ff.time_steps(disc, 1.0, T=0.3, tau=0.05))
    assert runs["compressed"][0].t == runs["dense"][0].t
    for a, b in zip(runs["dense"], runs["compressed"]):
        assert np.linalg.norm(a.u - b.u) <= 1e-7 * np.linalg.norm(a.u)
    # warm-started steps: fewer iterations once u changes slowly
    its = [st.info["iterations"] for st in runs["compressed"] if "iterations" in st.info]
    assert len(its) == 6 and its[-1] < its[0]


def test_discretise_operator_choice(monkeypatch):
    import fracfem as ff
    import fracfem.laplace as laplace

    mesh = disk_uniform(3)                               # 113 free nodes
    assert ff.discretise(mesh, 0.5, operator="auto").dense
    monkeypatch.setattr(laplace, "AUTO_DENSE_NODES", 113)
    assert ff.discretise(mesh, 0.5, operator="auto").dense       # up to the threshold
    monkeypatch.setattr(laplace, "AUTO_DENSE_NODES", 112)
    assert not ff.discretise(mesh, 0.5, operator="auto").dense   # compressed above it
    assert not ff.discretise(mesh, 0.5, operator="compressed").dense
    with pytest.raises(ValueError, match="operator='sparse'"):
        ff.discretise(mesh, 0.5, operator="sparse")


@pytest.mark.parametrize("s", [0.1, 0.9])
def test_compressed_kappa_matches_exterior_kernel(s, monkeypatch):
    from fracfem import compressed
    from fracfem.assembly import _boundary_edges, exterior_kernel, mesh_arrays
    from fracfem.compressed import CompressedKappa

    p, t = mesh_arrays(disk_uniform(5))
    edges, _ = _boundary_edges(p, t)
    # centroids, and points at 1e-6 … 0.3 edge lengths inside ∂Ω along the inward
    # normals of the edges' midpoints and quarter points, as the graded rules put them
    a, b = edges[:, :2], edges[:, 2:]
    ln = np.linalg.norm(b - a, axis=1)
    inward = np.column_stack([a[:, 1] - b[:, 1], b[:, 0] - a[:, 0]]) / ln[:, None]
    close = [a + w * (b - a) + (d * ln)[:, None] * inward
             for w in (0.25, 0.5) for d in (1e-6, 1e-3, 0.05, 0.3)]
    x = np.vstack([p[t].mean(axis=1), *close])
    exact = exterior_kernel(x, edges, s)
    leaf_sizes = []
    tree = compressed.cluster_tree
    monkeypatch.setattr(compressed, "cluster_tree",
                        lambda c, d, leaf, *r: leaf_sizes.append((len(c), leaf)) or
                        tree(c, d, leaf, *r))
    for leaves in ({"source_leaf": 16, "target_leaf": 16}, {}):   # {}: the operator's
        errs = []
        for order in (5, 8):
            kappa = CompressedKappa(edges, s, order=order, eta=0.5, **leaves)
            errs.append(np.max(np.abs(kappa(x) - exact) / exact))
        assert errs[1] <= 1e-8 and errs[0] > 10 * errs[1], (leaves, errs)
    # each tree with its own leaves: the points', then the edges' Gauss points'
    n, m = len(x), 2 * len(edges)
    assert leaf_sizes == [(n, 16), (m, 16)] * 2 + [
        (n, compressed.KAPPA_TARGET_LEAF), (m, compressed.KAPPA_SOURCE_LEAF)] * 2


@pytest.mark.parametrize("name, value", [("source_leaf", 0), ("target_leaf", 5000),
                                         ("target_leaf", 2.5), ("source_leaf", True)])
def test_compressed_kappa_refuses_bad_leaves(name, value):
    from fracfem.compressed import CompressedKappa

    edges = np.array([[0.0, 0.0, 1.0, 0.0], [1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 0.0]])
    with pytest.raises(ValueError, match=rf"{name}={value!r} must be an integer in \[1, 4096\]"):
        CompressedKappa(edges, 0.5, order=8, eta=0.5, **{name: value})


def test_operator_kappa_is_the_operators_exterior_term(monkeypatch):
    """stiffness_operator's κ is operator_kappa's: the same trees, order and admissibility."""
    from fracfem import compressed

    made = []
    real = compressed.CompressedKappa

    class Recording(real):
        def __init__(self, *args, **kwargs):
            super().__init__(*args, **kwargs)
            made.append(self)

    monkeypatch.setattr(compressed, "CompressedKappa", Recording)
    op = compressed.stiffness_operator(disk_uniform(3), 0.5, tol=1e-6, eta=0.8)
    (k,) = made
    assert (k.order, k.eta) == (compressed.chebyshev_order(1e-6) + 1, 0.4)
    assert (k.source_leaf, k.target_leaf) == op.info["kappa_leaves"] == (
        compressed.KAPPA_SOURCE_LEAF, compressed.KAPPA_TARGET_LEAF)


def test_obstacle_dg0_steps_with_compressed_operator_match_dense():
    import fracfem as ff

    coarse = disk_uniform(2)
    runs = {}
    for op in ("dense", "compressed"):
        prob = ff.mixed_problem("obstacle", coarse, 0.5, 0.0,
                                chi=lambda x: 1.0 - 4.0 * (x[0] ** 2 + x[1] ** 2),
                                operator=op)
        runs[op] = list(ff.time_steps(prob, 1.0, T=0.2, tau=0.05,
                                      solver_options={"tol": 1e-10}))
    for a, b in zip(runs["dense"][1:], runs["compressed"][1:]):
        assert np.linalg.norm(a.u - b.u) <= 1e-6 * np.linalg.norm(a.u)
        assert np.linalg.norm(a.lam - b.lam) <= 1e-5 * max(np.linalg.norm(a.lam), 1e-12)
    assert np.linalg.norm(runs["dense"][-1].lam) > 0       # u0 = 1: contact from t = 0



@pytest.mark.parametrize("kind", ["obstacle", "friction"])
def test_warm_started_compressed_steps_solve_the_same_steps_in_fewer_iterations(kind):
    """Compressed DG(0) steps start each PDAS from the last step's active sets and
    from the linear extrapolation of the last two steps; the steps are those
    of cold starts (λ⁰ = 0, u⁰ = u^{k−1}) to the solver's accuracy, in fewer
    inner PCG iterations (Example 4 with ũ₀ = 2: contact from t ≈ 0.5;
    Example 5: stick and slip from the first step)."""
    import fracfem as ff

    if kind == "obstacle":
        prob = ff.mixed_problem("obstacle", disk_uniform(3), 0.5, 0.0, operator="compressed",
                                chi=lambda x: 1.0 - 4.0 * (x[0] ** 2 + x[1] ** 2))
        u0 = 2.0
    else:
        prob = ff.mixed_problem("friction", disk_uniform(3), 0.6, 0.0, F=0.1,
                                operator="compressed")
        u0 = lambda x: (np.hypot(*x) - 1.0) * (np.hypot(*x) - 0.6)  # noqa: E731
    st = ff.Stepper(prob)
    runs = {warm: list(ff.time_steps(st, u0, T=0.6, tau=0.02, warm_start=warm,
                                     solver_options={"tol": 1e-10}))[1:]
            for warm in (True, False)}
    for a, b in zip(runs[True], runs[False]):
        assert np.linalg.norm(a.u - b.u) <= 1e-8 * np.linalg.norm(b.u)
        assert np.linalg.norm(a.lam - b.lam) <= 1e-6 * max(np.linalg.norm(b.lam), 1e-12)
    assert sum(np.any(step.lam) for step in runs[True]) >= 5      # steps with contact
    inner = {warm: sum(sum(step.info["inner_iterations"]) for step in steps)
             for warm, steps in runs.items()}
    assert inner[True] < inner[False]
    with pytest.raises(ValueError, match="guess"):
        st.step(runs[True][0].u[st.free], 0.02, np.zeros(len(st.free)), guess=np.ones(3))


def test_operator_matches_dense_matrix_on_thin_triangles():
    import fracfem as ff
    from fracfem.assembly import close_separated_pairs, mesh_arrays

    mesh = ff.disk_graded_rings(12, 3.0)
    p, t = mesh_arrays(mesh)
    assert len(close_separated_pairs(p, t, ff.QuadratureOptions())[0]) > 0
    A = _dense(mesh, 0.5)
    op = stiffness_operator(mesh, 0.5, leaf_size=8)
    assert op.info["far_blocks"] > 0
    x = np.random.default_rng(4).standard_normal(A.shape[0])
    assert np.linalg.norm(op @ x - A @ x) <= 1e-6 * np.linalg.norm(A @ x)


@pytest.mark.parametrize("s", [0.05, 0.5, 0.95])
def test_cos_power_series_matches_incomplete_beta(s):
    """F(φ₂) − F(φ₁), F = ∫₀^φ cos^(2s), against the regularised incomplete
    beta function, also where both ends lie near π/2 on one side of the foot
    (the difference of two values near F(π/2), formed without cancellation)."""
    from scipy.special import beta, betainc, gamma

    from fracfem import _h2_kernels as hk
    from fracfem.compressed import cos_power_series

    ca, cb = cos_power_series(s)
    half_b = 0.5 * beta(0.5, s + 0.5)
    full = 0.5 * np.sqrt(np.pi) * gamma(s + 0.5) / gamma(s + 1.0)

    def tail(t, ad):          # ∫_φ^(π/2) cos^(2s), φ = arctan(t/ad) ≥ 0
        return half_b * betainc(s + 0.5, 0.5, ad * ad / (ad * ad + t * t))

    def head(t, ad):          # ∫_0^φ cos^(2s) for φ ≥ 0
        return half_b * betainc(0.5, s + 0.5, t * t / (ad * ad + t * t))

    rng = np.random.default_rng(3)
    worst = 0.0
    for _ in range(2000):
        ad = 10.0 ** rng.uniform(-10, 0)
        t1, t2 = np.sort(np.abs(rng.standard_normal(2)) * 10.0 ** rng.uniform(-10, 1, 2))
        same_side = hk._cos_power_difference(t1, t2, ad, 2 * s, ca, cb, full)
        # the same interval mirrored, and one spanning the foot
        mirrored = hk._cos_power_difference(-t2, -t1, ad, 2 * s, ca, cb, full)
        spanning = hk._cos_power_difference(-t1, t2, ad, 2 * s, ca, cb, full)
        # the reference in the form that keeps its own accuracy: tails beyond
        # π/4, heads below; skipped where it cancels
        if t1 > ad:
            a, b = tail(t1, ad), tail(t2, ad)
        elif t2 > ad:
            a, b = full - tail(t2, ad), head(t1, ad)
        else:
            a, b = head(t2, ad), head(t1, ad)
        ref = a - b
        if ref < 1e-3 * a:
            continue
        ref_span = sum(head(t, ad) if t <= ad else full - tail(t, ad) for t in (t1, t2))
        worst = max(worst, abs(same_side - ref) / ref, abs(mirrored - ref) / ref,
                    abs(spanning - ref_span) / ref_span)
    assert worst <= 1e-11
    assert abs(hk._cos_power_difference(-1e300, 1e300, 1.0, 2 * s, ca, cb, full)
               - 2 * full) <= 1e-14


def test_cluster_tree_matches_its_reference():
    from fracfem.assembly import _element_geometry, mesh_arrays
    from fracfem.compressed import cluster_tree, cluster_tree_reference, square_around
    from fracfem.meshes import disk_graded_aniso

    p, t = mesh_arrays(disk_graded_aniso(0.05))
    _, cent, diam = _element_geometry(p, t)
    x = np.random.default_rng(4).random((5000, 2))
    x[:40] = 0.25                                   # coincident points stay one leaf
    for pts, dm, leaf, root in ((cent, diam, 8, None), (cent, diam, 64, None),
                                (x, np.zeros(len(x)), 16, square_around(x, cent))):
        fast = cluster_tree(pts, dm, leaf, root)
        ref = cluster_tree_reference(pts, dm, leaf, root)
        assert fast.keys() == ref.keys()
        for key in ref:
            np.testing.assert_array_equal(fast[key], ref[key], err_msg=key)
    leaves = np.flatnonzero(fast["child0"] < 0)
    assert (fast["end"] - fast["start"])[leaves].max() == 40


def test_restriction_to_free_nodes_in_place():
    import scipy.sparse as sp

    from fracfem.compressed import _restrict

    A = sp.random(200, 200, density=0.1, random_state=5, format="csr")
    A = (A + A.T).tocsr()
    A.sort_indices()
    A = sp.csr_matrix((A.data.copy(), A.indices.astype(np.int64),
                       A.indptr.astype(np.int64)), shape=A.shape)
    free = np.sort(np.random.default_rng(6).choice(200, 150, replace=False))
    expected = A[free][:, free].toarray()
    B = _restrict(A, free)
    np.testing.assert_array_equal(B.toarray(), expected)
    assert B.data.nbytes == 8 * B.nnz and B.has_sorted_indices


def test_in_place_symmetrisation_matches_its_reference():
    """symmetrize_csr_inplace (the assembly's) gives S + Sᵀ of the reference
    symmetrize_csr to the last bit, on a symmetric pattern with int32 and
    int64 indices."""
    import scipy.sparse as sp

    from fracfem import _h2_kernels as hk

    P = sp.random(300, 300, density=0.05, random_state=7, format="csr")
    P = (P + P.T + sp.eye(300)).tocsr()
    P.sort_indices()
    data = np.random.default_rng(8).standard_normal(P.nnz)   # not symmetric
    expected = hk.symmetrize_csr(P.indptr.astype(np.int64), P.indices.astype(np.int64), data)
    for itype in (np.int32, np.int64):
        got = data.copy()
        hk.symmetrize_csr_inplace(P.indptr.astype(np.int64), P.indices.astype(itype), got)
        np.testing.assert_array_equal(got, expected)
    S = sp.csr_matrix((data, P.indices, P.indptr), shape=P.shape)
    np.testing.assert_allclose(sp.csr_matrix((expected, P.indices, P.indptr),
                                             shape=P.shape).toarray(),
                               (S + S.T).toarray(), rtol=0, atol=1e-15)


def test_scatter_csr_adds_into_the_pattern_and_refuses_entries_outside_it():
    """scatter_csr sums local matrices into a CSR pattern as a dense scatter
    does, repeated node pairs included; an entry the pattern lacks (between
    two of its columns, past its last, in an empty row) raises instead of
    landing on a neighbour."""
    import scipy.sparse as sp

    from fracfem import _h2_kernels as hk

    rng = np.random.default_rng(11)
    n = 40
    nodes = rng.integers(0, n - 1, size=(25, 3))          # row n - 1 stays empty
    local = rng.standard_normal((25, 3, 3))
    rows = np.repeat(nodes, 3, axis=1).ravel()
    cols = np.tile(nodes, (1, 3)).ravel()
    P = sp.csr_matrix((np.ones(rows.size), (rows, cols)), shape=(n, n))
    P.sort_indices()
    indptr, indices = P.indptr.astype(np.int64), P.indices.astype(np.int32)
    data = np.zeros(P.nnz)
    hk.scatter_csr(indptr, indices, data, nodes, local, 0.5)
    dense = np.zeros((n, n))
    for k in range(len(nodes)):
        for a in range(3):
            for b in range(3):
                dense[nodes[k, a], nodes[k, b]] += 0.5 * local[k, a, b]
    got = sp.csr_matrix((data, indices, indptr), shape=(n, n)).toarray()
    np.testing.assert_allclose(got, dense, rtol=1e-14, atol=1e-15)

    i = int(np.argmax(np.diff(indptr)))                    # a row with a gap
    row = indices[indptr[i]:indptr[i + 1]]
    gap = next(j for j in range(row[0], row[-1]) if j not in row)
    before = data.copy()
    for a, b in [(i, gap), (i, int(row[-1]) + 1), (n - 1, 0)]:
        assert P[a, b] == 0
        with pytest.raises(IndexError, match="outside the near-field pattern"):
            hk._csr_add(indptr, indices, data, a, b, 1.0)
    np.testing.assert_array_equal(data, before)


def test_near_pattern_is_the_node_pairs_of_the_near_blocks():
    """The near field's pattern is exactly the node pairs of the elements of
    every near block (from the tree, pair by pair), with sorted int32 column
    indices."""
    from fracfem import compressed as C
    from fracfem.assembly import mesh_arrays

    p, t = mesh_arrays(disk_uniform(4))
    _, cent, diam = C._element_geometry(p, t)
    tree = C.cluster_tree(cent, diam, 8)
    _, near = C.block_tree(tree, tree, 1.0, 8.0)
    indptr, indices = C._near_pattern(tree, near, t, len(p))
    assert indices.dtype == np.int32 and indptr.dtype == np.int64
    assert all(np.all(np.diff(indices[indptr[i]:indptr[i + 1]]) > 0) for i in range(len(p)))
    pairs = set()
    for a, b in near:
        ea = tree["perm"][tree["start"][a]:tree["end"][a]]
        eb = tree["perm"][tree["start"][b]:tree["end"][b]]
        pairs.update((int(i), int(j)) for i in np.unique(t[ea]) for j in np.unique(t[eb]))
    rows = np.repeat(np.arange(len(p)), np.diff(indptr))
    assert set(zip(rows.tolist(), indices.tolist())) == pairs
    assert len(pairs) == len(indices)


def test_restriction_of_owned_arrays_compacts_them_in_place():
    """_restrict_arrays on arrays of its own (as the assembly's) keeps their
    memory: no second copy of the values or indices at the peak."""
    import scipy.sparse as sp

    from fracfem.compressed import _restrict_arrays

    A = sp.random(200, 200, density=0.1, random_state=9, format="csr")
    A = (A + A.T).tocsr()
    A.sort_indices()
    data, indices = A.data.copy(), np.array(A.indices, dtype=np.int32)
    free = np.sort(np.random.default_rng(10).choice(200, 150, replace=False))
    expected = A[free][:, free].toarray()
    B = _restrict_arrays(A.indptr.astype(np.int64), indices, data, free, 200)
    np.testing.assert_array_equal(B.toarray(), expected)
    assert np.shares_memory(B.data, data) and np.shares_memory(B.indices, indices)
    assert B.data.nbytes == 8 * B.nnz and B.indices.dtype == np.int32


@pytest.mark.parametrize("comps", [(-1,), (0, 1)])
def test_batched_far_field_matches_stored_coupling_matrices(comps):
    """far_values makes its coupling matrices batch by batch; the sums equal
    those with every matrix stored, whatever the batch size."""
    from fracfem import compressed as C
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, (900, 2))
    pts = rng.uniform(-1, 1, (700, 2))
    src = np.zeros((len(comps), len(pts), 1, 6))
    src[..., 0] = rng.standard_normal((len(comps), len(pts), 1))
    root = C.square_around(x, pts)
    tt = C.cluster_tree(x, np.zeros(len(x)), 16, root)
    ts = C.cluster_tree(pts, np.zeros(len(pts)), 16, root)
    far, _ = C.block_tree(tt, ts, 1.0, 2.0)
    m, expo = 6, -1.3
    z = C.chebyshev_points(m)
    f = C._far_blocks(tt, ts, far, C._tree_data(tt, x, z), C._tree_data(ts, pts, z), z,
                      expo, comps=comps)
    K = f["K"] if len(comps) > 1 else [f["K"]]
    assert len(f["grp_ptr"]) > 20                     # several batches below
    stored = sum(C._far_pass(f, src[c], K[c], nder=1)[:, 0, 0] for c in range(len(comps)))
    scale = np.abs(stored).max()
    assert scale > 0
    for batch in (None, 8 * m ** 4, 7 * 8 * m ** 4):   # default, one and seven per batch
        got = C.far_values(tt, ts, far, x, pts, m, expo, src, comps, batch_bytes=batch)
        assert got.shape == (len(x), 1)
        got = got[:, 0]
        assert np.abs(got - stored).max() <= 1e-13 * scale
    with pytest.raises(ValueError, match="batch_bytes=0"):
        C.far_values(tt, ts, far, x, pts, m, expo, src, comps, batch_bytes=0)


@pytest.mark.parametrize("name,s,leaf", [("lshape", 0.3, 8), ("disk", 0.8, 24),
                                         ("square", 0.5, 12)])
def test_leaf_matrix_product_matches_leaf_kernels(name, s, leaf):
    """The far field through the leaf matrix (W = M x, −c Mᵀ(G₀ + G₁, G₀))
    against its reference, the element sources and leaf kernels."""
    mesh = MESHES[name]()
    op = stiffness_operator(mesh, s, leaf_size=leaf)
    assert op.info["far_blocks"] > 0
    M = op.leaf_matrix
    p = op.info["order"] ** 2
    assert M.shape == (2 * p * len(op._far["src"]["leaves"]), op.shape[0])
    rng = np.random.default_rng(7)
    X = np.column_stack([rng.standard_normal(op.shape[0]), np.ones(op.shape[0]),
                         np.eye(op.shape[0])[:, op.shape[0] // 2]])
    assert np.linalg.norm(op.far_matvec_reference(X[:, 0])) > 0
    for x in X.T:
        ref = op.far_matvec_reference(x)
        np.testing.assert_allclose(op.far_matvec(x), ref, rtol=0,
                                   atol=1e-13 * max(np.abs(ref).max(), 1e-300))
    # the threaded sparse products against scipy's
    from fracfem.compressed import _csr_rmatvec
    g = rng.standard_normal(M.shape[0])
    np.testing.assert_allclose(_csr_rmatvec(M, g), M.T @ g, rtol=1e-12,
                               atol=1e-14 * np.abs(M.T @ g).max())
    for x in X.T:
        np.testing.assert_allclose(op.near_matvec(x), op.near @ x, rtol=1e-14, atol=0)
    # without the leaf matrix the product is the reference path, and the
    # operator holds less
    bare = stiffness_operator(mesh, s, leaf_size=leaf, leaf_matrices=False)
    assert bare.leaf_matrix is None
    x = X[:, 0]
    np.testing.assert_allclose(bare @ x, op @ x, rtol=0, atol=1e-13 * np.abs(op @ x).max())
    assert bare.nbytes < op.nbytes


def test_near_field_in_row_classes_equals_per_thread_copies():
    """The near field written by all threads into one array, a class of row
    clusters at a time, equals its reference (every thread a private copy,
    summed) to round-off, and does not depend on how many parts the parallel
    loop has; within a class no two row clusters share a node."""
    from fracfem import compressed as C
    from fracfem.assembly import QuadratureOptions, mesh_arrays
    from fracfem.meshes import disk_graded_aniso

    p, t = mesh_arrays(disk_graded_aniso(0.1))
    geometry = C._element_geometry(p, t)
    moments = C._element_moments(p, t)
    tree = C.cluster_tree(geometry[1], geometry[2], 8)
    quad = QuadratureOptions()
    _, near = C.block_tree(tree, tree, 1.0, float(quad.far_thresholds[0]))
    args = (p, t, tree, near, quad, 0.4, geometry, moments)

    ref = C._near_field(*args, per_thread_copies=True, nchunks=3)
    runs = [C._near_field(*args, nchunks=k) for k in (1, 2, 5)]
    for r in runs:
        np.testing.assert_array_equal(r[0], ref[0])
        np.testing.assert_array_equal(r[1], ref[1])
        np.testing.assert_array_equal(r[2], runs[0][2])      # bitwise, whatever the parts
        scale = np.abs(ref[2]).max()
        assert np.abs(r[2] - ref[2]).max() <= 1e-14 * scale
        Dr, Dref = r[3].sum(axis=0), ref[3].sum(axis=0)
        assert np.all(np.abs(Dr - Dref) <= 1e-13 * np.abs(Dref).max(axis=0))
    assert np.abs(ref[2]).max() > 0

    rows, _, _ = C.near_lists(near)
    order, ptr = C._row_classes(tree, rows, t, len(p))
    assert sorted(order.tolist()) == list(range(len(rows))) and ptr[-1] == len(rows)
    assert len(ptr) - 1 >= 2                                # neighbours do exist
    with pytest.raises(ValueError, match="must be leaves"):
        C._row_classes(tree, np.array([0]), t, len(p))      # the root is no leaf
    for k in range(len(ptr) - 1):
        seen = set()
        for ri in order[ptr[k]:ptr[k + 1]]:
            c = rows[ri]
            nodes = set(t[tree["perm"][tree["start"][c]:tree["end"][c]]].ravel().tolist())
            assert not nodes & seen
            seen |= nodes

    # what makes the classes race-free: a row cluster writes only rows of its own nodes
    from fracfem import _kernels

    indptr, indices = C._near_pattern(tree, near, t, len(p))
    qx, qw, lam, offs = C._far_rules(p, t, quad.far_orders, geometry[0])
    rows, bptr, cols = C.near_lists(near)
    row_of = np.repeat(np.arange(len(p)), np.diff(indptr))
    for ri in np.random.default_rng(5).choice(len(rows), 12, replace=False):
        data = np.zeros((1, len(indices)))
        _kernels.near_pairs(t, tree["perm"], tree["start"], tree["end"], bptr, rows, cols,
                            geometry[1], geometry[2], *moments, qx, qw, lam, offs,
                            np.asarray(quad.far_thresholds, dtype=np.float64), True, 0.4,
                            indptr, indices, len(p), np.array([ri]), np.array([0, 1]), 1,
                            data)
        c = rows[ri]
        own = set(t[tree["perm"][tree["start"][c]:tree["end"][c]]].ravel().tolist())
        written = set(row_of[data[0] != 0].tolist())
        assert written and written <= own


@pytest.mark.parametrize("name,s,leaf", [("lshape", 0.3, 8), ("disk", 0.8, 24)])
def test_product_of_a_block_of_columns_equals_the_products_column_by_column(
        name, s, leaf, monkeypatch):
    """op @ X (CompressedOperator._matmat: the near field and the leaf matrix read once
    for a block, the far field's expansions of all its columns together) against its
    reference, op @ x column by column; in blocks of every size up to more than the
    columns, with a last block shorter than the others."""
    from fracfem import compressed
    mesh = MESHES[name]()
    op = stiffness_operator(mesh, s, leaf_size=leaf)
    assert op.info["far_blocks"] > 0
    rng = np.random.default_rng(11)
    X = np.column_stack([rng.standard_normal((op.shape[0], 5)), np.ones(op.shape[0]),
                         np.eye(op.shape[0])[:, 3]])
    single = np.column_stack([op @ x for x in X.T])
    # the columns differ, so a block mixing them up would not pass
    assert np.linalg.norm(single[:, 0] - single[:, 1]) > 0.1 * np.linalg.norm(single[:, 0])
    for block in (1, 2, 3, 7, 32):
        monkeypatch.setattr(compressed, "MATMAT_COLUMNS", block)
        assert op.matmat_block() == block
        Y = op @ X
        assert Y.shape == X.shape
        np.testing.assert_allclose(Y, single, rtol=0, atol=1e-13 * np.abs(single).max())
    # a block of one column and no columns at all; a block of the wrong length
    np.testing.assert_allclose(op @ X[:, :1], single[:, :1], rtol=0,
                               atol=1e-13 * np.abs(single).max())
    assert (op @ X[:, :0]).shape == (op.shape[0], 0)
    with pytest.raises(ValueError, match="X must have shape"):
        op._matmat(X[1:])
    # the far field alone, against its own size (the near field dominates op @ x)
    monkeypatch.setattr(compressed, "MATMAT_COLUMNS", 4)
    far = np.column_stack([op.far_matvec(x) for x in X.T])
    np.testing.assert_allclose(op._far_matmat(np.ascontiguousarray(X[:, :4])), far[:, :4],
                               rtol=0, atol=1e-13 * np.abs(far).max())
    # on one thread (the coupling's sums are then the one thread's own array)
    import numba
    threads = numba.get_num_threads()
    numba.set_num_threads(1)
    try:
        np.testing.assert_allclose(op @ X, single, rtol=0,
                                   atol=1e-13 * np.abs(single).max())
    finally:
        numba.set_num_threads(threads)
    # a memory bound below one column's work arrays: one column at a time
    monkeypatch.setattr(compressed, "MATMAT_COLUMNS", 32)
    monkeypatch.setattr(compressed, "MATMAT_BYTES", 1)
    np.testing.assert_allclose(op @ X, single, rtol=0, atol=1e-13 * np.abs(single).max())
    # without the leaf matrix: the reference path, column by column
    bare = stiffness_operator(mesh, s, leaf_size=leaf, leaf_matrices=False)
    np.testing.assert_allclose(bare @ X, single, rtol=0, atol=1e-13 * np.abs(single).max())
