"""Discrete energy with j_H and the KKT report of the mixed problems (fracfem.kkt)."""
import numpy as np
import pytest
from skfem import Basis, ElementTriP1, Functional

import fracfem as ff
from fracfem import examples, kkt, vi


def element_integrals(mesh, u):
    """∫_T u_h per triangle T of mesh, by scikit-fem quadrature."""
    basis = Basis(mesh, ElementTriP1())

    @Functional
    def value(w):
        return w["u"]

    return value.elemental(basis, u=basis.interpolate(u))


def containing_triangle(coarse, x):
    """Index of the coarse triangle containing each point of x (barycentric test)."""
    p, t = coarse.p, coarse.t
    out = np.full(x.shape[1], -1)
    for j in range(t.shape[1]):
        a, b, c = p[:, t[0, j]], p[:, t[1, j]], p[:, t[2, j]]
        M = np.column_stack([b - a, c - a])
        lam = np.linalg.solve(M, x - a[:, None])
        inside = (lam[0] >= -1e-12) & (lam[1] >= -1e-12) & (lam.sum(axis=0) <= 1 + 1e-12)
        out[inside] = j
    return out


@pytest.fixture(scope="module")
def friction():
    prob = ff.Example3(s=0.6, a=1.0, b=3.0, F=0.3).problem(ff.disk_uniform(1))
    rng = np.random.default_rng(1)
    u = prob.disc.extend(rng.standard_normal(len(prob.disc.free)))
    return prob, u


def test_energy_with_jH_equals_its_definition(friction):
    # ½a(u,u) − (f,u) + Σ_j F |∫_{T_j} u|, with the integrals over T_j computed on the
    # fine mesh by quadrature and collected by point location, not through B
    prob, u = friction
    fine, coarse = prob.fine, prob.coarse
    A = ff.stiffness_matrix(fine, 0.6)[np.ix_(prob.disc.free, prob.disc.free)]
    f_u = float(ff.load_vector(fine, examples.radial_load(1.0, 3.0)) @ u)
    per_fine = element_integrals(fine, u)
    parent = containing_triangle(coarse, fine.p[:, fine.t].mean(axis=1))
    assert np.all(parent >= 0)
    per_coarse = np.bincount(parent, weights=per_fine, minlength=coarse.t.shape[1])
    uf = u[prob.disc.free]
    expected = 0.5 * uf @ A @ uf - f_u + 0.3 * np.abs(per_coarse).sum()
    assert kkt.discrete_energy(prob, u) == pytest.approx(expected, rel=1e-12)
    assert kkt.friction_functional(prob, u) == pytest.approx(0.3 * np.abs(per_coarse).sum(),
                                                             rel=1e-12)


def test_friction_solution_minimises_the_energy(friction):
    # the discrete friction problem is min_u ½a(u,u) − (f,u) + j_H(u), unconstrained
    prob, _ = friction
    u, lam, _ = vi.solve(prob, "pdas", tol=1e-12)
    E = kkt.discrete_energy(prob, u)
    rng = np.random.default_rng(2)
    for _ in range(10):
        v = prob.disc.extend(rng.standard_normal(len(prob.disc.free)))
        for eps in (1e-2, 1e-4):
            assert kkt.discrete_energy(prob, u + eps * v) > E - 1e-13


def test_energy_of_example1_decreases_towards_the_exact_energy():
    ex = ff.Example1(0.5)
    energies = []
    for level in (1, 2):
        disc = ex.problem(ff.disk_uniform(level))
        u = disc.extend(ff.solve_laplace(disc))
        energies.append(kkt.discrete_energy(disc, u))
        # Galerkin: E(u_h) = −½(f, u_h)
        assert energies[-1] == pytest.approx(-0.5 * float(disc.b @ u[disc.free]), rel=1e-12)
    assert ex.exact_energy < energies[1] < energies[0]


