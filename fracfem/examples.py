"""Data of the paper's examples where the paper leaves a choice (DESIGN.md)."""
from __future__ import annotations

import numpy as np

__all__ = ["paraboloid_obstacle", "radial_load", "segment_edges", "example2", "example3",
           "pure_slip_energy", "ring_initial"]


def paraboloid_obstacle(height: float = 1.0, slope: float = 4.0):
    """χ(x) = height − slope |x|² (Figure 3; max χ = 1 and χ ≤ 0 on ∂Ω by default)."""
    if not (np.isfinite(height) and np.isfinite(slope)):
        raise ValueError(f"obstacle height={height!r} and slope={slope!r} must be finite")
    if height - slope > 0:
        raise ValueError(f"obstacle χ = {height} − {slope}|x|² is positive on ∂Ω; the paper "
                         "assumes χ ≤ 0 in Ωᶜ (choose slope >= height)")
    return lambda x: height - slope * (x[0] ** 2 + x[1] ** 2)


def radial_load(a: float = 1.0, b: float = 0.0):
    """f(x) = a − b|x|²; b = 0 is the paper's f ≡ a, b > a a sign-changing load."""
    return lambda x: a - b * (x[0] ** 2 + x[1] ** 2)


def segment_edges(coarse, x0: float, x1: float, y: float = 0.0, tol: float = 1e-12):
    """Coarse edges on the segment [x0, x1] × {y}: the curve Γ̃ of thin problems.

    Raises ValueError unless these edges cover the whole segment.
    """
    from .mixed import edges_on_curve

    edges = edges_on_curve(coarse, lambda x: (np.abs(x[1] - y) < tol)
                           & (x[0] > x0 - tol) & (x[0] < x1 + tol))
    covered = np.sum(np.abs(coarse.p[0, edges[1]] - coarse.p[0, edges[0]]))
    if edges.shape[1] == 0 or abs(covered - (x1 - x0)) > 1e-9:
        raise ValueError(f"the segment [{x0}, {x1}] x {{{y}}} is not made of coarse mesh edges "
                         f"(edges found cover length {covered:.6g})")
    return edges


def example2(coarse, *, s: float = 0.5, height: float = 1.0, slope: float = 4.0,
             quadrature=None, operator: str = "dense"):
    """Example 2 on T_H = coarse: (−Δ)ˢu ≥ 1 above χ = height − slope|x|² (mixed form).

    ``operator``: the stiffness representation, 'dense', 'compressed' or 'auto'
    (:func:`fracfem.vi.mixed_problem`).  Returns (MixedProblem, f) — f is needed
    by the estimators.
    """
    from . import vi

    chi = paraboloid_obstacle(height, slope)
    return vi.mixed_problem("obstacle", coarse, s, 1.0, chi=chi, quadrature=quadrature,
                            operator=operator), 1.0


def example3(coarse, *, s: float = 0.6, a: float = 1.0, b: float = 0.0, F: float = 0.5,
             quadrature=None, operator: str = "dense"):
    """Example 3 on T_H = coarse: interior friction on Ω with f = a − b|x|², bound F.

    b = 0 is the paper's f ≡ 1 (then u > 0 and λ_H = F: pure slip); b > a changes the
    sign of f.  Returns (MixedProblem, f).
    """
    from . import vi

    f = radial_load(a, b)
    return vi.mixed_problem("friction", coarse, s, f, F=F, quadrature=quadrature,
                            operator=operator), f


def pure_slip_energy(s: float, F: float, a: float = 1.0) -> float:
    """Exact energy of Example 3 with f ≡ a > F ≥ 0 on the unit disk.

    u = (a − F) C_s (1 − |x|²)^s > 0 solves the friction problem with λ = F (pure
    slip), so E(u) = ½a(u,u) − (f,u) + F∫|u| = −½ (a − F)² (1, u₁), u₁ the solution
    for f = 1 (:func:`fracfem.exact.disk_energy`).
    """
    from .exact import disk_energy

    if not (np.isfinite(F) and np.isfinite(a) and 0 <= F < a):
        raise ValueError(f"pure slip needs 0 <= F < a, got F={F!r}, a={a!r}")
    return -0.5 * (a - F) ** 2 * disk_energy(s)


def ring_initial(r0: float = 0.6):
    """u₀(x) = (|x| − 1)(|x| − r0) of Example 5: > 0 for |x| < r0, < 0 in the ring."""
    if not (np.isfinite(r0) and 0 < r0 < 1):
        raise ValueError(f"r0={r0!r} must be in (0, 1)")
    def u0(x):
        r = np.sqrt(x[0] ** 2 + x[1] ** 2)
        return (r - 1.0) * (r - r0)
    return u0
