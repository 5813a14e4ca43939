"""Slow reference for :func:`fracfem.pointwise.fractional_laplacian_at` (tiny meshes).

:func:`fractional_laplacian_reference` implements the element-wise polar
formula directly and independently of the edge/Riesz formulation of the fast
kernel (slow, scipy.integrate.quad): for each element T' containing x or not,
exact radial integrals and adaptive quadrature in the angle (split at the
directions of the vertices and of the feet of the perpendiculars), P.V. for
the element containing x as −∫_θ ∇u_T·ω Φ(R(θ)) dθ with
Φ(R) = (R^(1−2s) − 1)/(1−2s) (log R for s = 1/2; the θ-independent divergent
part multiplies ∇u_T·ω, whose integral over the circle vanishes), and
u_h(x) κ(x) with κ from its boundary integral.
"""
from __future__ import annotations

import numpy as np

from fracfem.assembly import mesh_arrays
from fracfem.exact import c2s, check_s
from fracfem.pointwise import _check_points, _check_u, _jumps

__all__ = ["fractional_laplacian_reference"]


def _phi1(r, s):
    """Φ(r) = ∫_1^r ρ^(−2s) dρ (log r for s = 1/2)."""
    if s == 0.5:
        return np.log(r)
    return np.expm1((1.0 - 2.0 * s) * np.log(r)) / (1.0 - 2.0 * s)


def _ray_interval(x, V, th):
    """[r1, r2] of the ray x + r(cos th, sin th), r ≥ 0, inside the triangle V."""
    om = np.array([np.cos(th), np.sin(th)])
    lo, hi = 0.0, np.inf
    for k in range(3):
        a, b, c = V[k], V[(k + 1) % 3], V[(k + 2) % 3]
        n = np.array([a[1] - b[1], b[0] - a[0]])
        if n @ (c - a) < 0:
            n = -n                              # inward normal
        f0, fr = n @ (x - a), n @ om            # need f0 + r fr ≥ 0
        if fr > 0:
            lo = max(lo, -f0 / fr)
        elif fr < 0:
            hi = min(hi, -f0 / fr)
        elif f0 < 0:
            return 0.0, 0.0
    return lo, max(lo, hi)


def _angle_breaks(x, V):
    """Directions of the vertices and of the feet of the perpendiculars that
    fall inside the edges, as seen from x."""
    ang = [np.arctan2(*(v - x)[::-1]) for v in V]
    for k in range(3):
        a, b = V[k], V[(k + 1) % 3]
        tt = (x - a) @ (b - a) / ((b - a) @ (b - a))
        if 0.0 < tt < 1.0:
            f = a + tt * (b - a) - x
            ang.append(np.arctan2(f[1], f[0]))
    return np.array(ang)


def _polar_element(x, ux, V, uV, s, contains, quad, tol):
    """∫_{T'} (u_h(x) − u_h(y))|x−y|^(−2−2s) dy (P.V. if T' ∋ x), exact in r."""
    e1, e2 = V[1] - V[0], V[2] - V[0]
    det = e1[0] * e2[1] - e1[1] * e2[0]
    du1, du2 = uV[1] - uV[0], uV[2] - uV[0]
    g = np.array([du1 * e2[1] - du2 * e1[1], e1[0] * du2 - e2[0] * du1]) / det
    a = ux - (uV[0] + g @ (x - V[0]))           # u_h(x) − u_T'(x)
    br = _angle_breaks(x, V)
    if contains:
        def f(th):
            R = _ray_interval(x, V, th)[1]
            return -(g[0] * np.cos(th) + g[1] * np.sin(th)) * _phi1(R, s)
        br = np.sort(np.mod(br - br[0], 2 * np.pi)) + br[0]
        br = np.append(br, br[0] + 2 * np.pi)
    else:
        def f(th):
            r1, r2 = _ray_interval(x, V, th)
            if r2 <= r1:
                return 0.0
            gw = g[0] * np.cos(th) + g[1] * np.sin(th)
            return (a * (r1 ** (-2 * s) - r2 ** (-2 * s)) / (2 * s)
                    - gw * (_phi1(r2, s) - _phi1(r1, s)))
        cen = V.mean(axis=0) - x
        c0 = np.arctan2(cen[1], cen[0])
        br = np.sort(np.mod(br - c0 + np.pi, 2 * np.pi) - np.pi) + c0
    total = 0.0
    for lo, hi in zip(br[:-1], br[1:]):
        if hi - lo > 1e-15:
            total += quad(f, lo, hi, epsabs=tol, epsrel=tol, limit=200)[0]
    return total


def _kappa_reference(x, ba, bb, s, quad, tol):
    """κ(x) = (1/2s) Σ_e d_e ∫_e |x−y|^(−2−2s) dℓ over the oriented boundary."""
    total = 0.0
    for a, b in zip(ba, bb):
        L = np.linalg.norm(b - a)
        tv = (b - a) / L
        d = (a - x) @ np.array([tv[1], -tv[0]])
        t1 = (a - x) @ tv
        f = lambda tt: (d * d + (t1 + tt) ** 2) ** (-1.0 - s)  # noqa: E731
        pts = [-t1] if 0.0 < -t1 < L else None
        total += d * quad(f, 0.0, L, points=pts, epsabs=0.0, epsrel=tol, limit=200)[0]
    return total / (2.0 * s)


def fractional_laplacian_reference(mesh, u, points, elements, s, *,
                                   tol: float = 1e-11) -> np.ndarray:
    """Slow reference for :func:`fracfem.pointwise.fractional_laplacian_at`.

    c_{2,s} [Σ_{T'} ∫_{T'} (u_h(x) − u_h(y)) k(x−y) dy + u_h(x) κ(x)] with,
    for every element, exact radial integrals and adaptive Gauss–Kronrod
    (scipy.integrate.quad, tolerance ``tol``) in the angle, and κ from its
    boundary-integral form, also by quad.  Independent of the edge/Riesz
    formulation of the fast kernel.
    """
    from scipy.integrate import quad

    s = check_s(s)
    p, t = mesh_arrays(mesh)
    u = _check_u(u, len(p))
    x, el = _check_points(p, t, points, elements)
    _, _, _, bnodes = _jumps(p, t, u)
    ba, bb = p[bnodes[:, 0]], p[bnodes[:, 1]]
    out = np.empty(len(x))
    for i, (xi, ei) in enumerate(zip(x, el)):
        V = p[t[ei]]
        e1, e2, r = V[1] - V[0], V[2] - V[0], xi - V[0]
        det = e1[0] * e2[1] - e1[1] * e2[0]
        l1 = (r[0] * e2[1] - r[1] * e2[0]) / det
        l2 = (e1[0] * r[1] - e1[1] * r[0]) / det
        ux = u[t[ei]] @ np.array([1.0 - l1 - l2, l1, l2])
        acc = 0.0
        for k in range(len(t)):
            acc += _polar_element(xi, ux, p[t[k]], u[t[k]], s, k == ei, quad, tol)
        if ux != 0.0:
            acc += ux * _kappa_reference(xi, ba, bb, s, quad, tol)
        out[i] = c2s(s) * acc
    return out
