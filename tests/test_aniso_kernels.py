"""Tests of the graded rules of thin element pairs and of κ on thin elements
(fracfem._aniso_kernels and their use in fracfem.assembly) against the slow
references of tests/reference.py on pairs of aspect ratio 10³, and of the
assembled matrix on ring meshes.

Measured agreement with the references (default QuadratureOptions, aspect 10³):
triangle moments ≤ 3e-5 (worst on a shape-regular triangle, one panel per
edge), touching pairs ≤ 2e-6, a separated pair 6e-5 (the reference's own
accuracy there is ~1e-4).  The fixed rules miss the same quantities by
10 %–700 %.
"""
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la

import fracfem as ff
from fracfem import _aniso_kernels, _kernels, assembly
from fracfem.assembly import QuadratureOptions, _singular_local, mesh_arrays, stiffness_matrix
from fracfem.quadrature import gauss01

import reference as ref

DEFAULT = QuadratureOptions()
ASPECT = 1000.0


def strips(a=ASPECT):
    """Two layers of h × h/a rectangles, each split by its diagonal (nodes
    0–5), like the boundary layer of a ring mesh."""
    w = 1.0 / a
    return np.array([[0, 0], [1, 0], [0, w], [1, w], [0, 2 * w], [1, 2 * w]], dtype=float)


