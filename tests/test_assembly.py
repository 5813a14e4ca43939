"""Tests of fracfem.assembly and fracfem._kernels against the slow references of
tests/reference.py, plus numerical-analysis checks of the assembled matrix
(symmetry, positive definiteness, Galerkin energies against the exact solution
of Example 1).

Measured agreement (see the asserts for the tolerances):
- numba kernels vs the pair-by-pair references: ≤ 1e-14 relative (asserted 1e-12);
- exterior_kernel vs graded Gauss along the edges: ≤ 2e-11 relative at O(h)
  distance, ≤ 2e-7 on a 128-edge polygon (documented far-edge error < 1e-5);
- stiffness_matrix vs stiffness_matrix_reference (interior block of
  init_circle(2)): ≤ 1e-6 of max|A|, all of it from the κ term.
"""

import functools
from dataclasses import replace

import numpy as np
import pytest
import scipy.linalg as la
from skfem import MeshTri

from fracfem import _kernels, assembly, meshes
from fracfem.assembly import (QuadratureOptions, exterior_kernel, load_vector, mesh_arrays,
                              stiffness_matrix, touching_pairs)
from fracfem.exact import c2s, disk_energy
from fracfem.quadrature import triangle_rule

import reference as ref

KINDS = ("coincident", "edge", "vertex")
DEFAULT = QuadratureOptions()


@functools.lru_cache(maxsize=None)
def tiny(name):
    return {"circle1": lambda: MeshTri.init_circle(1),
            "circle2": lambda: MeshTri.init_circle(2),
            "square2": lambda: meshes.square(2),
            "lshape1": lambda: meshes.lshape(1)}[name]()


def arrays(name):
    return mesh_arrays(tiny(name))


def free_block(mesh):
    free = mesh.interior_nodes()
    return free, np.ix_(free, free)


def rel(a, b):
    """max |a − b| / max |b|."""
    return np.abs(np.asarray(a) - b).max() / np.abs(b).max()


def local_nodes(t, kind):
    edge_nodes, vertex_nodes = touching_pairs(t)
    return {"coincident": t, "edge": edge_nodes, "vertex": vertex_nodes}[kind]


def far_kernel_matrix(p, t, s, orders, thresholds, nchunks=2):
    """Matrix of _kernels.far_pairs (without c_{2,s}) as the assembly glues it
    (assembly.far_field_into): the off-diagonal part X + Xᵀ and the diagonal blocks
    from D."""
    quad = QuadratureOptions(far_orders=tuple(orders), far_thresholds=tuple(thresholds))
    A = np.zeros((len(p), len(p)))
    assembly.far_field_into(A, p, t, float(s), quad, assembly._element_geometry(p, t),
                            assembly._element_moments(p, t), nchunks)
    return A


def pair_kernel(P1, P2, s, order):
    """6 × 6 far-field matrix of one pair of triangles through the kernel."""
    p = np.vstack([P1, P2])
    t = np.array([[0, 1, 2], [3, 4, 5]])
    return far_kernel_matrix(p, t, s, (order,), (), nchunks=1)


# ---------------------------------------------------------------------------
# classification of pairs


@pytest.mark.parametrize("name", ["circle2", "square2", "lshape1"])
def test_touching_pairs_match_bruteforce_classification(name):
    p, t = arrays(name)
    edge_nodes, vertex_nodes = touching_pairs(t)
    e_ref, v_ref, sep = ref.classify_pairs(t)
    # same pairs, same local node order (P, Q shared in T's order, ...)
    assert sorted(map(tuple, edge_nodes)) == sorted(map(tuple, e_ref))
    assert sorted(map(tuple, vertex_nodes)) == sorted(map(tuple, v_ref))
    nt = len(t)
    assert len(edge_nodes) + len(vertex_nodes) + len(sep) == nt * (nt - 1) // 2


# ---------------------------------------------------------------------------
# singular pairs


@pytest.mark.parametrize("name", ["circle2", "lshape1"])
@pytest.mark.parametrize("s", [0.25, 0.75])
@pytest.mark.parametrize("kind", KINDS)
def test_singular_kernel_matches_reference(name, s, kind):
    p, t = arrays(name)
    nodes = local_nodes(t, kind)
    n = getattr(DEFAULT, kind)
    got = assembly._singular_local(p, nodes, kind, n, s)
    want = ref.singular_pairs_reference(p, nodes, kind, n, s)
    assert got.shape == want.shape == (len(nodes), nodes.shape[1], nodes.shape[1])
    assert rel(got, want) < 1e-12          # measured ≤ 7e-16


