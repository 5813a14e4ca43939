"""Tests of fracfem.solvers: Uzawa (Algorithm A) against the active set method.

A stand-in for the fractional stiffness matrix: the P1 Laplacian plus a small mass
term on the free nodes of the fine mesh (any dense SPD matrix will do).
"""

from functools import lru_cache

import numpy as np
import pytest
import scipy.linalg as la
from skfem import Basis, ElementTriP1, MeshTri, asm
from skfem.models.poisson import laplace, mass

from fracfem.mixed import (
    Friction,
    Obstacle,
    ThinFriction,
    ThinObstacle,
    coupling_matrix,
    edge_coupling_matrix,
    edges_on_curve,
    friction_bound,
    obstacle_from_function,
)
from fracfem.solvers import (
    ConvergenceError,
    cholesky_factor,
    pdas,
    schur_complement,
    schur_spectrum,
    uzawa,
)

AGREE = 1e-7  # Uzawa (tol 1e-12) vs PDAS, relative to the max norm


@lru_cache(maxsize=None)
def standin(k):
    """Meshes, free nodes, mass matrix and the stand-in A on init_circle(k)."""
    coarse = MeshTri.init_circle(k)
    fine = coarse.refined()
    basis = Basis(fine, ElementTriP1())
    M = asm(mass, basis)
    free = fine.interior_nodes()
    A = (asm(laplace, basis) + 0.1 * M)[free][:, free].toarray()
    return coarse, fine, free, M, A


def load(k, func):
    """f_i = ∫ f_h φ_i on the free nodes, f_h the P1 interpolant of ``func``."""
    _, fine, free, M, _ = standin(k)
    return (M @ func(fine.p))[free]


def interior_B(k):
    coarse, fine, free, _, _ = standin(k)
    return coupling_matrix(coarse, fine)[free]


def segment_B(k):
    coarse, fine, free, _, _ = standin(k)
    edges = edges_on_curve(coarse, lambda x: (np.abs(x[1]) < 1e-12)
                           & (np.abs(x[0]) <= 0.5 + 1e-12))
    return edge_coupling_matrix(coarse, fine, edges)[free]


def one(x):
    return np.ones_like(x[0])


def odd(x):
    """A sign-changing load: u > 0 for x > 0, u < 0 for x < 0."""
    return 4.0 * x[0]


def solve_both(A, B, f, cset):
    u1, lam1, info1 = uzawa(A, B, f, cset, tol=1e-12)
    u2, lam2, info2 = pdas(A, B, f, cset)
    return (u1, lam1, info1), (u2, lam2, info2)


def assert_agree(first, second, B):
    (u1, lam1, _), (u2, lam2, _) = first, second
    assert np.abs(u1 - u2).max() <= AGREE * np.abs(u2).max()
    assert np.abs(lam1 - lam2).max() <= AGREE * max(np.abs(lam2).max(), 1e-300)
    assert np.abs(B @ (lam1 - lam2)).max() <= AGREE * max(np.abs(B @ lam2).max(), 1e-300)


def assert_sign_kkt(cset, B, u, lam):
    """λ ≤ 0, Bᵀu − g ≥ 0, λ_j (Bᵀu − g)_j = 0 (obstacle, Signorini)."""
    y = B.T @ u - cset.g
    np.testing.assert_array_equal(cset.project(lam), lam)  # λ ∈ Λ_H exactly
    assert cset.contains(lam, tol=0.0)
    yscale = np.abs(B.T @ u).max()
    assert y.min() >= -1e-9 * yscale
    assert np.abs(lam * y).max() <= 1e-9 * yscale * np.abs(lam).max()


def assert_friction_kkt(cset, B, u, lam):
    """|λ_j| ≤ F_j and λ_j = F_j sign((Bᵀu)_j) where (Bᵀu)_j ≠ 0; returns slip mask."""
    y = B.T @ u
    np.testing.assert_array_equal(cset.project(lam), lam)
    assert np.all(np.abs(lam) <= cset.F)
    slip = np.abs(y) > 1e-8 * np.abs(y).max()
    np.testing.assert_allclose(lam[slip], cset.F[slip] * np.sign(y[slip]), rtol=1e-12)
    return slip


# ----------------------------------------------------------------- the four problems


