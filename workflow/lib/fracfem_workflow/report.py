"""Convergence rates and the paper's reference values (Section 8)."""
from __future__ import annotations

import numpy as np
import pandas as pd

__all__ = ["PAPER_RATES", "PAPER_S", "REFERENCE_MARGIN", "paper_rate", "fit_rate", "fit_mask",
           "masked_rate",
           "rate_table", "extrapolate_energy", "extrapolation_uncertainty",
           "energy_error", "contact_extent", "time_to_reach", "algorithm_c_table", "PARTS",
           "whole_numbers", "markdown_table"]

# error in H^s vs DOFs (parabolic: vs space-time DOFs), paper Section 8
PAPER_RATES = {
    (1, "uniform"): -0.252, (1, "graded"): -0.540, (1, "adaptive"): -0.510,
    (2, "uniform"): -0.245, (2, "graded"): -0.498, (2, "adaptive"): -0.363,
    (3, "uniform"): -0.220, (3, "graded"): -0.454, (3, "adaptive"): -0.429,
    (4, "uniform"): -0.173, (4, "graded"): -0.325, (4, "adaptive"): -0.319,
    (5, "uniform"): -0.156, (5, "graded"): -0.322, (5, "adaptive"): -0.323,
}
PAPER_S = {1: 0.5, 2: 0.5, 3: 0.6, 4: 0.5, 5: 0.6}
# data sets the paper's rates refer to: Example 3 as printed (f = 1), Example 4 with
# either initial value (the paper gives one set of rates for both)
PAPER_VARIANTS = ("", "printed", "u1", "u2")


def paper_rate(example, family, s, variant=""):
    """The paper's rate for this example and family, or None where the paper has none
    (an order s other than the paper's, or a data set the paper did not run)."""
    if not np.isclose(float(s), PAPER_S[int(example)]) or str(variant) not in PAPER_VARIANTS:
        return None
    return PAPER_RATES.get((int(example), family))


def fit_rate(dofs, errors) -> float:
    """Least-squares slope of log(error) against log(DOFs) over all points."""
    dofs = np.asarray(dofs, dtype=float)
    errors = np.asarray(errors, dtype=float)
    if len(dofs) < 2 or np.any(~np.isfinite(errors)) or np.any(errors <= 0):
        raise ValueError("fit_rate needs at least two finite positive errors")
    return float(np.polyfit(np.log(dofs), np.log(errors), 1)[0])


def local_slopes(dofs, errors, series) -> pd.Series:
    """Slope of log(error) against log(DOFs) from the previous run of the same series
    (rows in order within each series; NaN for a series' first run).  series: the
    series of each row, or a tuple of such keys."""
    dofs = pd.Series(np.asarray(dofs, dtype=float))
    errors = pd.Series(np.asarray(errors, dtype=float))
    keys = [pd.Series(np.asarray(k)) for k in (series if isinstance(series, tuple)
                                                else (series,))]
    return (np.log(errors).groupby(keys).diff() / np.log(dofs).groupby(keys).diff())


def cut_series(steps: pd.DataFrame, max_dofs: int, name: str) -> pd.DataFrame:
    """The steps of a series up to its first with at least max_dofs DOFs: the series
    Algorithm B gives when it stops there (its stopping rule).  A series that never
    reaches max_dofs cannot be cut, nor one whose start mesh has max_dofs DOFs already
    (one step: no rate): ValueError."""
    reached = np.flatnonzero(steps.dofs.to_numpy() >= max_dofs)
    if not len(reached):
        raise ValueError(f"max_dofs={max_dofs} is beyond the series {name!r}, which ends at "
                         f"{int(steps.dofs.iloc[-1])} DOFs; it must be at most that")
    if reached[0] == 0:
        raise ValueError(f"max_dofs={max_dofs} is reached by the start mesh of the series "
                         f"{name!r} ({int(steps.dofs.iloc[0])} DOFs): no step to fit a rate "
                         "through; it must exceed the start mesh's DOFs")
    return steps.iloc[:reached[0] + 1]