def physical_product_rule(P, kind, s, order=6):
    """∫_T∫_T'(φ_a(x)−φ_a(y))(φ_b(x)−φ_b(y))|x−y|^(−2−2s) by the product
    triangle rule on the physical triangles: exact when the kernel is a
    polynomial (s = −1, −2) — no relative coordinates involved."""
    lt, lt2 = ref._LAYOUT[kind]
    X, W = triangle_rule(order)
    lam = np.column_stack([1 - X.sum(1), X])
    PT, PT2 = P[list(lt)], P[list(lt2)]
    x, y = lam @ PT, lam @ PT2
    wx, wy = W * ref._area2(PT), W * ref._area2(PT2)
    m = len(P)
    out = np.zeros((m, m))
    for q in range(len(x)):
        for r in range(len(y)):
            U = np.zeros(m)
            np.add.at(U, list(lt), lam[q])
            np.add.at(U, list(lt2), -lam[r])
            out += wx[q] * wy[r] * np.sum((x[q] - y[r]) ** 2) ** (-1 - s) * np.outer(U, U)
    return out


@pytest.mark.parametrize("s", [-1.0, -2.0])
@pytest.mark.parametrize("kind", KINDS)
def test_singular_kernel_for_polynomial_kernels_against_physical_product_rule(s, kind):
    """Checks the geometry of the relative coordinates (M, signs, node layout,
    Jacobians) independently of reference.py."""
    p, t = arrays("circle2")
    nodes = local_nodes(t, kind)[::7]
    got = assembly._singular_local(p, nodes, kind, getattr(DEFAULT, kind), s)
    want = np.array([physical_product_rule(p[row], kind, s) for row in nodes])
    assert rel(got, want) < 1e-12          # measured ≤ 5e-15


@pytest.mark.parametrize("kind", KINDS)
def test_singular_local_matrices_are_psd_and_annihilate_constants(kind):
    p, t = arrays("circle2")
    loc = assembly._singular_local(p, local_nodes(t, kind), kind, getattr(DEFAULT, kind), 0.6)
    scale = np.abs(loc).max(axis=(1, 2))
    assert np.all(np.abs(loc.sum(axis=2)).max(axis=1) < 1e-13 * scale)
    assert np.all(np.abs(loc - loc.transpose(0, 2, 1)).max(axis=(1, 2)) < 1e-14 * scale)
    assert np.all(np.linalg.eigvalsh(loc).min(axis=1) > -1e-13 * scale)


@pytest.mark.parametrize("kind,tol", [("coincident", 1e-6), ("edge", 2e-4), ("vertex", 3e-3)])
def test_singular_rules_converge_on_mesh_pairs(kind, tol):
    """Default orders vs doubled orders, per local matrix, s = 0.9 (worst case).
    Measured on init_circle(2): coincident 2e-7, edge 6e-5, vertex 8e-4; the
    effect on the Galerkin energy is < 1e-4 of the squared energy error (see
    test_quadrature_convergence_of_the_energy)."""
    p, t = arrays("circle2")
    nodes = local_nodes(t, kind)
    n = getattr(DEFAULT, kind)
    a = assembly._singular_local(p, nodes, kind, n, 0.9)
    b = assembly._singular_local(p, nodes, kind, 2 * n, 0.9)
    c = assembly._singular_local(p, nodes, kind, 3 * n, 0.9)
    scale = np.abs(c).max(axis=(1, 2))
    assert np.max(np.abs(a - c).max(axis=(1, 2)) / scale) < tol
    assert np.max(np.abs(b - c).max(axis=(1, 2)) / scale) < tol / 10


# ---------------------------------------------------------------------------
# separated pairs


@pytest.mark.parametrize("name", ["circle2", "lshape1"])
@pytest.mark.parametrize("s", [0.25, 0.75])
@pytest.mark.parametrize("nchunks", [1, 3])
def test_far_pairs_single_gauss_level_matches_bruteforce(name, s, nchunks):
    p, t = arrays(name)
    got = far_kernel_matrix(p, t, s, (2,), (), nchunks)
    want = ref.far_matrix_reference(p, t, s, (2,), ())
    assert rel(got, want) < 1e-12          # measured ≤ 1e-15


@pytest.mark.parametrize("name", ["circle2", "lshape1"])
@pytest.mark.parametrize("s", [0.25, 0.75])
def test_far_pairs_taylor_level_matches_reference(name, s):
    p, t = arrays(name)
    got = far_kernel_matrix(p, t, s, (0,), ())
    want = ref.far_matrix_reference(p, t, s, (0,), ())
    assert rel(got, want) < 1e-12          # measured ≤ 2e-15


def test_far_pairs_all_levels_populated_match_reference():
    """Four levels with thresholds low enough that each holds pairs on a tiny mesh."""
    p, t = arrays("circle2")
    orders, thr = (0, 2, 4, 8), (2.0, 1.5, 1.2)
    levels = [ref._far_level(p[t[a]], p[t[b]], thr) for a, b in ref.classify_pairs(t)[2]]
    assert set(levels) == {0, 1, 2, 3}
    got = far_kernel_matrix(p, t, 0.4, orders, thr)
    want = ref.far_matrix_reference(p, t, 0.4, orders, thr)
    assert rel(got, want) < 1e-12