def rel(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


# ---------------------------------------------------------------------------
# the point–triangle moments


@pytest.mark.parametrize("V", [
    [[0.5, 0.2], [1.5, 0.3], [0.8, 1.2]],                 # shape regular, at distance ~ size
    [[0.01, 0.0], [1.0, 0.0], [0.5, 0.02]],               # thin, 0 near a vertex
    [[-1.0, 1e-3], [1.0, 2e-3], [0.3, 2.2e-3]],           # sliver over 0, aspect ~ 10³
    [[-0.5, 0.0625], [0.5, 0.0625], [0.5, 0.003]],        # radially thin seen from 0
])
@pytest.mark.parametrize("s", [0.25, 0.75])
def test_triangle_moments_against_reference(V, s):
    V = np.array(V)
    gx, gw = gauss01(DEFAULT.thin_gauss)
    K = np.empty(6)
    _aniso_kernels._tri_moments(V, s, gx, gw, DEFAULT.thin_ratio, K)
    assert rel(K, ref.triangle_moments_reference(V, s)) < 1e-4


# ---------------------------------------------------------------------------
# touching pairs of aspect ratio 10³

PAIRS = {
    "identical": ("coincident", [0, 1, 3]),
    "common long diagonal": ("edge", [0, 3, 1, 2]),
    "common long side (two layers)": ("edge", [2, 3, 0, 5]),
    "common vertex (two layers)": ("vertex", [3, 0, 1, 2, 5]),
}


@pytest.mark.parametrize("name", list(PAIRS))
def test_thin_touching_pairs_against_reference(name):
    kind, nodes = PAIRS[name]
    s = 0.75 if kind == "vertex" else 0.25
    p = strips()
    nd = np.array([nodes])
    assert _aniso_kernels.pair_closeness(p, nd, assembly._KIND[kind])[0] < 1.5 / ASPECT
    opts = {"epsrel": 1e-6, "n": 6} if kind != "coincident" else {}
    want = ref.thin_pairs_reference(p, nd, kind, s, **opts)[0]
    got = _singular_local(p, nd, kind, 5, s, DEFAULT)[0]
    assert rel(got, want) < 1e-5
    # the fixed rule at the default order is far off: the test is not vacuous
    fixed = _singular_local(p, nd, kind, getattr(DEFAULT, kind), s,
                            QuadratureOptions(thin_closeness=0.0))[0]
    assert rel(fixed, want) > 1e-2


def test_thin_pair_rules_agree_with_fixed_rules_on_a_shape_regular_pair():
    """Where the fixed rules converge (n = 30), the graded ones agree."""
    p = np.array([[0, 0], [1, 0.1], [0.3, 0.8], [0.6, -0.7], [-0.9, 0.2]], dtype=float)
    q = QuadratureOptions(thin_closeness=1.0)            # force the graded rules
    for kind, nodes in (("coincident", [0, 1, 2]), ("edge", [0, 1, 2, 3]),
                        ("vertex", [0, 1, 2, 3, 4])):
        nd = np.array([nodes])
        want = _singular_local(p, nd, kind, 30, 0.5, QuadratureOptions(thin_closeness=0.0))[0]
        assert rel(_singular_local(p, nd, kind, 5, 0.5, q)[0], want) < 1e-4


# ---------------------------------------------------------------------------
# close separated pairs


def test_thin_separated_pair_against_reference():
    """Layers 0 and 2 of the strips (gap = width = 10⁻³, length 1)."""
    w = 1.0 / ASPECT
    PT = np.array([[0, 0], [1, 0], [1, w]])
    PT2 = np.array([[0, 2 * w], [1, 3 * w], [0, 3 * w]])
    want = ref.separated_pair_reference(PT, PT2, 0.5, n=5, extra=2)
    p = np.vstack([PT, PT2])
    t = np.array([[0, 1, 2], [3, 4, 5]])
    got = np.empty((1, 6, 6))
    gx, gw = gauss01(DEFAULT.thin_gauss)
    _aniso_kernels.separated_blocks(p, t, np.array([[0, 1]]), 0.5, gx, gw, DEFAULT.thin_ratio, got)
    assert rel(got[0], want) < 3e-4
    assert rel(ref.far_pair_reference(PT, PT2, 8, 0.5), want) > 0.1


def test_thin_separated_pair_in_either_order():
    """A thin layer next to one twice as thick: the kernel integrates over
    the smaller triangle outside and the larger inside whichever comes first,
    and the block comes back in the caller's node order."""
    w = 1.0 / ASPECT
    PT = np.array([[0, 0], [1, 0], [1, w]])
    PT2 = np.array([[0, 2 * w], [1, 4 * w], [0, 4 * w]])
    want = ref.separated_pair_reference(PT, PT2, 0.5, n=5, extra=2)
    p = np.vstack([PT, PT2])
    t = np.array([[0, 1, 2], [3, 4, 5]])
    gx, gw = gauss01(DEFAULT.thin_gauss)
    got = np.empty((2, 6, 6))
    _aniso_kernels.separated_blocks(p, t, np.array([[0, 1], [1, 0]]), 0.5, gx, gw,
                                    DEFAULT.thin_ratio, got)
    assert rel(got[0], want) < 3e-4
    swap = [3, 4, 5, 0, 1, 2]
    assert rel(got[1][np.ix_(swap, swap)], want) < 3e-4
    assert np.allclose(got[1][np.ix_(swap, swap)], got[0], rtol=0, atol=1e-13 * abs(want).max())


def test_separated_rule_matches_product_gauss_on_distant_pairs():
    T1 = np.array([[0, 0], [1, 0.2], [0.3, 0.9]])
    T2 = np.array([[1.5, 0.5], [2.5, 0.3], [1.9, 1.4]])
    gx, gw = gauss01(DEFAULT.thin_gauss)
    got = np.empty((1, 6, 6))
    _aniso_kernels.separated_blocks(np.vstack([T1, T2]), np.array([[0, 1, 2], [3, 4, 5]]),
                                    np.array([[0, 1]]), 0.5, gx, gw, DEFAULT.thin_ratio, got)
    assert rel(got[0], ref.far_pair_reference(T1, T2, 19, 0.5)) < 1e-5


def test_close_separated_pairs_match_bruteforce_and_far_blocks_match_reference():
    mesh = ff.disk_graded_rings(4, 3.0)
    p, t = mesh_arrays(mesh)
    pairs, gap = assembly.close_separated_pairs(p, t, DEFAULT)
    _, _, sep = ref.classify_pairs(t)
    diam = np.array([max(np.linalg.norm(p[t[T, i]] - p[t[T, (i + 1) % 3]]) for i in range(3))
                     for T in range(len(t))])
    want = []
    for T, T2 in sep:
        g = min(np.linalg.norm(ref._nearest_on_segment(p[t[T, i]], p[t[T2, j]],
                                                        p[t[T2, (j + 1) % 3]]) - p[t[T, i]])
                for i in range(3) for j in range(3))
        g = min(g, min(np.linalg.norm(ref._nearest_on_segment(p[t[T2, j]], p[t[T, i]],
                                                               p[t[T, (i + 1) % 3]]) - p[t[T2, j]])
                       for i in range(3) for j in range(3)))
        if g < DEFAULT.thin_closeness * max(diam[T], diam[T2]):
            want.append((T, T2))
    assert len(want) > 10
    assert sorted(map(tuple, pairs)) == sorted(want)
    # the product rule far_pairs used for them, pair by pair
    area2, cent, _ = assembly._element_geometry(p, t)
    qx, qw, lam, offs = assembly._far_rules(p, t, DEFAULT.far_orders, area2)
    std = np.empty((len(pairs), 6, 6))
    _kernels.far_rule_blocks(t, pairs, cent, diam, qx, qw, lam, offs,
                             np.asarray(DEFAULT.far_thresholds), 0.5, std)
    for (T, T2), blk in zip(pairs[:40], std[:40]):
        order = DEFAULT.far_orders[ref._far_level(p[t[T]], p[t[T2]], DEFAULT.far_thresholds)]
        assert rel(blk, ref.far_pair_reference(p[t[T]], p[t[T2]], order, 0.5)) < 1e-12


def test_close_separated_pairs_are_never_of_the_taylor_level():
    """With a Taylor threshold small enough that close pairs can reach it (1.5 h with
    thin_closeness 1), close_separated_pairs keeps exactly the close pairs that
    pair_level, which far_pairs and far_rule_blocks use, puts in a Gauss level."""
    quad = ff.QuadratureOptions(far_orders=(0, 4, 8), far_thresholds=(1.5, 1.0),
                                thin_closeness=1.0)
    p, t = mesh_arrays(ff.disk_graded_rings(4, 3.0))
    pairs, _ = assembly.close_separated_pairs(p, t, quad)
    every, _ = assembly.close_separated_pairs(p, t, replace(quad, far_orders=(4, 4, 8)))
    _, cent, diam = assembly._element_geometry(p, t)
    thr = np.asarray(quad.far_thresholds, dtype=np.float64)

    def level(T, T2):
        return _kernels.pair_level(T, T2, cent, diam, thr, 3)[0]

    taylor = [tuple(q) for q in every if level(*q) == 0]
    assert len(taylor) > 0 and len(pairs) > 0      # both kinds occur
    assert all(level(*q) > 0 for q in pairs)
    assert sorted(map(tuple, pairs)) == sorted(set(map(tuple, every)) - set(taylor))
    # a pair exactly on the threshold, where d² < (R h)² and r² ≥ R·R·h·h round
    # differently: pair_level puts it in a Gauss level, so it is kept
    hm = 0.9046800706458055
    dx = 1.5 * hm
    assert not dx * dx < (1.5 * hm) ** 2 and not dx * dx >= 1.5 * 1.5 * hm * hm
    two = np.array([[0.0, 0.0], [1.0, 0.0], [0.0, 1.0],
                    [0.0, -0.01], [1.0, -0.01], [0.5, -1.0]])
    tt = np.array([[0, 1, 2], [3, 4, 5]])
    geometry = (np.ones(2), np.array([[dx, 0.0], [0.0, 0.0]]), np.full(2, hm))
    (pair,), _ = assembly.close_separated_pairs(two, tt, quad, geometry)
    assert tuple(pair) == (0, 1)
    assert _kernels.pair_level(0, 1, geometry[1], geometry[2], thr, 3)[0] == 1


def test_shape_regular_meshes_keep_the_fixed_rules():
    """No pair of disk_uniform is routed to the graded rules (closeness >= 0.46),
    so its matrix and cost are those of the fixed rules.  (disk_graded has a few
    green-refined pairs of closeness 0.24–0.3 that are.)"""
    p, t = mesh_arrays(ff.disk_uniform(4))
    edge_nodes, vertex_nodes = assembly.touching_pairs(t)
    for kind, nodes in ((0, t), (1, edge_nodes), (2, vertex_nodes)):
        assert _aniso_kernels.pair_closeness(p, nodes, kind).min() > 0.45
    assert len(assembly.close_separated_pairs(p, t, DEFAULT)[0]) == 0
    mesh = ff.disk_uniform(3)
    free = mesh.interior_nodes()
    A = stiffness_matrix(mesh, 0.5)[np.ix_(free, free)]
    B = stiffness_matrix(mesh, 0.5, quadrature=QuadratureOptions(thin_closeness=0.0))[
        np.ix_(free, free)]
    assert np.array_equal(A, B)


# ---------------------------------------------------------------------------
# assembled matrices on anisotropic meshes


@pytest.mark.parametrize("mesh", [ff.disk_graded_rings(8, 3.0), ff.disk_graded_aniso(1 / 8, 2.0)],
                         ids=["rings(8, 3)", "aniso(1/8, 2)"])
@pytest.mark.parametrize("s", [0.25, 0.75])
def test_ring_mesh_matrix_is_symmetric_positive_definite(mesh, s):
    free = mesh.interior_nodes()
    A = stiffness_matrix(mesh, s)[np.ix_(free, free)]
    assert np.abs(A - A.T).max() < 1e-13 * np.abs(A).max()
    la.cholesky(A, lower=True)
    assert np.all(np.diag(A) > 0)


def test_quadrature_converged_on_a_ring_mesh():
    """disk_graded_rings(8, 2), Example 1, s = 0.5: raising every knob moves
    (f, u_h) by < 1 % of the squared energy error (measured 5e-5); before the
    graded rules of thin pairs the change was 4 %."""
    mesh = ff.disk_graded_rings(8, 2.0)
    free = mesh.interior_nodes()
    b = ff.load_vector(mesh, 1.0)[free]
    e = [float(b @ np.linalg.solve(stiffness_matrix(mesh, 0.5, quadrature=q)[np.ix_(free, free)], b))
         for q in (DEFAULT, DEFAULT.raised())]
    err2 = ff.disk_energy(0.5) - e[0]
    assert 0 < err2 and abs(e[1] - e[0]) < 0.01 * err2


# ---------------------------------------------------------------------------
# options


def test_raised_raises_the_thin_pair_knobs():
    r = DEFAULT.raised()
    assert r.thin_gauss > DEFAULT.thin_gauss
    assert 1.0 < r.thin_ratio < DEFAULT.thin_ratio
    assert r.thin_closeness > DEFAULT.thin_closeness


@pytest.mark.parametrize("kwargs", [{"thin_gauss": 0}, {"thin_gauss": 33}, {"thin_gauss": 2.5},
                                    {"thin_closeness": -0.1}, {"thin_closeness": 1.5},
                                    {"thin_closeness": float("nan")}, {"thin_ratio": 1.0},
                                    {"thin_ratio": 9.0}])
def test_bad_thin_options_raise(kwargs):
    name = next(iter(kwargs))
    with pytest.raises(ValueError, match=rf"QuadratureOptions\.{name}="):
        QuadratureOptions(**kwargs)


# ---------------------------------------------------------------------------
# κ on thin elements at the boundary


@pytest.fixture(scope="module")
def ring_kappa():
    mesh = ff.disk_graded_rings(12, 4.0)
    p, t = mesh_arrays(mesh)
    edges, bnodes = assembly._boundary_edges(p, t)
    area2, _, diam = assembly._element_geometry(p, t)
    K = assembly._kappa_local(p, t, bnodes, edges, 0.75, DEFAULT)
    return p, t, np.isin(t, bnodes), diam ** 2 / area2, K


@pytest.mark.parametrize("nb, min_aspect", [(0, 100), (1, 1000), (2, 1000)])
def test_kappa_on_thin_elements_at_the_boundary(ring_kappa, nb, min_aspect):
    """disk_graded_rings(12, 4), s = 0.75: the thinnest element with nb nodes on
    ∂Ω against brute force (free-node entries; those of boundary nodes diverge
    for s >= 1/2).  Measured 5e-7, 2e-6, 8e-6; with thin_closeness = 0 (the
    rules for shape-regular elements) 2e-2, 8e-5, 2e-5, and 7e-4, 6e-5, 2e-5
    with those raised."""
    p, t, onb, aspect, K = ring_kappa
    cls = np.flatnonzero(onb.sum(1) == nb)
    T = int(cls[np.argmax(aspect[cls])])
    assert aspect[T] > min_aspect
    free = ~onb[T]
    want = ref.kappa_mass_thin_reference(p, t, T, 0.75, panels=100)[np.ix_(free, free)]
    assert rel(K[T][np.ix_(free, free)], want) < 2e-5


def test_pair_kernels_refuse_rules_larger_than_their_work_arrays():
    """far_pairs and near_pairs keep MAX_RULE_POINTS² work arrays per thread: a level
    with more points raises instead of writing past them."""
    t = np.array([[0, 1, 2], [3, 4, 5]])
    nt, nq = 2, _kernels.MAX_RULE_POINTS + 1
    cent, diam, area = np.zeros((nt, 2)), np.ones(nt), np.ones(nt)
    mom, grad = np.zeros((nt, 3)), np.zeros((nt, 3, 2))
    qx, qw, lam = np.zeros((nt, nq, 2)), np.zeros((nt, nq)), np.zeros((nq, 3))
    offsets, thresholds = np.array([0, nq]), np.zeros(0)
    with pytest.raises(ValueError, match="longer than the work arrays"):
        _kernels.far_pairs(np.zeros((6, 6)), t, cent, diam, area, mom, grad, qx, qw, lam,
                           offsets, thresholds, False, 0.5, np.arange(nt), np.array([0, nt]),
                           1)
    i1 = np.array([0, 1])
    with pytest.raises(ValueError, match="longer than the work arrays"):
        _kernels.near_pairs(t, np.arange(nt), np.array([0]), np.array([2]), i1,
                            np.array([0]), np.array([0]), cent, diam, area, mom, grad,
                            qx, qw, lam, offsets, thresholds, False, 0.5,
                            np.zeros(7, dtype=np.int64), np.zeros(0, dtype=np.int32), 6,
                            np.array([0]), i1, 1, np.zeros((1, 0)))