@pytest.mark.parametrize("k", [2, 3])
def test_obstacle_uzawa_and_pdas_agree(k):
    coarse, fine, free, _, A = standin(k)
    chi = lambda x: 0.5 * (1.0 - 4.0 * (x[0] ** 2 + x[1] ** 2))  # noqa: E731
    cset = obstacle_from_function(coarse, fine, chi)  # χ = (1 − 4|x|²)/2
    B, f = cset.B, load(k, one)
    first, second = solve_both(A, B, f, cset)
    assert_agree(first, second, B)
    for u, lam, _ in (first, second):
        assert_sign_kkt(cset, B, u, lam)
    lam = second[1]
    assert 0 < np.count_nonzero(lam < 0) < lam.size  # contact and no contact
    # contact pushes u up: u ≥ the free solution
    assert np.all(second[0] >= la.solve(A, f) - 1e-12)


def test_interior_friction_uzawa_and_pdas_agree():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    cset = Friction(B, 0.3 * 4.0)  # F = 0.3 max|f|
    first, second = solve_both(A, B, f, cset)
    assert_agree(first, second, B)
    for u, lam, _ in (first, second):
        slip = assert_friction_kkt(cset, B, u, lam)
        assert 0 < np.count_nonzero(slip) < slip.size  # stick and slip both occur
        assert np.any(lam[slip] > 0) and np.any(lam[slip] < 0)


def test_friction_on_a_subdomain():
    k = 2
    coarse, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    F = friction_bound(coarse, 2.0, subdomain=lambda x: x[1] > 0)  # S = upper half disk
    cset = Friction(B, F)
    first, second = solve_both(A, B, f, cset)
    assert_agree(first, second, B)
    lam = second[1]
    np.testing.assert_array_equal(lam[F == 0], 0.0)
    assert np.any(np.abs(lam[F > 0]) < F[F > 0] - 1e-6)  # a stick element in S


def test_thin_obstacle_uzawa_and_pdas_agree():
    k = 3
    _, fine, free, _, A = standin(k)
    B, f = segment_B(k), load(k, one)
    height = 0.3 - 0.4 * fine.p[0] ** 2  # obstacle g on Γ̃, above the free solution
    cset = ThinObstacle(B, height[free], s=0.75)
    first, second = solve_both(A, B, f, cset)
    assert_agree(first, second, B)
    for u, lam, _ in (first, second):
        assert_sign_kkt(cset, B, u, lam)
    lam = second[1]
    assert 0 < np.count_nonzero(lam < 0) < lam.size


def test_thin_friction_uzawa_and_pdas_agree():
    k = 3
    _, _, _, _, A = standin(k)
    B, f = segment_B(k), load(k, odd)
    cset = ThinFriction(B, 2.0, s=0.6)
    first, second = solve_both(A, B, f, cset)
    assert_agree(first, second, B)
    for u, lam, _ in (first, second):
        slip = assert_friction_kkt(cset, B, u, lam)
        assert 0 < np.count_nonzero(slip) < slip.size


# -------------------------------------------------------------------- limit cases


def test_never_active_obstacle_gives_the_free_solution():
    k = 2
    coarse, fine, _, _, A = standin(k)
    cset = obstacle_from_function(coarse, fine, lambda x: -10.0 + 0 * x[0])
    f = load(k, one)
    free_solution = la.solve(A, f)
    for u, lam, _ in solve_both(A, cset.B, f, cset):
        np.testing.assert_allclose(u, free_solution, rtol=1e-12)
        np.testing.assert_array_equal(lam, 0.0)


def test_zero_friction_gives_the_free_solution():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    free_solution = la.solve(A, f)
    for u, lam, _ in solve_both(A, B, f, Friction(B, 0.0)):
        np.testing.assert_allclose(u, free_solution, rtol=0,
                                   atol=1e-12 * np.abs(free_solution).max())
        np.testing.assert_array_equal(lam, 0.0)


def test_huge_friction_sticks_everywhere():
    """All stick: every coarse mean of u vanishes, so u is tiny, though not 0.

    B has fewer columns than rows, so Bλ = f has no solution and u = A⁻¹(f − Bλ)
    is a fine-scale oscillation with zero element means.  λ itself is only
    determined up to the checkerboard kernel of B here, so compare Bλ.
    """
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, one)
    cset = Friction(B, 1e3)
    first, second = solve_both(A, B, f, cset)
    free_solution = la.solve(A, f)
    for u, lam, _ in (first, second):
        assert np.abs(B.T @ u).max() <= 1e-9 * np.abs(B.T @ free_solution).max()
        assert np.linalg.norm(u) <= 1e-2 * np.linalg.norm(free_solution)
        assert np.abs(lam).max() < 1e3  # nowhere at the bound
    assert np.abs(first[0] - second[0]).max() <= AGREE * np.abs(free_solution).max()
    np.testing.assert_allclose(B @ first[1], B @ second[1], rtol=0,
                               atol=AGREE * np.abs(f).max())


