"""Tests of fracfem.mixed: coupling matrices and the constraint sets Λ_H."""

import numpy as np
import pytest
import scipy.sparse as sp
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from skfem import Basis, BilinearForm, ElementTriP0, ElementTriP1, MeshTri, asm

from fracfem.mixed import (
    Friction,
    Obstacle,
    ThinFriction,
    ThinObstacle,
    coupling_matrix,
    edge_coupling_matrix,
    edges_on_curve,
    friction_bound,
    obstacle_from_function,
)


def _meshes(k):
    coarse = MeshTri.init_circle(k)
    return coarse, coarse.refined()


def _areas(mesh):
    e1 = mesh.p[:, mesh.t[1]] - mesh.p[:, mesh.t[0]]
    e2 = mesh.p[:, mesh.t[2]] - mesh.p[:, mesh.t[0]]
    return 0.5 * np.abs(e1[0] * e2[1] - e1[1] * e2[0])


def _segment(x):
    """Γ̃ = {y = 0, |x| ≤ 1/2}."""
    return (np.abs(x[1]) < 1e-12) & (np.abs(x[0]) <= 0.5 + 1e-12)


def _reference_coupling(coarse, fine):
    """∫ φ_i μ_j by skfem quadrature on each fine element, parents by point location."""
    p1 = Basis(fine, ElementTriP1())
    p0 = Basis(fine, ElementTriP0())
    per_fine = asm(BilinearForm(lambda u, v, w: u * v), p0, p1)  # (nodes, fine elements)
    centroids = fine.p[:, fine.t].mean(axis=1)
    parent = coarse.element_finder()(*centroids)
    to_coarse = sp.csr_matrix((np.ones(fine.nelements), (np.arange(fine.nelements), parent)),
                              shape=(fine.nelements, coarse.nelements))
    return (per_fine @ to_coarse).toarray()


# ------------------------------------------------------------------ coupling_matrix


@pytest.mark.parametrize("k", [1, 2, 3])
def test_coupling_column_sums_are_coarse_areas(k):
    coarse, fine = _meshes(k)
    B = coupling_matrix(coarse, fine)
    assert B.shape == (fine.nvertices, coarse.nelements)
    np.testing.assert_allclose(B.T @ np.ones(fine.nvertices), _areas(coarse), rtol=1e-13)


def test_coupling_row_sums_are_lumped_mass():
    coarse, fine = _meshes(2)
    B = coupling_matrix(coarse, fine)
    lumped = asm(BilinearForm(lambda u, v, w: u * v), Basis(fine, ElementTriP1())).sum(axis=1)
    np.testing.assert_allclose(B.sum(axis=1), lumped, rtol=1e-12)


@pytest.mark.parametrize("k", [1, 2])
def test_coupling_matches_quadrature_reference(k):
    coarse, fine = _meshes(k)
    np.testing.assert_allclose(coupling_matrix(coarse, fine).toarray(),
                               _reference_coupling(coarse, fine), atol=1e-15, rtol=1e-12)


def test_coupling_any_orientation():
    coarse, _ = _meshes(2)
    t = coarse.t.copy()
    t[[1, 2], ::2] = t[[2, 1], ::2]  # every other triangle clockwise
    flipped = MeshTri(coarse.p, t)
    B = coupling_matrix(flipped, flipped.refined())
    assert B.min() >= 0
    np.testing.assert_allclose(np.asarray(B.sum(axis=0)).ravel(), _areas(coarse), rtol=1e-13)


def test_coupling_rejects_non_nested_meshes():
    coarse, fine = _meshes(1)
    with pytest.raises(ValueError, match="refinement"):
        coupling_matrix(coarse, fine.refined())
    with pytest.raises(ValueError, match="refinement"):
        coupling_matrix(coarse, coarse)


def test_checkerboard_is_in_the_kernel_of_the_free_coupling():
    """All interior vertices of init_circle have even degree: a 1-D kernel of B[free]."""
    coarse, fine = _meshes(2)
    B = coupling_matrix(coarse, fine)
    colour = np.full(coarse.nelements, -1)
    colour[0] = 0
    stack = [0]
    while stack:  # 2-colour the coarse elements across interior edges
        e = stack.pop()
        for facet in coarse.t2f[:, e]:
            for nb in coarse.f2t[:, facet]:
                if nb >= 0 and colour[nb] < 0:
                    colour[nb] = 1 - colour[e]
                    stack.append(nb)
    checkerboard = (1 - 2 * colour) / _areas(coarse)  # λ_j = ±1/|T_j|
    free = fine.interior_nodes()
    Bv = B @ checkerboard
    assert np.abs(Bv[free]).max() < 1e-12
    assert np.abs(Bv).max() > 0.1  # ... but not of the full B (boundary rows)