def eta_energy_time(runs: pd.DataFrame) -> pd.Series:
    """η_a of Algorithm C's passes: η with its time term (``eta2_time``, the
    indicator's h^{−2s}‖·‖²_{L²} form) replaced by the same term in the energy norm
    (``eta2_time_anorm``); NaN where a run has no such column or value."""
    if "eta2_time_anorm" not in runs:
        return pd.Series(np.nan, index=runs.index)
    return np.sqrt(runs.eta ** 2 - runs.eta2_time + runs.eta2_time_anorm)


# A rate is fitted only through runs whose error exceeds REFERENCE_MARGIN times the
# reference's own error: closer to it, the measured error is as much the reference's as
# the run's.  Fixed before any rate was looked at; the README states it.
REFERENCE_MARGIN = 3.0


def fit_mask(errors, reference_error=0.0) -> np.ndarray:
    """The runs a rate is fitted through: error > REFERENCE_MARGIN · reference_error
    (every run when the reference is exact, reference_error = 0); reference_error is one
    number or one per run (the parabolic examples: each run's uncertainty).  A reference
    error that is unknown (NaN) excludes nothing, an infinite one excludes its run; an
    error that is not finite is never fitted."""
    errors = np.asarray(errors, dtype=float)
    ref = np.broadcast_to(np.asarray(0.0 if reference_error is None else reference_error,
                                     dtype=float), errors.shape)
    return np.where(np.isnan(ref), True, errors > REFERENCE_MARGIN * ref) & np.isfinite(errors)


def masked_rate(dofs, errors, keep) -> float:
    """fit_rate through the runs where ``keep`` holds; NaN when fewer than two do."""
    keep = np.asarray(keep, dtype=bool)
    dofs, errors = np.asarray(dofs, dtype=float), np.asarray(errors, dtype=float)
    return fit_rate(dofs[keep], errors[keep]) if keep.sum() >= 2 else float("nan")


# Examples 1-3 measure the error as √(2 |E(u_h) − E_ref|) (error_interval's energy=True)
ENERGY_EXAMPLES = 3


def error_interval(error, uncertainty, energy=False):
    """(lower, upper) bounds of each run's true error from its measured ``error`` and the
    ``uncertainty`` of the reference it was measured against.

    energy=False (Examples 4, 5: a distance to the reference's limit, uncertain by up to
    ``uncertainty``): error ∓ uncertainty, the lower bound at least 0.  energy=True
    (Examples 2, 3: error = √(2 (E(u_h) − E_ref)) and uncertainty = √(2 δE), E_ref off by
    up to δE): √(error² ∓ uncertainty²), the lower at least 0 — inside error ∓ uncertainty."""
    e = np.asarray(error, dtype=float)
    u = np.asarray(uncertainty, dtype=float)
    if np.any(u < 0):
        raise ValueError(f"uncertainty must be >= 0, got {np.min(u)}")
    if energy:
        return np.sqrt(np.maximum(e ** 2 - u ** 2, 0.0)), np.sqrt(e ** 2 + u ** 2)
    return np.maximum(e - u, 0.0), e + u


def rate_bounds(dofs, lower, upper) -> tuple:
    """(least, greatest) least-squares slope of log e against log dofs over every choice
    of each run's error e_i within [lower_i, upper_i], run by run, independently.

    The slope is Σ w_i log e_i with w_i = (x_i − x̄) / Σ (x_j − x̄)², x = log dofs: linear
    in each log e_i, so the least slope takes every run with w_i > 0 (finer than the mean)
    at its lower bound and every other at its upper bound, and the greatest the reverse.
    A lower bound of 0 makes the least −inf (a run finer than the mean) or the greatest
    +inf (a coarser one); NaN for fewer than two runs or an unknown (NaN) bound."""
    x = np.log(np.asarray(dofs, dtype=float))
    lo = np.asarray(lower, dtype=float)
    hi = np.broadcast_to(np.asarray(upper, dtype=float), lo.shape)
    if len(x) < 2 or np.isnan(lo).any() or np.isnan(hi).any() or np.ptp(x) == 0:
        return float("nan"), float("nan")
    if np.any(lo < 0) or np.any(hi < lo) or not np.all(hi > 0):
        raise ValueError("need 0 <= lower <= upper and upper > 0 for every run")
    w = (x - x.mean()) / np.sum((x - x.mean()) ** 2)
    with np.errstate(divide="ignore"):
        log_lo, log_hi = np.log(lo), np.log(hi)
    # w_i = 0 contributes nothing whichever end is taken (avoids 0 · (−inf))
    least = np.sum(np.where(w > 0, w * log_lo, np.where(w < 0, w * log_hi, 0.0)))
    greatest = np.sum(np.where(w > 0, w * log_hi, np.where(w < 0, w * log_lo, 0.0)))
    return float(least), float(greatest)