@pytest.mark.parametrize("name", ["circle2", "square2", "lshape1"])
def test_element_classes_share_no_node(name):
    """Every element in exactly one class, ascending within it; no two elements of a class
    share a node; at most 3 (d − 1) + 1 classes, d the most elements at a node."""
    p, t = arrays(name)
    order, ptr = assembly.element_classes(t, len(p))
    assert sorted(order.tolist()) == list(range(len(t))) and ptr[0] == 0 and ptr[-1] == len(t)
    for k in range(len(ptr) - 1):
        cls = order[ptr[k]:ptr[k + 1]]
        assert len(cls) and np.all(np.diff(cls) > 0)
        nodes = t[cls].ravel()
        assert len(np.unique(nodes)) == len(nodes)
    d = np.bincount(t.ravel()).max()
    assert len(ptr) - 1 <= 3 * (d - 1) + 1


@pytest.mark.parametrize("n", [1, 63, 64, 130])
@pytest.mark.parametrize("nchunks", [1, 3])
def test_add_transpose_in_place(n, nchunks):
    A = np.random.default_rng(n).standard_normal((n, n))
    want = A + A.T
    _kernels.add_transpose_inplace(A, nchunks)
    assert np.array_equal(A, want)


def test_far_field_between_separated_nodes_does_not_depend_on_threads():
    """Threads share A one class of elements at a time, so an entry between two nodes
    that share no element (the far field's terms alone) receives its terms in one order
    whatever the number of threads: bit for bit the same; the rest to round-off."""
    p, t = mesh_arrays(meshes.disk_uniform(3))
    runs = [far_kernel_matrix(p, t, 0.5, (0, 2, 4), (4.0, 2.0), nchunks=k) for k in (1, 2, 5)]
    inc = np.zeros((len(p), len(t)))
    inc[t.ravel(), np.repeat(np.arange(len(t)), 3)] = 1.0
    separate = (inc @ inc.T) == 0
    assert separate.sum() > 0.5 * separate.size
    for A in runs[1:]:
        assert np.array_equal(A[separate], runs[0][separate])
        assert rel(A, runs[0]) < 1e-14


def taylor_jet(P1, P2, s):
    """Taylor-corrected centroid rule derived differently from
    ref.taylor_pair_reference: expand ε ↦ ∫∫ U_a U_b k(D + ε(ξ−η)) with
    U = δ + ε(∇φ·ξ − ∇φ'·η), k's ε-Taylor coefficients from 1D calculus of
    (|D|² + 2εD·w + ε²|w|²)^(α/2), keep ε⁰..ε², integrate with a product rule."""
    X, W = triangle_rule(6)
    lam = np.column_stack([1 - X.sum(1), X])
    c1, c2 = P1.mean(0), P2.mean(0)
    xi, eta = lam @ P1 - c1, lam @ P2 - c2
    w1, w2 = W * ref._area2(P1), W * ref._area2(P2)
    D = c1 - c2
    al = -2.0 - 2.0 * s
    q0 = D @ D

    def grads(P):       # ∇ of the affine hat functions: [1 x y] C = I
        return np.linalg.inv(np.column_stack([np.ones(3), P]))[1:].T

    G1 = np.vstack([grads(P1), np.zeros((3, 2))])
    G2 = np.vstack([np.zeros((3, 2)), grads(P2)])
    U0 = np.array([1, 1, 1, -1, -1, -1]) / 3.0
    out = np.zeros((6, 6))
    for q in range(len(W)):
        for r in range(len(W)):
            w = xi[q] - eta[r]
            k0 = q0 ** (al / 2)
            k1 = al / 2 * q0 ** (al / 2 - 1) * 2 * (D @ w)
            k2 = 0.5 * (al / 2 * (al / 2 - 1) * q0 ** (al / 2 - 2) * (2 * (D @ w)) ** 2
                        + al / 2 * q0 ** (al / 2 - 1) * 2 * (w @ w))
            U1 = G1 @ xi[q] - G2 @ eta[r]
            out += w1[q] * w2[r] * (np.outer(U0, U0) * (k0 + k1 + k2)
                                    + (np.outer(U0, U1) + np.outer(U1, U0)) * (k0 + k1)
                                    + np.outer(U1, U1) * k0)
    return out


PAIR1 = np.array([[0.0, 0.0], [1.0, 0.2], [0.3, 0.9]])
PAIR2 = np.array([[0.0, 0.0], [0.8, -0.3], [0.5, 0.7]])
DIRECTION = np.array([np.cos(0.7), np.sin(0.7)])


