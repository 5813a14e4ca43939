"""Obstacle and friction problems with the fractional stiffness matrix (Problem 5.15)."""
import numpy as np
import pytest

import fracfem as ff
from fracfem import examples, vi
from fracfem.solvers import ConvergenceError

CHI = examples.paraboloid_obstacle(1.0, 4.0)


@pytest.fixture(scope="module")
def coarse():
    return ff.disk_uniform(3)


def unconstrained(prob):
    return prob.disc.extend(ff.solve_laplace(prob.disc))


@pytest.mark.parametrize("kind, s, kw", [
    ("obstacle", 0.5, {"chi": CHI}),
    ("friction", 0.6, {"F": 0.5}),
])
def test_uzawa_and_pdas_agree_and_satisfy_the_constraints(coarse, kind, s, kw):
    f = 1.0 if kind == "obstacle" else examples.radial_load(1.0, 3.0)
    prob = vi.mixed_problem(kind, coarse, s, f, **kw)
    u1, l1, i1 = vi.solve(prob, "uzawa", tol=1e-12)
    u2, l2, i2 = vi.solve(prob, "pdas")
    assert np.abs(u1 - u2).max() < 1e-8 * np.abs(u2).max()
    assert np.abs(l1 - l2).max() < 1e-6 * np.abs(l2).max()
    cs = prob.cset
    assert cs.contains(l2, 0.0)                       # λ_H ∈ Λ_H exactly
    y = cs.B.T @ u2[prob.disc.free] - cs.g
    ymax = np.abs(y).max()
    if kind == "obstacle":
        contact = l2 < 0
        assert 0 < contact.sum() < len(l2)            # a genuine free boundary
        assert y.min() > -1e-10 * ymax                # coarse means of u − χ ≥ 0
        assert np.abs(y[contact]).max() < 1e-10 * ymax  # contact only where the mean gap is 0
    else:
        F = cs.upper
        slip = np.isclose(np.abs(l2), F, rtol=1e-10)
        stick = ~slip
        assert stick.any() and (l2[slip] > 0).any() and (l2[slip] < 0).any()
        assert np.all(np.sign(y[slip & (np.abs(y) > 1e-10 * ymax)])
                      == np.sign(l2[slip & (np.abs(y) > 1e-10 * ymax)]))
        assert np.abs(y[stick]).max() < 1e-9 * ymax


def test_inactive_obstacle_gives_the_unconstrained_solution(coarse):
    prob = vi.mixed_problem("obstacle", coarse, 0.5, 1.0, chi=lambda x: -5.0 + 0 * x[0])
    u, lam, _ = vi.solve(prob, "uzawa")
    assert np.all(lam == 0.0)
    np.testing.assert_allclose(u, unconstrained(prob), rtol=1e-12, atol=1e-14)


def test_zero_friction_gives_the_unconstrained_solution(coarse):
    prob = vi.mixed_problem("friction", coarse, 0.6, 1.0, F=0.0)
    u, lam, _ = vi.solve(prob, "pdas")
    assert np.all(lam == 0.0)
    np.testing.assert_allclose(u, unconstrained(prob), rtol=1e-12, atol=1e-14)


def test_large_friction_holds_everything(coarse):
    """F ≥ max|f|: stick on every coarse element, Bᵀu = 0 (coarse means vanish);
    u_h itself is then only a small oscillation of the fine space."""
    prob = vi.mixed_problem("friction", coarse, 0.6, 1.0, F=10.0)
    u, lam, _ = vi.solve(prob, "pdas")
    assert np.all(np.abs(lam) < 10.0)                 # nothing slips
    means = prob.cset.B.T @ u[prob.disc.free]
    assert np.abs(means).max() < 1e-12
    assert np.abs(u).max() < 0.05 * np.abs(unconstrained(prob)).max()


def test_thin_problems_need_s_above_one_half(coarse):
    edges = examples.segment_edges(coarse, -0.5, 0.5)
    for kind, kw in (("thin_obstacle", {"height": lambda x: 0 * x[0]}),
                     ("thin_friction", {"F": 0.5})):
        with pytest.raises(ValueError, match="s"):
            vi.mixed_problem(kind, coarse, 0.5, 1.0, edges=edges, **kw)


def test_thin_obstacle_contact_and_agreement(coarse):
    edges = examples.segment_edges(coarse, -0.5, 0.5)
    prob = vi.mixed_problem("thin_obstacle", coarse, 0.75, -1.0, edges=edges,
                            height=lambda x: np.full(x.shape[1:], -0.05))
    u1, l1, _ = vi.solve(prob, "uzawa", tol=1e-12)
    u2, l2, _ = vi.solve(prob, "pdas")
    assert np.all(l2 <= 0) and (l2 < 0).any()
    np.testing.assert_allclose(u1, u2, atol=1e-8 * np.abs(u2).max())
    # the discrete constraint: means of u − g over every coarse edge of Γ̃ are
    # ≥ 0 (λ_H is P0 on edges, so u_h may dip below g between edge midpoints)
    y = prob.cset.B.T @ u2[prob.disc.free] - prob.cset.g
    scale = np.abs(prob.cset.g).max()                 # |∫_e g ds|
    assert y.min() > -1e-10 * scale
    assert np.abs(y[l2 < 0]).max() < 1e-10 * scale


def test_bad_input_is_refused(coarse):
    with pytest.raises(ValueError, match="kind"):
        vi.mixed_problem("signorini", coarse, 0.5, 1.0)
    with pytest.raises(ValueError, match="F"):
        vi.mixed_problem("friction", coarse, 0.5, 1.0, F=-1.0)
    with pytest.raises(ValueError, match="χ"):
        vi.mixed_problem("obstacle", coarse, 0.5, 1.0, chi=lambda x: 1.0 + 0 * x[0])
    with pytest.raises(ValueError, match="not made of coarse mesh edges"):
        examples.segment_edges(coarse, -0.3, 0.3)
    with pytest.raises(ValueError, match="slope"):
        examples.paraboloid_obstacle(1.0, 0.5)
    prob = vi.mixed_problem("obstacle", coarse, 0.5, 1.0, chi=CHI)
    with pytest.raises(ValueError, match="solver"):
        vi.solve(prob, "newton")
    with pytest.raises(ConvergenceError):
        vi.solve(prob, "uzawa", maxiter=2)
