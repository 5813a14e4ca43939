"""Rates and reference energies (fracfem_workflow.report)."""

import numpy as np
import pandas as pd
import pytest

from fracfem import assembly, exact, laplace, meshes
from fracfem_workflow.report import (energy_error, extrapolate_energy, extrapolation_uncertainty,
                                     fit_rate, rate_table)
from pages import page_tables


def test_extrapolation_recovers_the_model_limit():
    N = np.array([100.0, 400.0, 1500.0, 5000.0])
    E = -0.6 + 0.3 * N ** -0.8
    out = extrapolate_energy(N, E)
    assert out["energy"] == pytest.approx(-0.6, abs=1e-12)
    assert out["beta"] == pytest.approx(0.8, rel=1e-9)
    assert out["dofs_used"] == [400, 1500, 5000]


def test_extrapolation_uses_the_three_finest_in_any_order():
    N = np.array([5000.0, 100.0, 1500.0, 400.0])
    E = 1.0 + 2.0 * N ** -0.5
    assert extrapolate_energy(N, E)["energy"] == pytest.approx(1.0, abs=1e-12)


@pytest.mark.parametrize("E", [[1.0, 0.9, 0.95], [1.0, 1.0, 0.9], [1.0, 0.9, np.nan]])
def test_extrapolation_refuses_non_monotone_energies(E):
    with pytest.raises(ValueError, match="energ"):
        extrapolate_energy([10, 20, 40], E)


def test_extrapolation_refuses_accelerating_decrease():
    # differences growing on a geometric DOF sequence: no β > 0 fits
    with pytest.raises(ValueError, match="β"):
        extrapolate_energy([10, 20, 40], [1.0, 0.99, 0.9])


def test_extrapolation_uncertainty_vanishes_on_the_model_and_bounds_a_correction():
    N = 113.0 * 2.05 ** np.arange(9)            # an adaptive series: ×2 DOFs per step
    exact_model = -0.6 + 0.3 * N ** -1.0
    assert extrapolation_uncertainty(N, exact_model)["uncertainty"] < 1e-6
    # a second, faster-decaying term: the limit of the three finest is off, and the
    # change when the finest run is left out is at least that far off
    E = -0.6 + 0.3 * N ** -1.0 + 2.0 * N ** -1.5
    out = extrapolation_uncertainty(N, E)
    true_error = float(energy_error(out["energy"], -0.6))
    assert true_error > 1e-4                     # the correction does move the limit
    assert true_error <= out["uncertainty"] <= 5 * true_error
    assert out["uncertainty"] == pytest.approx(np.sqrt(2 * max(
        abs(out["energy"] - out["previous"]), abs(out["previous"] - out["before"]))))
    with pytest.raises(ValueError, match="five"):
        extrapolation_uncertainty(N[:4], E[:4])


def test_energy_error_is_the_energy_norm_error_of_example_1():
    """E(v) − E(u) = ½‖u − v‖²_a for every v, since a(u, v) = (f, v).  For v = u_h,
    Galerkin orthogonality gives ‖u − u_h‖²_a = a(u, u) − a(u_h, u_h), with a(u, u) =
    (f, u) exact and a(u_h, u_h) = u_hᵀAu_h from the matrix (E(u_h) uses (f, u_h)
    instead); for v = u_h + δφ_k it gives Pythagoras, ‖u − u_h‖²_a + δ² a(φ_k, φ_k)."""
    s = 0.5
    disc = laplace.discretise(meshes.disk_uniform(3), s, 1.0)
    uh = laplace.solve_laplace(disc)
    e_exact = -0.5 * exact.disk_energy(s)          # E(u) = ½ a(u, u) − (f, u) = −½ (f, u)
    err = energy_error(assembly.energy(disc.A, disc.b, uh), e_exact)
    assert err == pytest.approx(np.sqrt(exact.disk_energy(s) - uh @ disc.A @ uh), rel=1e-9)
    assert 0.05 < err < 0.5                        # a real discretisation error
    k, delta = len(uh) // 2, 0.1
    v = uh.copy()
    v[k] += delta
    err_v = energy_error(assembly.energy(disc.A, disc.b, v), e_exact)
    assert err_v == pytest.approx(np.sqrt(err ** 2 + delta ** 2 * disc.A[k, k]), rel=1e-9)
    np.testing.assert_allclose(energy_error([assembly.energy(disc.A, disc.b, uh),
                                             assembly.energy(disc.A, disc.b, v)], e_exact),
                               [err, err_v], rtol=1e-15)


