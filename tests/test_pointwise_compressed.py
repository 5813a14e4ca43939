"""The compressed path of fracfem.pointwise against the dense one.

The compressed path sums the edges near a point with the dense path's rules
and the far ones through cluster trees and Chebyshev interpolation, so the
two differ by the interpolation error alone: checked on the disk, the square
and the L-shape for s ∈ {0.1, 0.5, 0.9}, for u_h vanishing on ∂Ω and not,
as tol falls, for u_h ≡ 1 (c κ), for s → 0, with raised quadrature options
(far sources at Gauss points instead of midpoints) and in the a posteriori
estimator.
"""
from functools import lru_cache

import numpy as np
import pytest

import fracfem as ff
import fracfem.pointwise as pw
from fracfem import estimators
from fracfem.assembly import _boundary_edges, exterior_kernel, mesh_arrays
from fracfem.exact import c2s
from fracfem.meshes import disk_uniform, lshape, square
from fracfem.pointwise import (PointwiseOptions, fractional_laplacian_at,
                               fractional_laplacian_qp)

MESHES = {"disk": lambda: disk_uniform(4), "square": lambda: square(20),
          "lshape": lambda: lshape(4)}


@lru_cache(maxsize=None)
def mesh(name):
    return MESHES[name]()


def random_u(m, seed, boundary):
    u = np.random.default_rng(seed).standard_normal(m.p.shape[1])
    if not boundary:
        u[m.boundary_nodes()] = 0.0
    return u


def rel_diff(a, b):
    return np.abs(a - b).max() / np.abs(b).max()


def both(m, u, s, order=2, **kw):
    """Values at the points of triangle_rule(order): (compressed, dense)."""
    return (fractional_laplacian_qp(m, u, s, order, method="compressed", **kw)[0],
            fractional_laplacian_qp(m, u, s, order, method="dense",
                                    options=kw.get("options"))[0])


@pytest.mark.parametrize("name", list(MESHES))
@pytest.mark.parametrize("s", [0.1, 0.5, 0.9])
def test_compressed_matches_dense(name, s):
    m = mesh(name)
    for seed, boundary in ((1, False), (2, True)):
        comp, dense = both(m, random_u(m, seed, boundary), s)
        assert rel_diff(comp, dense) <= 1e-6, (name, s, boundary)


def test_error_falls_with_tol():
    m = mesh("disk")
    u = random_u(m, 3, True)
    dense = fractional_laplacian_qp(m, u, 0.3, 2, method="dense")[0]
    errs = [rel_diff(fractional_laplacian_qp(m, u, 0.3, 2, method="compressed",
                                             tol=tol)[0], dense)
            for tol in (1e-3, 1e-5, 1e-7, 1e-9)]
    assert all(b < 0.5 * a for a, b in zip(errs, errs[1:])), errs
    assert errs[0] > 1e-6 and errs[-1] < 1e-8, errs


@pytest.mark.parametrize("s", [0.2, 0.8])
def test_constant_reproduces_kappa(s):
    # u_h ≡ 1: only the double layer over ∂Ω remains, (−Δ)^s u_h = c κ
    m = mesh("lshape")
    p, t = mesh_arrays(m)
    x = p[t].mean(axis=1)
    edges, _ = _boundary_edges(p, t)
    exact = c2s(s) * exterior_kernel(x, edges, s)
    val = fractional_laplacian_at(m, np.ones(len(p)), x, np.arange(len(t)), s,
                                  method="compressed")
    assert rel_diff(val, exact) <= 1e-6


def test_small_s_stays_conditioned():
    # G(r) = (r^(−2s) − ℓ₀^(−2s))/(2s) → log(ℓ₀/r): no cancellation of 1/(2s)
    m = mesh("square")
    u = random_u(m, 4, False)
    for s in (1e-2, 1e-4):
        comp, dense = both(m, u, s)
        assert rel_diff(comp, dense) <= 1e-6, s


def test_raised_options_gauss_sources():
    # the farthest class with Gauss points (not the corrected midpoint): the
    # far field takes every Gauss point as a source
    opt = PointwiseOptions().raised()
    assert opt.points[-1] > 0
    m = mesh("disk")
    comp, dense = both(m, random_u(m, 5, True), 0.6, options=opt)
    assert rel_diff(comp, dense) <= 1e-6


def test_single_boundary_class_and_wide_near_zone():
    # one Gauss rule for every boundary edge beyond `near`, and a sinh zone
    # reaching past the last ratio: the far field must leave both alone
    opt = PointwiseOptions(near=7.0, boundary_ratios=(), boundary_points=(6,))
    m = mesh("lshape")
    comp, dense = both(m, random_u(m, 7, True), 0.4, options=opt)
    assert rel_diff(comp, dense) <= 1e-6


def test_auto_switches_by_pairs(monkeypatch):
    m = mesh("square")
    u = random_u(m, 6, False)
    comp, dense = both(m, u, 0.5)
    assert np.array_equal(fractional_laplacian_qp(m, u, 0.5, 2)[0], dense)
    monkeypatch.setattr(pw, "AUTO_PAIRS", 0.0)
    assert np.array_equal(fractional_laplacian_qp(m, u, 0.5, 2)[0], comp)


