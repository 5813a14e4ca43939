"""DG(0) time stepping (fracfem.parabolic), space-time indicators
(fracfem.spacetime_estimators) and Algorithm C (fracfem.spacetime_adaptive).

Manufactured solution u = e^{−t} w, w = (1−|x|²)^{1+s}, s = 1/2, T = 1, error in
L²(0, T; energy norm) computed exactly in time (measured when these tests were
written):

* τ → 0 on disk_uniform(3) (113 free nodes): errors 0.1502, 0.0862, 0.0539,
  0.0405, 0.0360, 0.0347 for τ = 1/2 … 1/64, space floor e_h = 0.03421 (τ = 1/1024).
  Raw orders 0.80, 0.68, 0.41, … fall as the space error takes over; the time
  part e_τ = √(e² − e_h²) has orders 0.89, 0.93, 0.94, 0.94, 0.93 (on
  disk_uniform(4): 0.89, 0.93, 0.96, 0.97, 0.96), i.e. first order in τ.
* h → 0 with τ = 1/256: errors 0.0730, 0.0343, 0.0144 on disk_uniform(2, 3, 4):
  orders 1.09, 1.25 in h — the same as the elliptic Galerkin error of w itself
  (1.09, 1.26, 1.35 up to disk_uniform(5)), i.e. pre-asymptotic and rising
  towards the P1 rate in H^s for w ∈ H^{s+3/2−ε}: min(2 − s, 3/2) = 3/2 for s = 1/2.
  The tests assert orders in (1, 1.5), increasing.
"""
from functools import lru_cache

import numpy as np
import pytest

from fracfem import (assembly, exact, laplace, meshes, parabolic, spacetime_adaptive,
                     spacetime_estimators, vi)
from fracfem.transfer import SlabwiseReference, SpaceTimeReference

S = 0.5


def chi(x):
    return 1.0 - 4.0 * np.sum(np.asarray(x) ** 2, axis=0)


def ex5_u0(x):
    r = np.sqrt(np.sum(np.asarray(x) ** 2, axis=0))
    return (r - 1.0) * (r - 0.6)


@lru_cache(maxsize=None)
def heat_stepper(level, s=S):
    return parabolic.Stepper(laplace.discretise(meshes.disk_uniform(level), s, 0.0))


@lru_cache(maxsize=None)
def mixed_stepper(kind, level, s=S, F=0.1, far=False):
    coarse = meshes.disk_uniform(level)
    if kind == "obstacle":
        obstacle = (lambda x: -10.0 + 0.0 * x[0]) if far else chi
        prob = vi.mixed_problem("obstacle", coarse, s, 0.0, chi=obstacle)
    else:
        prob = vi.mixed_problem("friction", coarse, s, 0.0, F=F)
    return parabolic.Stepper(prob)


# ------------------------------------------------------------ manufactured solution


def manufactured_error(st, n, T=1.0, s=S):
    """‖u − u_hτ‖_{L²(0,T; a)}, exact in time (u^k constant on I_k)."""
    steps = parabolic.time_steps(st, lambda x: exact.bubble(x, s), T=T, tau=T / n,
                                 f=lambda x, t: exact.heat_source(x, t, s))
    return exact.heat_error(steps, st.disc, s)


def test_bubble_energy_closed_form():
    from scipy.integrate import quad

    for s in (0.2, 0.5, 0.8):
        val, _ = quad(lambda r: 2 * np.pi * r * exact.bubble(np.array([r, 0.0]), s)
                      * exact.bubble_laplacian(np.array([r, 0.0]), s), 0, 1,
                      epsabs=1e-13, epsrel=1e-13)
        assert exact.bubble_energy(s) == pytest.approx(val, rel=1e-10)


def test_manufactured_source_satisfies_the_equation():
    # u_t + (−Δ)^s u = f for u = e^{−t} w, pointwise inside the disk
    x = np.array([[0.1, -0.5, 0.3], [0.2, 0.4, -0.7]])
    for t in (0.0, 0.7):
        ut = -exact.heat_solution(x, t, S)
        lap = np.exp(-t) * exact.bubble_laplacian(x, S)
        np.testing.assert_allclose(ut + lap, exact.heat_source(x, t, S), rtol=1e-14)


def test_first_order_in_tau():
    st = heat_stepper(3)
    e = np.array([manufactured_error(st, n) for n in (2, 4, 8, 16, 32, 64)])
    eh = manufactured_error(st, 1024)
    assert np.all(np.diff(e) < 0) and e[-1] > eh                 # monotone, above floor
    np.testing.assert_allclose(e[0], 0.1502, rtol=2e-3)
    np.testing.assert_allclose(eh, 0.03421, rtol=2e-3)
    raw = np.log2(e[:-1] / e[1:])
    assert 0.75 < raw[0] < 1.05                                  # time error dominates
    assert np.all(np.diff(raw) < 0)                              # then the space floor
    et = np.sqrt(e ** 2 - eh ** 2)
    orders = np.log2(et[:-1] / et[1:])
    assert np.all((orders > 0.85) & (orders < 1.05)), orders


def test_convergence_in_h():
    e = np.array([manufactured_error(heat_stepper(level), 256) for level in (2, 3, 4)])
    np.testing.assert_allclose(e, [0.0730, 0.0343, 0.0144], rtol=1e-2)
    orders = np.log2(e[:-1] / e[1:])
    assert np.all((orders > 1.0) & (orders < 1.5)), orders
    assert orders[1] > orders[0]                                 # towards 1.5


def test_time_dependent_load_uses_the_time_mean():
    # f(x, t) = t: f̄_k = (t_{k−1} + t_k)/2 exactly (Gauss); compare with a
    # time-independent load of that value on one step
    st = heat_stepper(2)
    a = list(parabolic.time_steps(st, 0.0, times=[0.2, 0.5], f=lambda x, t: t + 0 * x[0]))
    b = list(parabolic.time_steps(st, 0.0, times=[0.2, 0.5], f=0.35))
    c = list(parabolic.time_steps(st, 0.0, times=[0.2, 0.5], f=lambda x: 0.35 + 0 * x[0]))
    np.testing.assert_allclose(a[1].u, b[1].u, rtol=1e-13, atol=1e-15)
    np.testing.assert_allclose(c[1].u, b[1].u, rtol=1e-13, atol=1e-15)
    assert np.max(np.abs(b[1].u)) > 0


def test_source_signature_convention():
    assert parabolic.Source(lambda x, t: x[0]).time_dependent
    assert not parabolic.Source(lambda x: x[0]).time_dependent
    assert not parabolic.Source(2.0).time_dependent
    assert parabolic.Source(np.sin, f_time=False).time_dependent is False
    with pytest.raises(ValueError, match="f_time"):
        parabolic.Source(lambda x, t, y: x)
    with pytest.raises(ValueError, match="f must be"):
        parabolic.Source("one")


# ------------------------------------------------------------ stepping basics


def test_initial_projection():
    st = heat_stepper(3)
    free = st.free
    ph1 = parabolic.initial_projection(st, 1.0)
    b = assembly.load_vector(st.mesh, 1.0)[free]
    np.testing.assert_allclose(st.M @ ph1[free], b, rtol=1e-12)  # (P_h u₀ − u₀, φ_i) = 0
    assert np.all(ph1[st.mesh.boundary_nodes()] == 0.0)
    # an element of V_h is its own projection (array input, all or free nodes)
    v = ph1 * st.mesh.p[0]
    np.testing.assert_allclose(parabolic.initial_projection(st, v), v, atol=1e-13)
    np.testing.assert_allclose(parabolic.initial_projection(st, v[free]), v, atol=1e-13)
    # the k = 0 record holds it
    first = next(parabolic.time_steps(st, 1.0, T=1.0, tau=0.5))
    assert first.k == 0 and first.t == 0.0 and first.lam is None
    np.testing.assert_allclose(first.u, ph1)