@pytest.mark.parametrize("s", [0.1, 0.5, 0.9])
@pytest.mark.parametrize("dist", [3.0, 20.0])
def test_taylor_reference_agrees_with_jet_derivation_and_kernel(s, dist):
    P2 = PAIR2 + dist * DIRECTION
    a = ref.taylor_pair_reference(PAIR1, P2, s)
    assert rel(a, taylor_jet(PAIR1, P2, s)) < 1e-12
    assert rel(pair_kernel(PAIR1, P2, s, 0), a) < 1e-12


def taylor_errors(s, dists):
    """Per-pair errors of the kernel's Taylor level against order 12."""
    out = {"entries": [], "diagonal": [], "off": [], "linear": []}
    u_grad = np.array([0.3, -1.1])
    for d in dists:
        P2 = PAIR2 + d * DIRECTION
        a = pair_kernel(PAIR1, P2, s, 0)
        b = pair_kernel(PAIR1, P2, s, 12)
        assert rel(b, ref.far_pair_reference(PAIR1, P2, 12, s)) < 1e-12
        e, sc = np.abs(a - b), np.abs(b).max()
        out["entries"].append(e.max() / sc)
        out["diagonal"].append(max(e[:3, :3].max(), e[3:, 3:].max()) / sc)
        out["off"].append(e[:3, 3:].max() / sc)
        u = np.concatenate([PAIR1 @ u_grad, P2 @ u_grad])     # a global linear u
        out["linear"].append(abs(u @ (a - b) @ u) / (u @ b @ u))
    return out


DISTS = np.array([4.0, 8.0, 16.0, 32.0, 64.0])


def slope(errors):
    return np.polyfit(np.log(DISTS), np.log(errors), 1)[0]


@pytest.mark.parametrize("s", [0.1, 0.5, 0.9])
def test_taylor_rule_error_decay_for_smooth_functions(s):
    """A fixed pair moved apart (h/d from 1/4 to 1/64): for u linear on both
    triangles, a(u, u) of the pair has relative error O((h/d)³) (fitted
    slope −3.07 … −3.14), and the coupling block T × T' O((h/d)²) (slope
    −1.9 … −1.8).  The diagonal blocks are only O(h/d): see the xfail test
    below."""
    err = taylor_errors(s, DISTS)
    assert slope(err["linear"]) < -2.8
    assert slope(err["off"]) < -1.7
    assert err["entries"][0] < 0.06


@pytest.mark.parametrize("s", [0.5])
def test_taylor_rule_entries_decay_at_least_like_h_over_d(s):
    """Single entries (diagonal blocks) drop third-moment terms: O(h/d), as the
    kernel's docstring says; the quadratic form is O((h/d)^3) (test above)."""
    err = taylor_errors(s, DISTS)
    assert slope(err["entries"]) < -0.8


# ---------------------------------------------------------------------------
# exterior kernel κ


@pytest.mark.parametrize("name", ["circle2", "square2", "lshape1"])
def test_boundary_edges_match_reference(name):
    p, t = arrays(name)
    E, bn = assembly._boundary_edges(p, t)
    E_ref, bn_ref = ref.boundary_edges_reference(p, t)
    assert sorted(map(tuple, E)) == sorted(map(tuple, E_ref))
    np.testing.assert_array_equal(bn, bn_ref)
    # Ω on the left: the polygon's signed area (shoelace) is the mesh area
    area = 0.5 * np.sum(E[:, 0] * E[:, 3] - E[:, 2] * E[:, 1])
    assert area == pytest.approx(0.5 * sum(ref._area2(p[tri]) for tri in t), rel=1e-13)


def probe_points(p, t, edges):
    """Groups of points inside Ω: centroids; 30 % along every boundary edge at
    distance δ; from every boundary node toward an adjacent element's centroid."""
    cent = p[t].mean(1)
    a, b = edges[:, :2], edges[:, 2:]
    inward = np.column_stack([-(b - a)[:, 1], (b - a)[:, 0]])
    inward /= np.linalg.norm(inward, axis=1)[:, None]
    groups = {("centroids", 0.1): cent}
    for dist in [1e-9, 1e-6, 1e-3, 3e-2]:
        groups[("edge", dist)] = 0.3 * a + 0.7 * b + dist * inward
    bn = np.unique(t[np.isin(t, ref.boundary_edges_reference(p, t)[1])])
    el = [np.flatnonzero((t == v).any(1))[0] for v in bn]
    for delta in [1e-8, 1e-4, 1e-2]:
        groups[("vertex", delta * 0.2)] = p[bn] + delta * (cent[el] - p[bn])
    return groups


@pytest.mark.parametrize("name", ["circle2", "square2", "lshape1"])
@pytest.mark.parametrize("s", [0.05, 0.5, 0.95])
def test_exterior_kernel_matches_bruteforce_near_and_far(name, s):
    """Tolerance 1e-9 + 4e-16/dist: κ ~ dist^(−2s) and dist is computed from
    O(1) coordinates with absolute rounding ~1e-16, so the relative
    condition number is ~2s·|x|/dist (measured: 2e-8 at dist 1e-9, ≤ 2e-11
    at dist ≥ 1e-3)."""
    p, t = arrays(name)
    E, _ = ref.boundary_edges_reference(p, t)
    for (group, dist), x in probe_points(p, t, E).items():
        want = ref.kappa_reference(x, E, s)
        assert np.all(want > 0)
        got = exterior_kernel(x, E, s)
        err = np.abs(got - want) / want
        assert err.max() < 1e-9 + 4e-16 / dist, (group, dist, err.max())


