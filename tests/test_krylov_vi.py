"""PDAS and Uzawa for a stiffness operator (fracfem.krylov_vi) against the dense PDAS.

Two operators: the stand-in dense SPD matrix of tests/test_solvers.py seen only
through products (so the solvers alone are compared, at solver tolerance), and
the compressed fractional stiffness operator of vi.mixed_problem (then the
compression error, tol = 1e-10, enters as well).
"""
import numpy as np
import pytest
import scipy.linalg as la
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from test_solvers import interior_B, load, odd, one, segment_B, standin

import fracfem as ff
from fracfem import examples, krylov_vi, solvers, vi
from fracfem.mixed import (Friction, ThinFriction, ThinObstacle, coupling_matrix,
                           friction_bound, obstacle_from_function)
from fracfem.solvers import ConvergenceError

AGREE = 1e-8        # operator vs dense path, same matrix: relative max norm
COMPRESSED = 1e-10  # accuracy of the compressed operator in these tests
CHI = examples.paraboloid_obstacle(1.0, 4.0)


class Operator(spla.LinearOperator):
    """A dense matrix seen only through ``@`` and ``diagonal()``."""

    def __init__(self, A):
        super().__init__(np.float64, A.shape)
        self._A = A
        self.products = 0

    def _matvec(self, x):
        self.products += 1
        return self._A @ np.ravel(x)

    def diagonal(self):
        return np.diag(self._A).copy()


def standin_case(kind, k):
    """(A, cset, f) of tests/test_solvers.py for each constraint kind."""
    coarse, fine, free, _, A = standin(k)
    if kind == "obstacle":
        chi = lambda x: 0.5 * (1.0 - 4.0 * (x[0] ** 2 + x[1] ** 2))  # noqa: E731
        return A, obstacle_from_function(coarse, fine, chi), load(k, one)
    if kind == "friction":
        return A, Friction(interior_B(k), 1.2), load(k, odd)
    if kind == "thin_obstacle":
        return A, ThinObstacle(segment_B(k), (0.3 - 0.4 * fine.p[0] ** 2)[free], s=0.75), \
            load(k, one)
    return A, ThinFriction(segment_B(k), 2.0, s=0.6), load(k, odd)


def assert_close(u, lam, u_ref, lam_ref, B, rel):
    assert np.abs(u - u_ref).max() <= rel * np.abs(u_ref).max()
    scale = max(np.abs(lam_ref).max(), 1e-300)
    assert np.abs(lam - lam_ref).max() <= rel * scale
    assert np.abs(B @ (lam - lam_ref)).max() <= rel * max(np.abs(B @ lam_ref).max(), 1e-300)


def assert_kkt(cset, B, u, lam, rel, u_free):
    """λ ∈ Λ_H exactly, y = Bᵀu − g feasible on E and with the sign of λ at the
    bounds (complementarity): the KKT conditions of Problem 5.15; y relative to
    Bᵀu_free, u_free the unconstrained solution."""
    np.testing.assert_array_equal(cset.project(lam), lam)
    y = B.T @ u - cset.g
    tol = rel * max(np.abs(B.T @ u_free).max(), np.abs(cset.g).max())
    lower, upper = cset.lower, cset.upper
    at_up, at_low = lam == upper, lam == lower
    inside = ~(at_up | at_low)
    assert np.all(np.abs(y[inside]) <= tol)            # contact / stick: y = 0
    assert np.all(y[at_up & ~at_low] >= -tol)          # λ = upper ⇒ y ≥ 0
    assert np.all(y[at_low & ~at_up] <= tol)           # λ = lower ⇒ y ≤ 0
    return inside


# ------------------------------------------------ the solvers alone (same matrix)