def test_estimator_same_with_either_method():
    m = disk_uniform(4)
    disc = ff.discretise(m, 0.5, 1.0)
    u = disc.extend(ff.solve_laplace(disc))
    est = {meth: estimators.estimate_laplace(disc, u, 1.0, method=meth)
           for meth in ("dense", "compressed")}
    a, b = est["compressed"], est["dense"]
    assert abs(a["eta"] - b["eta"]) <= 1e-8 * b["eta"]
    assert np.abs(a["eta2_fine"] - b["eta2_fine"]).max() <= 1e-8 * b["eta2_fine"].max()


def test_obstacle_estimator_same_with_either_method():
    prob = ff.vi.mixed_problem("obstacle", disk_uniform(2), 0.5, 1.0,
                               chi=ff.examples.paraboloid_obstacle())
    u, lam, _ = ff.vi.solve(prob, "pdas")
    eta = [estimators.estimate(prob, u, lam, f=1.0, method=meth)["eta"]
           for meth in ("dense", "compressed")]
    assert abs(eta[0] - eta[1]) <= 1e-8 * eta[0]


@pytest.mark.parametrize("kw, match", [
    (dict(method="fast"), r"method='fast' must be one of \('dense', 'compressed', 'auto'\)"),
    (dict(method=None), "method=None must be one of"),
    (dict(tol=0.0), r"tol=0.0 must be a number in \[1e-14, 1\)"),
    (dict(tol=1.0), r"tol=1.0 must be a number in \[1e-14, 1\)"),
    (dict(tol=float("nan")), r"tol=nan must be a number in \[1e-14, 1\)"),
    (dict(tol="1e-8"), r"tol='1e-8' must be a number"),
    (dict(tol=True), "tol=True must be a number"),
])
def test_bad_method_and_tol_refused(kw, match):
    m = disk_uniform(1)
    u = np.zeros(m.p.shape[1])
    with pytest.raises(ValueError, match=match):
        fractional_laplacian_qp(m, u, 0.5, 2, **kw)
    with pytest.raises(ValueError, match=match):
        fractional_laplacian_at(m, u, m.p[:, m.t[:, 0]].mean(axis=1)[None], [0], 0.5, **kw)
    disc = ff.discretise(m, 0.5, 1.0)
    with pytest.raises(ValueError, match=match):
        estimators.estimate_laplace(disc, u, 1.0, **kw)


@pytest.mark.parametrize("method", ["dense", "compressed"])
@pytest.mark.parametrize("s", [0.3, 0.5, 0.8])
def test_batch_of_functions_equals_one_at_a_time(method, s):
    """u of shape (Nv, K): column r equals the evaluation of u[:, r] alone, for
    u_h vanishing on ∂Ω and not (double layer) and a zero column: with the
    same edges (J_e ≠ 0 on all) the rules and trees are the same, so the two
    agree to round-off.  A column whose J_e vanishes on most edges has, alone,
    fewer sources and other trees: the compressed values then differ by the
    compression error, checked against the dense path as elsewhere here."""
    m = mesh("lshape")
    cols = [random_u(m, 11, False), random_u(m, 12, True), np.zeros(m.p.shape[1])]
    local = np.zeros(m.p.shape[1])
    local[m.t[:, 0]] = 1.0                       # J_e ≠ 0 only near element 0
    cols.append(local)
    U = np.column_stack(cols)
    batch = fractional_laplacian_qp(m, U, s, 2, method=method)[0]
    assert batch.shape == m.t.T.shape[:1] + (triangle_points(2), len(cols))
    for r, u in enumerate(cols[:3]):
        one = fractional_laplacian_qp(m, u, s, 2, method=method)[0]
        scale = max(np.abs(one).max(), 1.0)
        assert np.abs(batch[..., r] - one).max() <= 1e-12 * scale, (r, method, s)
    assert np.abs(batch[..., 2]).max() == 0.0
    dense = fractional_laplacian_qp(m, local, s, 2, method="dense")[0]
    assert rel_diff(batch[..., 3], dense) <= (1e-12 if method == "dense" else 1e-6)


def triangle_points(order):
    return len(ff.quadrature.triangle_rule(order)[1])


def test_batch_shape_errors():
    m = mesh("square")
    nv = m.p.shape[1]
    with pytest.raises(ValueError, match=r"u must have shape \(%d,\) or \(%d, K\)" % (nv, nv)):
        fractional_laplacian_qp(m, np.zeros((nv, 0)), 0.5, 2)
    with pytest.raises(ValueError, match="u must have shape"):
        fractional_laplacian_qp(m, np.zeros((nv, 2, 1)), 0.5, 2)
    bad = np.zeros((nv, 2))
    bad[3, 1] = np.inf
    with pytest.raises(ValueError, match=r"non-finite values at nodes \[3\]"):
        fractional_laplacian_qp(m, bad, 0.5, 2)
