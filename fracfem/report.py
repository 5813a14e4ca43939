"""Convergence rates and the paper's reference values (Section 8)."""
from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["PAPER_RATES", "PAPER_S", "fit_rate", "rate_table"]

# error in H^s vs DOFs (parabolic: vs space-time DOFs), paper Section 8
PAPER_RATES = {
    (1, "uniform"): -0.252, (1, "graded"): -0.540, (1, "adaptive"): -0.510,
    (2, "uniform"): -0.245, (2, "graded"): -0.498, (2, "adaptive"): -0.363,
    (3, "uniform"): -0.220, (3, "graded"): -0.454, (3, "adaptive"): -0.429,
    (4, "uniform"): -0.173, (4, "graded"): -0.325, (4, "adaptive"): -0.319,
    (5, "uniform"): -0.156, (5, "graded"): -0.322, (5, "adaptive"): -0.323,
}
PAPER_S = {1: 0.5, 2: 0.5, 3: 0.6, 4: 0.5, 5: 0.6}


def fit_rate(dofs, errors) -> float:
    """Least-squares slope of log(error) against log(DOFs) over all points."""
    dofs = np.asarray(dofs, dtype=float)
    errors = np.asarray(errors, dtype=float)
    if len(dofs) < 2 or np.any(~np.isfinite(errors)) or np.any(errors <= 0):
        raise ValueError("fit_rate needs at least two finite positive errors")
    return float(np.polyfit(np.log(dofs), np.log(errors), 1)[0])


def rate_table(df: pd.DataFrame, x: str = "dofs", y: str = "error") -> pd.DataFrame:
    """One row per (example, family, s): fitted rate next to the paper's."""
    rows = []
    for (ex, fam, s), g in df.groupby(["example", "family", "s"], sort=True):
        paper = PAPER_RATES.get((int(ex), fam)) if np.isclose(s, PAPER_S[int(ex)]) else None
        rows.append({"example": int(ex), "family": fam, "s": float(s),
                     "rate": round(fit_rate(g[x], g[y]), 3),
                     "paper_rate": paper, "n_points": len(g),
                     "dof_min": int(g[x].min()), "dof_max": int(g[x].max())})
    return pd.DataFrame(rows)
