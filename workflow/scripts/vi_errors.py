"""Errors of Examples 2 and 3 in every family: energy differences against a reference.

error = √(2 |E(u_h) − E_ref|), E the discrete energy ½a(u_h,u_h) − (f,u_h) (+ j_H(u_h)).
For Example 1 this is exactly ‖u − u_h‖_a (Galerkin orthogonality).  E_ref is exact
for the printed Example 3 (pure slip) and otherwise the three-point extrapolation
of the reference family's energies (fracfem.report.extrapolate_energy).
"""
import json
import logging

import numpy as np
import pandas as pd

from fracfem import examples
from fracfem.io import atomic_path, with_provenance, write_table
from fracfem.report import energy_error, extrapolate_energy, fit_rate

WALL = ["t_mesh", "t_assembly", "t_factorisation", "t_schur", "t_pdas"]


def reference_energy(problem, cfg, series):
    """(E_ref, description dict); series holds all families (adaptive too)."""
    fam = cfg["reference"]["family"]
    info = {"problem": problem, "reference_family": fam}
    for name, g in series.groupby("family"):
        try:
            ext = extrapolate_energy(g.dofs, g.energy)
        except ValueError as err:
            if name == fam:       # the reference itself must exist
                raise
            # the other family only serves as a cross-check (pre-asymptotic on tiny meshes)
            logging.warning("no extrapolation of the %s family: %s", name, err)
            ext = {"energy": float("nan"), "beta": float("nan"), "dofs_used": []}
        info[f"extrapolated_{name}"] = ext["energy"]
        info[f"beta_{name}"] = ext["beta"]
        info[f"dofs_{name}"] = ext["dofs_used"]
    exact = None
    if problem.startswith("ex3-"):
        v = cfg["example3"]["variants"][problem[4:]]
        if v["b"] == 0 and v["a"] > v["F"]:
            exact = examples.pure_slip_energy(cfg["example3"]["s"], v["F"], v["a"])
    info["exact"] = exact
    ref = exact if exact is not None else info[f"extrapolated_{fam}"]
    info["reference"] = ref
    info["kind"] = "exact (pure slip)" if exact is not None else f"extrapolated ({fam})"
    return ref, info


def main(problem, cfg, series_csv, adaptive_csv, out_csv, out_json):
    series = pd.read_csv(series_csv)
    adapt = pd.read_csv(adaptive_csv)
    series = series.assign(t_wall=series[WALL].sum(axis=1), eta=np.nan)
    adapt = adapt.assign(t_wall=adapt.t_cumulative)
    cols = ["problem", "family", "s", "tag", "dofs", "energy", "eta", "t_wall", "peak_mem_mb"]
    df = pd.concat([series[cols], adapt[cols]], ignore_index=True)
    ref, info = reference_energy(problem, cfg, df)
    df["error"] = energy_error(df.energy, ref)
    df["below_reference"] = df.energy < ref   # E_h < E_ref: nonconforming or reference off
    df["efficiency"] = df.eta / df.error
    df["example"] = 2 if problem == "ex2" else 3
    df["variant"] = "" if problem == "ex2" else problem[4:]
    df["reference_energy"] = ref
    # the reference's own error against the finest error of the series
    finest = df.error.min()
    if info["exact"] is not None:
        fam = cfg["reference"]["family"]
        info["extrapolation_error"] = float(energy_error(info[f"extrapolated_{fam}"],
                                                         info["exact"]))
    ext = [info[f"extrapolated_{f}"] for f in ("uniform", "graded", "adaptive")
           if np.isfinite(info[f"extrapolated_{f}"])]
    # how uncertain is the reference?  the spread of the families' limits (at least two),
    # and the fitted rates if any of them were taken as the reference instead
    info["extrapolation_families"] = len(ext)
    info["extrapolation_spread"] = (float(energy_error(max(ext), min(ext))) if len(ext) >= 2
                                    else None)
    rates = {}
    for fam, g in df.groupby("family"):
        fits = []
        for e in ext:
            err = energy_error(g.energy, e)
            if np.all(err > 0):
                fits.append(fit_rate(g.dofs, err))
        rates[fam] = [min(fits), max(fits)] if fits else None
    info["rate_range_over_references"] = rates
    info["finest_error"] = float(finest)
    logging.info("%s", info)
    write_table(with_provenance(df), out_csv)
    clean = {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
             for k, v in info.items()}
    with atomic_path(out_json) as tmp:
        tmp.write_text(json.dumps(clean, indent=1, allow_nan=False))


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.wildcards.problem, snakemake.params.config,  # noqa: F821
         snakemake.input.series, snakemake.input.adaptive,  # noqa: F821
         snakemake.output.csv, snakemake.output.json)  # noqa: F821