def with_variant_key(df: pd.DataFrame) -> pd.DataFrame:
    """A copy of ``df`` whose ``variant`` column is a string ("" for none, or when
    the column is missing): the key by which the rate tables group and match their
    rows (TIER_KEYS)."""
    out = df.copy()
    out["variant"] = (out["variant"].astype(object).fillna("").astype(str)
                      if "variant" in out else "")
    return out


def rate_table(df: pd.DataFrame, x: str = "dofs", y: str = "error") -> pd.DataFrame:
    """One row per (example, variant, family, s): fitted rate next to the paper's.

    ``variant`` (optional column) separates data sets of one example; the paper's
    rate is shown for the paper's order s and the variants of PAPER_VARIANTS only.
    ``reference_error`` (optional column, 0 when absent: exact reference) is the
    reference's own error; only runs passing :func:`fit_mask` enter the fit, and a
    row with fewer than two of them has no rate (NaN).  ``rate_min`` and ``rate_max``
    (:func:`rate_bounds`) are the least and greatest rate of the same runs with each
    error anywhere within its :func:`error_interval` (energy errors for the examples up
    to ENERGY_EXAMPLES): NaN where ``rate`` is, or a bound is unknown.
    """
    df = with_variant_key(df)
    if "reference_error" not in df:
        df["reference_error"] = 0.0
    rows = []
    for (ex, var, fam, s), g in df.groupby(["example", "variant", "family", "s"], sort=True):
        paper = paper_rate(ex, fam, s, var)
        ref_err = float(g.reference_error.max())
        mask = fit_mask(g[y], g.reference_error)
        keep = g[mask]
        rate = round(masked_rate(g[x], g[y], mask), 3)
        # Examples 1-3 measure errors from energies (E_ref uncertain), 4 and 5 distances
        lo, hi = rate_bounds(keep[x], *error_interval(keep[y], keep.reference_error,
                                                      energy=ex <= ENERGY_EXAMPLES))
        fitted = keep if len(keep) else g
        rows.append({"example": int(ex), "variant": var, "family": fam, "s": float(s),
                     "rate": rate, "rate_min": round(lo, 3), "rate_max": round(hi, 3),
                     "paper_rate": paper, "n_points": len(keep),
                     "n_excluded": len(g) - len(keep),
                     "dof_min": int(fitted[x].min()), "dof_max": int(fitted[x].max()),
                     "reference_error": ref_err, "smallest_error": float(g[y].min())})
    return pd.DataFrame(rows)


# a tier whose parabolic series are unfinished has, in place of its rates.csv, whichever of
# these partial tables its rules have written (file name: what it holds)
PARTIAL_RATE_TABLES = {"rates-elliptic.csv": "Examples 1–3",
                       "rates-parabolic.csv": "parabolic problems whose error tables are kept"}

TIER_KEYS = ["example", "variant", "family", "s"]
TIER_COLUMNS = ["rate", "n_points", "dof_max", "smallest_error"]