# ----------------------------------------------------------- step size and spectrum


def test_schur_spectrum_dense_and_lanczos():
    k = 2
    _, _, _, _, A = standin(k)
    B = interior_B(k)
    factor = cholesky_factor(A)
    dense = schur_spectrum(factor, B)
    sigma = la.eigvalsh(schur_complement(factor, B))
    assert dense["method"] == "dense" and dense["kernel_dim"] == 1  # the checkerboard
    assert dense["sigma_max"] == pytest.approx(sigma[-1], rel=1e-12)
    assert dense["sigma_min"] == pytest.approx(sigma[1], rel=1e-9)
    lanczos = schur_spectrum(factor, B, dense_limit=0)
    assert lanczos["method"] == "lanczos"
    assert lanczos["sigma_max"] == pytest.approx(sigma[-1], rel=1e-7)
    # thin problems: the midpoint rows make B injective, no kernel
    assert schur_spectrum(factor, segment_B(k))["kernel_dim"] == 0


def test_uzawa_step_and_lanczos_path():
    k = 2
    coarse, fine, _, _, A = standin(k)
    cset = obstacle_from_function(coarse, fine, lambda x: 0.5 * (1 - 4 * (x[0] ** 2 + x[1] ** 2)))
    f = load(k, one)
    u, lam, info = uzawa(A, cset.B, f, cset, tol=1e-12)
    assert info["rho"] == pytest.approx(2.0 / (info["sigma_max"] + info["sigma_min"]))
    assert set(info["seconds"]) == {"factorisation", "eigenvalues", "iterations"}
    assert info["residual"] < 1e-12 and len(info["residuals"]) == info["iterations"] + 1
    u2, lam2, info2 = uzawa(A, cset.B, f, cset, tol=1e-12, dense_limit=0)
    assert info2["rho"] == pytest.approx(1.9 / info["sigma_max"], rel=1e-7)
    np.testing.assert_allclose(lam2, lam, rtol=0, atol=AGREE * np.abs(lam).max())


def test_factor_reuse_and_warm_start():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    cset = Friction(B, 1.2)
    factor = cholesky_factor(A)
    u, lam, info = uzawa(A, B, f, cset)
    u_f, lam_f, _ = uzawa(None, B, f, cset, factor=factor)
    np.testing.assert_array_equal(u, u_f)
    np.testing.assert_array_equal(lam, lam_f)
    _, _, warm = uzawa(None, B, f, cset, factor=factor, rho=info["rho"], lam0=lam)
    assert warm["iterations"] < 0.1 * info["iterations"]
    S = schur_complement(factor, B)
    u_s, lam_s, info_s = uzawa(None, B, f, cset, factor=factor, schur=S)
    assert info_s["rho"] == pytest.approx(info["rho"], rel=1e-12)
    assert abs(info_s["iterations"] - info["iterations"]) <= 2  # same iteration
    np.testing.assert_allclose(u_s, u, rtol=0, atol=1e-9 * np.abs(u).max())
    u_p, lam_p, _ = pdas(None, B, f, cset, factor=factor, schur=S)
    np.testing.assert_allclose(lam_p, lam, rtol=0, atol=1e-6 * np.abs(lam).max())
    # a given S whose asymmetry is round-off gives the same answer; a larger one is refused
    E = np.random.default_rng(3).standard_normal(S.shape) * 1e-12 * np.abs(S).max()
    _, lam_r, info_r = uzawa(None, B, f, cset, factor=factor, schur=S + E)
    assert info_r["iterations"] == info_s["iterations"]
    np.testing.assert_allclose(lam_r, lam_s, rtol=0, atol=1e-9 * np.abs(lam).max())
    for solver in (uzawa, pdas):
        with pytest.raises(ValueError, match=r"schur must be symmetric.*allowed: 1e-08"):
            solver(None, B, f, cset, factor=factor, schur=S + 1e-6 * np.abs(S).max() * np.triu(
                np.ones_like(S), 1))
    with pytest.raises(ValueError, match="schur must be finite"):
        uzawa(None, B, f, cset, factor=factor, schur=np.where(S == S.max(), np.nan, S))
    from fracfem import solvers
    assert solvers._SYMMETRIC.get(id(S)) is S and not S.flags.writeable   # not scanned again
    with pytest.raises(ValueError, match="read-only"):
        S[0, 1] += 1.0
    _check_schur = solvers._check_schur
    np.testing.assert_array_equal(_check_schur(S + E, S.shape[0]),
                                  _check_schur(S + E, S.shape[0]).T)