def test_uniform_grid_factorises_once():
    st = parabolic.Stepper(heat_stepper(2).disc)
    steps = parabolic.solve_parabolic(st, 1.0, T=1.0, tau=0.1)
    assert len(steps) == 11 and steps[-1].t == pytest.approx(1.0)
    assert st.n_factorisations == 1
    parabolic.solve_parabolic(st, 1.0, times=[0, 0.1, 0.3, 0.4, 0.6])  # τ = 0.1, 0.2
    assert st.n_factorisations == 2
    # T/τ not an integer: ⌈T/τ⌉ equal steps of length ≤ τ
    np.testing.assert_allclose(parabolic.time_grid(T=1.0, tau=0.3), [0, .25, .5, .75, 1])


@pytest.mark.parametrize("kwargs, match", [
    (dict(T=1.0, tau=0.0), "tau"), (dict(T=1.0, tau=-1.0), "tau"),
    (dict(T=1.0, tau=np.inf), "tau"), (dict(T=1.0, tau=np.nan), "tau"),
    (dict(T=0.0, tau=0.1), "T"), (dict(T=-1.0, tau=0.1), "T"),
    (dict(T=np.inf, tau=0.1), "T"), (dict(T=1.0), "tau"), (dict(), "times"),
    (dict(times=[0.0, 0.5, 0.5]), "strictly increasing"),
    (dict(times=[0.0, 1.0, 0.5]), "strictly increasing"),
    (dict(times=[0.0]), "at least 2"), (dict(times=[0.0, np.nan]), "finite"),
    (dict(times=[0, 1], T=1.0, tau=0.5), "either"),
    (dict(T=1.0, tau=0.5, solver="newton"), "solver"),
    (dict(T=1.0, tau=0.5, time_quadrature=0), "time_quadrature"),
])
def test_bad_time_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        list(parabolic.time_steps(heat_stepper(2), 1.0, **kwargs))


@pytest.mark.parametrize("u0, match", [
    (np.nan, "u0"), (np.inf, "u0"), (np.zeros(3), "u0 must be"),
    (lambda x: np.nan * x[0], "u0 must be finite"),
])
def test_bad_initial_values(u0, match):
    with pytest.raises(ValueError, match=match):
        list(parabolic.time_steps(heat_stepper(2), u0, T=1.0, tau=0.5))


def test_bad_problem_type():
    with pytest.raises(TypeError, match="MixedProblem"):
        parabolic.Stepper(np.eye(3))


# ------------------------------------------------------------ Lemma 4.5: stability


@pytest.mark.parametrize("tau", [1e-6, 1e-3, 1.0, 1e3])
def test_unconstrained_energy_stability(tau):
    """f = 0: ‖u^k‖_M and a(u^k, u^k) non-increasing; the DG(0) energy identity
    ½‖u^M‖² + Σ_k (½‖u^k − u^{k−1}‖² + τ a(u^k, u^k)) = ½‖P_h u₀‖² (Lemma 4.5 with
    equality for the discrete solution)."""
    st = heat_stepper(3)
    free, A, M = st.free, st.disc.A, st.M
    steps = parabolic.solve_parabolic(st, 1.0, T=12 * tau, tau=tau)
    u = [s.u[free] for s in steps]
    mass = np.array([v @ (M @ v) for v in u])
    energy = np.array([v @ (A @ v) for v in u])
    assert np.all(np.diff(mass) <= 1e-13 * mass[:-1])
    assert np.all(np.diff(energy) <= 1e-13 * energy[:-1])
    assert mass[-1] < mass[0]
    lhs = 0.5 * mass[-1] + sum(0.5 * (b - a) @ (M @ (b - a)) + tau * (b @ (A @ b))
                               for a, b in zip(u[:-1], u[1:]))
    assert lhs == pytest.approx(0.5 * mass[0], rel=1e-11)


def _check_step_kkt(st, step, prev, tol=1e-9):
    """λ ∈ Λ_H, feasibility Bᵀu − g ≥ 0 (obstacle), complementarity, relative to
    the scale of the step data (|B|ᵀ|u^{k−1}|, |B|ᵀ|u^k|, g)."""
    cs = st.cset
    u = step.u[st.free]
    y = cs.B.T @ u - cs.g
    lam = step.lam
    absB = abs(cs.B).T                              # no cancellation: round-off scale
    y_scale = max((absB @ np.abs(prev.u[st.free])).max(), (absB @ np.abs(u)).max(),
                  np.abs(cs.g).max(), 1e-300)
    lam_scale = max(np.max(np.abs(lam)), np.max(np.abs(cs.lower[np.isfinite(cs.lower)]),
                                                initial=0.0), 1e-300)
    if cs.kind in ("obstacle", "thin_obstacle"):
        assert np.all(lam <= 0)
        assert y.min() >= -tol * y_scale
        assert np.max(np.abs(lam * y)) <= tol * lam_scale * y_scale
    else:  # friction: |λ| ≤ F; where |λ| < F (stick) y = 0; λ_j y_j = F_j |y_j|
        F = cs.upper
        assert np.all(np.abs(lam) <= F + 1e-14)
        inner = np.abs(lam) < F * (1 - 1e-8)
        assert np.max(np.abs(y[inner]), initial=0.0) <= tol * y_scale
        np.testing.assert_allclose(lam * y, F * np.abs(y), rtol=0,
                                   atol=tol * lam_scale * y_scale)


@pytest.mark.parametrize("u0", [1.0, 2.0])
@pytest.mark.parametrize("tau", [1e-3, 0.05, 1.0])
def test_obstacle_stepping(u0, tau):
    """Obstacle χ = 1 − 4|x|², f = 0.  Theory with the constraint: testing with
    v = u^k gives the identity ½‖u^k‖² + ½‖u^k − u^{k−1}‖² + τ a(u^k,u^k) +
    τ λ^k·g = ½‖u^{k−1}‖² (λ·Bᵀu = λ·g by complementarity), and λ·g has no sign,
    so Lemma 4.5 does not bound ‖u^k‖ by ‖u^{k−1}‖ any more.  What holds: u^k
    minimises ‖v − u^{k−1}‖²_M/(2τ) + ½a(v,v) over K_h = {Bᵀv ≥ g}, so for feasible
    u^{k−1} the energy decreases: ½a(u^k,u^k) + ‖u^k − u^{k−1}‖²_M/(2τ) ≤ ½a(u^{k−1},u^{k−1})."""
    st = mixed_stepper("obstacle", 2)
    free, A, M, cs = st.free, st.disc.A, st.M, st.cset
    steps = parabolic.solve_parabolic(st, u0, T=10 * tau, tau=tau)
    assert (cs.B.T @ steps[0].u[free] - cs.g).min() > 0          # P_h u₀ ∈ K_h here
    for prev, cur in zip(steps[:-1], steps[1:]):
        _check_step_kkt(st, cur, prev)
        a, b = prev.u[free], cur.u[free]
        ident = (0.5 * b @ (M @ b) + 0.5 * (b - a) @ (M @ (b - a)) + tau * b @ (A @ b)
                 + tau * cur.lam @ cs.g)
        assert ident == pytest.approx(0.5 * a @ (M @ a), rel=1e-10)
        lhs = 0.5 * b @ (A @ b) + (b - a) @ (M @ (b - a)) / (2 * tau)
        assert lhs <= 0.5 * a @ (A @ a) * (1 + 1e-12)
    # for these data (u₀ ≥ χ) the mass norm still falls; contact happens
    mass = [s.u[free] @ (M @ s.u[free]) for s in steps]
    assert np.all(np.diff(mass) < 0)
    if tau == 1.0:
        assert np.count_nonzero(steps[-1].lam < 0) > 0


