"""Tests of fracfem.quadrature: triangle rules, the relative-coordinate
("cone") rules of singular element pairs and their radial factors."""

from math import factorial

import numpy as np
import pytest
from scipy.integrate import quad

from fracfem.quadrature import (coincident_rule, collapsed_triangle_rule, edge_rule,
                                gauss01, radial_factor, triangle_rule, vertex_rule)

RULES = {"coincident": coincident_rule, "edge": edge_rule, "vertex": vertex_rule}
DIM = {"coincident": 2, "edge": 3, "vertex": 4}
DEFAULT_N = {"coincident": 10, "edge": 6, "vertex": 5}     # QuadratureOptions()


def monomial_integral(i, j):
    """∫_τ̂ x^i y^j = i! j! / (i + j + 2)!."""
    return factorial(i) * factorial(j) / factorial(i + j + 2)


# ---------------------------------------------------------------------------
# 1D and triangle rules


@pytest.mark.parametrize("n", [1, 2, 5, 12])
def test_gauss01_exact_to_degree_2n_minus_1(n):
    x, w = gauss01(n)
    assert np.all((x > 0) & (x < 1))
    for k in range(2 * n):
        assert w @ x**k == pytest.approx(1.0 / (k + 1), rel=1e-13)


def test_gauss01_rejects_n_below_one():
    with pytest.raises(ValueError, match="n=0"):
        gauss01(0)


@pytest.mark.parametrize("order", range(0, 20))
def test_triangle_rule_exact_for_monomials_up_to_its_degree(order):
    X, W = triangle_rule(order)
    assert X.shape == (len(W), 2)
    assert W.sum() == pytest.approx(0.5, rel=1e-14)
    # points in the closed reference triangle
    assert np.all(X >= -1e-14) and np.all(X.sum(1) <= 1 + 1e-14)
    deg = max(order, 1)
    for i in range(deg + 1):
        for j in range(deg + 1 - i):
            val = W @ (X[:, 0] ** i * X[:, 1] ** j)
            assert val == pytest.approx(monomial_integral(i, j), rel=1e-12, abs=1e-15), (i, j)


def test_triangle_rule_is_not_exact_beyond_its_degree():
    """Guards against a test that would pass for any rule: order 1 (the
    centroid) already misses x²."""
    X, W = triangle_rule(1)
    assert abs(W @ X[:, 0] ** 2 - monomial_integral(2, 0)) > 1e-3


@pytest.mark.parametrize("n", [1, 3, 6])
def test_collapsed_triangle_rule_exact_to_degree_2n_minus_2(n):
    X, W = collapsed_triangle_rule(n)
    for i in range(2 * n - 1):
        for j in range(2 * n - 1 - i):
            val = W @ (X[:, 0] ** i * X[:, 1] ** j)
            assert val == pytest.approx(monomial_integral(i, j), rel=1e-12), (i, j)


# ---------------------------------------------------------------------------
# singular (relative-coordinate) rules


def gauge(kind, z):
    """ρ(z) of the polytopes in the quadrature.py docstrings."""
    if kind == "coincident":
        return np.max(np.abs(np.column_stack([z[:, 0], z[:, 1], z[:, 0] + z[:, 1]])), axis=1)
    if kind == "edge":
        return np.maximum(0, z[:, 0]) + np.maximum(z[:, 1], z[:, 2] - z[:, 0])
    return np.maximum(z[:, 0] + z[:, 1], z[:, 2] + z[:, 3])


@pytest.mark.parametrize("kind", list(RULES))
@pytest.mark.parametrize("n", [2, 5])
def test_face_points_lie_on_the_unit_gauge_surface(kind, n):
    z, w = RULES[kind](n)
    assert z.shape == (len(w), DIM[kind])
    assert np.all(w > 0)
    np.testing.assert_allclose(gauge(kind, z), 1.0, rtol=0, atol=1e-14)


@pytest.mark.parametrize("kind", list(RULES))
@pytest.mark.parametrize("n", [1, 4, 10])
def test_weights_times_radial_factor_give_the_volume_of_tau_x_tau(kind, n):
    """s = 0, G = 1: ∫_τ̂∫_τ̂ 1 = 1/4 for every kind and every n."""
    z, w = RULES[kind](n)
    assert radial_factor(kind, 0.0) * w.sum() == pytest.approx(0.25, rel=1e-14)


