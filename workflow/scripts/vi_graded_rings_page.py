"""Why Example 2's graded rate differs from the paper's: its graded family at every ring
count, not only at the ring counts the series picks.

The graded series takes T_H = disk_graded_aniso(h) for a few h, that is
disk_graded_rings(n) with n = ceil(1/h).  If the errors of every n between lie on one
power law of the DOFs, the series' rate is that power law's, whichever n it picks.  If
they do not, the rate through a few of them depends on which: the page fits every window
and every n, 2n, 4n family.  It also changes the measure: the mixed form's averaged
constraint lets u_h dip below χ, which lowers E(u_h); the lifted error measures ũ_h =
max(u_h, χ) at the fine nodes instead, which meets the constraint there.  Beside them: the
dip, its share of the lifted energy error, and the discrete contact set.
"""
import json
from pathlib import Path

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import DOFS, legend_below, plt, save
from fracfem_workflow.report import (contact_extent, energy_error, fit_mask, local_slopes,
                                     masked_rate, paper_rate)

SERIES = "graded series"
RATIO = "contact radius / reference"   # against the large reference run's
LIFTED = "lifted error"
SHARE = "dip's share"


def series_rings(series: pd.DataFrame, rings: pd.DataFrame) -> pd.Series:
    """The ring count of each run of the graded series (tags h<h>: n = ceil(1/h)), after
    checking that the ring-count run of that n is the same run: the same DOFs and the
    same energy (relative 1e-9).  A series run outside the ring counts: ValueError."""
    n = series.tag.map(lambda tag: ff.graded_ring_count(ff.parse_series_tag(tag)[1]))
    by_n = rings.set_index("n")
    missing = sorted(set(n) - set(by_n.index))
    if missing:
        raise ValueError(f"the graded series' ring counts {missing} lie outside the ring "
                         f"counts run, {int(by_n.index.min())}..{int(by_n.index.max())}; "
                         "widen example2.graded_rings")
    for tag, k, dofs, energy in zip(series.tag, n, series.dofs, series.energy):
        ring = by_n.loc[k]
        if int(ring.dofs) != int(dofs) or not np.isclose(ring.energy, energy, rtol=1e-9,
                                                         atol=0.0):
            raise ValueError(f"the graded run {tag} (n = {k}: {dofs} DOFs, E = {energy!r}) "
                             f"is not the ring-count run n = {k} ({int(ring.dofs)} DOFs, "
                             f"E = {ring.energy!r}): they must be the same mesh and solver")
    return n


def ring_table(rings, reference_energy, reference_error, reference_radius, series_n):
    """One row per ring count: the error √(2|E(u_h) − E_ref|) and the lifted error
    √(2|E(ũ_h) − E_ref|); whether a rate may be fitted through each (`fitted`, `lifted
    fitted`: its energy not below E_ref and its error above 3× the reference's own, as in
    the rate table); the local slopes to the next smaller ring count (both fitted); the
    dip's share (E(ũ_h) − E(u_h)) / (E(ũ_h) − E_ref), NaN where an energy lies below
    E_ref; the contact set; and whether the graded series has this n."""
    df = rings.sort_values("n").reset_index(drop=True)
    out = pd.DataFrame({"n": df.n, "dofs": df.dofs, "energy": df.energy,
                        "lifted energy": df["lifted energy"]})
    for energy, error, fitted, slope in (
            ("energy", "error", "fitted", "local slope"),
            ("lifted energy", LIFTED, "lifted fitted", "lifted local slope")):
        out[error] = energy_error(df[energy], reference_energy)
        keep = (df[energy].to_numpy() >= reference_energy) & fit_mask(out[error],
                                                                      reference_error)
        out[fitted] = keep
        both = keep & np.r_[False, keep[:-1]]
        local = local_slopes(out.dofs, out[error], np.zeros(len(out))).to_numpy()
        out[slope] = np.where(both, local, np.nan)
    out["largest dip"] = df["largest dip"]
    above = ((df.energy.to_numpy() >= reference_energy)
             & (df["lifted energy"].to_numpy() >= reference_energy))
    out[SHARE] = np.where(above, (df["lifted energy"] - df.energy)
                          / (df["lifted energy"] - reference_energy), np.nan)
    out["contact elements"] = df["contact elements"]
    out[RATIO] = df["contact radius"] / reference_radius
    out["in graded series"] = out.n.isin(set(series_n))
    return out