# ------------------------------------------------------------- edge_coupling_matrix


@pytest.mark.parametrize("k", [2, 3])
def test_edge_coupling_column_sums_are_edge_lengths(k):
    coarse, fine = _meshes(k)
    edges = edges_on_curve(coarse, _segment)
    Be = edge_coupling_matrix(coarse, fine, edges)
    lengths = np.linalg.norm(coarse.p[:, edges[0]] - coarse.p[:, edges[1]], axis=0)
    assert edges.shape == (2, 2 ** k)
    np.testing.assert_allclose(Be.T @ np.ones(fine.nvertices), lengths, rtol=1e-13)
    assert lengths.sum() == pytest.approx(1.0)


def test_edge_coupling_integrates_linear_functions_exactly():
    coarse, fine = _meshes(2)
    edges = coarse.facets[:, ::5]  # any coarse edges, incl. off-axis ones
    Be = edge_coupling_matrix(coarse, fine, edges)
    v = lambda x: 1.0 + 2.0 * x[0] - 3.0 * x[1]  # noqa: E731
    a, b = coarse.p[:, edges[0]], coarse.p[:, edges[1]]
    exact = np.linalg.norm(b - a, axis=0) * v(0.5 * (a + b))
    np.testing.assert_allclose(Be.T @ v(fine.p), exact, rtol=1e-13)
    # the interior row of each edge is its midpoint, weight |e|/2
    assert np.allclose(Be.max(axis=0).toarray().ravel(), 0.5 * np.linalg.norm(b - a, axis=0))


def test_edge_coupling_rejects_non_edges():
    coarse, fine = _meshes(2)
    edges = edges_on_curve(coarse, _segment)
    # the two ends of the horizontal diameter are not joined by a coarse edge
    left, right = np.argmin(coarse.p[0]), np.argmax(coarse.p[0])
    with pytest.raises(ValueError, match=r"Γ̃ is not made of coarse mesh edges: pair"):
        edge_coupling_matrix(coarse, fine, np.array([[left], [right]]))
    with pytest.raises(ValueError, match="shape"):
        edge_coupling_matrix(coarse, fine, edges.T)
    with pytest.raises(ValueError, match="repeat"):
        edge_coupling_matrix(coarse, fine, np.hstack((edges, edges[::-1, :1])))
    with pytest.raises(ValueError, match="coarse nodes"):
        edge_coupling_matrix(coarse, fine, np.array([[0], [coarse.nvertices]]))


# ------------------------------------------------------------------ constraint sets


def _B(m=6, n=9):
    return sp.random(n, m, density=0.5, random_state=0, format="csr")


@settings(max_examples=50, deadline=None)
@given(arrays(np.float64, 6, elements=st.floats(-1e3, 1e3)),
       arrays(np.float64, 6, elements=st.floats(0, 1e3)),
       arrays(np.float64, 6, elements=st.floats(0, 1)))
def test_projection_is_exact_and_idempotent(lam, F, t):
    for cset in (Obstacle(_B(), g=np.zeros(6)), Friction(_B(), F),
                 ThinObstacle(_B(), g=np.zeros(6), s=0.75), ThinFriction(_B(), F, s=0.6)):
        p = cset.project(lam)
        assert cset.contains(p)
        np.testing.assert_array_equal(cset.project(p), p)
        # nearest point: no member of Λ_H (a point of the box) is closer
        lo = np.maximum(cset.lower, -1e4)
        mu = lo + t * (cset.upper - lo)
        assert np.linalg.norm(lam - p) <= np.linalg.norm(lam - mu) + 1e-9


def test_constraint_set_interface():
    B = _B()
    chi = np.linspace(-1, 1, 9)
    obstacle = Obstacle(B, chi)
    np.testing.assert_allclose(obstacle.g, B.T @ chi)
    assert obstacle.kind == "obstacle" and obstacle.n_multipliers == 6
    assert obstacle.contains(-np.ones(6)) and not obstacle.contains(np.full(6, 1e-3))
    assert obstacle.contains(np.full(6, 1e-3), tol=1e-2)
    friction = Friction(B, 2.0)
    np.testing.assert_array_equal(friction.F, np.full(6, 2.0))
    np.testing.assert_array_equal(friction.g, np.zeros(6))
    assert friction.kind == "friction"
    assert ThinObstacle(B, chi, s=0.6).kind == "thin_obstacle"
    assert ThinFriction(B, 1.0, s=0.9).kind == "thin_friction"
    np.testing.assert_array_equal(friction.project(np.array([-5, -1, 0, 1, 5, 2.5])),
                                  [-2, -1, 0, 1, 2, 2])