def test_fit_rate_and_variants_in_rate_table():
    N = np.array([100, 400, 1600])
    df = pd.DataFrame({"example": 3, "family": "uniform", "s": 0.6, "dofs": np.tile(N, 2),
                       "error": np.r_[N ** -0.25, 2 * N ** -0.5],
                       "variant": ["printed"] * 3 + ["signchange"] * 3})
    assert fit_rate(N, N ** -0.25) == pytest.approx(-0.25)
    t = rate_table(df).set_index("variant")
    assert t.loc["printed", "rate"] == pytest.approx(-0.25)
    assert t.loc["printed", "paper_rate"] == pytest.approx(-0.220)
    assert t.loc["signchange", "rate"] == pytest.approx(-0.5)
    assert pd.isna(t.loc["signchange", "paper_rate"])


def test_rate_table_fits_only_runs_well_above_the_reference_error():
    N = np.array([100, 400, 1600, 6400])
    err = N ** -0.5
    df = pd.DataFrame({"example": 2, "family": "graded", "s": 0.5, "dofs": N, "error": err})
    exact = rate_table(df).iloc[0]
    assert exact.n_points == 4 and exact.n_excluded == 0 and exact.reference_error == 0
    # the last run's error is below 3 × the reference's: left out of the fit
    df["reference_error"] = err[-1] / 2.5
    t = rate_table(df).iloc[0]
    assert (t.n_points, t.n_excluded, t.dof_max) == (3, 1, 1600)
    assert t.rate == pytest.approx(-0.5) and t.smallest_error == pytest.approx(err[-1])
    # a reference as coarse as the runs leaves no rate, rather than a wrong one
    df["reference_error"] = err[1] / 2
    t = rate_table(df).iloc[0]
    assert t.n_points == 1 and np.isnan(t.rate)


def test_rate_bounds_are_the_extreme_fits_over_every_error_within_its_bounds():
    """rate_bounds against brute force: the least and greatest fitted slope over all 2^n
    corners of the box lower_i ≤ e_i ≤ upper_i, and no slope of a point inside the box
    beyond them; exact errors give the fit itself."""
    from itertools import product

    from fracfem_workflow.report import error_interval, rate_bounds

    rng = np.random.default_rng(3)
    N = np.array([300, 900, 2500, 8000, 30000])
    err = 2.0 * N ** -0.3 * np.exp(rng.normal(0, 0.05, N.size))
    u = err * rng.uniform(0.05, 0.3, N.size)
    lo, hi = rate_bounds(N, *error_interval(err, u))
    corners = [fit_rate(N, err + np.array(signs) * u) for signs in product((-1, 1), repeat=5)]
    assert lo == pytest.approx(min(corners), abs=1e-12)
    assert hi == pytest.approx(max(corners), abs=1e-12)
    inside = [fit_rate(N, err + rng.uniform(-1, 1, N.size) * u) for _ in range(200)]
    assert lo <= min(inside) and max(inside) <= hi and lo < fit_rate(N, err) < hi
    assert rate_bounds(N, err, err) == pytest.approx((fit_rate(N, err),) * 2, abs=1e-12)
    # an error that could be 0: the finest run makes the least slope −inf, the coarsest
    # the greatest +inf; an unknown bound, a single run, bounds the wrong way round
    assert rate_bounds(N, np.where(N == N[-1], 0.0, err), err)[0] == -np.inf
    assert rate_bounds(N, np.where(N == N[0], 0.0, err), err)[1] == np.inf
    assert np.isnan(rate_bounds(N, err * np.nan, err)).all()
    assert np.isnan(rate_bounds(N[:1], err[:1], err[:1])).all()
    with pytest.raises(ValueError, match="lower <= upper"):
        rate_bounds(N, err + u, err)
    with pytest.raises(ValueError, match="uncertainty must be >= 0"):
        error_interval(err, -u)
    # in the rate table: through the fitted runs only, around the rate
    df = pd.DataFrame({"example": 4, "family": "graded", "s": 0.5, "dofs": N, "error": err,
                       "reference_error": u.max()})
    t = rate_table(df).iloc[0]
    keep = err > 3 * u.max()
    assert (t.rate_min, t.rate_max) == pytest.approx(
        np.round(rate_bounds(N[keep], *error_interval(err[keep], u.max())), 3))
    assert t.rate_min < t.rate < t.rate_max
    # a fitted run whose bound is unknown: a rate, but no bounds
    t = rate_table(df.assign(reference_error=np.where(N == N[0], np.nan, 0.01))).iloc[0]
    assert np.isfinite(t.rate) and np.isnan(t.rate_min) and np.isnan(t.rate_max)