@pytest.mark.parametrize("kind", ["obstacle", "friction", "thin_obstacle", "thin_friction"])
def test_operator_pdas_and_uzawa_agree_with_dense_pdas(kind):
    A, cset, f = standin_case(kind, 2)
    u_ref, lam_ref, _ = solvers.pdas(A, cset.B, f, cset)
    op = Operator(A)
    u, lam, info = solvers.pdas(op, cset.B, f, cset)     # dispatches on the operator
    assert op.products > 0 and info["inner_iterations"]
    assert_close(u, lam, u_ref, lam_ref, cset.B, AGREE)
    u_free = la.solve(A, f)
    inside = assert_kkt(cset, cset.B, u, lam, 1e-10, u_free)
    assert np.count_nonzero(inside) > 0                # contact resp. stick somewhere
    # the KKT equation itself: A u + Bλ = f
    assert np.abs(A @ u + cset.B @ lam - f).max() <= 1e-9 * np.abs(f).max()
    u2, lam2, info2 = solvers.uzawa(op, cset.B, f, cset, tol=1e-12)
    assert info2["sigma_max"] == pytest.approx(
        la.eigvalsh(solvers.schur_complement(la.cho_factor(A), cset.B))[-1], rel=1e-6)
    assert_close(u2, lam2, u_ref, lam_ref, cset.B, 1e-7)
    assert_kkt(cset, cset.B, u2, lam2, 1e-9, u_free)


def test_operator_pdas_on_a_larger_mesh_and_a_friction_subdomain():
    A, cset, f = standin_case("obstacle", 3)
    u_ref, lam_ref, _ = solvers.pdas(A, cset.B, f, cset)
    u, lam, _ = krylov_vi.pdas(Operator(A), cset.B, f, cset)
    assert_close(u, lam, u_ref, lam_ref, cset.B, AGREE)
    coarse, _, _, _, A = standin(2)
    F = friction_bound(coarse, 2.0, subdomain=lambda x: x[1] > 0)
    cset = Friction(interior_B(2), F)
    f = load(2, odd)
    u_ref, lam_ref, _ = solvers.pdas(A, cset.B, f, cset)
    u, lam, _ = krylov_vi.pdas(Operator(A), cset.B, f, cset)
    assert_close(u, lam, u_ref, lam_ref, cset.B, AGREE)
    np.testing.assert_array_equal(lam[F == 0], 0.0)


def test_all_stick_on_a_mesh_where_B_has_a_kernel():
    """init_circle: every interior vertex has even degree, the checkerboard is in
    the kernel of B, so B_EᵀD⁻¹B_E is singular when everything sticks; the
    minimum-norm λ of the dense path is found all the same."""
    _, _, _, _, A = standin(2)
    B, f = interior_B(2), load(2, one)
    cset = Friction(B, 1e3)
    u_ref, lam_ref, _ = solvers.pdas(A, B, f, cset)
    u, lam, info = krylov_vi.pdas(Operator(A), B, f, cset)
    assert info["n_constrained"][-1] == B.shape[1]        # all stick
    free_solution = la.solve(A, f)
    assert np.abs(u - u_ref).max() <= AGREE * np.abs(free_solution).max()
    assert np.abs(lam - lam_ref).max() <= AGREE * np.abs(lam_ref).max()
    assert np.abs(B.T @ u).max() <= 1e-9 * np.abs(B.T @ free_solution).max()


def test_warm_starts_save_inner_iterations():
    A, cset, f = standin_case("obstacle", 3)
    op = Operator(A)
    u, lam, warm = krylov_vi.pdas(op, cset.B, f, cset, loose=False)
    _, _, cold = krylov_vi.pdas(op, cset.B, f, cset, loose=False, warm_start=False)
    assert warm["iterations"] == cold["iterations"] >= 2
    # the first solve (unconstrained, from 0) is the same; every later one starts
    # from the previous u instead of the nearest feasible point to 0
    assert warm["inner_iterations"][0] == cold["inner_iterations"][0]
    assert sum(warm["inner_iterations"][1:]) < sum(cold["inner_iterations"][1:])
    # loose steps until the sets settle, then one accurate solve: fewer iterations
    _, lam_l, loose = krylov_vi.pdas(op, cset.B, f, cset)
    assert sum(loose["inner_iterations"]) < 0.9 * sum(warm["inner_iterations"])
    np.testing.assert_allclose(lam_l, lam, rtol=0, atol=AGREE * np.abs(lam).max())
    # from the solution (the next step of a time series, say): one step, few iterations
    _, _, again = krylov_vi.pdas(op, cset.B, f, cset, lam0=lam, u0=u)
    assert again["iterations"] <= 2
    assert sum(again["inner_iterations"]) < 0.5 * sum(warm["inner_iterations"])