def test_kappa_reference_is_converged():
    p, t = arrays("circle2")
    E, _ = ref.boundary_edges_reference(p, t)
    x = np.concatenate(list(probe_points(p, t, E).values()))
    a = ref.kappa_reference(x, E, 0.9)
    b = ref.kappa_reference(x, E, 0.9, n=30)
    assert rel(a / b, np.ones_like(a)) < 1e-13


def test_exterior_kernel_far_from_edges_on_a_fine_polygon():
    """128 edges, so most edges take the 2- and 4-point far-edge rules
    (documented relative error < 1e-5; measured ≤ 2e-7)."""
    p, t = mesh_arrays(meshes.disk_uniform(5))
    E, _ = assembly._boundary_edges(p, t)
    rng = np.random.default_rng(3)
    x = np.vstack([p[t[rng.choice(len(t), 100, replace=False)]].mean(1), [[0.0, 0.0]]])
    for s in [0.05, 0.5, 0.95]:
        want = ref.kappa_reference(x, E, s)
        assert np.max(np.abs(exterior_kernel(x, E, s) - want) / want) < 1e-6


@pytest.mark.parametrize("s", [0.05, 0.5, 0.95])
def test_kappa_at_the_centre_of_the_disk(s):
    """κ(0) = π/s for the unit disk; the inscribed N-gon (N = 256) is smaller,
    so π/s ≤ κ(0) ≤ π/s (1 + s (π/N)²); its exact value is
    (N/2s) ∫_{−π/N}^{π/N} (cos φ / cos(π/N))^(2s) dφ."""
    from scipy.integrate import quad
    p, t = mesh_arrays(meshes.disk_uniform(6))
    E, _ = assembly._boundary_edges(p, t)
    N = len(E)
    assert N == 256
    k0 = exterior_kernel(np.zeros((1, 2)), E, s)[0]
    assert np.pi / s <= k0 <= np.pi / s * (1 + s * (np.pi / N) ** 2)
    a = np.pi / N
    poly = N / (2 * s) * quad(lambda f: (np.cos(f) / np.cos(a)) ** (2 * s), -a, a,
                              epsabs=0, epsrel=1e-13)[0]
    assert k0 == pytest.approx(poly, rel=1e-7)     # measured ≤ 6e-9


@pytest.mark.parametrize("name", ["circle2", "lshape1"])
@pytest.mark.parametrize("s", [0.25, 0.9])
def test_kappa_mass_matrices_against_reference(name, s):
    """∫_T φ_a φ_b κ of the assembly's graded rules vs the reference's
    (tensor-graded, converged to ≤ 1e-7), on the entries with both nodes free.
    Measured: circle2 5e-7 / 3e-5, lshape1 1e-6 / 1.4e-4 (s = 0.25 / 0.9):
    the assembly's rules are graded toward ∂Ω but not toward the ends of a
    boundary edge, which the polygon's corners make singular."""
    p, t = arrays(name)
    E, bn = assembly._boundary_edges(p, t)
    got = assembly._kappa_local(p, t, bn, E, s, DEFAULT)
    want = ref.kappa_mass_reference(p, t, s)
    free = ~np.isin(t, bn)
    mask = free[:, :, None] & free[:, None, :]
    assert np.abs(got - want)[mask].max() < 3e-4 * np.abs(want[mask]).max()


def test_kappa_mass_reference_self_convergence():
    """Entries with a boundary node diverge for s ≥ 1/2 and are not compared."""
    p, t = arrays("circle1")
    a = ref.kappa_mass_reference(p, t, 0.9)
    b = ref.kappa_mass_reference(p, t, 0.9, n=8, layers=16, theta_layers=8, n_interior=14,
                                 n_edge=20)
    free = ~np.isin(t, tiny("circle1").boundary_nodes())
    mask = free[:, :, None] & free[:, None, :]
    assert np.abs(a - b)[mask].max() < 2e-7 * np.abs(b[mask]).max()


@pytest.mark.parametrize("s", [0.3, 0.8])
def test_kernel_floor_matches_double_loop(s):
    p, t = arrays("circle2")
    cent = p[t].mean(1)
    want = 0.0
    for i in range(len(cent)):
        for j in range(i + 1, len(cent)):
            want += np.sum((cent[i] - cent[j]) ** 2) ** (-1 - s)
    for nchunks in (1, 2, 5):
        assert _kernels.kernel_floor(np.ascontiguousarray(cent), s, nchunks) == \
            pytest.approx(want, rel=1e-12)