def window_rates(table, series_n) -> pd.DataFrame:
    """The rates of the error, through its fitted ring counts (the rate table's rule), and
    of the lifted error, through those of them where it is fitted too, among: the graded
    series' ring counts; every ring count; every ring count from n on
    (each n whose window holds at least four fitted by the error, n among them); each
    family n, 2n, 4n, ... (h halved; from its smallest fitted member, at least two
    fitted)."""
    fitted = table.n[table.fitted].to_numpy()
    last = int(fitted.max(initial=0))

    def rate(ns, column, mask):
        sub = table[mask]
        keep = sub.n.isin(ns).to_numpy()
        return masked_rate(sub.dofs, sub[column], keep), int(keep.sum())

    def row(name, ns):
        r, points = rate(ns, "error", table.fitted)
        lifted, lifted_points = rate(ns, LIFTED, table.fitted & table["lifted fitted"])
        return {"fitted through": name,
                "ring counts": ", ".join(map(str, sorted(set(fitted) & set(ns)))),
                "points": points, "rate": r, "lifted points": lifted_points,
                "lifted rate": lifted}

    every = set(table.n)
    rows = [row(SERIES, set(series_n)), row("every ring count", every)]
    rows += [row(f"every ring count from n = {k}", {n for n in every if n >= k})
             for k in fitted[1:] if (fitted >= k).sum() >= 4]
    for k in fitted:
        if k % 2 == 0 and k // 2 in fitted:
            continue                      # a member of the family from k/2
        family = {int(k) * 2 ** j for j in range(int(np.log2(last / k)) + 1)}
        if len(family & set(fitted)) >= 2:
            rows.append(row(f"n = {k}, {2 * k}, … (h halved)", family))
    return pd.DataFrame(rows)


def spread(rates: pd.DataFrame, column: str) -> str:
    """The range of a rate column over the windows and families (not the first two rows:
    the series and every ring count)."""
    r = rates[column].iloc[2:].dropna()
    return f"{r.min():.3f} … {r.max():.3f}" if len(r) else "nan"