@pytest.mark.parametrize("kind, factor", [("obstacle", 0.5), ("friction", 1.05)])
def test_pair_start_reads_the_first_sets_off_a_nearby_solution(kind, factor):
    """A time step's problem: f moved from a solved one, enough to move some of
    the active sets.  Starting from that solution pair's sets (pair_start)
    reaches the solution of the solve with λ⁰ to the solvers' accuracy, here in
    fewer inner iterations; a pair_start without a pair is refused by name."""
    A, cset, f = standin_case(kind, 3)
    op = Operator(A)
    u, lam, _ = krylov_vi.pdas(op, cset.B, f, cset)
    assert 0 < np.count_nonzero(lam) and np.count_nonzero(lam != cset.upper) > 0
    f2 = f * factor + 0.01 * np.abs(f).max() * np.cos(np.arange(f.size))
    u_ref, lam_ref, _ = solvers.pdas(A, cset.B, f2, cset, tol=1e-12)
    u_l, lam_l, with_lam = krylov_vi.pdas(op, cset.B, f2, cset, lam0=lam, u0=u)
    u_p, lam_p, paired = krylov_vi.pdas(op, cset.B, f2, cset, lam0=lam, u0=u,
                                        pair_start=True)
    for uu, ll in ((u_l, lam_l), (u_p, lam_p)):
        assert_close(uu, ll, u_ref, lam_ref, cset.B, AGREE)
    def sets(mu):
        return np.where(mu == cset.upper, 1, np.where(mu == cset.lower, -1, 0))
    assert np.any(sets(lam_ref) != sets(lam))   # some of the sets moved
    assert sum(paired["inner_iterations"]) < sum(with_lam["inner_iterations"])
    for bad in ({"u0": u}, {"lam0": lam}):
        with pytest.raises(ValueError, match="pair_start"):
            krylov_vi.pdas(op, cset.B, f2, cset, pair_start=True, **bad)


@pytest.mark.parametrize("loose", [True, False])
def test_a_start_far_from_the_solution_is_solved_as_accurately(loose):
    """The inner PCG's stopping test scales with the current iterate's A u, not the
    start's: u⁰ = the solution shifted far along null(Bᵀ) (every constraint value
    unchanged, so the first sets are the solution's) still ends at the solution to
    the solvers' accuracy, also when the sets' first solve is the last."""
    A, cset, f = standin_case("obstacle", 3)
    op = Operator(A)
    u, lam, _ = krylov_vi.pdas(op, cset.B, f, cset)
    u_ref, lam_ref, _ = solvers.pdas(A, cset.B, f, cset, tol=1e-12)
    B = cset.B.toarray()
    w = np.cos(np.arange(f.size) * 0.7)
    v = w - B @ np.linalg.lstsq(B, w, rcond=None)[0]     # Bᵀv = 0
    far = u + 1e4 * np.abs(u).max() * v / np.abs(v).max()
    u_p, lam_p, _ = krylov_vi.pdas(op, cset.B, f, cset, lam0=lam, u0=far, pair_start=True,
                                   loose=loose)
    assert_close(u_p, lam_p, u_ref, lam_ref, cset.B, AGREE)


# ------------------------------------------------------------- compressed operator


def problem(kind, coarse, operator):
    f = examples.radial_load(1.0, 3.0)
    if kind == "obstacle":
        return vi.mixed_problem(kind, coarse, 0.5, 1.0, chi=CHI, operator=operator,
                                tol=COMPRESSED)
    if kind == "friction":
        return vi.mixed_problem(kind, coarse, 0.6, f, F=0.5, operator=operator,
                                tol=COMPRESSED)
    edges = examples.segment_edges(coarse, -0.5, 0.5)
    if kind == "thin_obstacle":
        return vi.mixed_problem(kind, coarse, 0.75, -1.0, edges=edges, operator=operator,
                                height=lambda x: np.full(x.shape[1:], -0.05), tol=COMPRESSED)
    return vi.mixed_problem(kind, coarse, 0.75, f, edges=edges, F=0.2, operator=operator,
                            tol=COMPRESSED)