def test_energy_error_bounds_are_those_of_every_reference_energy_within_its_uncertainty():
    """Examples 2, 3: error = √(2 (E_h − E_ref)), the reference energy E_ref uncertain by
    δE, the table's reference_error = √(2 δE).  The interval of error_interval(energy=True)
    is exactly the range of √(2 (E_h − E)) over E in [E_ref − δE, E_ref + δE], tighter
    than error ∓ reference_error; and the rate bounds of the rate table built from it
    contain the rate against every such E (one E for all runs, as in the pipeline)."""
    from fracfem_workflow.report import error_interval, rate_bounds

    N = np.array([1000, 2000, 4000, 8000])
    E_ref, dE = -1.0, 2e-5
    E_h = E_ref + 0.5 * (0.8 * N ** -0.5) ** 2
    err, u = energy_error(E_h, E_ref), np.sqrt(2 * dE)
    lo, hi = error_interval(err, u, energy=True)
    scan = np.array([energy_error(E_h, E) for E in np.linspace(E_ref - dE, E_ref + dE, 101)])
    assert lo == pytest.approx(scan.min(axis=0), rel=1e-12)
    assert hi == pytest.approx(scan.max(axis=0), rel=1e-12)
    plain = error_interval(err, u)
    assert np.all(plain[0] < lo) and np.all(hi < plain[1])
    least, greatest = rate_bounds(N, lo, hi)
    rates = [fit_rate(N, e) for e in scan]
    assert least <= min(rates) and max(rates) <= greatest
    # the rate table takes this interval for Examples 1-3, error ∓ reference_error after
    # (a quarter of the uncertainty, so that every run is fitted)
    df = pd.DataFrame({"example": 2, "family": "graded", "s": 0.5, "dofs": N, "error": err,
                       "reference_error": u / 4})
    t = rate_table(df).iloc[0]
    assert t.n_points == N.size
    assert (t.rate_min, t.rate_max) == pytest.approx(
        np.round(rate_bounds(N, *error_interval(err, u / 4, energy=True)), 3))
    t = rate_table(df.assign(example=4)).iloc[0]
    assert (t.rate_min, t.rate_max) == pytest.approx(
        np.round(rate_bounds(N, *error_interval(err, u / 4)), 3))
    assert t.rate_min < rate_table(df).iloc[0].rate_min


def test_fit_bounds_per_run_nan_and_infinite():
    """One bound per run (the parabolic errors' own uncertainties): each run is judged by
    its own; an unknown bound (NaN) excludes nothing, an infinite one its run, and an error
    that is not finite is never fitted; with_fit_bound falls back to the reference run's
    error only where the uncertainty is unknown."""
    from fracfem_workflow.report import fit_mask, with_fit_bound

    err = np.array([0.5, 0.3, 0.2, 0.1, np.nan])
    keep = fit_mask(err, np.array([0.1, 0.2, np.nan, np.inf, np.nan]))
    assert keep.tolist() == [True, False, True, False, False]
    assert fit_mask(err[:4], 0.05).tolist() == [True, True, True, False]
    df = pd.DataFrame({"error": err[:3], "error_uncertainty": [0.01, np.nan, np.inf],
                       "reference_error": 0.07})
    b = with_fit_bound(df)
    assert b.reference_error.tolist() == [0.01, 0.07, np.inf]
    assert (b.reference_run_error == 0.07).all()
    N = np.array([100.0, 400, 1600, 6400])
    t = rate_table(pd.DataFrame({"example": 4, "family": "uniform", "s": 0.5, "dofs": N,
                                 "error": N ** -0.3,
                                 "reference_error": [1e-3, 1e-3, 1.0, 1e-3]})).iloc[0]
    assert (t.n_points, t.n_excluded) == (3, 1) and t.rate == pytest.approx(-0.3)
    assert t.reference_error == 1.0