def test_obstacle_can_raise_the_mass_norm():
    """u₀ = 0 below χ: the obstacle pushes u up, ‖u^k‖_M grows from 0 — the
    λ·g term of the identity is what Lemma 4.5 alone does not see."""
    st = mixed_stepper("obstacle", 2)
    steps = parabolic.solve_parabolic(st, 0.0, T=0.3, tau=0.1)
    mass = [s.u[st.free] @ (st.M @ s.u[st.free]) for s in steps]
    assert mass[0] == 0.0 and mass[1] > 0 and np.any(steps[1].lam < 0)
    for prev, cur in zip(steps[:-1], steps[1:]):
        _check_step_kkt(st, cur, prev)


@pytest.mark.parametrize("tau", [1e-3, 0.05, 1.0])
def test_friction_stepping(tau):
    """Friction F = 0.1, u₀ of Example 5 (s = 0.6): λ^k·Bᵀu^k = j_H(u^k) =
    Σ F_j |(Bᵀu^k)_j| ≥ 0, so Lemma 4.5's bound survives: ‖u^k‖_M non-increasing;
    and the energy ½a + j_H decreases (u^k minimises the step functional)."""
    st = mixed_stepper("friction", 2, s=0.6)
    free, A, M, cs = st.free, st.disc.A, st.M, st.cset
    steps = parabolic.solve_parabolic(st, ex5_u0, T=10 * tau, tau=tau)

    def j(v):
        return np.sum(cs.upper * np.abs(cs.B.T @ v))

    for prev, cur in zip(steps[:-1], steps[1:]):
        _check_step_kkt(st, cur, prev)
        a, b = prev.u[free], cur.u[free]
        assert cur.lam @ (cs.B.T @ b) == pytest.approx(j(b), rel=1e-9, abs=1e-15)
        assert b @ (M @ b) <= a @ (M @ a) * (1 + 1e-12)
        lhs = 0.5 * b @ (A @ b) + j(b) + (b - a) @ (M @ (b - a)) / (2 * tau)
        assert lhs <= (0.5 * a @ (A @ a) + j(a)) * (1 + 1e-12)
    lam = steps[1].lam
    assert np.any(np.abs(lam) >= 0.1 * (1 - 1e-12))               # slip somewhere


@pytest.mark.parametrize("kind, u0", [("obstacle", 2.0), ("friction", ex5_u0)])
def test_pdas_and_uzawa_agree_per_step(kind, u0):
    st = mixed_stepper(kind, 2)
    n0 = st.n_factorisations
    kw = dict(T=0.6, tau=0.1)
    pd = parabolic.solve_parabolic(st, u0, solver="pdas", **kw)
    uz = parabolic.solve_parabolic(st, u0, solver="uzawa",
                                   solver_options=dict(tol=1e-12, maxiter=200_000), **kw)
    for prev, a, b in zip(pd[:-1], pd[1:], uz[1:]):
        scale = np.max(np.abs(a.u))
        assert np.max(np.abs(a.u - b.u)) <= 1e-8 * scale
        assert np.max(np.abs(a.lam - b.lam)) <= 1e-6 * np.max(np.abs(a.lam))
        _check_step_kkt(st, b, prev, tol=1e-7)
    assert st.n_factorisations <= n0 + 1                          # both reuse one τ


def test_inactive_obstacle_reproduces_the_heat_equation():
    st = mixed_stepper("obstacle", 2, far=True)
    heat = parabolic.Stepper(st.disc)
    kw = dict(T=1.0, tau=0.1, f=lambda x, t: np.cos(3 * t) * (1 + x[0]))
    a = parabolic.solve_parabolic(st, 1.0, **kw)
    b = parabolic.solve_parabolic(heat, 1.0, **kw)
    for x, y in zip(a[1:], b[1:]):
        assert np.all(x.lam == 0.0)
        np.testing.assert_allclose(x.u, y.u, rtol=0, atol=1e-13 * np.abs(y.u).max())


def test_thin_problems_step():
    coarse = meshes.disk_uniform(2)
    from fracfem import mixed
    edges = mixed.edges_on_curve(coarse, lambda x: np.abs(x[1]) < 1e-12)
    prob = vi.mixed_problem("thin_obstacle", coarse, 0.7, 0.0, edges=edges,
                            height=lambda x: 0.2 + 0 * x[0])
    st = parabolic.Stepper(prob)
    steps = parabolic.solve_parabolic(st, 1.0, T=0.5, tau=0.1)
    for prev, cur in zip(steps[:-1], steps[1:]):
        _check_step_kkt(st, cur, prev)
    assert np.any(steps[-1].lam < 0)


# ------------------------------------------------------------ space-time indicators


def test_indicators_of_the_manufactured_solution():
    """Disk_uniform(3), τ = 1/4, 1/8, 1/16 (measured): η = 0.390, 0.210, 0.117
    against errors 0.086, 0.054, 0.040; time part η²_time = 0.149, 0.0414,
    0.0110 (÷3.6, ÷3.8: η_time ~ τ, the first-order time error); space part
    0.00259, 0.00253, 0.00250; initial part 1.86e-4 for every τ."""
    st = heat_stepper(3)
    f = lambda x, t: exact.heat_source(x, t, S)  # noqa: E731
    u0 = lambda x: exact.bubble(x, S)  # noqa: E731
    res = []
    for n in (4, 8, 16):
        steps = parabolic.solve_parabolic(st, u0, T=1.0, tau=1 / n, f=f)
        ind = spacetime_estimators.space_time_indicators(st, steps, u0, f=f)
        res.append(ind)
        err = manufactured_error(st, n)
        assert 1.0 < ind["eta"] / err < 6.0
        assert ind["eta_parts"]["contact"] == 0.0
        assert ind["space_fine"].shape == (n, st.mesh.t.shape[1])
        np.testing.assert_allclose(ind["eta2_fine"], ind["initial_fine"]
                                   + ind["space_fine"].sum(0) + ind["time_fine"].sum(0)
                                   + ind["contact_fine"].sum(0), rtol=1e-12)
        np.testing.assert_allclose(ind["total"], ind["space"] + ind["time"]
                                   + ind["contact"], rtol=1e-12)
    np.testing.assert_allclose([r["eta"] for r in res], [0.390, 0.210, 0.117], rtol=1e-2)
    time_part = np.array([r["eta_parts"]["time"] for r in res])
    assert np.all((time_part[:-1] / time_part[1:] > 3.3)
                  & (time_part[:-1] / time_part[1:] < 4.3))
    space_part = np.array([r["eta_parts"]["space"] for r in res])
    np.testing.assert_allclose(space_part, space_part[0], rtol=0.05)
    assert res[0]["eta_parts"]["initial"] == res[2]["eta_parts"]["initial"] > 0