# ---------------------------------------------------------------------------
# the assembled matrix


@functools.lru_cache(maxsize=None)
def reference_parts(s):
    return ref.stiffness_matrix_reference(tiny("circle2"), s, parts=True)


@pytest.mark.parametrize("s", [0.25, 0.75])
def test_stiffness_matrix_matches_reference_on_interior_block(s):
    """Singular and far parts agree to rounding (next tests); the κ term
    differs by the assembly's κ quadrature error.  Tolerance: 5e-5 of the
    largest κ entry (exterior_kernel's documented 1e-5 plus the graded
    rules; measured 5e-7 at s = 0.25, 5e-6 at s = 0.75), which is also
    ≤ 1e-5 of max|A| — far below the discretisation error (the squared
    energy error is ~12 % of the energy on this mesh)."""
    mesh = tiny("circle2")
    _, ix = free_block(mesh)
    parts = reference_parts(s)
    want = (parts["singular"] + parts["far"] + parts["kappa"])[ix]
    got = stiffness_matrix(mesh, s)[ix]
    err = np.abs(got - want).max()
    assert err < 5e-5 * np.abs(parts["kappa"][ix]).max()
    assert err < 1e-5 * np.abs(want).max()


def test_stiffness_matrix_reference_has_nan_boundary():
    mesh = tiny("circle1")
    A = ref.stiffness_matrix_reference(mesh, 0.5)
    bn = mesh.boundary_nodes()
    _, ix = free_block(mesh)
    assert np.isnan(A[bn]).all() and np.isnan(A[:, bn]).all() and np.isfinite(A[ix]).all()


@pytest.mark.parametrize("s", [0.25, 0.75])
def test_stiffness_far_field_glue_is_exact(s):
    """Only the far-field rules differ between the two assemblies, so κ and
    the singular part cancel: the difference must equal c (F₁ − F₂) of the
    references to rounding."""
    mesh = tiny("circle2")
    p, t = arrays("circle2")
    _, ix = free_block(mesh)
    q1 = QuadratureOptions(far_orders=(0, 2, 4, 8), far_thresholds=(2.0, 1.5, 1.2))
    q2 = QuadratureOptions(far_orders=(2,), far_thresholds=())
    A1, A2 = stiffness_matrix(mesh, s, quadrature=q1), stiffness_matrix(mesh, s, quadrature=q2)
    F1 = ref.far_matrix_reference(p, t, s, q1.far_orders, q1.far_thresholds)
    F2 = ref.far_matrix_reference(p, t, s, q2.far_orders, q2.far_thresholds)
    diff = c2s(s) * (F1 - F2)[ix]
    assert np.abs(diff).max() > 1e-4 * np.abs(A1[ix]).max()     # not vacuous
    assert np.abs((A1 - A2)[ix] - diff).max() < 1e-12 * np.abs(A1[ix]).max()


@pytest.mark.parametrize("s", [0.25, 0.75])
def test_stiffness_singular_glue_is_exact(s):
    mesh = tiny("circle2")
    p, t = arrays("circle2")
    _, ix = free_block(mesh)
    low = QuadratureOptions(coincident=3, edge=2, vertex=2)
    A1, A2 = stiffness_matrix(mesh, s, quadrature=low), stiffness_matrix(mesh, s)
    diff = c2s(s) * (ref.singular_matrix_reference(p, t, s, low)
                     - ref.singular_matrix_reference(p, t, s, DEFAULT))[ix]
    assert np.abs(diff).max() > 1e-4 * np.abs(A1[ix]).max()
    assert np.abs((A1 - A2)[ix] - diff).max() < 1e-12 * np.abs(A1[ix]).max()


def test_stiffness_matrix_does_not_depend_on_nchunks():
    mesh = meshes.disk_uniform(3)
    _, ix = free_block(mesh)
    A1 = stiffness_matrix(mesh, 0.5, nchunks=1)[ix]
    A3 = stiffness_matrix(mesh, 0.5, nchunks=3)[ix]
    assert rel(A3, A1) < 1e-13


@pytest.mark.parametrize("mesh", [tiny("circle2"), meshes.lshape(1)])
def test_boundary_rows_and_columns_are_nan(mesh):
    A = stiffness_matrix(mesh, 0.7)
    bn = mesh.boundary_nodes()
    free, ix = free_block(mesh)
    assert np.isnan(A[bn]).all() and np.isnan(A[:, bn]).all()
    assert np.isfinite(A[ix]).all()
    assert A.shape == (mesh.p.shape[1],) * 2


MESHES = {"disk_uniform(3)": lambda: meshes.disk_uniform(3),
          "square(4)": lambda: meshes.square(4),
          "lshape(2)": lambda: meshes.lshape(2)}


