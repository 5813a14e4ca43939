"""Quadrature rules, built once in Python as plain arrays (rules as data).

Singular element pairs of the bilinear form of the integral fractional
Laplacian are integrated in *relative coordinates*: for a pair of triangles
mapped from the reference triangle τ̂ = {x̂₁, x̂₂ ≥ 0, x̂₁ + x̂₂ ≤ 1}, the
integrand (φ(x) − φ(y))(ψ(x) − ψ(y)) |x − y|^(−2−2s) depends only on a
vector z in R^d (d = 2 identical, 3 common edge, 4 common vertex), on which it
is positively homogeneous of degree −2s.  The domain of z is a polytope P
with gauge ρ, and the remaining weight is (1 − ρ(z))^k.  Writing z = r w with
w on the faces of P where ρ = 1 ("cone decomposition"),

    ∫ G(z) (1 − ρ(z))^k dz = B(s) · Σ_faces ∫_F G(w) |det[w, ∂w/∂u]| du,

with the radial factor B(s) = ∫₀¹ r^(d−1−2s) (1 − r)^k dr in closed form.
The face integrands are smooth (the faces avoid z = 0), so Gauss rules on
the faces converge exponentially.  The rules below hold the face points w
and weights; the radial factors are :func:`radial_factor`.
"""
from __future__ import annotations

import numpy as np
from numpy.polynomial.legendre import leggauss

__all__ = [
    "gauss01",
    "triangle_rule",
    "coincident_rule",
    "edge_rule",
    "vertex_rule",
    "radial_factor",
]


def gauss01(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss–Legendre rule with n points on [0, 1]."""
    if n < 1:
        raise ValueError(f"number of Gauss points n={n} must be >= 1")
    x, w = leggauss(n)
    return 0.5 * (x + 1.0), 0.5 * w


def triangle_rule(order: int) -> tuple[np.ndarray, np.ndarray]:
    """Symmetric rule on τ̂ exact for polynomials of degree ``order``.

    Returns points (nq, 2) and weights (nq,) summing to 1/2.  Order 1 is the
    centroid rule; higher orders are scikit-fem's Dunavant-type rules.
    """
    if order <= 1:
        return np.array([[1.0 / 3.0, 1.0 / 3.0]]), np.array([0.5])
    from skfem.quadrature import get_quadrature
    from skfem.refdom import RefTri

    X, W = get_quadrature(RefTri, int(order))
    return np.ascontiguousarray(X.T), np.ascontiguousarray(W)


def collapsed_triangle_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Conical (Duffy) product rule on τ̂ with n² points, any n."""
    u, wu = gauss01(n)
    U, V = np.meshgrid(u, u, indexing="ij")
    W = np.outer(wu, wu) * (1.0 - U)
    pts = np.column_stack([U.ravel(), (V * (1.0 - U)).ravel()])
    return pts, W.ravel()


def _segment_faces(vertices: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Points and weights on the closed polygon through ``vertices``."""
    u, wu = gauss01(n)
    pts, wts = [], []
    m = len(vertices)
    for i in range(m):
        a, b = vertices[i], vertices[(i + 1) % m]
        pts.append(a[None, :] + u[:, None] * (b - a)[None, :])
        wts.append(wu * abs(a[0] * b[1] - a[1] * b[0]))  # |det[w, ∂w/∂u]|
    return np.vstack(pts), np.concatenate(wts)


def coincident_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Face rule for identical triangles, z = x̂ − ŷ in the hexagon τ̂ − τ̂.

    The overlap area |τ̂ ∩ (τ̂ + z)| = ½ (1 − ρ(z))², so with
    B = radial_factor("coincident", s):
    ∫_τ̂∫_τ̂ G(x̂ − ŷ) = B · Σ_q w_q G(z_q) for G homogeneous of degree −2s.
    """
    hexagon = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 1.0],
                        [-1.0, 0.0], [0.0, -1.0], [1.0, -1.0]])
    z, w = _segment_faces(hexagon, n)
    return z, 0.5 * w


def edge_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Face rule for triangles with a common edge.

    With x = P + x̂₁(Q−P) + x̂₂(R−P) and y = P + ŷ₁(Q−P) + ŷ₂(R'−P) (common
    edge PQ), z = (x̂₁ − ŷ₁, x̂₂, ŷ₂); the length of the remaining variable is
    1 − ρ(z) with ρ(z) = max(0, z₁) + max(z₂, z₃ − z₁).  The four faces of
    {ρ ≤ 1, z₂, z₃ ≥ 0} are two parallelograms and two triangles.
    """
    u, wu = gauss01(n)
    U, V = np.meshgrid(u, u, indexing="ij")
    Wq = np.outer(wu, wu).ravel()
    U, V = U.ravel(), V.ravel()
    tri, wtri = collapsed_triangle_rule(n)
    faces = [
        (np.column_stack([1.0 - U, U, V]), Wq),                      # ρ = z₁ + z₂
        (np.column_stack([tri[:, 0], tri[:, 1], np.ones(len(tri))]), wtri),   # ρ = z₃
        (np.column_stack([-tri[:, 0], np.ones(len(tri)), tri[:, 1]]), wtri),  # ρ = z₂
        (np.column_stack([U - 1.0, V, U]), Wq),                      # ρ = z₃ − z₁
    ]
    return np.vstack([f[0] for f in faces]), np.concatenate([f[1] for f in faces])


def vertex_rule(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Face rule for triangles with a common vertex, z = (x̂, ŷ) in τ̂ × τ̂.

    ρ(z) = max(x̂₁ + x̂₂, ŷ₁ + ŷ₂).  On the face x̂₁ + x̂₂ = 1,
    w = ((1−t₁, t₁), η(1−t₂, t₂)) with Jacobian η; symmetrically for ŷ.
    """
    g, wg = gauss01(n)
    T1, E, T2 = np.meshgrid(g, g, g, indexing="ij")
    T1, E, T2 = T1.ravel(), E.ravel(), T2.ravel()
    W = (wg[:, None, None] * wg[None, :, None] * wg[None, None, :]).ravel() * E
    half1 = np.column_stack([1.0 - T1, T1, E * (1.0 - T2), E * T2])
    half2 = np.column_stack([E * (1.0 - T1), E * T1, 1.0 - T2, T2])
    return np.vstack([half1, half2]), np.concatenate([W, W])


def radial_factor(kind: str, s: float) -> float:
    """B(s) = ∫₀¹ r^(d−1−2s) (1 − r)^k dr for the three singular cases."""
    if kind == "coincident":   # d = 2, k = 2
        return 2.0 / ((2.0 - 2.0 * s) * (3.0 - 2.0 * s) * (4.0 - 2.0 * s))
    if kind == "edge":         # d = 3, k = 1
        return 1.0 / ((3.0 - 2.0 * s) * (4.0 - 2.0 * s))
    if kind == "vertex":       # d = 4, k = 0
        return 1.0 / (4.0 - 2.0 * s)
    raise ValueError(f"kind={kind!r} must be 'coincident', 'edge' or 'vertex'")