def test_initial_term():
    st = heat_stepper(3)
    ini = spacetime_estimators.initial_indicators(st, 1.0)
    ph1 = parabolic.initial_projection(st, 1.0)[st.free]
    area = assembly.load_vector(st.mesh, 1.0).sum()
    # ‖1 − P_h 1‖² = |Ω_h| − ‖P_h 1‖²_M since (1, P_h 1) = ‖P_h 1‖²_M
    assert ini["l2sq"] == pytest.approx(area - ph1 @ (st.M @ ph1), rel=1e-9)
    # the error of P_h 1 sits at the boundary (u₀ = 1 does not vanish there)
    boundary = np.zeros(st.mesh.p.shape[1], bool)
    boundary[st.mesh.boundary_nodes()] = True
    at_boundary = boundary[st.mesh.t].any(axis=0)
    assert ini["elements"][at_boundary].sum() > 0.5 * ini["l2sq"]
    # patch localisation: each node term is its patch sum
    split = spacetime_estimators.initial_indicators(st, 1.0, localisation="split")
    assert split["eta2_fine"].sum() == pytest.approx(split["total"], rel=1e-12)
    assert ini["total"] == pytest.approx(split["total"], rel=1e-12)
    # an element of V_h is its own projection: no initial term
    v = parabolic.initial_projection(st, lambda x: np.cos(x[0]))
    assert spacetime_estimators.initial_indicators(st, v)["total"] < 1e-25


def test_time_term_formula():
    st = heat_stepper(2)
    steps = parabolic.solve_parabolic(st, 1.0, T=0.2, tau=0.1)
    out = spacetime_estimators.step_indicators(st, steps[0].u, steps[1], localisation="split")
    du = steps[1].u - steps[0].u
    pts, wts, bary = __import__("fracfem.pointwise", fromlist=["x"]).quadrature_points(
        st.mesh, 4)
    el = np.einsum("tq,tq->t", wts, (du[st.mesh.t.T] @ bary.T) ** 2)   # ‖du‖²_{L²(T)}
    from fracfem.estimators import patch_diameters
    h = patch_diameters(st.mesh)
    w = np.zeros(st.mesh.p.shape[1])
    w[st.free] = 0.1 * h[st.free] ** (-2 * S)
    np.testing.assert_allclose(out["time"], w[st.mesh.t].sum(0) * el, rtol=1e-10)
    assert out["time"].sum() == pytest.approx(out["time_total"], rel=1e-12)


def test_space_part_for_huge_tau_is_the_elliptic_indicator():
    """τ = 1e8, f = 1: one step from u₀ = 0 is the elliptic obstacle problem, and
    the step's space part / τ is the residual part of estimators.estimate."""
    from fracfem import estimators

    st = mixed_stepper("obstacle", 2)
    steps = parabolic.solve_parabolic(st, 0.0, times=[0.0, 1e8], f=1.0)
    out = spacetime_estimators.step_indicators(st, steps[0].u, steps[1], f=1.0)
    est = estimators.estimate(st.problem, steps[1].u, steps[1].lam, f=1.0)
    np.testing.assert_allclose(out["space"] / 1e8, est["parts"]["residual_fine"],
                               rtol=1e-6, atol=1e-12 * est["parts"]["residual_fine"].max())
    assert out["n_contact_nodes"] == len(est["parts"]["contact_nodes"]) > 0
    # the obstacle's Lemma 5.21 term vanishes up to the solver's complementarity residual
    assert abs(out["contact_total"]) <= 1e-8 * out["space_total"]


def test_friction_indicators_and_contact_term():
    st = mixed_stepper("friction", 2, s=0.6)
    steps = parabolic.solve_parabolic(st, ex5_u0, T=0.3, tau=0.1)
    ind = spacetime_estimators.space_time_indicators(st, steps, ex5_u0)
    assert np.all(ind["contact_fine"] >= 0) and np.all(ind["time_fine"] >= 0)
    assert np.all(ind["space_fine"] >= 0) and ind["eta"] > 0
    assert np.all(ind["contact"] >= -1e-15)


@pytest.mark.parametrize("method", ["dense", "compressed"])
def test_batched_steps_equal_one_step_at_a_time(method):
    """steps_indicators evaluates (−Δ)ˢu^k of all its steps in one batched call;
    every indicator equals that of step_indicators step by step (friction,
    u₀ ≠ 0 in the first step, five steps, either evaluation path)."""
    st = mixed_stepper("friction", 3, s=0.6)
    steps = parabolic.solve_parabolic(st, ex5_u0, T=0.25, tau=0.05)
    batch = spacetime_estimators.steps_indicators(st, steps[0].u, steps[1:], method=method)
    assert len(batch) == 5
    for prev, cur, got in zip(steps[:-1], steps[1:], batch):
        one = spacetime_estimators.step_indicators(st, prev.u, cur, method=method)
        assert got["k"] == cur.k and one["space_total"] > 0
        for key in ("space", "time", "contact", "eta2_fine"):
            np.testing.assert_allclose(got[key], one[key], rtol=1e-12,
                                       atol=1e-13 * one[key].max(), err_msg=key)
        for key in ("space_total", "time_total", "contact_total", "total"):
            assert got[key] == pytest.approx(one[key], rel=1e-12, abs=1e-16), key
    with pytest.raises(ValueError, match="consecutive, got k = 1 followed by k = 3"):
        spacetime_estimators.steps_indicators(st, steps[0].u, [steps[1], steps[3]])
    assert spacetime_estimators.steps_indicators(st, steps[0].u, []) == []


def test_algorithm_c_same_with_any_estimate_batch(monkeypatch):
    """Algorithm C estimates the steps of a slab in batches of BATCH_STEPS; one
    step per batch (the plain order: solve a step, estimate it) gives the same
    passes: estimators, per-step rows, marks and snapshots."""
    def run():
        return spacetime_adaptive.algorithm_c(_ex4_problem(), meshes.disk_uniform(1), 2.0,
                                              T=1.0, theta=0.5, iterations=2,
                                              output_times=(0.0, 0.4, 1.0))
    batched = run()
    monkeypatch.setattr(spacetime_adaptive, "BATCH_STEPS", 1)
    single = run()
    assert max(sl.n_steps for r in batched for sl in r.slabs) > 1   # batches of several
    for a, b in zip(batched, single):
        assert a.eta == pytest.approx(b.eta, rel=1e-12) and a.dofs == b.dofs
        for key in ("t", "tau", "slab", "space", "time", "contact", "total", "n_active"):
            np.testing.assert_allclose(a.steps[key], b.steps[key], rtol=1e-11, atol=1e-300)
        for pa, pb in zip(a.prism_eta2, b.prism_eta2):
            np.testing.assert_allclose(pa, pb, rtol=1e-11)
        assert [m.tolist() for m in a.marked or []] == [m.tolist() for m in b.marked or []]
        assert sorted(a.outputs) == sorted(b.outputs) == [0.0, 0.4, 1.0]
        for t_out in a.outputs:
            np.testing.assert_array_equal(a.outputs[t_out]["u"], b.outputs[t_out]["u"])


def test_time_term_in_the_energy_norm():
    """time_anorm_total = τ a(u^k − u^{k−1}, u^k − u^{k−1}) with the problem's own
    stiffness (a diagnostic beside η, not part of it)."""
    st = mixed_stepper("friction", 2, s=0.6)
    steps = parabolic.solve_parabolic(st, ex5_u0, T=0.2, tau=0.1)
    out = spacetime_estimators.step_indicators(st, steps[0].u, steps[1])
    du = (steps[1].u - steps[0].u)[st.free]
    expected = 0.1 * du @ (np.asarray(st.disc.A) @ du)
    assert expected > 0
    assert out["time_anorm_total"] == pytest.approx(expected, rel=1e-12)
    assert out["total"] == pytest.approx(out["space_total"] + out["time_total"]
                                         + out["contact_total"], rel=1e-12)


