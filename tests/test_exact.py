"""Tests of fracfem.exact: c_{2,s}, the disk solution of Example 1 and check_s."""

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.special import gamma

from fracfem.exact import (bubble_laplacian, c2s, check_s, disk_energy, disk_solution,
                           disk_solution_constant)

S_VALUES = [0.05, 0.1, 0.25, 0.5, 0.6, 0.75, 0.9, 0.95]


@pytest.mark.parametrize("s", [v for v in S_VALUES if v != 0.5])
def test_c2s_is_the_closed_form_of_the_defining_integral(s):
    """1/c = ∫_{R²} (1 − cos z₁) |z|^(−2−2s) dz, evaluated by another route than the
    implementation's: integrating over z₂ gives |t|^(−1−2s) √π Γ(s+½)/Γ(s+1), and
    ∫₀^∞ (1 − cos t) t^(−1−α) dt = Γ(1−α) cos(πα/2)/α for α = 2s ≠ 1 (the
    Mellin transform of 1 − cos); s = ½ is the removable singularity, tested below."""
    inner = np.sqrt(np.pi) * gamma(s + 0.5) / gamma(s + 1)
    radial = gamma(1 - 2 * s) * np.cos(np.pi * s) / (2 * s)
    assert c2s(s) == pytest.approx(1.0 / (inner * 2 * radial), rel=1e-13)


def test_c2s_known_value_at_one_half():
    # 2 · ½ · Γ(3/2) / (π Γ(1/2)) = 1/(2π)
    assert c2s(0.5) == pytest.approx(1.0 / (2.0 * np.pi), rel=1e-14)


def test_c2s_limits():
    """c2s(s)/s → 1/π as s → 0 and c2s(s)/(1−s) → 4/π as s → 1 (Γ(1−s) ~ 1/(1−s));
    the errors are O(s) and O(1−s)."""
    for eps in [1e-3, 1e-5, 1e-7]:
        assert c2s(eps) / eps == pytest.approx(1.0 / np.pi, rel=5 * eps)
        assert c2s(1 - eps) / eps == pytest.approx(4.0 / np.pi, rel=5 * eps)
    assert np.all(np.diff([c2s(s) for s in np.linspace(0.01, 0.6, 30)]) > 0)


@pytest.mark.parametrize("s", [0.2, 0.5, 0.8])
def test_c2s_normalises_the_fourier_symbol(s):
    """c ∫_{R²} (1 − cos z₁) |z|^(−2−2s) dz = 1, i.e. (−Δ)^s e^{iξ·x} = |ξ|^{2s} e^{iξ·x}.

    Integrating over z₂ first: ∫ (t² + w²)^(−1−s) dw = |t|^(−1−2s) √π Γ(s+½)/Γ(s+1),
    then 2 ∫₀^∞ (1 − cos t) t^(−1−2s) dt with the oscillatory tail by QAWF.
    """
    inner = np.sqrt(np.pi) * gamma(s + 0.5) / gamma(s + 1)
    a = quad(lambda t: 2 * np.sin(0.5 * t) ** 2 * t ** (-1 - 2 * s), 0, 1, epsabs=0,
             epsrel=1e-11, limit=200)[0]
    tail = 1.0 / (2 * s) - quad(lambda t: t ** (-1 - 2 * s), 1, np.inf, weight="cos",
                                wvar=1.0)[0]
    assert c2s(s) * inner * 2 * (a + tail) == pytest.approx(1.0, rel=1e-8)


def test_disk_solution_constant_limits():
    """s → 0: (−Δ)⁰ = I and (1−|x|²)⁰ = 1, so C → 1; s → 1: −Δ[(1−|x|²)/4] = 1, so
    C → 1/4; both with O(s), O(1−s) errors.  s = ½: 2/π, the mean exit time of the
    Cauchy process from the unit disk at its centre (Getoor 1961)."""
    for eps in [1e-3, 1e-5, 1e-7]:
        assert abs(disk_solution_constant(eps) - 1.0) <= eps
        assert abs(disk_solution_constant(1 - eps) - 0.25) <= eps
    assert disk_solution_constant(0.5) == pytest.approx(2.0 / np.pi, rel=1e-14)


def fractional_laplacian_of_disk_solution(x0, s):
    """(−Δ)^s u(x0) for u = C_s(1−|x|²)_+^s at any x0 in the disk, by quadrature.

    (−Δ)^s u(x0) = c ∫₀^π ∫₀^∞ (2u(x0) − u(x0+rω) − u(x0−rω)) r^(−1−2s) dr dθ;
    the radial integral is split at the distances to the circle along ±ω, the part
    r < δ = 10⁻³(1−|x0|²) uses the second-order Taylor term (error O(δ^(4−2s))) and
    the part beyond the circle, where u = 0, is 2u(x0) R^(−2s)/(2s) in closed form.
    """
    C = disk_solution_constant(s)
    a = 1.0 - x0 @ x0
    delta = 1e-3 * a                     # u varies on the scale 1 − |x0|² near x0

    def radial(th):
        b = x0 @ np.array([np.cos(th), np.sin(th)])
        root = np.sqrt(b * b + a)
        lo, hi = sorted((root - b, root + b))
        d2 = 4 * s * (s - 1) * a ** (s - 2) * b * b - 2 * s * a ** (s - 1)  # ∂²_r (a−2rb−r²)^s
        head = -C * d2 * delta ** (2 - 2 * s) / (2 - 2 * s)

        def f(r):
            up, um = max(a - 2 * r * b - r * r, 0.0), max(a + 2 * r * b - r * r, 0.0)
            return C * (2 * a ** s - up ** s - um ** s) * r ** (-1 - 2 * s)

        body = sum(quad(f, u, v, epsabs=0, epsrel=1e-10, limit=200)[0]
                   for u, v in ((delta, lo), (lo, hi)))
        return head + body + 2 * C * a ** s * hi ** (-2 * s) / (2 * s)

    return c2s(s) * quad(radial, 0, np.pi, epsabs=0, epsrel=1e-10, limit=200)[0]


