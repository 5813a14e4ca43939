"""Public entry points check their meshes once and refuse dense problems that cannot fit."""
import tracemalloc
from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings, strategies as st
from skfem import MeshTri

import fracfem as ff
from fracfem import estimators, examples, memory, meshes, solvers, transfer, vi
from fracfem.assembly import dense_bytes
from fracfem.meshes import _coincident_pairs, validate_mesh
from fracfem.memory import ENV, DenseMemoryError

CHI = examples.paraboloid_obstacle()


def _interior_node(mesh):
    """An interior node with at least four triangles (so half of them is at least two)."""
    count = np.bincount(mesh.t.ravel(), minlength=mesh.p.shape[1])
    return next(int(i) for i in mesh.interior_nodes() if count[i] >= 4)


def duplicated_used(mesh):
    """Node k split into two copies at one place, each referenced by some triangles."""
    p, t = mesh.p.copy(), mesh.t.copy()
    k = _interior_node(mesh)
    n = p.shape[1]
    tri = np.flatnonzero((t == k).any(axis=0))
    for e in tri[: len(tri) // 2]:
        t[t[:, e] == k, e] = n
    return MeshTri(np.hstack([p, p[:, [k]]]), t, sort_t=False), (k, n)


def duplicated_unused(mesh):
    """An extra copy of node k that no triangle references."""
    k = _interior_node(mesh)
    return MeshTri(np.hstack([mesh.p, mesh.p[:, [k]]]), mesh.t, sort_t=False), (k, mesh.p.shape[1])


def corrupted(mesh, kind):
    """(bad mesh, regex the error must match) for one kind of corruption."""
    p, t = mesh.p.copy(), mesh.t.copy()
    n = p.shape[1]
    if kind == "duplicate used":
        bad, (k, j) = duplicated_used(mesh)
        return bad, rf"\.p has duplicate nodes: \[{k}, {j}\]"
    if kind == "duplicate unused":
        bad, (k, j) = duplicated_unused(mesh)
        return bad, rf"\.p has duplicate nodes: \[{k}, {j}\]"
    if kind == "unused":
        return (MeshTri(np.hstack([p, [[5.0], [5.0]]]), t, sort_t=False),
                rf"\.p has unused nodes not referenced by .*\.t: \[{n}\]")
    if kind == "zero area":
        # move an interior vertex of triangle e onto the midpoint of its opposite edge
        k = _interior_node(mesh)
        e = int(np.flatnonzero((t == k).any(axis=0))[0])
        a, b = (v for v in t[:, e] if v != k)
        p[:, k] = 0.5 * (p[:, a] + p[:, b])
        return MeshTri(p, t, sort_t=False), rf"\.t has \(near-\)zero-area triangles \[{e}"
    if kind == "nan":
        k = _interior_node(mesh)
        p[1, k] = np.nan
        return MeshTri(p, t, sort_t=False), rf"\.p has NaN/inf coordinates at nodes \[{k}\]"
    if kind == "p shape":
        return (SimpleNamespace(p=np.vstack([p, p[:1]]), t=t),
                r"\.p must be a float array of shape \(2, Nv\).*shape \(3, ")
    if kind == "t shape":
        return (SimpleNamespace(p=p, t=t[:2]),
                r"\.t must be an integer array of shape \(3, Nt\).*shape \(2, ")
    raise AssertionError(kind)


KINDS = ["duplicate used", "duplicate unused", "unused", "zero area", "nan", "p shape", "t shape"]


def test_used_duplicate_changes_the_answer_without_the_check(monkeypatch):
    """What the check guards against: a node split into two copies cracks the mesh and,
    unchecked, (f, u_h) silently drops from 1.2567 to 1.14 on disk_uniform(3)."""
    good = ff.disk_uniform(3)
    bad, (k, j) = duplicated_used(good)

    # without the graded rules of thin pairs, which refuse the crack on their own
    quad = ff.QuadratureOptions(thin_closeness=0.0)

    def energy(mesh, quadrature=quad):
        disc = ff.discretise(mesh, 0.5, 1.0, quadrature=quadrature)
        return float(disc.b @ ff.solve_laplace(disc))

    e_good = energy(good)
    assert abs(e_good - ff.disk_energy(0.5)) < 0.1 * ff.disk_energy(0.5)
    with pytest.raises(ValueError, match=rf"^mesh\.p has duplicate nodes: \[{k}, {j}\]"):
        energy(bad)
    monkeypatch.setattr(meshes, "validate_mesh", lambda p, t, name="": None)
    assert abs(energy(bad) - e_good) > 0.05 * e_good
    with pytest.raises(ValueError, match=r"element pair with nodes .* is degenerate"):
        energy(bad, None)          # the thin-pair rules refuse the crack instead of crashing


def test_validated_block_refuses_a_bad_mesh():
    bad, (k, j) = duplicated_used(ff.disk_uniform(3))
    with pytest.raises(ValueError, match=rf"^coarse\.p has duplicate nodes: \[{k}, {j}\]"):
        with meshes.validated(coarse=bad):
            pass


@pytest.mark.parametrize("kind", KINDS)
def test_stiffness_matrix_rejects(kind):
    bad, match = corrupted(ff.disk_uniform(3), kind)
    with pytest.raises(ValueError, match=r"^mesh" + match):
        ff.stiffness_matrix(bad, 0.5)
    with pytest.raises(ValueError, match=r"^mesh" + match):
        ff.load_vector(bad, 1.0)


@pytest.mark.parametrize("kind", KINDS)
def test_discretise_rejects(kind):
    bad, match = corrupted(ff.disk_uniform(3), kind)
    with pytest.raises(ValueError, match=r"^mesh" + match):
        ff.discretise(bad, 0.5, 1.0)


@pytest.mark.parametrize("kind", KINDS)
def test_mixed_problem_rejects(kind):
    bad, match = corrupted(ff.disk_uniform(2), kind)
    with pytest.raises(ValueError, match=r"^coarse" + match):
        vi.mixed_problem("obstacle", bad, 0.5, 1.0, chi=CHI)
    with pytest.raises(ValueError, match=r"^coarse" + match):
        vi.mixed_problem("friction", bad, 0.6, 1.0, F=0.5)


@pytest.mark.parametrize("kind", ["duplicate used", "zero area", "nan"])
def test_other_entries_reject(kind):
    good = ff.disk_uniform(2)
    bad, match = corrupted(good, kind)
    with pytest.raises(ValueError, match=r"^mesh" + match):
        meshes.refine_disk(bad)
    with pytest.raises(ValueError, match=r"^mesh_from" + match):
        transfer.transfer(bad, np.zeros(bad.p.shape[1]), good)
    with pytest.raises(ValueError, match=r"^mesh_to" + match):
        transfer.transfer(good, np.zeros(good.p.shape[1]), bad)
    with pytest.raises(ValueError, match=r"^mesh" + match):
        transfer.locate(bad, np.zeros((2, 1)))


def test_not_a_mesh_is_named():
    with pytest.raises(ValueError, match=r"^mesh must be a scikit-fem triangle mesh .*ndarray"):
        ff.stiffness_matrix(np.zeros((2, 3)), 0.5)


def _count_checks(monkeypatch):
    calls = []
    real = meshes.validate_mesh

    def counting(p, t, *, name=""):
        calls.append(name)
        return real(p, t, name=name)

    monkeypatch.setattr(meshes, "validate_mesh", counting)
    return calls


def test_each_entry_checks_each_mesh_once(monkeypatch):
    calls = _count_checks(monkeypatch)
    mesh = ff.disk_uniform(2)
    ff.stiffness_matrix(mesh, 0.5)
    assert calls == ["mesh"]
    calls.clear()
    disc = ff.discretise(mesh, 0.5, 1.0)      # stiffness_matrix and load_vector inside
    assert calls == ["mesh"]
    calls.clear()
    u = disc.extend(ff.solve_laplace(disc))
    estimators.estimate_laplace(disc, u, 1.0)  # residual, pointwise, patch diameters inside
    assert calls == ["disc.mesh"]
    calls.clear()
    prob = vi.mixed_problem("friction", ff.disk_uniform(1), 0.6, 1.0, F=0.5)
    assert calls == ["coarse", "mesh"]         # the fine mesh once, inside discretise
    calls.clear()
    u, lam, _ = vi.solve(prob, "pdas")
    estimators.estimate(prob, u, lam, f=1.0)
    assert sorted(calls) == ["prob.coarse", "prob.fine"]
    calls.clear()
    transfer.transfer(prob.fine, u, mesh)
    assert calls == ["mesh_from", "mesh_to"]


# ------------------------------------------------------------ duplicate search

@settings(max_examples=60, deadline=None)
@given(n=st.integers(3, 60), seed=st.integers(0, 2**32 - 1),
       spread=st.sampled_from([0.5, 1.0, 1.5, 3.0]))
def test_coincident_pairs_against_brute_force(n, seed, spread):
    """Clusters of points about tol apart on a grid (many equal x and y): every node of
    a pair closer than tol in both coordinates is reported, and every reported pair is
    within 2 tol in x and tol in y."""
    rng = np.random.default_rng(seed)
    tol = 1e-3
    p = rng.integers(-3, 3, size=(2, n)) + rng.uniform(-spread, spread, size=(2, n)) * tol
    pairs = _coincident_pairs(p, tol)
    dx = np.abs(p[0][:, None] - p[0][None, :])
    dy = np.abs(p[1][:, None] - p[1][None, :])
    for i, j in pairs:
        assert i < j and dx[i, j] < 2 * tol and dy[i, j] <= tol
    reported = set(pairs.ravel().tolist())
    for i, j in zip(*np.nonzero(np.triu((dx < tol) & (dy <= tol), k=1))):
        assert i in reported and j in reported


def test_near_duplicate_across_a_cell_boundary_is_found():
    """Nodes 1e-16 apart on either side of a cell boundary of the first sort (x = 0)."""
    m = ff.square(4)
    p, t = m.p.copy(), m.t.copy()
    k = int(next(i for i in m.interior_nodes() if p[0, i] == 0.0))
    q = p[:, [k]] - np.array([[1e-16], [0.0]])
    width = 2 * 1e-14 * np.abs(p).max()
    assert np.floor(q[0, 0] / width) != np.floor(p[0, k] / width)   # the first pass splits them
    tri = np.flatnonzero((t == k).any(axis=0))[0]
    t[t[:, tri] == k, tri] = p.shape[1]
    with pytest.raises(ValueError, match=rf"^p has duplicate nodes: \[{k}, {p.shape[1]}\]"):
        validate_mesh(np.hstack([p, q]), t)


# ------------------------------------------------------------ memory guard

def test_memory_refusal_names_size_memory_and_alternative():
    mesh = ff.disk_uniform(6)                     # 8321 nodes: about 0.6 GiB
    n = mesh.p.shape[1]
    tracemalloc.start()
    try:
        with pytest.raises(DenseMemoryError) as err:
            ff.stiffness_matrix(mesh, 0.5, memory_limit="100M", nchunks=2)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    msg = str(err.value)
    assert isinstance(err.value, MemoryError) and isinstance(err.value, ValueError)
    assert f"N = {n} nodes" in msg
    need = dense_bytes(n, mesh.t.shape[1], 2) / 2**30
    assert f"needs about {need:.3g} GiB" in msg and 0.5 < need < 0.7
    assert "only 0.0977 GiB are allowed by memory_limit=" in msg
    assert "use a coarser mesh (about N = " in msg
    assert "operator='compressed'" in msg
    fit = int(msg.split("about N = ")[1].split()[0])
    assert 0 < fit < n and 8 * fit**2 < 100 * 2**20
    assert peak < 20 * 2**20, peak                 # the 530 MiB matrix was never allocated


_PEAK_SCRIPT = """
import resource, sys
import numba
import fracfem as ff
what, nchunks = sys.argv[1], int(sys.argv[2])
numba.set_num_threads(min(nchunks, numba.config.NUMBA_NUM_THREADS))
run = ((lambda m: ff.stiffness_matrix(m, 0.5, nchunks=nchunks)) if what == "matrix"
       else (lambda m: ff.discretise(m, 0.5, 1.0)))
run(ff.disk_uniform(2))                                   # kernels loaded
mesh = ff.disk_uniform(5)
before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
run(mesh)
after = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
print((after - before) * 1024 / (8.0 * mesh.p.shape[1] ** 2))
"""


@pytest.mark.parametrize("what,nchunks,bound", [("matrix", 1, 2.0), ("matrix", 6, 2.0),
                                                ("discretise", 2, 1.75)])
def test_dense_assembly_holds_one_matrix_whatever_the_threads(what, nchunks, bound):
    """The far field goes into the matrix itself: assembling disk_uniform(5) (2,113 nodes,
    a 36 MB matrix) with 1 or 6 far-field chunks raises the peak resident memory of a fresh
    process by less than two matrices (one far-field copy per chunk, as before, would add
    six more); discretise takes the free block (1,985 nodes) inside that matrix, by less
    than 1.75 matrices (a copy of the block beside it: 1.98 measured)."""
    import subprocess
    import sys
    out = subprocess.run([sys.executable, "-c", _PEAK_SCRIPT, what, str(nchunks)], check=True,
                         capture_output=True, text=True)
    growth = float(out.stdout.split()[-1])
    assert growth < bound, (what, nchunks, growth)


def test_huge_mesh_is_refused_without_a_forced_limit():
    """disk_uniform(8): 1.3·10⁵ nodes, about 130 GiB."""
    mesh = ff.disk_uniform(8)
    need = dense_bytes(mesh.p.shape[1], mesh.t.shape[1], 2)
    avail = memory.available_memory()
    if avail is None or avail >= need:
        pytest.skip("this machine would fit the problem")
    with pytest.raises(DenseMemoryError,
                       match=r"N = 131585 nodes .*needs about 1[23]\d GiB.* GiB are available"):
        ff.stiffness_matrix(mesh, 0.5, nchunks=2)


def test_environment_limit_reaches_discretise_mixed_problem_and_solvers(monkeypatch):
    prob = vi.mixed_problem("friction", ff.disk_uniform(2), 0.6, 1.0, F=0.5)
    monkeypatch.setenv(ENV, "64K")
    with pytest.raises(DenseMemoryError, match=rf"N = 145 nodes .*allowed by {ENV}.*coarser mesh"):
        ff.discretise(ff.disk_uniform(3), 0.5, 1.0)
    with pytest.raises(DenseMemoryError, match=rf"N = 145 nodes .*allowed by {ENV}"):
        vi.mixed_problem("obstacle", ff.disk_uniform(2), 0.5, 1.0, chi=CHI)
    n, m = prob.cset.B.shape
    with pytest.raises(DenseMemoryError, match=rf"Cholesky factor of the {n} × {n}"):
        solvers.cholesky_factor(prob.disc.A)
    monkeypatch.setenv(ENV, "1K")
    factor = (np.eye(4), True)
    with pytest.raises(DenseMemoryError, match=r"Schur complement .* m = 30 multipliers"):
        solvers.schur_complement(factor, sp.random(4, 30, density=0.5, random_state=0))


@pytest.mark.parametrize("bad", ["lots", "-1G", 0, -5.0, float("nan"), float("inf")])
def test_bad_memory_limit_is_named(bad):
    with pytest.raises(ValueError, match=r"memory_limit=.* must be a positive number of bytes"):
        ff.stiffness_matrix(ff.disk_uniform(1), 0.5, memory_limit=bad)