def test_indicator_argument_checks():
    st = heat_stepper(2)
    steps = parabolic.solve_parabolic(st, 1.0, T=0.2, tau=0.1)
    with pytest.raises(ValueError, match="k >= 1"):
        spacetime_estimators.step_indicators(st, steps[0].u, steps[0])
    with pytest.raises(ValueError, match="localisation"):
        spacetime_estimators.step_indicators(st, steps[0].u, steps[1], localisation="nodes")
    with pytest.raises(ValueError, match="k = 0"):
        spacetime_estimators.space_time_indicators(st, steps[1:], 1.0)
    from fracfem import estimators, mixed
    with pytest.raises(ValueError, match="rh_extra"):
        estimators.residual_indicators(st.mesh, steps[1].u, S, 0.0, rh_extra=np.ones(3))
    coarse = meshes.disk_uniform(2)
    edges = mixed.edges_on_curve(coarse, lambda x: np.abs(x[1]) < 1e-12)
    thin = parabolic.Stepper(vi.mixed_problem("thin_friction", coarse, 0.7, 0.0,
                                              edges=edges, F=0.1))
    steps = parabolic.solve_parabolic(thin, 1.0, T=0.1, tau=0.1)
    with pytest.raises(ValueError, match="thin_friction"):
        spacetime_estimators.step_indicators(thin, steps[0].u, steps[1])


# ------------------------------------------------------------ Algorithm C


def _ex4_problem(counter=None):
    def make(coarse):
        if counter is not None:
            counter.append(coarse)
        return vi.mixed_problem("obstacle", coarse, S, 0.0, chi=chi)
    return make


@lru_cache(maxsize=None)
def _ex4_run():
    """Example 4 (ũ₀ = 2) from disk_uniform(1), θ = 1/2, 3 passes (measured:
    η = 2.380, 1.944, 1.532 with 75, 678, 2745 space-time DOFs)."""
    calls = []
    recs = spacetime_adaptive.algorithm_c(_ex4_problem(calls), meshes.disk_uniform(1), 2.0, T=1.0,
                                 theta=0.5, iterations=3,
                                 output_times=(0.0, 0.4, 0.8, 1.0))
    return recs, calls


def _ex4_reference():
    """(make, problem, pieces): a run with 40 uniform steps on the fine mesh of the last
    pass's last slab, a reference of one mesh for _ex4_run's passes."""
    make = _ex4_problem()
    finest = _ex4_run()[0][-1].slabs[-1].coarse
    reference = spacetime_adaptive.solve_slabs(
        make, [spacetime_adaptive.Slab(0.0, 1.0, finest, n_steps=40)], 2.0, T=1.0).pieces
    return make, make(finest), reference


def test_algorithm_c_reduces_the_estimator():
    recs, _ = _ex4_run()
    eta = np.array([r.eta for r in recs])
    assert np.all(np.diff(eta) < 0), eta
    np.testing.assert_allclose(eta, [2.380, 1.944, 1.532], rtol=1e-2)
    assert np.all(np.diff([r.dofs for r in recs]) > 0)
    for r in recs:
        assert r.dofs == sum(sl.n_steps * sl.n_free for sl in r.slabs)
        assert r.eta ** 2 == pytest.approx(sum(r.eta_parts.values()), rel=1e-12)
        assert len(r.steps["t"]) == sum(sl.n_steps for sl in r.slabs)
        np.testing.assert_allclose(np.sum(r.steps["total"]) + r.eta_parts["initial"],
                                   sum(t["total"] for t in r.slab_totals), rtol=1e-12)
        # prism indicators hold every fine-element contribution
        assert sum(p.sum() for p in r.prism_eta2) > 0
        assert set(r.timings) >= {"assemble", "solve", "estimate", "mark", "refine"}
    assert recs[-1].stop == "iterations" and recs[-1].marked is None


def test_pass_size_predicts_each_pass_before_it_is_solved(tmp_path):
    """pass_size of a pass's slabs is its dofs; of the slabs it hands on (also as a
    checkpoint writes and reads them), the next pass's dofs, steps and largest mesh."""
    recs, _ = _ex4_run()
    for r in recs:
        size = spacetime_adaptive.pass_size(r.slabs, S)
        assert size["spacetime_dofs"] == r.dofs
        assert size["steps"] == len(r.steps["t"]) and size["slabs"] == len(r.slabs)
        assert size["max_dofs_per_step"] == max(sl.n_free for sl in r.slabs)
    for r, nxt in zip(recs[:-1], recs[1:]):
        spacetime_adaptive.save_slabs(tmp_path / "c.npz", r.next_slabs)
        slabs, _ = spacetime_adaptive.load_slabs(tmp_path / "c.npz")
        for given in (r.next_slabs, slabs):
            size = spacetime_adaptive.pass_size(given, S)
            assert size["spacetime_dofs"] == nxt.dofs > r.dofs
            assert size["steps"] == sum(sl.n_steps for sl in nxt.slabs)
    with pytest.raises(ValueError, match="s=1.0"):
        spacetime_adaptive.pass_size(recs[0].slabs, 1.0)
    with pytest.raises(ValueError, match="non-empty list of Slab"):
        spacetime_adaptive.pass_size([], S)
    with pytest.raises(ValueError, match="c_tau"):
        spacetime_adaptive.pass_size(recs[0].slabs, S, c_tau=0.0)


def test_solve_slabs_repeats_a_pass_and_leaves_its_slabs_alone():
    recs, _ = _ex4_run()
    for r in recs:
        steps = [sl.n_steps for sl in r.slabs]
        again = spacetime_adaptive.solve_slabs(_ex4_problem(), r.slabs, 2.0, T=1.0)
        assert again.eta == pytest.approx(r.eta, rel=1e-12) and again.dofs == r.dofs
        np.testing.assert_allclose(again.steps["total"], r.steps["total"], rtol=1e-11)
        assert again.marked is None and len(again.pieces) == sum(steps)
        assert again.timings["total"] > 0
    last = recs[-1].slabs
    before = [dict(vars(sl)) for sl in last]
    twice = spacetime_adaptive.solve_slabs(_ex4_problem(), last, 2.0, T=1.0, time_refinement=2)
    assert [sl.n_steps for sl in twice.slabs] == [2 * b["n_steps"] for b in before]
    for sl, b in zip(last, before):                    # the caller's slabs as they were
        assert vars(sl).keys() == b.keys()
        assert all(vars(sl)[k] is v or vars(sl)[k] == v for k, v in b.items())


def test_solve_slabs_time_refinement_converges_at_first_order():
    """Backward Euler on a fixed space mesh: the distance d_m to a run with 64× the
    steps halves as τ halves (measured d_m/d_2m = 1.71, 1.84, 1.96 for m = 1, 2, 4;
    2.03, 2.07, 2.14 if d_m ∝ 1/m − 1/64), and the time indicator's square ∝ τ²
    (ratios 3.3, 3.6, 3.8 → 4)."""
    slabs = _ex4_run()[0][0].slabs                         # one slab on one mesh
    run = {m: spacetime_adaptive.solve_slabs(_ex4_problem(), slabs, 2.0, T=1.0,
                                             time_refinement=m) for m in (1, 2, 4, 8, 64)}
    assert [run[m].dofs for m in (1, 2, 64)] == [run[1].dofs * m for m in (1, 2, 64)]
    prob = _ex4_problem()(slabs[0].coarse)
    ref = SpaceTimeReference(run[64].pieces, prob.disc.A, prob.disc.free)
    d = np.array([ref.distance(run[m].pieces) for m in (1, 2, 4, 8)])
    halving = d[:-1] / d[1:]
    assert np.all(halving > 1.6) and np.all(halving < 2.2) and np.all(np.diff(halving) > 0)
    time2 = np.array([run[m].eta_parts["time"] for m in (1, 2, 4, 8)])
    quarter = time2[:-1] / time2[1:]
    assert np.all(quarter > 3.0) and np.all(quarter < 4.2) and np.all(np.diff(quarter) > 0)