def product_integral(kind, G, order=6):
    """Brute force ∫_τ̂∫_τ̂ G(z(x̂, ŷ)) by the product triangle rule."""
    X, W = triangle_rule(order)
    x = np.repeat(X, len(X), axis=0)
    y = np.tile(X, (len(X), 1))
    w = np.outer(W, W).ravel()
    if kind == "coincident":
        z = x - y
    elif kind == "edge":
        z = np.column_stack([x[:, 0] - y[:, 0], x[:, 1], y[:, 1]])
    else:
        z = np.column_stack([x, y])
    return w @ G(z)


@pytest.mark.parametrize("kind", list(RULES))
@pytest.mark.parametrize("s", [-1.0, -2.0])
@pytest.mark.parametrize("n", ["small", "default"])
def test_rules_integrate_polynomial_kernels_exactly(kind, s, n):
    """For s = −1, −2, G(z) = (a·z)(b·z)|Mz|^(−2−2s) is a polynomial of
    degree 2, 4 (homogeneous of degree −2s): the cone rule times the radial
    factor must reproduce the product Gauss integral over τ̂ × τ̂."""
    n = 3 if n == "small" else DEFAULT_N[kind]
    rng = np.random.default_rng(abs(int(10 * s)) + DIM[kind])
    d = DIM[kind]
    zq, wq = RULES[kind](n)
    for _ in range(3):
        M = rng.normal(size=(2, d))
        a, b = rng.normal(size=d), rng.normal(size=d)

        def G(z):
            return (z @ a) * (z @ b) * np.sum((z @ M.T) ** 2, axis=1) ** (-1.0 - s)

        exact = product_integral(kind, G)
        approx = radial_factor(kind, s) * (wq @ G(zq))
        assert approx == pytest.approx(exact, rel=1e-12, abs=1e-14 * abs(exact))


@pytest.mark.parametrize("kind", list(RULES))
def test_rules_converge_for_a_singular_kernel(kind):
    """s = 0.5, G = |Mz|^(−3)(a·z)(b·z) with M of an actual pair of
    triangles (Mz = x − y vanishes only at z = 0): the face integrands are
    smooth, the rules converge; default n vs 2n agree to 1e-4."""
    rng = np.random.default_rng(7)
    d = DIM[kind]
    P, Q, R = np.array([0.0, 0.0]), np.array([1.0, 0.1]), np.array([0.3, 0.8])
    R2, Q2 = np.array([0.6, -0.7]), np.array([-0.9, 0.2])
    M = {"coincident": np.column_stack([Q - P, R - P]),
         "edge": np.column_stack([Q - P, R - P, P - R2]),
         "vertex": np.column_stack([Q - P, R - P, P - Q2, P - R2])}[kind]
    a, b = rng.normal(size=d), rng.normal(size=d)

    def val(n):
        zq, wq = RULES[kind](n)
        G = (zq @ a) * (zq @ b) * np.sum((zq @ M.T) ** 2, axis=1) ** -1.5
        return radial_factor(kind, 0.5) * (wq @ G)

    n = DEFAULT_N[kind]
    ref = val(30)
    err = [abs(val(k * n) / ref - 1) for k in (1, 2, 3)]
    # geometric convergence; the vertex rule converges slowest (about a
    # factor 2 per point here, where T' has a 144° angle at P): its default
    # n = 5 leaves ~2e-3 relative error on this integrand
    assert err[0] < {"coincident": 1e-8, "edge": 1e-6, "vertex": 5e-3}[kind]
    assert err[1] < err[0] / 5 or err[1] < 1e-13
    assert err[2] < 1e-5


@pytest.mark.parametrize("kind,d,k", [("coincident", 2, 2), ("edge", 3, 1), ("vertex", 4, 0)])
@pytest.mark.parametrize("s", [0.01, 0.25, 0.5, 0.77, 0.99])
def test_radial_factor_against_quad(kind, d, k, s):
    """B(s) = ∫₀¹ r^(d−1−2s)(1−r)^k dr."""
    val, err = quad(lambda r: 1.0, 0.0, 1.0, weight="alg", wvar=(d - 1 - 2 * s, k))
    assert radial_factor(kind, s) == pytest.approx(val, rel=1e-12)
    val2, _ = quad(lambda r: r ** (d - 1 - 2 * s) * (1 - r) ** k, 0.0, 1.0,
                   epsabs=0, epsrel=1e-12, limit=200)
    assert radial_factor(kind, s) == pytest.approx(val2, rel=1e-9)


@pytest.mark.parametrize("kind", ["Coincident", "edges", "", None, 3])
def test_radial_factor_rejects_unknown_kind(kind):
    with pytest.raises(ValueError, match="kind"):
        radial_factor(kind, 0.5)