@pytest.fixture
def no_dense_solver(monkeypatch):
    """Any Cholesky factor or Schur complement fails the test."""
    def refuse(*args, **kwargs):
        raise AssertionError("a dense factorisation was formed")
    monkeypatch.setattr(solvers, "cholesky_factor", refuse)
    monkeypatch.setattr(solvers, "schur_complement", refuse)
    monkeypatch.setattr(la, "cho_factor", refuse)


@pytest.mark.parametrize("kind", ["obstacle", "friction", "thin_obstacle", "thin_friction"])
@pytest.mark.parametrize("level", [2, 3])
def test_compressed_pdas_agrees_with_dense_pdas(kind, level, request):
    coarse = ff.disk_uniform(level)
    dense = problem(kind, coarse, "dense")
    u_ref, lam_ref, _ = vi.solve(dense, "pdas")
    prob = problem(kind, coarse, "compressed")
    assert not prob.disc.dense and prob.disc.A.shape == dense.disc.A.shape
    request.getfixturevalue("no_dense_solver")
    u, lam, info = vi.solve(prob, "pdas")
    assert prob.factor is None and prob.schur is None
    B = prob.cset.B
    assert_close(u, lam, u_ref, lam_ref, B, 1e-9)
    u_free = ff.solve_laplace(prob.disc)
    inside = assert_kkt(prob.cset, B, u[prob.disc.free], lam, 1e-10, u_free)
    if kind == "obstacle":
        assert 0 < np.count_nonzero(lam < 0) < lam.size   # a genuine free boundary
    if kind.endswith("friction"):
        assert 0 < np.count_nonzero(inside) < lam.size    # stick and slip
    if level == 3:
        assert prob.disc.A.info["far_blocks"] > 0


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["obstacle", "friction", "thin_obstacle", "thin_friction"])
def test_compressed_uzawa_agrees_with_dense_pdas(kind, no_dense_solver):
    coarse = ff.disk_uniform(2)
    prob = problem(kind, coarse, "compressed")
    u, lam, info = vi.solve(prob, "uzawa", tol=1e-9)
    assert info["rho"] == pytest.approx(1.9 / info["sigma_max"])
    u_p, lam_p, _ = vi.solve(prob, "pdas")
    assert_close(u, lam, u_p, lam_p, prob.cset.B, 1e-7)
    assert_kkt(prob.cset, prob.cset.B, u[prob.disc.free], lam, 1e-8,
               ff.solve_laplace(prob.disc))


def test_operator_choice_and_inactive_constraints():
    coarse = ff.disk_uniform(2)
    prob = vi.mixed_problem("obstacle", coarse, 0.5, 1.0, chi=lambda x: -5.0 + 0 * x[0],
                            operator="compressed")
    u, lam, _ = vi.solve(prob, "pdas")
    np.testing.assert_array_equal(lam, 0.0)
    u_free = prob.disc.extend(ff.solve_laplace(prob.disc))
    np.testing.assert_allclose(u, u_free, rtol=0, atol=1e-9 * np.abs(u_free).max())
    assert vi.mixed_problem("friction", coarse, 0.6, 1.0, F=0.5,
                            operator="auto").disc.dense        # small: dense


# ---------------------------------------------------------- errors and bad input


def test_convergence_errors():
    A, cset, f = standin_case("friction", 2)
    op = Operator(A)
    with pytest.raises(ConvergenceError, match="PDAS") as err:
        krylov_vi.pdas(op, cset.B, f, cset, maxiter=1)
    assert err.value.iterations == 1
    with pytest.raises(ConvergenceError, match="inner PCG") as err:
        krylov_vi.pdas(op, cset.B, f, cset, inner_maxiter=2)
    assert err.value.iterations == 2 and err.value.residual > 1e-10
    with pytest.raises(ConvergenceError, match="Uzawa") as err:
        krylov_vi.uzawa(op, cset.B, f, cset, maxiter=2)
    assert err.value.iterations == 2