def test_schur_gradient_updates_equal_the_full_product():
    """Uzawa's d − Sλ from the rows of S where λ changed equals the full product along a
    sequence of sparse and dense changes and past several refreshes, reading far fewer
    rows of S than one full product per step (S symmetric, as every S that reaches it:
    schur_complement's, or a given one through _check_schur)."""
    rng = np.random.default_rng(3)
    m = 300
    X = rng.standard_normal((m, m))
    _check_schur_gradient(rng, X @ X.T, m)


def _check_schur_gradient(rng, S, m):
    from fracfem.solvers import _SchurGradient

    d = rng.standard_normal(m)
    refresh, steps = 16, 200
    grad = _SchurGradient(d, S, refresh=refresh)
    lam = np.zeros(m)
    for n in range(steps):
        if n % 50 == 49:
            lam = rng.standard_normal(m)                       # everything changes
        elif n % 7 == 3:
            pass                                               # nothing changes
        else:                                                  # a few, in place
            k = rng.choice(m, size=5, replace=False)
            lam[k] += rng.standard_normal(5)
        g = grad(lam)
        np.testing.assert_allclose(g, d - S @ lam, rtol=0,
                                   atol=1e-12 * np.abs(S).max() * np.abs(lam).sum())
    # refreshed at least every refresh + 1 calls, and not much more often
    assert steps / (refresh + 1) <= grad.full_products <= steps / refresh + 4 + 1
    assert grad.rows_read < 0.2 * steps * m


# -------------------------------------------------------------------- bad input


def test_uzawa_raises_convergence_error():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    with pytest.raises(ConvergenceError, match="Uzawa") as err:
        uzawa(A, B, f, Friction(B, 1.2), maxiter=2)
    assert err.value.iterations == 2 and err.value.residual > 0
    assert isinstance(err.value, RuntimeError)


def test_pdas_raises_convergence_error():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    with pytest.raises(ConvergenceError, match="PDAS") as err:
        pdas(A, B, f, Friction(B, 2.4), maxiter=1)
    assert err.value.iterations == 1


def test_solver_input_checks():
    k = 2
    _, _, _, _, A = standin(k)
    B, f = interior_B(k), load(k, odd)
    cset = Friction(B, 1.0)
    with pytest.raises(ValueError, match="f must have shape"):
        uzawa(A, B, f[:-1], cset)
    with pytest.raises(ValueError, match="A must have shape"):
        pdas(A[:-1, :-1], B, f, cset)
    with pytest.raises(ValueError, match="multipliers"):
        uzawa(A, B, f, Friction(B[:, :-1], 1.0))
    with pytest.raises(ValueError, match="positive definite"):
        uzawa(-A, B, f, cset)
    with pytest.raises(ValueError, match="rho"):
        uzawa(A, B, f, cset, rho=-1.0)
    with pytest.raises(ValueError, match="maxiter"):
        uzawa(A, B, f, cset, maxiter=0)
    with pytest.raises(ValueError, match="schur"):
        uzawa(A, B, f, cset, schur=np.eye(3))
    with pytest.raises(ValueError, match="lam0"):
        pdas(A, B, f, cset, lam0=np.ones(3))
    with pytest.raises(ValueError, match="Obstacle|obstacle|g"):
        Obstacle(B, g=np.ones(3))


# ------------------------------------------------------------------ the blocked Cholesky


def _spd(n, seed=0):
    rng = np.random.default_rng(seed)
    G = rng.standard_normal((n, n))
    return G @ G.T / n + np.eye(n)