def test_space_time_reference_products_with_a_basis_match_one_product_per_piece():
    """SpaceTimeReference applies the reference's matrix to a basis of each mesh's
    pieces (singular values above RANK_RTOL of the largest): the distances of the
    passes of Algorithm C, as solved and with 16 times the time steps, agree with
    every direction kept (rank_rtol=0, at most one product per piece) to 1e-9, with
    fewer products (measured: relative differences ≤ 2e-15; with 16 times the steps
    10, 22, 34 products for 48, 96, 144 pieces)."""
    recs = _ex4_run()[0]
    make, prob, reference = _ex4_reference()
    runs = {m: [spacetime_adaptive.solve_slabs(make, rec.slabs, 2.0, T=1.0,
                                               time_refinement=m).pieces for rec in recs]
            for m in (1, 16)}
    exact = SpaceTimeReference(reference, prob.disc.A, prob.disc.free, rank_rtol=0)
    basis = SpaceTimeReference(reference, prob.disc.A, prob.disc.free)
    for ref in (exact, basis):      # the reference's own products, kept from here on
        assert ref.distance(reference) < 1e-12 * ref.distance(runs[1][0])
    assert exact.matvecs == 2 * len(reference) + len(runs[1][0])
    for m, passes in runs.items():
        for pieces in passes:
            before = (exact.matvecs, basis.matvecs)
            d_exact, d_basis = exact.distance(pieces), basis.distance(pieces)
            assert d_basis == pytest.approx(d_exact, rel=1e-9)
            used = basis.matvecs - before[1]
            assert used <= exact.matvecs - before[0] <= len(pieces)
            if m == 16:
                assert 3 * used < len(pieces), (used, len(pieces))
    with pytest.raises(ValueError, match="rank_rtol"):
        SpaceTimeReference(reference, prob.disc.A, prob.disc.free, rank_rtol=1.0)


def test_slabwise_reference_measures_each_slab_in_its_own_mesh():
    """SlabwiseReference, an Algorithm C pass as the reference (one mesh per slab):
    on one mesh throughout it is SpaceTimeReference, also when that mesh is split into
    two slabs at a time inside u's steps; a pass shifted by c·w (w a nodal vector of
    each mesh) is at c (Σ_j |slab j| wᵀA_j w)^{1/2}; the reference is at 0 from itself."""
    recs = _ex4_run()[0]
    make, prob, reference = _ex4_reference()
    passes = [spacetime_adaptive.solve_slabs(make, rec.slabs, 2.0, T=1.0).pieces
              for rec in recs]
    one = SpaceTimeReference(reference, prob.disc.A, prob.disc.free)
    calls, ops = [], {}

    def operator(mesh):                                      # a piece's (fine) mesh
        calls.append(mesh)
        if id(mesh) not in ops:
            disc = laplace.discretise(mesh, S, 0.0)
            ops[id(mesh)] = disc.A, np.asarray(disc.free)
        return ops[id(mesh)]

    same = SlabwiseReference(reference, lambda m: (prob.disc.A, prob.disc.free))
    fine = reference[0][2]
    twin = meshes.MeshTri(fine.p.copy(), fine.t.copy())       # the same mesh, another object
    split = SlabwiseReference([pc if k < 13 else (pc[0], pc[1], twin, pc[3])
                               for k, pc in enumerate(reference)], operator)
    assert len(split.slabs) == 2                              # t = 13/40: inside u's steps
    for pieces in passes:
        d = one.distance(pieces)
        assert same.distance(pieces) == pytest.approx(d, rel=1e-12)
        assert split.distance(pieces) == pytest.approx(d, rel=1e-10)
    # the last pass as the reference: its slabs' meshes differ
    last = passes[-1]
    calls.clear()
    passwise = SlabwiseReference(last, operator)
    distinct = list({id(pc[2]): pc[2] for pc in last}.values())
    # slabs on one mesh object in a row are measured as one (here 3 slabs, 2 meshes)
    assert len(recs[-1].slabs) >= len(passwise.slabs) >= len(distinct) > 1
    d = passwise.distances([last, passes[0]])
    assert d[0] < 1e-12 * d[1] and d[1] == pytest.approx(passwise.distance(passes[0]))
    # one operator per slab and measurement, on that slab's mesh
    assert [id(m) for m in calls] == [id(sl[0][2]) for sl in passwise.slabs] * 2
    rng = np.random.default_rng(4)
    w = {}
    for m in distinct:
        A, free = ops[id(m)]
        w[id(m)] = np.zeros(m.p.shape[1])
        w[id(m)][free] = rng.standard_normal(len(free))
    expected = sum((t1 - t0) * w[id(m)][ops[id(m)][1]] @ (
        ops[id(m)][0] @ w[id(m)][ops[id(m)][1]]) for t0, t1, m, _ in last)
    shifted = [(t0, t1, m, u + 0.3 * w[id(m)]) for t0, t1, m, u in last]
    assert passwise.distance(shifted) == pytest.approx(0.3 * np.sqrt(expected), rel=1e-10)
    with pytest.raises(ValueError, match="time intervals differ"):
        passwise.distance([(2 * t0, 2 * t1, m, u) for t0, t1, m, u in last])   # on [0, 2]


def test_solve_slabs_rejects_what_is_not_a_solved_pass():
    slabs = _ex4_run()[0][-1].slabs
    make = _ex4_problem()
    with pytest.raises(ValueError, match="time_refinement=0"):
        spacetime_adaptive.solve_slabs(make, slabs, 2.0, T=1.0, time_refinement=0)
    with pytest.raises(ValueError, match="cover"):
        spacetime_adaptive.solve_slabs(make, slabs[:-1], 2.0, T=1.0)
    with pytest.raises(ValueError, match="cover"):
        spacetime_adaptive.solve_slabs(make, slabs, 2.0, T=2.0)
    with pytest.raises(ValueError, match="n_steps"):
        spacetime_adaptive.solve_slabs(make, [spacetime_adaptive.Slab(0.0, 1.0, slabs[0].coarse)],
                                       2.0, T=1.0)
    with pytest.raises(ValueError, match="non-empty list of Slab"):
        spacetime_adaptive.solve_slabs(make, [], 2.0, T=1.0)
    with pytest.raises(ValueError, match="cover"):
        spacetime_adaptive.solve_slabs(
            make, [spacetime_adaptive.Slab(0.0, float("nan"), slabs[0].coarse, n_steps=2),
                   spacetime_adaptive.Slab(float("nan"), 1.0, slabs[0].coarse, n_steps=2)],
            2.0, T=1.0)