def whole_numbers(df: pd.DataFrame, columns=()) -> pd.DataFrame:
    """The table as a page shows it: integer columns, and the ``columns`` named (counts
    and DOFs that are floats because a row has none), as whole numbers, blank where
    missing.  As they are, an integer column of an all-numeric frame prints as floats,
    and a float count in exponent form (1.98e+03) with its missing values as nan.

    A named column holding a value that is not a whole number is refused (ValueError
    naming the column and the value), not rounded."""
    named = {columns} if isinstance(columns, str) else set(columns)
    shown = df.copy()
    for c in shown.columns:
        if c in named or pd.api.types.is_integer_dtype(shown[c]):
            values = []
            for v in shown[c]:
                if pd.isna(v):
                    values.append(None)
                    continue
                try:
                    whole = float(v).is_integer()
                except (TypeError, ValueError):
                    whole = False
                if not whole:
                    raise ValueError(f"column {c!r}: {v!r} is not a whole number (a count "
                                     "or DOFs shown whole)")
                values.append(int(v))
            shown[c] = pd.Series(values, index=shown.index, dtype=object)
    return shown


def markdown_table(df: pd.DataFrame, counts=(), fixed=None, digits: str = ".4g") -> str:
    """The table in Markdown as a page prints it: integer columns and the ``counts`` named
    whole (:func:`whole_numbers`), the columns of ``fixed`` in the format it maps them to
    (times and memory in fixed notation: ``{"t_wall": ".1f"}``), every other number to
    ``digits``."""
    fixed = fixed or {}
    return whole_numbers(df, counts).to_markdown(
        index=False, floatfmt=[fixed.get(c, digits) for c in df.columns])


def join_tiers(rates: pd.DataFrame, others: dict) -> pd.DataFrame:
    """The rate table with the rates of other tiers beside it.

    ``others`` maps a tier's name to its rate table (as :func:`rate_table`);
    each adds the columns ``<column>_<name>`` for the columns TIER_COLUMNS,
    matched on (example, variant, family, s), NaN where that tier has no such
    row.  A row of another tier that this table lacks is not added."""
    out = with_variant_key(rates)
    for name, other in others.items():
        missing = [c for c in TIER_KEYS + TIER_COLUMNS if c not in other]
        if missing:
            raise ValueError(f"tier {name!r}: rate table lacks the columns {missing}")
        o = with_variant_key(other[TIER_KEYS + TIER_COLUMNS])
        if o.duplicated(TIER_KEYS).any():
            raise ValueError(f"tier {name!r}: rate table repeats a row")
        o = o.rename(columns={c: f"{c}_{name}" for c in TIER_COLUMNS})
        out = out.merge(o, on=TIER_KEYS, how="left", validate="one_to_one")
    return out


def extrapolate_energy(dofs, energies) -> dict:
    """Limit E_∞ of energies E_k = E_∞ + C N_k^{−β} through the last three points.

    The three-point (Aitken-type) fit solves the model exactly on the three
    finest meshes: β from the ratio of the two differences, then C and E_∞.  It
    is the reference energy of Examples 2 and 3, whose solutions are unknown;
    the workflow measures its accuracy on Example 1 (exact energy) and on the
    printed Example 3 (exact pure-slip solution).  Raises when the energies do
    not decrease monotonically with a slowing rate (no such model fits).
    """
    from scipy.optimize import brentq

    N = np.asarray(dofs, dtype=float)
    E = np.asarray(energies, dtype=float)
    if N.shape != E.shape or N.ndim != 1 or len(N) < 3:
        raise ValueError("extrapolate_energy needs at least three (dofs, energy) pairs")
    order = np.argsort(N)
    N, E = N[order][-3:], E[order][-3:]
    if not (np.all(np.isfinite(E)) and np.all(np.diff(N) > 0)):
        raise ValueError("extrapolate_energy needs finite energies on distinct DOF counts")
    d1, d2 = E[0] - E[1], E[1] - E[2]
    if not (d1 > 0 and d2 > 0):
        raise ValueError(f"energies {E.tolist()} do not decrease on the three finest meshes: "
                         "no model E_∞ + C N^(−β) with C, β > 0 fits")
    ratio = d1 / d2

    def gap(b):
        return (N[0] ** -b - N[1] ** -b) / (N[1] ** -b - N[2] ** -b) - ratio

    lo, hi = 1e-4, 10.0
    if gap(lo) * gap(hi) > 0:
        raise ValueError(f"energy differences {d1:.3e}, {d2:.3e} on {N.tolist()} DOFs admit "
                         "no exponent β in (0, 10)")
    beta = brentq(gap, lo, hi, xtol=1e-12)
    C = d1 / (N[0] ** -beta - N[1] ** -beta)
    return {"energy": float(E[2] - C * N[2] ** -beta), "beta": float(beta), "C": float(C),
            "dofs_used": N.astype(int).tolist()}