@pytest.mark.parametrize("block", [64, 97, 299, 300])      # dividing n, not, n − 1, n
def test_blocked_cholesky_is_scipys_factor(block):
    from fracfem.solvers import cho_factor
    A = _spd(300)
    c, lower = cho_factor(A, blocked_n=0, block=block)
    ref, _ = la.cho_factor(A, lower=True)
    assert lower is False and c.flags.f_contiguous       # Lᵀ, in LAPACK's own order
    assert np.allclose(np.triu(c), np.tril(ref).T, rtol=0, atol=1e-13 * np.abs(ref).max())
    b = np.arange(300.0)
    assert np.allclose(A @ la.cho_solve((c, lower), b), b, rtol=0, atol=1e-10)


def test_blocked_cholesky_in_place():
    from fracfem.solvers import cho_factor
    A = _spd(200, 1)
    work = A.copy()
    c, lower = cho_factor(work, overwrite_a=True, blocked_n=0, block=50)
    assert np.shares_memory(c, work) and c.shape == A.shape           # no copy of A
    ref, _ = la.cho_factor(A, lower=True)
    assert np.allclose(np.triu(c), np.tril(ref).T, rtol=0, atol=1e-13 * np.abs(ref).max())
    with pytest.raises(ValueError, match="block=0 must be"):
        cho_factor(A, blocked_n=0, block=0)
    with pytest.raises(ValueError, match="square"):
        cho_factor(A[:, :10])


def test_the_pdas_blocks_solve_through_the_blocked_factor(monkeypatch):
    """_spd_solve (PDAS's blocks of S) reads the condition estimate from whichever
    triangle the factor holds."""
    from fracfem import solvers
    S, rhs = _spd(150, 3), np.linspace(-1.0, 1.0, 150)
    anorm = np.linalg.norm(S, 1)
    expected = la.lapack.dpocon(la.cho_factor(S, lower=True)[0], anorm, uplo="L")[0]
    blocked, dpocon, seen = solvers.cho_factor, la.lapack.dpocon, []

    def spy(c, norm, uplo):
        out = dpocon(c, norm, uplo=uplo)
        seen.append(out[0])
        return out
    monkeypatch.setattr(solvers, "cho_factor",
                        lambda *a, **k: blocked(*a, blocked_n=0, block=40, **k))
    monkeypatch.setattr(solvers.la.lapack, "dpocon", spy)
    assert np.allclose(S @ solvers._spd_solve(S, rhs), rhs, rtol=0, atol=1e-11)
    assert len(seen) == 1 and np.isclose(seen[0], expected, rtol=1e-10)


def test_blocked_cholesky_names_the_minor_as_scipy_does():
    from fracfem.solvers import cho_factor
    A = _spd(120, 2)
    A[70, 70] = -1.0                                       # the 71st leading minor fails
    with pytest.raises(np.linalg.LinAlgError) as ours:
        cho_factor(A, blocked_n=0, block=32)
    with pytest.raises(np.linalg.LinAlgError) as scipys:
        la.cho_factor(A, lower=True)
    assert str(ours.value) == str(scipys.value)
    assert str(ours.value).startswith("71-th leading minor")
    A = _spd(120, 2)
    A[100, 3] = np.nan                                     # in the lower triangle
    with pytest.raises(ValueError, match="infs or NaNs"):
        cho_factor(A, blocked_n=0, block=32)


def test_the_dense_solvers_factor_large_matrices_by_blocks(monkeypatch):
    """solve_laplace and cholesky_factor (the VI and parabolic solvers' factor) go through
    cho_factor: made to block from 0 rows on, their solutions are the same."""
    import fracfem as ff
    from fracfem import solvers
    disc = ff.Example1(0.5).problem(ff.disk_uniform(3))
    u = ff.solve_laplace(disc)
    factor = solvers.cholesky_factor(disc.A)
    calls = []
    blocked = solvers.cho_factor

    def spy(*args, **kwargs):
        calls.append(args[0].shape[0])
        return blocked(*args, blocked_n=0, block=16, **kwargs)
    monkeypatch.setattr(solvers, "cho_factor", spy)
    monkeypatch.setattr(ff.laplace, "cho_factor", spy)
    assert np.allclose(ff.solve_laplace(disc), u, rtol=1e-12, atol=0)
    blocked_factor = solvers.cholesky_factor(disc.A)
    assert blocked_factor[1] is False
    assert np.allclose(np.triu(blocked_factor[0]), np.tril(factor[0]).T, rtol=0,
                       atol=1e-12 * np.abs(factor[0]).max())
    assert calls == [len(u), len(u)]