def test_bad_arguments_name_the_parameter():
    A, cset, f = standin_case("friction", 2)
    op, B = Operator(A), cset.B
    for kwargs, name in [({"tol": 0.0}, "tol"), ({"maxiter": 0}, "maxiter"),
                         ({"inner_tol": 1.5}, "inner_tol"), ({"inner_maxiter": 0}, "inner_maxiter"),
                         ({"M": "jacobi"}, "M"), ({"u0": np.ones(3)}, "u0"),
                         ({"lam0": np.ones(3)}, "lam0"), ({"c": -1.0}, "c"),
                         ({"globalize": "yes"}, "globalize")]:
        with pytest.raises(ValueError, match=name):
            krylov_vi.pdas(op, B, f, cset, **kwargs)
    with pytest.raises(ValueError, match="rho"):
        krylov_vi.uzawa(op, B, f, cset, rho=-1.0)
    with pytest.raises(ValueError, match="f must"):
        krylov_vi.pdas(op, B, f[:-1], cset)
    with pytest.raises(ValueError, match="A must have shape"):
        krylov_vi.pdas(Operator(A[:-1, :-1]), B, f, cset)
    with pytest.raises(ValueError, match="diagonal"):
        krylov_vi.pdas(spla.aslinearoperator(A), B, f, cset)
    with pytest.raises(ValueError, match="positive definite"):
        krylov_vi.pdas(Operator(-A), B, f, cset)
    with pytest.raises(ValueError, match="factor and schur"):
        solvers.pdas(op, B, f, cset, factor=la.cho_factor(A))
    with pytest.raises(TypeError, match="inner_tol"):
        solvers.pdas(A, B, f, cset, inner_tol=1e-8)     # a Krylov option for a dense A
    with pytest.raises(ValueError, match="operator"):
        vi.mixed_problem("friction", ff.disk_uniform(2), 0.6, 1.0, F=0.5, operator="sparse")
    coarse, fine, free, _, _ = standin(2)
    zero = coupling_matrix(coarse, fine)[free].tolil()
    zero[:, 0] = 0.0
    zero = zero.tocsr()
    with pytest.raises(ValueError, match="zero column"):
        krylov_vi.pdas(op, zero, f, Friction(zero, 1.0))


def test_lanczos_sigma_max_matches_the_dense_spectrum():
    A, cset, f = standin_case("obstacle", 2)
    sigma = la.eigvalsh(solvers.schur_complement(la.cho_factor(A), cset.B))
    est = krylov_vi.schur_sigma_max(Operator(A), cset.B)
    assert est["sigma_max"] == pytest.approx(sigma[-1], rel=1e-6)
    assert est["sigma_max"] <= sigma[-1] * (1 + 1e-12)     # a Ritz value: from below
    assert est["steps"] < 40
    # thin problems: a handful of multipliers, Lanczos ends on an invariant subspace
    A, cset, f = standin_case("thin_obstacle", 2)
    sigma = la.eigvalsh(solvers.schur_complement(la.cho_factor(A), cset.B))
    est = krylov_vi.schur_sigma_max(Operator(A), cset.B)
    assert est["sigma_max"] == pytest.approx(sigma[-1], rel=1e-9)
    assert est["steps"] <= cset.B.shape[1]


def test_prolong_multiplier_gives_each_child_its_parent_value():
    coarse = ff.disk_uniform(2)
    fine = vi.fine_mesh(coarse)               # parent of e is e mod n_H
    lam = np.random.default_rng(5).standard_normal(coarse.t.shape[1])
    np.testing.assert_array_equal(vi.prolong_multiplier(coarse, lam, fine),
                                  lam[np.arange(fine.t.shape[1]) % coarse.t.shape[1]])
    with pytest.raises(ValueError, match="lam has shape"):
        vi.prolong_multiplier(coarse, lam[:-1], fine)