@pytest.mark.parametrize("mesh_name", list(MESHES))
@pytest.mark.parametrize("s", [0.1, 0.5, 0.9])
def test_free_block_is_symmetric_positive_definite(mesh_name, s):
    mesh = MESHES[mesh_name]()
    _, ix = free_block(mesh)
    A = stiffness_matrix(mesh, s)[ix]
    assert np.abs(A - A.T).max() < 1e-13 * np.abs(A).max()
    la.cholesky(A, lower=True)                     # raises if not SPD
    ev = np.linalg.eigvalsh(0.5 * (A + A.T))
    assert ev.min() > 0
    assert np.all(np.diag(A) > 0)


# ---------------------------------------------------------------------------
# Galerkin energies against the exact solution of Example 1


@functools.lru_cache(maxsize=None)
def galerkin_energy(level, s, raised=False):
    """(f, u_h) = bᵀA⁻¹b on disk_uniform(level), f = 1."""
    mesh = meshes.disk_uniform(level)
    free, ix = free_block(mesh)
    quad = QuadratureOptions().raised() if raised else None
    A = stiffness_matrix(mesh, s, quadrature=quad)[ix]
    b = load_vector(mesh, 1.0)[free]
    return float(b @ la.cho_solve(la.cho_factor(A), b))


ENERGY_S = [0.1, 0.25, 0.5, 0.75, 0.9]
LEVELS = [2, 3, 4]


@pytest.mark.parametrize("s", ENERGY_S)
def test_galerkin_energy_increases_below_the_exact_energy(s):
    e = [galerkin_energy(level, s) for level in LEVELS]
    assert e[0] < e[1] < e[2] < disk_energy(s)


@pytest.mark.parametrize("s", ENERGY_S)
def test_energy_error_decreases_at_a_plausible_rate(s):
    """‖u − u_h‖_a = sqrt((f,u) − (f,u_h)); uniform meshes give h^(1/2)
    asymptotically (u ~ dist^s).  Measured rates per halving of h:
    0.49 (s = 0.1) … 0.90 (s = 0.9, preasymptotic)."""
    err = np.sqrt(disk_energy(s) - np.array([galerkin_energy(level, s) for level in LEVELS]))
    rates = np.log2(err[:-1] / err[1:])
    assert np.all(rates > 0.4) and np.all(rates < 1.0), rates


def test_quadrature_convergence_of_the_energy():
    """Raising every quadrature order changes (f, u_h) by < 1 % of the squared
    energy error (measured 7e-5) on disk_uniform(4), s = 0.5."""
    s = 0.5
    e = galerkin_energy(4, s)
    e_raised = galerkin_energy(4, s, raised=True)
    assert abs(e_raised - e) < 0.01 * (disk_energy(s) - e)


# ---------------------------------------------------------------------------
# bad input


@pytest.mark.parametrize("s", [0, 1, -0.1, 1.5, float("nan"), "a"])
def test_bad_s_raises(s):
    with pytest.raises(ValueError, match="s="):
        stiffness_matrix(tiny("circle1"), s)
    p, t = arrays("circle1")
    E, _ = assembly._boundary_edges(p, t)
    with pytest.raises(ValueError, match="s="):
        exterior_kernel(np.zeros((1, 2)), E, s)


def test_zero_area_triangle_raises():
    p = np.array([[0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, 0.0]])
    t = np.array([[0, 1, 2], [0, 1, 3]]).T           # second one is flat
    mesh = MeshTri(p, t)
    with pytest.raises(ValueError, match=r"mesh\.t has \(near-\)zero-area triangles \[1\]"):
        stiffness_matrix(mesh, 0.5)
    with pytest.raises(ValueError, match=r"zero-area triangles \[1\]"):
        load_vector(mesh, 1.0)


def test_nan_coordinates_raise():
    p = np.array([[0.0, 1.0, 0.0, np.nan], [0.0, 0.0, 1.0, 1.0]])
    t = np.array([[0, 1, 2], [1, 3, 2]]).T
    mesh = MeshTri(p, t)
    with pytest.raises(ValueError, match=r"mesh\.p has NaN/inf coordinates at nodes \[3\]"):
        stiffness_matrix(mesh, 0.5)


@pytest.mark.parametrize("bad", [np.nan, np.inf])
def test_load_vector_rejects_non_finite_f(bad):
    mesh = tiny("circle1")
    with pytest.raises(ValueError, match="non-finite"):
        load_vector(mesh, lambda x: np.where(x[0] > 0.5, bad, 1.0))
    with pytest.raises(ValueError, match="non-finite"):
        load_vector(mesh, bad)


def test_load_vector_integrates_polynomials():
    """Σ_i b_i = ∫ f (the hat functions sum to 1); f = 1 + x² + xy."""
    mesh = meshes.square(3)
    b = load_vector(mesh, lambda x: 1 + x[0] ** 2 + x[0] * x[1])
    assert b.sum() == pytest.approx(4 + 4 / 3, rel=1e-13)