def test_algorithm_c_slabs_cover_the_interval_and_refine_locally():
    recs, calls = _ex4_run()
    for r in recs:
        a = np.array([sl.a for sl in r.slabs])
        b = np.array([sl.b for sl in r.slabs])
        assert a[0] == 0.0 and b[-1] == 1.0 and np.all(a[1:] == b[:-1]) and np.all(b > a)
        np.testing.assert_allclose(np.diff(r.steps["t"][r.steps["slab"] == 0]),
                                   r.slabs[0].tau)
        for sl in r.slabs:                      # τ ≤ c h^{2s}, c = 1
            assert sl.tau <= sl.h_max ** (2 * S) * (1 + 1e-12)
            assert sl.fine.t.shape[1] == 4 * sl.coarse.t.shape[1]
    for prev, cur in zip(recs[:-1], recs[1:]):
        assert len(cur.slabs) == len(prev.slabs) + len(prev.bisected)
    # the first pass marks all 16 elements of disk_uniform(1); the second is local
    n_old = [sl.coarse.t.shape[1] for sl in recs[1].slabs]
    assert 0 < sum(m.size for m in recs[1].marked) < sum(n_old)
    # iteration 1 → 2: slab 0 bisected, slab 1 unmarked keeps its mesh object
    r1, r2 = recs[1], recs[2]
    assert r1.bisected == [0] and r1.marked[1].size == 0
    assert r2.slabs[2].coarse is r1.slabs[1].coarse
    n = r1.slabs[0].coarse.t.shape[1]
    assert n < r2.slabs[0].coarse.t.shape[1] < 4 * n
    # bisected halves keep the number of steps: τ halves
    assert r2.slabs[0].tau == pytest.approx(0.5 * r1.slabs[0].tau)
    # assembled once per distinct mesh per pass, unchanged meshes reused
    assert len(calls) == len({id(c) for c in calls})


def test_algorithm_c_continued_from_a_saved_pass_is_the_uninterrupted_run(tmp_path):
    """A run stopped after pass 1 and continued from its saved next mesh (save_slabs,
    load_slabs) solves pass 2 as the run that went on: the same slabs and steps, and
    indicators and states the same up to round-off (its cache of assembled problems
    starts empty: a mesh assembled again, as with any cache budget; two uninterrupted
    runs agree bit for bit)."""
    recs, _ = _ex4_run()
    r1, r2 = recs[1], recs[2]
    assert recs[-1].next_slabs is None and r1.bisected == [0]
    path = tmp_path / "pass2.npz"
    spacetime_adaptive.save_slabs(path, r1.next_slabs, iteration=np.array(2))
    slabs, extra = spacetime_adaptive.load_slabs(path)
    assert int(extra["iteration"]) == 2 and list(extra) == ["iteration"]
    # the two halves of the bisected slab share one mesh object again
    assert len(slabs) == 3 and slabs[0].coarse is slabs[1].coarse
    assert slabs[2].coarse is not slabs[0].coarse
    for got, want in zip(slabs, r1.next_slabs):
        assert (got.a, got.b, got.n_steps) == (want.a, want.b, want.n_steps)
        np.testing.assert_array_equal(got.coarse.p, want.coarse.p)
        np.testing.assert_array_equal(got.coarse.t, want.coarse.t)
    (cont,) = spacetime_adaptive.algorithm_c(
        _ex4_problem(), None, 2.0, T=1.0, theta=0.5, iterations=3, slabs=slabs,
        first_iteration=2, output_times=(0.0, 0.4, 0.8, 1.0))
    assert cont.iteration == 2 and cont.stop == "iterations" and cont.dofs == r2.dofs
    assert cont.eta == pytest.approx(r2.eta, rel=1e-12)
    for key in ("space", "time", "initial"):
        assert cont.eta_parts[key] == pytest.approx(r2.eta_parts[key], rel=1e-12), key
    assert [(sl.a, sl.b, sl.n_steps, sl.n_free) for sl in cont.slabs] == \
        [(sl.a, sl.b, sl.n_steps, sl.n_free) for sl in r2.slabs]
    for key in ("t", "tau", "slab", "n_active"):
        np.testing.assert_array_equal(cont.steps[key], r2.steps[key], err_msg=key)
    for key in ("space", "time", "total"):
        np.testing.assert_allclose(cont.steps[key], r2.steps[key], rtol=1e-11, err_msg=key)
    for a, b in zip(cont.prism_eta2, r2.prism_eta2):
        np.testing.assert_allclose(a, b, rtol=1e-11, atol=1e-14 * b.max())
    for t_out in r2.outputs:
        np.testing.assert_allclose(cont.outputs[t_out]["u"], r2.outputs[t_out]["u"],
                                   rtol=0, atol=1e-12)
    np.testing.assert_allclose(cont.final["lam"], r2.final["lam"], rtol=0, atol=1e-12)


@pytest.mark.parametrize("kwargs, match", [
    (dict(first_iteration=3), r"first_iteration=3 must be an integer in \[0, iterations\)"),
    (dict(first_iteration=-1), "first_iteration=-1"),
    (dict(first_iteration=1), "needs the slabs of that pass"),
    (dict(slabs=[]), "non-empty list of Slab"),
    (dict(slabs="abc"), "non-empty list of Slab"),
])
def test_algorithm_c_continued_bad_arguments(kwargs, match):
    with pytest.raises(ValueError, match=match):
        spacetime_adaptive.algorithm_c(_ex4_problem(), meshes.disk_uniform(1), 2.0, T=1.0,
                                       theta=0.5, iterations=3, **kwargs)
    coarse = meshes.disk_uniform(1)
    half = [spacetime_adaptive.Slab(0.0, 0.5, coarse, n_steps=2)]
    with pytest.raises(ValueError, match=r"cover \[0, T\]"):
        spacetime_adaptive.algorithm_c(_ex4_problem(), None, 2.0, T=1.0, theta=0.5,
                                       iterations=3, slabs=half, first_iteration=1)
    with pytest.raises(ValueError, match="reserved"):
        spacetime_adaptive.save_slabs("unused.npz", half, slab_x=np.ones(2))

def test_algorithm_c_outputs():
    recs, _ = _ex4_run()
    r = recs[-1]
    assert sorted(r.outputs) == [0.0, 0.4, 0.8, 1.0]
    o0 = r.outputs[0.0]
    assert o0["lam"] is None and o0["t_step"] == 0.0
    st = parabolic.Stepper(vi.mixed_problem("obstacle", o0["coarse"], S, 0.0, chi=chi))
    np.testing.assert_allclose(o0["u"], parabolic.initial_projection(st, 2.0), rtol=1e-12)
    for t in (0.4, 0.8, 1.0):
        o = r.outputs[t]
        sl = r.slabs[o["slab"]]
        assert o["t_step"] - sl.tau < t <= o["t_step"] + 1e-12
        assert o["u"].shape == (o["mesh"].p.shape[1],)
        assert o["lam"].shape == (o["coarse"].t.shape[1],) and np.all(o["lam"] <= 0)
    assert r.final["t_step"] == pytest.approx(1.0)
    np.testing.assert_allclose(r.final["u"], r.outputs[1.0]["u"])
    # ũ₀ = 2 reaches the obstacle (χ = 1 − 4|x|²) only after some time
    assert 0.3 < r.first_contact_time < 1.0
    assert np.count_nonzero(r.final["lam"] < 0) > 0


@pytest.mark.parametrize("kwargs, match", [
    (dict(theta=0.0), "θ"), (dict(theta=1.0), "θ"), (dict(theta=np.nan), "θ"),
    (dict(theta="0.5"), "θ"), (dict(iterations=0), "iterations"),
    (dict(T=0.0), "T"), (dict(c_tau=-1.0), "c_tau"), (dict(marking="max"), "marking"),
    (dict(output_times=(0.5, 2.0)), "output_times"), (dict(solver="cg"), "solver"),
    (dict(bisect_fraction=0.0), "bisect_fraction"),
])
def test_algorithm_c_bad_arguments(kwargs, match):
    args = dict(T=1.0, theta=0.5, iterations=2)
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        spacetime_adaptive.algorithm_c(_ex4_problem(), meshes.disk_uniform(1), 2.0, **args)
    with pytest.raises(ValueError, match="u0"):
        spacetime_adaptive.algorithm_c(_ex4_problem(), meshes.disk_uniform(1), np.ones(3),
                              T=1.0, theta=0.5, iterations=1)