@pytest.mark.slow
def test_nested_iteration_needs_fewer_pdas_steps_and_solves_the_same_problem():
    def problem(level):
        return vi.mixed_problem("obstacle", ff.disk_uniform(level), 0.5, 1.0, chi=CHI,
                                operator="compressed", tol=COMPRESSED)

    def problems():
        return (problem(level) for level in (2, 3, 4))

    *_, (u, lam, info) = vi.solve_nested(problems(), "pdas")
    u_cold, lam_cold, cold = vi.solve(problem(4), "pdas")
    assert np.abs(lam - lam_cold).max() <= AGREE * np.abs(lam_cold).max()
    assert np.abs(u - u_cold).max() <= AGREE * np.abs(u_cold).max()
    # measured: 3 steps from the level-3 solution, 6 from λ = 0
    assert info["iterations"] <= cold["iterations"] - 2
    with pytest.raises(ValueError, match="sets lam0"):
        next(vi.solve_nested(problems(), "pdas", lam0=lam))


def cycling_box_problem():
    """A box problem (B = I, friction bounds) on which the plain active-set steps
    never settle: A is SPD, but BᵀA⁻¹B = A⁻¹ is not an M-matrix (found by a search
    over random 3–8 dimensional problems; this is seed 1541)."""
    rng = np.random.default_rng(1541)
    n = int(rng.integers(3, 9))
    Q = np.linalg.qr(rng.standard_normal((n, n)))[0]
    A = Q @ np.diag(10 ** rng.uniform(0, 3, n)) @ Q.T
    A = 0.5 * (A + A.T)
    B = sp.identity(n, format="csr")
    f = rng.standard_normal(n) * 10
    return A, B, f, Friction(B, rng.uniform(0.1, 5, n))


def test_feasible_steps_solve_where_plain_active_set_steps_cycle():
    A, B, f, cset = cycling_box_problem()
    with pytest.raises(ConvergenceError):
        krylov_vi.pdas(Operator(A), B, f, cset, globalize=False, maxiter=60, loose=False)
    u, lam, info = krylov_vi.pdas(Operator(A), B, f, cset, maxiter=60)
    assert info["globalized_at"] is not None and info["residual"] < 1e-10
    inside = assert_kkt(cset, B, u, lam, 1e-9, la.solve(A, f))
    assert 0 < np.count_nonzero(inside) < len(f)          # stick and slip
    assert np.abs(A @ u + lam - f).max() <= 1e-9 * np.abs(f).max()
    # the dense path (S = BᵀA⁻¹B formed) cycles the same way, halving c in vain,
    # and its feasible steps find the same point
    with pytest.raises(ConvergenceError):
        solvers.pdas(A, B, f, cset, globalize=False)
    u_ref, lam_ref, info_ref = solvers.pdas(A, B, f, cset)
    assert info_ref["globalized_at"] is not None
    assert_kkt(cset, B, u_ref, lam_ref, 1e-9, la.solve(A, f))
    assert_close(u, lam, u_ref, lam_ref, B, AGREE)


@pytest.mark.parametrize("kind", ["obstacle", "friction"])
def test_feasible_steps_from_the_start_reach_the_dense_solution(kind):
    """globalize=True: every step feasible and monotone in the dual energy; the
    same solution as the dense path, in few steps (the active-set candidate is
    taken whole near the solution)."""
    A, cset, f = standin_case(kind, 2)
    u_ref, lam_ref, info_ref = solvers.pdas(A, cset.B, f, cset)
    assert info_ref["globalized_at"] is None          # plain steps suffice here
    u, lam, info = krylov_vi.pdas(Operator(A), cset.B, f, cset, globalize=True)
    assert info["globalized_at"] == 0 and info["iterations"] <= 15
    assert_close(u, lam, u_ref, lam_ref, cset.B, AGREE)
    u2, lam2, info2 = solvers.pdas(A, cset.B, f, cset, globalize=True)
    assert info2["globalized_at"] == 0 and info2["iterations"] <= 15
    assert_close(u2, lam2, u_ref, lam_ref, cset.B, AGREE)
