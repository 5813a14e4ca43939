"""Data of the paper's examples where the paper leaves a choice (DESIGN.md)."""
from __future__ import annotations

import numpy as np

__all__ = ["paraboloid_obstacle", "radial_load", "segment_edges"]


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
