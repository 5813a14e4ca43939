"""Discrete energy and KKT conditions of a solved mixed problem (Problem 5.15).

With y = Bᵀu − g the discrete solution (u_h, λ_H) satisfies

    A u + B λ = b                  (stationarity)
    λ ∈ Λ_H                        (Remark 5.16)
    obstacle: y ≥ 0, λ·y = 0       (contact where λ < 0)
    friction: y = 0 where |λ| < F  (stick), λ = ±F elsewhere (slip).

:func:`kkt_report` measures how well a pair satisfies them; :func:`discrete_energy`
is E(u_h) = ½a(u_h,u_h) − (f,u_h) + j_H(u_h), whose minimum over the constraint
set is the discrete solution.
"""
from __future__ import annotations

import numpy as np

from .assembly import energy
from .laplace import Discretisation

__all__ = ["contact_set", "discrete_energy", "friction_functional", "kkt_report"]


def _free_values(disc, u) -> np.ndarray:
    u = np.asarray(u, dtype=float)
    n_all, n_free = disc.mesh.p.shape[1], len(disc.free)
    if u.shape == (n_all,):
        return u[disc.free]
    raise ValueError(f"u must hold one value per node of the fine mesh, shape ({n_all},); "
                     f"got shape {u.shape} (free nodes: {n_free})")


def friction_functional(prob, u) -> float:
    """j_H(u) = Σ_j F_j |⟨μ_j, u⟩| of a friction problem (interior or thin).

    u holds one value per fine node (as :func:`fracfem.vi.solve` returns it).
    """
    if not prob.kind.endswith("friction"):
        raise ValueError(f"j_H is defined for friction problems, not kind={prob.kind!r}")
    uf = _free_values(prob.disc, u)
    return float(np.sum(prob.cset.upper * np.abs(prob.cset.B.T @ uf)))


def discrete_energy(prob, u) -> float:
    """E(u) = ½a(u,u) − (f,u), plus j_H(u) for friction problems.

    prob: a :class:`fracfem.vi.MixedProblem` or a
    :class:`fracfem.laplace.Discretisation`; u: one value per node of its mesh.
    """
    disc = prob if isinstance(prob, Discretisation) else prob.disc
    e = energy(disc.A, disc.b, _free_values(disc, u))
    if not isinstance(prob, Discretisation) and prob.kind.endswith("friction"):
        e += friction_functional(prob, u)
    return e


def contact_set(lam, *, rtol: float = 1e-9) -> np.ndarray:
    """The multipliers λ_H of an obstacle problem at contact: λ < −rtol · max |λ| (a
    boolean mask, as :func:`kkt_report` counts them; all False when λ ≡ 0)."""
    lam = np.asarray(lam, dtype=float)
    if lam.ndim != 1:
        raise ValueError(f"lam must hold one value per multiplier (1-d), got shape {lam.shape}")
    return lam < -rtol * max(np.abs(lam).max(initial=0.0), 1e-300)


def kkt_report(prob, u, lam, *, rtol: float = 1e-9) -> dict:
    """How well (u, λ) satisfies the KKT conditions of ``prob``, and its active sets.

    u: one value per fine node; lam: one value per multiplier.  A multiplier
    counts as at a bound when it lies within ``rtol`` (relative) of it.  Returns
    multipliers, lambda_in_set, max_stationarity_residual (max |Au + Bλ − b|) and
    obstacle: contact, min_gap (min y, ≥ 0 when feasible), max_complementarity
    (max |λ y|); friction: slip_plus, slip_minus, stick, max_stick_residual
    (max |y| where |λ| < F), max_friction_excess (max |λ| − F, ≤ 0 when λ ∈ Λ_H).
    """
    cs, disc = prob.cset, prob.disc
    uf = _free_values(disc, u)
    lam = np.asarray(lam, dtype=float)
    if lam.shape != (cs.n_multipliers,):
        raise ValueError(f"lam must have shape ({cs.n_multipliers},), got {lam.shape}")
    y = cs.B.T @ uf - cs.g
    out = {"multipliers": len(lam), "lambda_in_set": bool(cs.contains(lam, 0.0))}
    if prob.kind.endswith("obstacle"):
        out.update(contact=int(contact_set(lam, rtol=rtol).sum()),
                   min_gap=float(y.min()),
                   max_complementarity=float(np.abs(lam * y).max()))
    else:
        F = cs.upper
        plus = np.isclose(lam, F, rtol=rtol, atol=0) & (F > 0)
        minus = np.isclose(lam, -F, rtol=rtol, atol=0) & (F > 0)
        stick = ~plus & ~minus
        out.update(slip_plus=int(plus.sum()), slip_minus=int(minus.sum()),
                   stick=int(stick.sum()),
                   max_stick_residual=float(np.abs(y[stick]).max(initial=0.0)),
                   max_friction_excess=float((np.abs(lam) - F).max()))
    out["max_stationarity_residual"] = float(
        np.abs(disc.A @ uf + cs.B @ lam - disc.b).max())
    return out