def extrapolation_uncertainty(dofs, energies) -> dict:
    """:func:`extrapolate_energy` through the three finest runs, and its uncertainty.

    ``uncertainty`` = √(2 max(|E_∞ − E_∞'|, |E_∞' − E_∞''|)) (the scale of
    :func:`energy_error`), E_∞' and E_∞'' the same extrapolation without the finest run,
    and without the two finest: how much the limit still moved over the last two runs
    added.  Two changes rather than one, because the exponent fitted through three runs
    of an adaptive series oscillates from window to window.  Needs at least five runs.
    """
    N = np.asarray(dofs, dtype=float)
    E = np.asarray(energies, dtype=float)
    if N.shape != E.shape or N.ndim != 1 or len(N) < 5:
        raise ValueError("extrapolation_uncertainty needs at least five (dofs, energy) pairs, "
                         f"got {len(N)}")
    order = np.argsort(N)
    N, E = N[order], E[order]
    last = extrapolate_energy(N, E)
    previous = extrapolate_energy(N[:-1], E[:-1])
    before = extrapolate_energy(N[:-2], E[:-2])
    change = max(abs(last["energy"] - previous["energy"]),
                 abs(previous["energy"] - before["energy"]))
    return {**last, "previous": previous["energy"], "before": before["energy"],
            "uncertainty": float(np.sqrt(2.0 * change))}


def geometric_tail(d12: float, d23: float) -> tuple[float, float]:
    """(r, d₂₃ r/(1 − r)): the error of the finest of three runs u₁, u₂, u₃ of one family
    with consecutive distances d₁₂ = ‖u₁ − u₂‖, d₂₃ = ‖u₂ − u₃‖, if the family converges
    geometrically with the ratio r = d₂₃/d₁₂ of those distances."""
    r = d23 / d12
    if not 0.0 < r < 1.0:
        raise RuntimeError(f"the family does not converge: distances d12 = {d12:.4g}, "
                           f"d23 = {d23:.4g} (ratio {r:.3g})")
    return r, d23 * r / (1.0 - r)


def reference_family_error(coarsest, middle, reference) -> dict:
    """The measured error of a parabolic reference run from the two coarser runs of its
    family: d12 = ‖u₁ − u₂‖ in the a-norm of u₂'s mesh, d23 = ‖u₂ − u₃‖ in that of the
    reference, then :func:`geometric_tail`.

    coarsest: the pieces [(t0, t1, mesh, u)] of u₁; middle: (pieces, free-node operator,
    free nodes) of u₂; reference: the :class:`fracfem.transfer.SpaceTimeReference` of u₃.
    Returns {'d12', 'd23', 'ratio', 'error'}."""
    from fracfem.transfer import SpaceTimeReference

    pieces, A, free = middle
    d12 = SpaceTimeReference(pieces, A, free).distance(coarsest)
    d23 = reference.distance(pieces)
    r, err = geometric_tail(d12, d23)
    return {"d12": d12, "d23": d23, "ratio": r, "error": err}


def with_fit_bound(df):
    """A parabolic errors table with its reference's row (para_reference_error) in every
    row: that row's ``reference_error``, the finest run's own measured error, becomes
    ``reference_run_error``, and ``reference_error``, the bound of :func:`fit_mask`,
    becomes each run's ``error_uncertainty`` (the uncertainty of its distance to the
    family's limit), or the finest run's error where that is not measured (NaN: fewer
    than four runs of the family to extrapolate through; an infinite one stays)."""
    df = df.rename(columns={"reference_error": "reference_run_error"})
    unc = df["error_uncertainty"] if "error_uncertainty" in df else np.nan
    df["reference_error"] = pd.Series(unc, index=df.index, dtype=float).where(
        lambda u: u.notna(), df["reference_run_error"])
    return df