def test_far_rules_refuse_more_points_than_the_kernels_work_arrays():
    """_far_rules (which QuadratureOptions' degree limit, 12, keeps callers below)
    refuses rules of more than _kernels.MAX_RULE_POINTS points, naming the orders."""
    mesh = meshes.square(1)
    p, t = mesh.p.T.copy(), mesh.t.T.copy()
    n = len(triangle_rule(18)[1])
    assert n > _kernels.MAX_RULE_POINTS
    with pytest.raises(ValueError, match=rf"far_orders \[2, 18\] ask for {n}"):
        assembly._far_rules(p, t, (2, 18))
    assert assembly._far_rules(p, t, (12,))[3][-1] == len(triangle_rule(12)[1])


@pytest.mark.parametrize("kwargs, match", [
    ({"far_orders": (18,), "far_thresholds": ()}, "far_orders"),      # outside [0, 12]
    ({"far_orders": (2, 0), "far_thresholds": (4.0,)}, "Taylor"),
    ({"far_orders": (0, 2), "far_thresholds": (2.0, 4.0)}, "far_thresholds"),
    ({"far_orders": (0, 2, 4), "far_thresholds": (4.0, 2.0)}, None),  # valid
    ({"coincident": 0}, "coincident"),
])
def test_quadrature_options_are_validated(kwargs, match):
    if match is None:
        QuadratureOptions(**kwargs)
        return
    with pytest.raises(ValueError, match=match):
        QuadratureOptions(**kwargs)


def test_raised_keeping_the_taylor_rule():
    """raised(keep_taylor=True) differs from raised() only in the farthest class's rule,
    which stays the Taylor rule (order 0) from twice its ratio, as the compressed operator
    needs; options without a Taylor class raise as raised() does; a non-boolean is refused."""
    plain, kept = DEFAULT.raised(), DEFAULT.raised(keep_taylor=True)
    assert DEFAULT.far_orders[0] == 0 and plain.far_orders[0] == 2 and kept.far_orders[0] == 0
    assert kept.far_orders[1:] == plain.far_orders[1:]
    assert kept.far_thresholds == plain.far_thresholds == tuple(2 * r for r in
                                                                 DEFAULT.far_thresholds)
    assert replace(kept, far_orders=plain.far_orders) == plain
    gauss = QuadratureOptions(far_orders=(2, 4), far_thresholds=(4.0,))
    assert gauss.raised(keep_taylor=True) == gauss.raised()
    with pytest.raises(ValueError, match="keep_taylor='yes'"):
        DEFAULT.raised(keep_taylor="yes")


# ---------------------------------------------------------------------------
# fixed defects (regression tests)


def test_far_level_of_order_one_is_consistent():
    mesh = tiny("circle2")
    p, t = arrays("circle2")
    _, ix = free_block(mesh)
    s = 0.5
    A1 = stiffness_matrix(mesh, s, quadrature=QuadratureOptions(far_orders=(1,),
                                                                far_thresholds=()))
    A2 = stiffness_matrix(mesh, s, quadrature=QuadratureOptions(far_orders=(2,),
                                                                far_thresholds=()))
    F2 = ref.far_matrix_reference(p, t, s, (2,), ())
    # either reading of "order 1" would do: centroid product rule or Taylor rule
    ok = [np.abs((A1 - A2)[ix] - c2s(s) * (ref.far_matrix_reference(p, t, s, (o,), ())
                                             - F2)[ix]).max() < 1e-10
          for o in (1, 0)]
    assert any(ok)


def test_mismatched_far_thresholds_raise():
    with pytest.raises(ValueError):
        stiffness_matrix(tiny("circle1"), 0.5, quadrature=QuadratureOptions(
            far_orders=(0, 2), far_thresholds=(8.0, 4.0, 2.0)))


def test_nchunks_zero_raises():
    with pytest.raises(ValueError):
        stiffness_matrix(tiny("circle1"), 0.5, nchunks=0)


def test_distance_to_edges_by_tree_equals_all_pairs():
    """The k-d tree path gives exactly the all-pairs distances, also on a
    non-convex polygon and at boundary vertices (distance 0)."""
    from fracfem.assembly import (_boundary_edges, _distance_to_edges,
                                  _distance_to_edges_all, mesh_arrays)
    from fracfem.meshes import disk_graded_aniso, lshape

    rng = np.random.default_rng(7)
    for mesh in (lshape(4), disk_graded_aniso(0.05)):
        p, t = mesh_arrays(mesh)
        edges, _ = _boundary_edges(p, t)
        assert len(edges) > 64
        x = np.vstack([p, p[t].mean(axis=1), rng.uniform(-1.2, 1.2, (500, 2))])
        fast, ref = _distance_to_edges(x, edges), _distance_to_edges_all(x, edges)
        np.testing.assert_array_equal(fast, ref)
        assert np.count_nonzero(fast == 0.0) >= len(edges)