def test_paper_rate_only_for_the_papers_order_and_data():
    from fracfem_workflow.report import PAPER_RATES, paper_rate
    assert paper_rate(1, "graded", 0.5) == PAPER_RATES[(1, "graded")]
    assert paper_rate(1, "graded", 0.3) is None              # another s: the paper has none
    assert paper_rate(3, "uniform", 0.6, "printed") == PAPER_RATES[(3, "uniform")]
    assert paper_rate(3, "uniform", 0.6, "signchange") is None
    assert paper_rate(4, "adaptive", 0.5, "u2") == PAPER_RATES[(4, "adaptive")]


def test_geometric_tail_is_exact_for_a_geometric_family_and_refuses_divergence():
    from fracfem_workflow.report import geometric_tail

    # u_k = u + C q^k v (v a unit vector): ‖u_k − u_{k+1}‖ = C q^k (1 − q)
    C, q = 0.7, 0.45
    d12, d23 = C * q * (1 - q), C * q**2 * (1 - q)
    r, err = geometric_tail(d12, d23)
    assert r == pytest.approx(q, rel=1e-14)
    assert err == pytest.approx(C * q**3, rel=1e-13)       # ‖u_3 − u‖
    with pytest.raises(RuntimeError, match="does not converge"):
        geometric_tail(0.1, 0.1)


def test_reference_family_error_measures_a_geometric_family_exactly():
    """u_k = u + C q^k v on one mesh and time interval: the measured error of u_3 is
    C q^3 ‖v‖_a, the distances C q^k (1 − q) ‖v‖_a."""
    from fracfem import discretise
    from fracfem.transfer import SpaceTimeReference
    from fracfem_workflow.report import reference_family_error

    mesh = meshes.disk_uniform(2)
    disc = discretise(mesh, 0.5)
    rng = np.random.default_rng(5)
    u, v = (disc.extend(rng.standard_normal(len(disc.free))) for _ in range(2))
    C, q = 0.8, 0.5
    run = [[(0.0, 1.0, mesh, u + C * q**k * v)] for k in (1, 2, 3)]
    norm_v = np.sqrt(v[disc.free] @ disc.A @ v[disc.free])
    fam = reference_family_error(run[0], (run[1], disc.A, disc.free),
                                 SpaceTimeReference(run[2], disc.A, disc.free))
    assert fam["d12"] == pytest.approx(C * q * (1 - q) * norm_v, rel=1e-10)
    assert fam["ratio"] == pytest.approx(q, rel=1e-10)
    assert fam["error"] == pytest.approx(C * q**3 * norm_v, rel=1e-10)


def test_join_tiers_puts_each_tiers_rate_beside_the_same_row():
    from fracfem_workflow.report import join_tiers
    ours = pd.DataFrame({"example": [1, 2, 4], "variant": ["", "", "u1"],
                         "family": ["adaptive", "uniform", "adaptive"], "s": [0.5, 0.5, 0.5],
                         "rate": [-0.5, -0.25, -0.16], "n_points": [5, 4, 2],
                         "dof_max": [15000, 8000, 60000], "smallest_error": [0.01, 0.1, 0.14]})
    big = pd.DataFrame({"example": [4, 1, 3], "variant": ["u1", np.nan, ""],
                        "family": ["adaptive", "adaptive", "graded"], "s": [0.5, 0.5, 0.6],
                        "rate": [-0.31, -0.49, -0.4], "n_points": [6, 9, 3],
                        "dof_max": [10**7, 10**5, 10**4], "smallest_error": [0.03, 0.002, 0.01]})
    out = join_tiers(ours, {"paper-scale": big})
    assert list(out.rate) == list(ours.rate)                  # rows and order kept
    assert list(out["rate_paper-scale"].iloc[[0, 2]]) == [-0.49, -0.31]
    assert np.isnan(out["rate_paper-scale"].iloc[1])         # that tier has no such row
    assert list(out["dof_max_paper-scale"].iloc[[0, 2]]) == [10**5, 10**7]
    assert len(out) == 3                                      # its extra row is not added
    with pytest.raises(ValueError, match="repeats a row"):
        join_tiers(ours, {"x": pd.concat([big, big])})
    with pytest.raises(ValueError, match="lacks the columns"):
        join_tiers(ours, {"x": big.drop(columns="dof_max")})