def energy_error(energy, reference) -> np.ndarray:
    """√(2 |E(u_h) − E_ref|): the energy-norm error for Example 1 (exact there)."""
    return np.sqrt(2.0 * np.abs(np.asarray(energy, dtype=float) - reference))


def contact_extent(points, triangles, lam) -> dict:
    """The discrete contact set of an obstacle problem whose multipliers λ_H belong to the
    triangles of T_H (points 2×N, triangles 3×M, lam M values): its number of elements
    (`contact elements`) and the radius of the disk of its area, √(area/π) (`contact
    radius`; 0 without contact)."""
    from fracfem import contact_set
    from fracfem.meshes import triangle_areas
    t = np.asarray(triangles)
    lam = np.asarray(lam, dtype=float)
    if lam.shape != (t.shape[1],):
        raise ValueError(f"lam has shape {lam.shape}, T_H {t.shape[1]} triangles: "
                         "the contact set needs one multiplier per triangle")
    contact = contact_set(lam)
    area = triangle_areas(points, t[:, contact]).sum()
    return {"contact elements": int(contact.sum()),
            "contact radius": float(np.sqrt(area / np.pi))}


def time_to_reach(wall_times, errors, level) -> float:
    """Wall time at which a series first reaches the error ``level`` (log-log
    interpolation between its runs, ordered by wall time); NaN if it never does."""
    order = np.argsort(np.asarray(wall_times, dtype=float), kind="stable")
    e = np.log(np.asarray(errors, dtype=float)[order])
    t = np.log(np.asarray(wall_times, dtype=float)[order])
    for k in range(len(e)):
        if e[k] <= np.log(level):
            if k == 0:
                return float(np.exp(t[0]))
            w = (e[k - 1] - np.log(level)) / (e[k - 1] - e[k])
            return float(np.exp(t[k - 1] + w * (t[k] - t[k - 1])))
    return np.nan


def algorithm_c_table(df):
    """Algorithm C per problem: the error's and the estimator's rate, and the efficiency
    index η/error of every pass."""
    rows = []
    for prob, d in df[df.family == "adaptive"].groupby("problem"):
        d = d.sort_values("spacetime_dofs")
        keep = fit_mask(d.error, d.reference_error)
        eff = d.eta / d.error
        parts = {}
        for part in PARTS:
            col = d[f"eta2_{part}"].clip(lower=0.0) ** 0.5 if f"eta2_{part}" in d else None
            # a part at round-off level (the obstacle's contact term) has no rate
            parts[f"η_{part} rate (same runs)"] = (
                np.nan if col is None or not np.all(col > 1e-6 * d.eta)
                else masked_rate(d.spacetime_dofs, col, keep))
        finest = d.iloc[-1]
        # the same with the time term in the energy norm (a diagnostic outside η)
        anorm = {}
        eta_a = eta_energy_time(d)
        if eta_a.notna().all():
            anorm = {"η_time,a rate (same runs)": masked_rate(
                         d.spacetime_dofs, d.eta2_time_anorm.clip(lower=0.0) ** 0.5, keep),
                     "η_a rate (same runs)": masked_rate(d.spacetime_dofs, eta_a, keep),
                     "η_a efficiency per pass": ", ".join(f"{e:.2f}"
                                                          for e in eta_a / d.error)}
        rows.append({"problem": prob, "passes": len(d),
                     "spacetime_dofs": int(d.spacetime_dofs.max()),
                     "error rate (fitted runs)": masked_rate(d.spacetime_dofs, d.error, keep),
                     "η rate (same runs)": masked_rate(d.spacetime_dofs, d.eta, keep),
                     "η rate (all)": fit_rate(d.spacetime_dofs, d.eta),
                     **parts,
                     "time share of η² (finest)": (finest.get("eta2_time", np.nan)
                                                    / finest.eta ** 2),
                     "fitted": int(keep.sum()),
                     "efficiency per pass": ", ".join(f"{e:.2f}" for e in eff),
                     "max/min": eff.max() / eff.min(), **anorm})
    return pd.DataFrame(rows)


PARTS = ("space", "time", "contact", "initial")    # the parts of η² (Theorem 6.18)