def test_algorithm_c_friction_and_doerfler():
    make = lambda c: vi.mixed_problem("friction", c, 0.6, 0.0, F=0.1)  # noqa: E731
    recs = spacetime_adaptive.algorithm_c(make, meshes.disk_uniform(1), ex5_u0, T=1.0, theta=0.5,
                                 iterations=2, marking="doerfler", output_times=(0.2,))
    m = recs[0].marked
    eta2 = np.concatenate(recs[0].prism_eta2)
    chosen = np.concatenate([p[i] for p, i in zip(recs[0].prism_eta2, m)])
    assert chosen.sum() >= 0.5 * eta2.sum() * (1 - 1e-12)       # Dörfler bulk
    assert recs[1].eta < recs[0].eta
    assert recs[0].first_contact_time is None
    # Example 5 comes to rest: slip and stick coexist at t = 0.2, every coarse element
    # sticks (λ strictly inside [−F, F]) by T, and each snapshot satisfies the friction
    # complementarity: |λ_j| ≤ F_j, mean of u_h zero on sticking elements, and
    # λ_j ⟨μ_j, u_h⟩ = F_j |⟨μ_j, u_h⟩| (slip against the sign of the motion)
    n_act = recs[1].steps["n_active"]
    for snap, stick in ((recs[1].outputs[0.2], "some"), (recs[1].final, "all")):
        prob = make(snap["coarse"])
        F = prob.cset.upper
        lam, y = snap["lam"], prob.cset.B.T @ snap["u"][prob.disc.free]
        sticks = np.abs(lam) < F * (1 - 1e-9)
        assert np.all(np.abs(lam) <= F * (1 + 1e-12))
        assert np.abs(y[sticks]).max(initial=0.0) <= 1e-12 * np.abs(y).max(initial=1e-300) + 1e-15
        np.testing.assert_allclose(lam * y, F * np.abs(y), rtol=0,
                                   atol=1e-10 * np.max(F * np.abs(y)) + 1e-18)
        k = int(np.searchsorted(recs[1].steps["t"], snap["t_step"] - 1e-12))
        assert n_act[k] == np.count_nonzero(sticks)
        if stick == "some":
            assert 0 < sticks.sum() < len(lam) and np.abs(y).max() > 1e-4
        else:
            assert sticks.all()
    with pytest.raises(TypeError, match="MixedProblem"):
        spacetime_adaptive.algorithm_c(lambda c: laplace.discretise(meshes.refine_disk(c), S),
                              meshes.disk_uniform(1), 1.0, T=1.0, theta=0.5, iterations=1)


def test_algorithm_c_same_with_any_cache_budget():
    """A budget of one byte keeps only the stepper in use: meshes met again are
    assembled again, and the passes are the same as with every mesh cached."""
    built = []

    def run(**kw):
        make = _ex4_problem()

        def counted(coarse):
            built.append(id(coarse))
            return make(coarse)
        return spacetime_adaptive.algorithm_c(counted, meshes.disk_uniform(1), 2.0, T=1.0,
                                              theta=0.5, iterations=3, **kw)
    cached = run()
    n_cached = len(built)
    built.clear()
    tight = run(cache_bytes=1)
    assert len(built) > n_cached          # the tight budget assembled meshes again
    for a, b in zip(cached, tight):       # the same up to round-off
        assert a.eta == pytest.approx(b.eta, rel=1e-12) and a.dofs == b.dofs
        np.testing.assert_allclose(a.steps["total"], b.steps["total"], rtol=1e-11)
    with pytest.raises(ValueError, match="cache_bytes='lots'"):
        run(cache_bytes="lots")


def test_algorithm_c_cache_stays_within_budget_as_steppers_grow(monkeypatch):
    """Each slab's steps add factorisations to its stepper after it was cached;
    the budget holds when the next slab asks for its stepper, not only after
    insertions (at most one stepper, the one in use, may exceed it alone)."""
    seen = []
    stepper = spacetime_adaptive._stepper

    def watched(slab, cache, make_problem, cache_bytes, *where):
        held = sum(st.nbytes for _, st in cache.values())
        seen.append((held, len(cache)))
        return stepper(slab, cache, make_problem, cache_bytes, *where)
    monkeypatch.setattr(spacetime_adaptive, "_stepper", watched)
    # measured: pass 1 caches a 0.36 MB stepper and inserts one of 1.4 MB that its
    # steps grow to 4.3 MB; the two together exceed 3 MB at pass 2's first slab
    budget = 3_000_000
    spacetime_adaptive.algorithm_c(_ex4_problem(), meshes.disk_uniform(1), 2.0, T=1.0,
                                   theta=0.5, iterations=3, cache_bytes=budget)
    assert any(held > budget for held, _ in seen)       # a stepper alone over budget
    assert all(held <= budget or n == 1 for held, n in seen)


def test_stepper_nbytes_counts_what_it_holds():
    st = parabolic.Stepper(mixed_stepper("friction", 2, s=0.6).problem)   # nothing cached
    n = st.n_free
    before = st.nbytes
    assert before >= 8 * n * n               # the dense stiffness matrix
    st.operator(0.1)                          # + Cholesky factor and dense mass
    assert st.nbytes - before >= 2 * 8 * n * n


def test_stepper_cache_keeps_what_the_next_sweep_needs_first():
    """Sweeps visit the slabs in time order: with room for k of n meshes, the
    cache drops the one needed furthest ahead, so a repeated sweep assembles at
    least n − k meshes again (a sweep starts with at most k of its n meshes at
    hand) but fewer than n, where dropping the least recently used would
    assemble all n every time."""
    from collections import OrderedDict

    class Held:                        # stands for a Stepper: only its size matters
        nbytes = 1

    def sweeps(order, budget, passes=8):
        cache, built = OrderedDict(), []
        for _ in range(passes):
            built.append(0)
            for j, key in enumerate(order):
                if key in cache:
                    cache.move_to_end(key)
                else:
                    cache[key] = (None, Held())
                    built[-1] += 1
                    spacetime_adaptive._trim(cache, budget, order, j)
                spacetime_adaptive._trim(cache, budget, order, j)
                assert key in cache and len(cache) <= max(budget, 1)
        return built

    for k in (2, 3, 4):
        built = sweeps(list("abcde"), budget=k)
        assert built[0] == 5 and all(5 - k <= b < 5 for b in built[1:]), (k, built)
    assert sweeps(list("abcde"), budget=3)[:3] == [5, 2, 2]
    assert sweeps(list("abcde"), budget=5) == [5] + [0] * 7
    assert sweeps(list("abcde"), budget=1) == [5] * 8     # only the one in use
    # slabs bisected in time share a mesh: a repeated key costs nothing more
    assert sweeps(list("aabbcdde"), budget=3) == sweeps(list("abcde"), budget=3)
    # a mesh of no slab of the sweep (refined away) goes before any other
    cache = OrderedDict((k, (None, Held())) for k in "xab")
    spacetime_adaptive._trim(cache, 2, list("ab"), 1)
    assert list(cache) == ["a", "b"]
    # the one in use stays even alone over the budget
    cache = OrderedDict(a=(None, Held()))
    spacetime_adaptive._trim(cache, 0, ["a"], 0)
    assert list(cache) == ["a"]