def test_whole_numbers_prints_counts_whole_and_missing_blank():
    from fracfem_workflow.report import whole_numbers
    df = pd.DataFrame({"passes": [3, 12], "dof_max": [16440205.0, np.nan],
                       "rate": [-0.25, np.nan]})
    shown = whole_numbers(df, ["dof_max"])
    page = shown.to_markdown(index=False, floatfmt=".4g")
    (rows,) = page_tables(page)
    assert rows[0]["dof_max"] == "16440205" and "e+07" not in page
    assert rows[1]["dof_max"] == ""                           # missing DOFs: blank
    assert rows[1]["rate"] == "nan"                           # a rate is not a count
    assert shown["passes"].tolist() == [3, 12] and type(shown["passes"][0]) is int
    assert df["dof_max"].dtype == float                       # the frame is not changed
    with pytest.raises(ValueError, match="column 'rate': -0.25 is not a whole number"):
        whole_numbers(df, "rate")                             # refused, not rounded to 0


def test_local_slopes_per_series():
    from fracfem_workflow.report import local_slopes
    N = np.array([10.0, 40.0, 160.0, 10.0, 100.0])
    err = np.concatenate([N[:3] ** -0.25, [1.0, 0.1]])
    fam = ["a", "a", "a", "b", "b"]
    slopes = local_slopes(N, err, fam).to_numpy()
    assert np.isnan(slopes[0]) and np.isnan(slopes[3])     # each series' first run
    np.testing.assert_allclose(slopes[[1, 2, 4]], [-0.25, -0.25, -1.0])
    # two keys: (s, family); a series of one run has no slope
    s = [0.5, 0.5, 0.75, 0.5, 0.5]
    two = local_slopes(N, err, (s, fam)).to_numpy()
    assert np.isnan(two[2]) and two[1] == pytest.approx(-0.25)


def test_eta_energy_time_swaps_the_time_term():
    from fracfem_workflow.report import eta_energy_time
    runs = pd.DataFrame({"eta": [5.0, 2.0], "eta2_time": [16.0, 3.0],
                         "eta2_time_anorm": [7.0, 1.0]})
    np.testing.assert_allclose(eta_energy_time(runs), [4.0, np.sqrt(2.0)])
    assert eta_energy_time(runs.drop(columns="eta2_time_anorm")).isna().all()


def test_contact_extent_counts_the_contact_elements_and_their_area():
    """All of a disk mesh in contact: every element, and √(area/π) of its polygon; none: 0;
    one multiplier per triangle or ValueError."""
    import fracfem as ff
    from fracfem_workflow.report import contact_extent
    m = ff.disk_uniform(3)
    p, t = m.p, m.t
    a, b, c = (p[:, t[k]] for k in range(3))
    area = 0.5 * np.abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])).sum()
    full = contact_extent(p, t, -np.ones(t.shape[1]))
    assert full["contact elements"] == t.shape[1]
    assert full["contact radius"] == pytest.approx(np.sqrt(area / np.pi))
    assert full["contact radius"] < 1.0
    lam = np.zeros(t.shape[1])
    assert contact_extent(p, t, lam) == {"contact elements": 0, "contact radius": 0.0}
    inner = np.linalg.norm(p[:, t].mean(axis=1), axis=0) < 0.3
    lam[inner] = -1.0
    got = contact_extent(p, t, lam)
    assert got["contact elements"] == inner.sum() and 0 < got["contact radius"] < 0.5
    with pytest.raises(ValueError, match="one multiplier per triangle"):
        contact_extent(p, t, lam[:-1])


def test_markdown_table_formats_each_column_as_named():
    """Counts whole and blank where missing, a named column in its own format, every other
    number to the digits asked for."""
    from fracfem_workflow.report import markdown_table
    df = pd.DataFrame({"steps": [5, 330], "dofs": [113.0, np.nan], "t_wall": [0.41, 10310.44],
                       "eta": [2.16312, 0.0724771]})
    (rows,) = page_tables(markdown_table(df, ["dofs"], {"t_wall": ".1f"}, digits=".3g"))
    assert [r["steps"] for r in rows] == ["5", "330"]
    assert [r["dofs"] for r in rows] == ["113", ""]
    assert [r["t_wall"] for r in rows] == ["0.4", "10310.4"]
    assert [r["eta"] for r in rows] == ["2.16", "0.0725"]