def test_obstacle_energy_has_no_jH():
    prob = ff.Example2().problem(ff.disk_uniform(1))
    u = prob.disc.extend(np.linspace(0, 1, len(prob.disc.free)))
    assert kkt.discrete_energy(prob, u) == ff.energy(prob.disc.A, prob.disc.b,
                                                     u[prob.disc.free])
    with pytest.raises(ValueError, match="friction"):
        kkt.friction_functional(prob, u)


def test_kkt_report_of_an_exact_obstacle_solution_is_zero():
    # a KKT point by construction: pick u, λ ≤ 0 and y ≥ 0 with λ·y = 0, then set
    # g = Bᵀu − y and b = Au + Bλ
    prob = ff.Example2().problem(ff.disk_uniform(1))
    rng = np.random.default_rng(3)
    m = prob.cset.n_multipliers
    uf = rng.standard_normal(len(prob.disc.free))
    contact = np.arange(m) % 3 == 0
    lam = np.where(contact, -rng.uniform(0.5, 1.0, m), 0.0)
    y = np.where(contact, 0.0, rng.uniform(0.1, 1.0, m))
    prob.cset.g = prob.cset.B.T @ uf - y
    prob.disc.b = prob.disc.A @ uf + prob.cset.B @ lam
    rep = kkt.kkt_report(prob, prob.disc.extend(uf), lam)
    assert rep["lambda_in_set"] and rep["contact"] == contact.sum()
    assert np.array_equal(kkt.contact_set(lam), contact)
    assert not kkt.contact_set(np.zeros(m)).any()
    with pytest.raises(ValueError, match="one value per multiplier"):
        kkt.contact_set(lam[None, :])
    assert rep["max_complementarity"] == 0.0
    assert abs(rep["min_gap"]) < 1e-14
    assert rep["max_stationarity_residual"] < 1e-12 * np.abs(prob.disc.b).max()
    # the same pair with one violated condition each
    bad = lam.copy()
    bad[np.flatnonzero(~contact)[0]] = -0.5    # λ < 0 where the gap is open
    rep = kkt.kkt_report(prob, prob.disc.extend(uf), bad)
    assert rep["max_complementarity"] > 0.01 and rep["max_stationarity_residual"] > 0.01
    rep = kkt.kkt_report(prob, prob.disc.extend(uf), -lam + 0.1)
    assert not rep["lambda_in_set"]


def test_kkt_report_of_a_pdas_friction_solution_is_zero(friction):
    prob, _ = friction
    u, lam, _ = vi.solve(prob, "pdas", tol=1e-12)
    rep = kkt.kkt_report(prob, u, lam)
    # f = 1 − 3|x|² changes sign: slip of both signs and stick
    assert rep["slip_plus"] > 0 and rep["slip_minus"] > 0 and rep["stick"] > 0
    assert rep["slip_plus"] + rep["slip_minus"] + rep["stick"] == rep["multipliers"]
    assert rep["lambda_in_set"] and rep["max_friction_excess"] <= 1e-15
    scale = np.abs(prob.cset.B.T @ u[prob.disc.free]).max()
    assert rep["max_stick_residual"] < 1e-12 * scale
    assert rep["max_stationarity_residual"] < 1e-12 * np.abs(prob.disc.b).max()
    # moving u off the solution opens the stick set and breaks stationarity
    v = prob.disc.extend(np.ones(len(prob.disc.free)))
    rep = kkt.kkt_report(prob, u + 1e-3 * v, lam)
    assert rep["max_stick_residual"] > 1e-6 and rep["max_stationarity_residual"] > 1e-6


def test_kkt_report_refuses_wrong_shapes(friction):
    prob, u = friction
    with pytest.raises(ValueError, match="u must"):
        kkt.kkt_report(prob, u[prob.disc.free], np.zeros(prob.cset.n_multipliers))
    with pytest.raises(ValueError, match="lam"):
        kkt.kkt_report(prob, u, np.zeros(3))