@pytest.mark.parametrize("s", [0.25, 0.5, 0.75])
@pytest.mark.parametrize("x0", [(0.5, 0.2), (0.0, 0.9)])
def test_disk_solution_solves_the_equation_off_centre(s, x0):
    """(−Δ)^s u = 1 also away from the centre (no radial symmetry used)."""
    val = fractional_laplacian_of_disk_solution(np.array(x0), s)
    assert val == pytest.approx(1.0, rel=1e-7)


def radial_fractional_laplacian_at_zero(u0, du, s):
    """(−Δ)^s u(0) = c 2π ∫₀^∞ (u(0) − u(r)) r^(−1−2s) dr for radial u with
    support in the unit disk (the first-order term cancels by symmetry);
    du(r) = u(0) − u(r) for r < 1, written without cancellation."""
    inner = sum(quad(lambda r: du(r) * r ** (-1 - 2 * s), a, b, epsabs=0,
                     epsrel=1e-11, limit=400)[0] for a, b in ((0, 0.5), (0.5, 1)))
    return c2s(s) * 2 * np.pi * (inner + u0 / (2 * s))


@pytest.mark.parametrize("s", [0.1, 0.25, 0.5, 0.75, 0.9])
def test_disk_solution_solves_the_equation_at_the_centre(s):
    """(−Δ)^s [C_s (1−|x|²)_+^s](0) = 1 by direct quadrature of the singular integral."""
    C = disk_solution_constant(s)
    val = radial_fractional_laplacian_at_zero(
        C, lambda r: -C * np.expm1(s * np.log1p(-r * r)), s)
    assert val == pytest.approx(1.0, rel=1e-7)


@pytest.mark.parametrize("s", [0.25, 0.5, 0.75])
def test_bubble_laplacian_at_the_centre(s):
    val = radial_fractional_laplacian_at_zero(
        1.0, lambda r: -np.expm1((1 + s) * np.log1p(-r * r)), s)
    assert bubble_laplacian(np.zeros((2, 1)), s)[0] == pytest.approx(val, rel=1e-7)


def test_disk_solution_values():
    s = 0.3
    x = np.array([[0.0, 0.6, 1.0, 2.0], [0.0, 0.0, 0.0, 0.0]])
    u = disk_solution(x, s)
    C = disk_solution_constant(s)
    np.testing.assert_allclose(u, [C, C * 0.64 ** s, 0.0, 0.0], rtol=1e-14)


@pytest.mark.parametrize("s", [0.1, 0.25, 0.5, 0.75, 0.9])
def test_disk_energy_is_the_integral_of_u(s):
    """(f, u) = ∫ u over the unit disk = 2π ∫₀¹ C_s (1−r²)^s r dr = C_s π/(1+s)."""
    C = disk_solution_constant(s)
    val = 2 * np.pi * quad(lambda r: C * (1 - r * r) ** s * r, 0, 1, epsabs=0,
                           epsrel=1e-13)[0]
    assert disk_energy(s) == pytest.approx(val, rel=1e-10)
    # and via the 2D quadrature of disk_solution on a polar grid (independent path)
    r, wr = np.polynomial.legendre.leggauss(60)
    r, wr = 0.5 * (r + 1), 0.5 * wr
    th = np.linspace(0, 2 * np.pi, 8, endpoint=False)
    pts = np.stack([np.outer(r, np.cos(th)), np.outer(r, np.sin(th))])
    val2 = np.sum(disk_solution(pts, s) * (wr * r)[:, None]) * 2 * np.pi / len(th)
    assert disk_energy(s) == pytest.approx(val2, rel=1e-3)


# ---------------------------------------------------------------------------
# check_s


@pytest.mark.parametrize("s", [0.5, 1e-12, 1 - 1e-12, np.float32(0.25), 1 / 3])
def test_check_s_accepts_values_in_the_open_interval(s):
    out = check_s(s)
    assert isinstance(out, float) and out == pytest.approx(float(s))


@pytest.mark.parametrize("s", [0, 1, -0.1, 1.5, float("nan"), float("inf"), -float("inf")])
def test_check_s_rejects_out_of_range(s):
    with pytest.raises(ValueError, match=r"s=.*outside the allowed range \(0\.0, 1\.0\)"):
        check_s(s)


@pytest.mark.parametrize("s", ["a", None, [0.5], {}, object()])
def test_check_s_rejects_non_numbers(s):
    with pytest.raises(ValueError, match=r"s=.*must be a number in \(0\.0, 1\.0\)"):
        check_s(s)


def test_check_s_names_the_parameter_and_custom_bounds():
    with pytest.raises(ValueError, match=r"^theta=2\.5 is outside the allowed range \(0, 2\)$"):
        check_s(2.5, name="theta", low=0, high=2)
    assert check_s(1.5, low=1, high=2) == 1.5


@pytest.mark.parametrize("func", [c2s, disk_solution_constant, disk_energy])
def test_functions_of_s_validate_s(func):
    with pytest.raises(ValueError, match="s="):
        func(1.0)
    with pytest.raises(ValueError, match="s="):
        func("a")
