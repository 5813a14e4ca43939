"""The time step of a DG(0) run tied to its mesh: τ = factor · h^{2s} (Section 6.3).

The paper balances the time and space errors with τ ≈ h^{2s} (uniform meshes),
τ ≈ 0.5 h_max^{2s} (graded meshes) and a local τ ≈ h^{2s} (space-time adaptive
meshes); every run of Examples 4 and 5 takes its step from :func:`time_step`.
"""
from __future__ import annotations

import numbers

import numpy as np

from .exact import check_s

__all__ = ["time_step"]


def _positive(name: str, value) -> float:
    if (isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real)
            or not np.isfinite(value) or not value > 0):
        raise ValueError(f"{name}={value!r} must be a finite number > 0")
    return float(value)


def time_step(h_max: float, s: float, factor: float = 1.0) -> float:
    """τ = factor · h_max^{2s}.

    Parameters
    ----------
    h_max : largest triangle diameter of the mesh (> 0)
    s : fractional order in (0, 1)
    factor : the constant of the rule (> 0); the paper takes 1 on uniform and
        0.5 on graded meshes
    """
    h_max = _positive("h_max", h_max)
    s = check_s(s)
    factor = _positive("factor", factor)
    return factor * h_max ** (2 * s)