def main(rings_csv, reference_json, errors_csv, reference_meshes, md, png):
    rings = pd.read_csv(rings_csv)
    ref = json.loads(Path(reference_json).read_text())
    e_ref, u_ref = ref["extrapolated_large"], ref["large_uncertainty"]
    meshes = np.load(reference_meshes)
    r_ref = contact_extent(meshes["pc"], meshes["tc"], meshes["lam"])["contact radius"]
    errors = pd.read_csv(errors_csv)
    series = errors[errors.family == "graded"]
    series_n = series_rings(series, rings)
    s = float(errors.s.iloc[0])
    table = ring_table(rings, e_ref, u_ref, r_ref, series_n)
    rates = window_rates(table, series_n)
    paper = paper_rate(2, "graded", s)
    paper = "" if paper is None else f" (the paper: {paper:.3f})"
    grading = float(rings.grading.iloc[0])
    with atomic_path(md) as tmp:
        tmp.write_text(
            f"Example 2 (s = {s:g}) on the graded family at every ring count: T_H = "
            f"disk_graded_rings(n, {grading:g}) for n = {int(table.n.min())}.."
            f"{int(table.n.max())}, T_h its refinement, solved as the graded series' runs "
            "are. The graded series takes T_H = disk_graded_aniso(h), the same mesh as n = "
            f"ceil(1/h): n = {', '.join(map(str, sorted(set(series_n))))} (the same DOFs "
            "and energies, checked).\n\n"
            "`error` is √(2|E(u_h) − E_ref|), as in the rate table, against the large "
            f"reference's E_ref = {e_ref:.6g}, whose own error is {u_ref:.3g}. The averaged "
            "constraint of the mixed form lets u_h dip below χ (`largest dip`: max(χ − u_h) "
            "over the fine nodes), which lowers E(u_h). `lifted error` is √(2|E(ũ_h) − "
            "E_ref|) for ũ_h = max(u_h, χ) at the fine nodes: u_h with its dip removed "
            "at the nodes. Between them ũ_h can still lie below the concave χ (by χ's "
            "interpolation error), so neither measure bounds the error in the energy norm "
            "(E(v) − E(u) ≥ ½‖v − u‖²_a holds for v ≥ χ everywhere); they show how much "
            "of the measured error the dip moves. `dip's share` = "
            "(E(ũ_h) − E(u_h)) / (E(ũ_h) − E_ref): the part of the lifted energy error "
            "that the dip takes off (nan where an energy lies below E_ref). A rate is "
            "fitted through the ring counts whose energy is not below E_ref and whose error "
            "exceeds 3× the reference's (`fitted`, as in the rate table); the lifted rate "
            "through those of them where the same holds for the lift (`lifted fitted`). "
            "The contact set is "
            "the elements of T_H where λ_H < 0; `contact radius / reference` compares "
            "√(area/π) with the large reference run's, "
            f"{r_ref:.4f}.\n\n"
            f"Rates{paper}; over the windows from n on and the h-halved families they "
            f"range over {spread(rates, 'rate')} (error) and "
            f"{spread(rates, 'lifted rate')} (lifted error):\n\n"
            + rates.to_markdown(index=False, floatfmt=".3f") + "\n\n"
            "Every ring count:\n\n" + table.to_markdown(index=False, floatfmt=".4g") + "\n")
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.8))
    for col, marker, colour, mask, name in (
            ("error", "o", "C0", table.fitted, "error"),
            (LIFTED, "s", "C1", table.fitted & table["lifted fitted"],
             "lifted error ($\\tilde u_h = \\max(u_h, \\chi)$ at the nodes)")):
        fit = table[mask]
        mine = fit[fit["in graded series"]]
        ax.loglog(fit.dofs, fit[col], marker=marker, color=colour, ms=4, lw=0.8,
                  label=f"{name}, every ring count")
        r = rates["rate" if col == "error" else "lifted rate"].iloc[0]
        ax.loglog(mine.dofs, mine[col], marker, mfc="none", mec=colour, ms=11, mew=1.5,
                  label=f"{col}: the {SERIES}' ring counts, rate {r:.3f}")
    fit = table[table.fitted]
    paper_slope = paper_rate(2, "graded", s)
    if paper_slope is not None and len(fit):
        x = fit.dofs.to_numpy(float)[[0, -1]]
        y0 = float(fit.error.iloc[0]) * 1.4
        ax.loglog(x, y0 * (x / x[0]) ** paper_slope, "k--", lw=0.8,
                  label=f"slope of the paper's rate, {paper_slope:.3f}")
    ax.axhline(3 * u_ref, color="grey", lw=0.7, ls=":", label="3× the reference's error")
    ax.set_xlabel(DOFS)
    ax.set_ylabel("$\\sqrt{2\\,|E - E_{\\mathrm{ref}}|}$")
    ax.set_title(f"Example 2 ($s = {s:g}$): graded meshes, every ring count $n$"
                 f"\nrate through every $n$: {rates.rate.iloc[1]:.3f} (error), "
                 f"{rates['lifted rate'].iloc[1]:.3f} (lifted)")
    legend_below(ax)
    share = table[table[SHARE].notna()]
    bx.plot(share.n, share[SHARE], "o-", color="C2", ms=4, lw=0.8, label="every ring count")
    mine = share[share["in graded series"]]
    bx.plot(mine.n, mine[SHARE], "o", mfc="none", mec="C2", ms=11, mew=1.5,
            label=f"the {SERIES}' ring counts")
    bx.set_ylim(0, max(1.0, float(share[SHARE].to_numpy().max(initial=0.0))) * 1.05)
    bx.xaxis.set_major_locator(plt.MaxNLocator(integer=True))
    bx.set_xlabel("ring count $n$ of $T_H$")
    bx.set_ylabel(SHARE)
    bx.set_title("the dip's share of the lifted energy error\n"
                 "$(E(\\tilde u_h) - E(u_h))\\,/\\,(E(\\tilde u_h) - E_{\\mathrm{ref}})$")
    legend_below(bx)
    save(fig, png)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.rings, snakemake.input.reference, snakemake.input.errors,  # noqa: F821
         snakemake.input.meshes, snakemake.output.md, snakemake.output.png)  # noqa: F821
