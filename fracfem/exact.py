"""Constants and exact solutions of the integral fractional Laplacian in 2D."""
from __future__ import annotations

import numbers

import numpy as np
from scipy.special import gamma

__all__ = [
    "check_s",
    "c2s",
    "disk_solution_constant",
    "disk_solution",
    "disk_energy",
    "bubble_laplacian",
    "bubble",
    "bubble_energy",
    "heat_solution",
    "heat_source",
    "heat_error",
]


def check_s(s, *, name: str = "s", low: float = 0.0, high: float = 1.0) -> float:
    """Return s as float if low < s < high, else raise a ValueError naming it."""
    if isinstance(s, (bool, np.bool_)) or not isinstance(s, (numbers.Real, np.floating,
                                                            np.integer)):
        raise ValueError(f"{name}={s!r} must be a number in ({low}, {high})")
    val = float(s)
    if not (np.isfinite(val) and low < val < high):
        raise ValueError(f"{name}={s!r} is outside the allowed range ({low}, {high})")
    return val


def c2s(s: float) -> float:
    """c_{2,s} = 2^{2s} s Γ(1+s) / (π Γ(1−s)), the constant of (−Δ)^s in 2D."""
    s = check_s(s)
    return 2.0 ** (2 * s) * s * gamma(1 + s) / (np.pi * gamma(1 - s))


def disk_solution_constant(s: float) -> float:
    """C_s with (−Δ)^s [C_s (1−|x|²)_+^s] = 1 on the unit disk."""
    s = check_s(s)
    return 1.0 / (2.0 ** (2 * s) * gamma(1 + s) ** 2)


def disk_solution(x: np.ndarray, s: float) -> np.ndarray:
    """u(x) = C_s (1−|x|²)_+^s, the solution for f = 1 on the unit disk."""
    r2 = np.sum(np.asarray(x) ** 2, axis=0)
    return disk_solution_constant(s) * np.clip(1.0 - r2, 0.0, None) ** s


def disk_energy(s: float) -> float:
    """(f, u) = a(u, u) = C_s π / (1+s) for f = 1 on the unit disk."""
    return disk_solution_constant(s) * np.pi / (1.0 + s)


def bubble_laplacian(x: np.ndarray, s: float) -> np.ndarray:
    """(−Δ)^s (1−|x|²)_+^{1+s} = 2^{2s} Γ(2+s) Γ(1+s) (1 − (1+s)|x|²) in |x| < 1."""
    s = check_s(s)
    r2 = np.sum(np.asarray(x) ** 2, axis=0)
    return 2.0 ** (2 * s) * gamma(2 + s) * gamma(1 + s) * (1.0 - (1.0 + s) * r2)


def bubble(x: np.ndarray, s: float) -> np.ndarray:
    """w(x) = (1−|x|²)_+^{1+s}, the profile of the manufactured heat solution."""
    s = check_s(s)
    r2 = np.sum(np.asarray(x) ** 2, axis=0)
    return np.clip(1.0 - r2, 0.0, None) ** (1.0 + s)


def bubble_energy(s: float) -> float:
    """a(w, w) = ∫ w (−Δ)^s w = 2πK/((2+s)(3+s)), K = 2^{2s}Γ(2+s)Γ(1+s).

    With ρ = |x|²: π K ∫₀¹ (1−ρ)^{1+s}(1 − (1+s)ρ) dρ
    = π K (1/(2+s) − (1+s)/((2+s)(3+s))) = 2πK/((2+s)(3+s)).
    """
    s = check_s(s)
    K = 2.0 ** (2 * s) * gamma(2 + s) * gamma(1 + s)
    return 2.0 * np.pi * K / ((2.0 + s) * (3.0 + s))


def heat_solution(x: np.ndarray, t: float, s: float) -> np.ndarray:
    """u(x, t) = e^{−t} (1−|x|²)_+^{1+s}: solves u_t + (−Δ)^s u = heat_source."""
    return np.exp(-t) * bubble(x, s)


def heat_source(x: np.ndarray, t: float, s: float) -> np.ndarray:
    """f(x, t) = e^{−t}((−Δ)^s w − w) in the unit disk, w = :func:`bubble`."""
    return np.exp(-t) * (bubble_laplacian(x, s) - bubble(x, s))


def heat_error(steps, disc, s: float) -> float:
    """‖u − u_hτ‖_{L²(0,T; a)} for u = :func:`heat_solution` = e^{−t}(1−|x|²)^{1+s}.

    Exact in time: u^k is constant on I_k, so ∫_{I_k}‖e^{−t}w − u^k‖²_a dt =
    a(w,w)∫e^{−2t} − 2a(w,u^k)∫e^{−t} + τ_k a(u^k,u^k), with a(w, φ_i) =
    ((−Δ)ˢw, φ_i) and a(w,w) in closed form (:func:`bubble_energy`).
    ``steps``: the :class:`fracfem.parabolic.TimeStep` records of a run on ``disc``
    (k = 0 is skipped).
    """
    from .assembly import load_vector   # assembly imports this module

    aw = load_vector(disc.mesh, lambda x: bubble_laplacian(x, s))[disc.free]
    ww = bubble_energy(s)
    err2 = 0.0
    for step in steps:
        if step.k == 0:
            continue
        a, b = step.t - step.tau, step.t
        u = step.u[disc.free]
        err2 += (ww * 0.5 * (np.exp(-2 * a) - np.exp(-2 * b))
                 - 2.0 * (aw @ u) * (np.exp(-a) - np.exp(-b)) + step.tau * (u @ (disc.A @ u)))
    if not err2 > 0:
        raise RuntimeError(f"squared error {err2:.3e} <= 0: round-off or a wrong run")
    return float(np.sqrt(err2))
