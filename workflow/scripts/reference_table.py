"""How good are the reference energies?  Table of references, their checks on
problems with exact energies, and the adaptive efficiency indices."""
import json

import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.report import (energy_error, extrapolate_energy, fit_mask, local_slopes,
                                     markdown_table)

# the large series' wall time and memory in whole seconds and MB, its DOFs and the number of
# families whole: printed to four significant digits they came out as 3.002e+05 and 2.035e+04
FIXED_COLUMNS = {"large time [s]": ".0f", "large peak MB": ".0f"}
COUNTS = ("large DOFs", "families")


def ex1_checks(ex1_csv, family):
    """The extrapolation applied to Example 1, whose energy is exact."""
    df = pd.read_csv(ex1_csv)
    rows = []
    for s, g in df[df.family == family].groupby("s"):
        E = -0.5 * g.fu_h.values
        exact = -0.5 * g.fu_exact.values[0]
        ext = extrapolate_energy(g.dofs.values, E)
        rows.append({"problem": f"ex1 (s={s:g})", "reference": "exact",
                     "E_ref": exact, "extrapolated": ext["energy"],
                     "reference error": float(energy_error(ext["energy"], exact)),
                     "finest error": float(df[df.s == s].error.min())})
    return rows


def reference_table_markdown(table):
    """The table of references as the page prints it: the counts whole, the large series'
    time and memory in fixed notation (FIXED_COLUMNS), the rest to four significant digits."""
    return markdown_table(table, COUNTS, FIXED_COLUMNS)


def main(refs, errors, ex1_csv, family, md):
    rows = ex1_checks(ex1_csv, family)
    for ref_json in refs:
        info = json.loads(open(ref_json).read())
        exact = info["exact"] is not None
        err = info["extrapolation_error"] if exact else info["large_uncertainty"]
        rows.append({"problem": info["problem"], "reference": info["kind"],
                     "E_ref": info["reference"],
                     "extrapolated": info[f"extrapolated_{family}"],
                     "reference error": err, "finest error": info["finest_error"],
                     "large DOFs": info["large_finest_dofs"],
                     "large extrapolated": info["extrapolated_large"],
                     "large uncertainty": info["large_uncertainty"],
                     "large check": info.get("large_check", np.nan),
                     "large time [s]": info["large_seconds"],
                     "large peak MB": info["large_peak_mb"],
                     "spread of the extrapolations": (np.nan if info["extrapolation_spread"]
                                                      is None else info["extrapolation_spread"]),
                     "families": info["extrapolation_families"],
                     **{f"{fam} rate range": ("—" if r is None else "{:.3f} … {:.3f}".format(*r))
                        for fam, r in sorted(info["rate_range_over_references"].items())}})
    table = pd.DataFrame(rows)
    table["ratio"] = table["reference error"] / table["finest error"]
    eff, graded = [], []
    for csv in errors:
        d = pd.read_csv(csv)
        g = d[d.family == "graded"].sort_values("dofs")
        g = g.assign(fitted=fit_mask(g.error, g.reference_error.iloc[0]) & ~g.below_reference)
        # slopes between consecutive runs of the fit (the others have no meaningful error)
        fit = g[g.fitted]
        g["local slope"] = pd.Series(local_slopes(fit.dofs, fit.error, fit.problem).to_numpy(),
                                     index=fit.index)
        graded.append(g[["problem", "tag", "dofs", "energy", "error", "fitted",
                         "local slope"]])
        a = d[d.family == "adaptive"].sort_values("dofs")
        eff.append({"problem": d.problem.iloc[0], "steps": len(a),
                    "dofs": f"{a.dofs.min()}–{a.dofs.max()}",
                    "efficiency min": a.efficiency.min(), "efficiency max": a.efficiency.max(),
                    "max/min": a.efficiency.max() / a.efficiency.min(),
                    "efficiency per step": " ".join(f"{v:.2f}" for v in a.efficiency)})
    text = ("Reference energies. For Example 1 and the printed Example 3 the energy is exact "
            "and 'reference error' is how far the three-point extrapolation of the "
            f"{family} series lands from it (√(2|E_extrap − E|)). "
            "For Example 2 and the sign-changing Example 3, E_ref is the three-point "
            "extrapolation of a large Algorithm B series computed with operator='auto' "
            "('large DOFs': its finest mesh), and 'reference error' is its measured "
            "uncertainty: √(2 max(|E_∞ − E_∞'|, |E_∞' − E_∞''|)), E_∞' and E_∞'' the "
            "extrapolations without the finest run and without the two finest ('large "
            "uncertainty'). On the printed Example 3 the same large series is "
            "extrapolated too and 'large check' is its distance to the exact energy, to be "
            "compared with its 'large uncertainty'. 'large time [s]', 'large peak MB': wall "
            "time and peak memory of the whole large series (when it was computed, on two "
            "cores). 'extrapolated' and 'spread of the extrapolations' "
            f"(√(2|max E − min E|) over the {family}, uniform, graded and adaptive families' "
            "limits; 'families' counts those that exist) are cross-checks; the rate ranges "
            "are the fitted rates with each family's limit, and the large series' limit, in "
            "turn as the reference. "
            "'finest error' is the smallest error of any family of the series.\n\n"
            + reference_table_markdown(table)
            + "\n\nEfficiency index η / error along the adaptive series (Algorithm B):\n\n"
            + pd.DataFrame(eff).to_markdown(index=False, floatfmt=".3g")
            + "\n\nThe graded family (the paper's anisotropic meshes) run by run: "
            "'fitted' marks the runs its rate is fitted through (error above 3× the "
            "reference error and energy above the reference energy), 'local slope' is "
            "the slope from the previous fitted run.\n\n"
            + pd.concat(graded).to_markdown(index=False, floatfmt=".4g") + "\n")
    if not np.all(np.isfinite(table["E_ref"])):
        raise RuntimeError("a reference energy is not finite")
    with atomic_path(md) as tmp:
        tmp.write_text(text)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.refs), list(snakemake.input.errors),  # noqa: F821
         snakemake.input.ex1, snakemake.params.family, snakemake.output.md)  # noqa: F821