@pytest.mark.parametrize("F", [-0.1, np.nan, np.inf, [1, 1, 1, 1, 1, -1e-9]])
def test_bad_friction_bound(F):
    with pytest.raises(ValueError, match="F"):
        Friction(_B(), F)
    with pytest.raises(ValueError, match="F"):
        ThinFriction(_B(), F, s=0.75)


@pytest.mark.parametrize("s", [0.5, 0.3, 1.0, 1.2, np.nan, True])
def test_thin_sets_need_s_above_one_half(s):
    with pytest.raises(ValueError, match=r"s in the open interval \(1/2, 1\).*s = "):
        ThinObstacle(_B(), g=np.zeros(6), s=s)
    with pytest.raises(ValueError, match=r"\(1/2, 1\)"):
        ThinFriction(_B(), 1.0, s=s)


def test_obstacle_data_checks():
    B = _B()
    with pytest.raises(ValueError, match="exactly one"):
        Obstacle(B, np.zeros(9), g=np.zeros(6))
    with pytest.raises(ValueError, match="exactly one"):
        Obstacle(B)
    with pytest.raises(ValueError, match="chi"):
        Obstacle(B, np.zeros(5))
    with pytest.raises(ValueError, match="g"):
        Obstacle(B, g=np.full(6, np.nan))
    with pytest.raises(ValueError, match="shape"):
        Friction(B, np.ones(5))


# ------------------------------------------------------------------- data helpers


def test_obstacle_from_function_quadrature():
    coarse, fine = _meshes(2)
    chi = lambda x: 1.0 - 4.0 * (x[0] ** 2 + x[1] ** 2)  # noqa: E731
    cset = obstacle_from_function(coarse, fine, chi)
    free = fine.interior_nodes()
    np.testing.assert_allclose(cset.B.toarray(), coupling_matrix(coarse, fine)[free].toarray())
    # a quadratic is integrated exactly by order >= 2: compare with a much higher order
    high = obstacle_from_function(coarse, fine, chi, intorder=12)
    np.testing.assert_allclose(cset.g, high.g, rtol=1e-12, atol=1e-15)
    # the P1 interpolant differs by O(h²) only, and from above: χ is concave
    nodal = coupling_matrix(coarse, fine).T @ chi(fine.p)
    assert np.all(nodal <= cset.g + 1e-15)
    assert np.abs(nodal - cset.g).max() < 0.05 * np.abs(cset.g).max()
    # an affine χ: exact both ways
    affine = lambda x: -2.0 + 0.5 * x[0] - 0.25 * x[1]  # noqa: E731
    np.testing.assert_allclose(obstacle_from_function(coarse, fine, affine).g,
                               coupling_matrix(coarse, fine).T @ affine(fine.p), rtol=1e-12)


def test_obstacle_from_function_rejects_positive_boundary_values():
    coarse, fine = _meshes(1)
    with pytest.raises(ValueError, match=r"χ must be <= 0 on the boundary.*max χ = 0\.5"):
        obstacle_from_function(coarse, fine, lambda x: 0.5 + 0 * x[0])
    with pytest.raises(ValueError, match="intorder"):
        obstacle_from_function(coarse, fine, lambda x: -1 + 0 * x[0], intorder=2)
    # zero up to rounding on the circle nodes, negative on the chord midpoints
    zero_on_circle = lambda x: (x[0] ** 2 + x[1] ** 2) - 1.0  # noqa: E731
    assert obstacle_from_function(coarse, fine, zero_on_circle).kind == "obstacle"
    # ... whereas 1 − |x|² is positive at the chord midpoints of the fine boundary
    with pytest.raises(ValueError, match="χ"):
        obstacle_from_function(coarse, fine, lambda x: 1.0 - (x[0] ** 2 + x[1] ** 2))


def test_friction_bound_on_a_subdomain():
    coarse, _ = _meshes(2)
    F = friction_bound(coarse, 0.3, subdomain=lambda x: x[0] > 0)
    centroids = coarse.p[:, coarse.t].mean(axis=1)
    np.testing.assert_array_equal(F, np.where(centroids[0] > 0, 0.3, 0.0))
    np.testing.assert_array_equal(friction_bound(coarse, 0.3), np.full(coarse.nelements, 0.3))
    with pytest.raises(ValueError, match="F"):
        friction_bound(coarse, -1.0)
