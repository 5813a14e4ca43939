"""Errors of Examples 2 and 3 in every family: energy differences against a reference.

error = √(2 |E(u_h) − E_ref|), E the discrete energy ½a(u_h,u_h) − (f,u_h) (+ j_H(u_h)).
For Example 1 this is exactly ‖u − u_h‖_a (Galerkin orthogonality).  E_ref is exact
for the printed Example 3 (pure slip) and otherwise the three-point extrapolation
(fracfem_workflow.report.extrapolate_energy) of a large Algorithm B series computed
with operator='auto' (rule vi_adaptive_large, to reference.large.max_dofs DOFs).  Its
own error, `reference_error`, is measured as the larger change of that extrapolation
when the finest or the two finest runs are left out
(report.extrapolation_uncertainty); where the energy is exact, the
same extrapolation is compared with it (`large_check`).  The mesh families' own
extrapolations are kept as a cross-check.
"""
import json

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.report import (energy_error, extrapolate_energy, extrapolation_uncertainty,
                                     fit_rate)
from fracfem_workflow.runs import mismatched_parameters, parameter_names, start

logger = script_logger("vi_errors")

WALL = ["t_mesh", "t_assembly", "t_factorisation", "t_schur", "t_pdas"]


def reference_energy(problem, exact, reference_family, series, large):
    """(E_ref, description dict); series holds all families (adaptive too), large the
    large Algorithm B series (dofs, energy)."""
    info = {"problem": problem, "reference_family": reference_family}
    big = extrapolation_uncertainty(large.dofs, large.energy)
    finest = large.loc[large.dofs.idxmax()]
    info.update({"extrapolated_large": big["energy"], "beta_large": big["beta"],
                 "dofs_large": big["dofs_used"], "large_uncertainty": big["uncertainty"],
                 "large_finest_dofs": int(finest.dofs),
                 "large_finest_energy": float(finest.energy),
                 "large_seconds": float(large.t_cumulative.max()),
                 "large_peak_mb": float(large.peak_mem_mb.max()),
                 "large_provenance": {k: str(large[k].iloc[0]) for k in
                                      ("git_commit", "created", "operator") if k in large}})
    for name, g in series.groupby("family"):
        try:
            ext = extrapolate_energy(g.dofs, g.energy)
        except ValueError as err:
            # the families only serve as a cross-check (pre-asymptotic on tiny meshes)
            logger.warning("no extrapolation of the %s family: %s", name, err)
            ext = {"energy": float("nan"), "beta": float("nan"), "dofs_used": []}
        info[f"extrapolated_{name}"] = ext["energy"]
        info[f"beta_{name}"] = ext["beta"]
        info[f"dofs_{name}"] = ext["dofs_used"]
    info["exact"] = exact
    ref = exact if exact is not None else info["extrapolated_large"]
    info["reference"] = ref
    info["large_finest_error"] = float(energy_error(info["large_finest_energy"], ref))
    info["kind"] = ("exact (pure slip)" if exact is not None
                    else f"extrapolated (Algorithm B to {info['large_finest_dofs']:,} DOFs)")
    if exact is not None:   # how good would the large reference have been?
        info["large_check"] = float(energy_error(info["extrapolated_large"], exact))
    return ref, info


def check_data(large, problem, data):
    """``large`` (a large series' table) if it was computed for ``data``, else ValueError."""
    if mismatched_parameters(large.iloc[0].to_dict(),
                             {"data": json.dumps(data, sort_keys=True)}):
        raise ValueError(f"the large reference series of {problem} was computed for "
                         f"{large.data.iloc[0]}, not for this run's data {data}")
    return large


def main(problem, example, data, reference_family, series, adaptive, large, csv, json_path,
         log=None):
    """problem: the run's name; example, data: fracfem.example(example, **data)."""
    start(log)
    exact = ff.example(example, **data).exact_energy
    series = pd.read_csv(series)
    adapt = pd.read_csv(adaptive)
    series = series.assign(t_wall=series[WALL].sum(axis=1), eta=np.nan)
    adapt = adapt.assign(t_wall=adapt.t_cumulative)
    cols = ["problem", "family", "s", "tag", "dofs", "energy", "eta", "t_wall", "peak_mem_mb"]
    params = parameter_names(dict.fromkeys([*series.columns, *adapt.columns]))
    df = pd.concat([series[cols + [c for c in params if c in series]],
                    adapt[cols + [c for c in params if c in adapt]]], ignore_index=True)
    large = check_data(pd.read_csv(large), problem, data)
    ref, info = reference_energy(problem, exact, reference_family, df, large)
    df["error"] = energy_error(df.energy, ref)
    df["below_reference"] = df.energy < ref   # E_h < E_ref: nonconforming or reference off
    df["efficiency"] = df.eta / df.error
    df["example"] = int(example[2:])
    df["variant"] = "" if problem == "ex2" else problem[4:]
    df["reference_energy"] = ref
    df["reference_family"] = reference_family
    # the reference's own error against the finest error of the series
    finest = df.error.min()
    if info["exact"] is not None:
        info["extrapolation_error"] = float(energy_error(
            info[f"extrapolated_{reference_family}"], info["exact"]))
    ext = [info[f"extrapolated_{f}"] for f in sorted(df.family.unique())
           if np.isfinite(info[f"extrapolated_{f}"])]
    limits = ext + [info["extrapolated_large"]]    # the references the rate ranges try
    # how uncertain is the reference?  the spread of the families' limits (at least two),
    # and the fitted rates if any of them were taken as the reference instead
    info["extrapolation_families"] = len(ext)
    info["extrapolation_spread"] = (float(energy_error(max(ext), min(ext))) if len(ext) >= 2
                                    else None)
    rates = {}
    for fam, g in df.groupby("family"):
        fits = []
        for e in limits:
            err = energy_error(g.energy, e)
            if np.all(err > 0):
                fits.append(fit_rate(g.dofs, err))
        rates[fam] = [min(fits), max(fits)] if fits else None
    info["rate_range_over_references"] = rates
    info["finest_error"] = float(finest)
    # the reference's own error: 0 when exact, else the measured uncertainty of the
    # large series' extrapolation
    df["reference_error"] = 0.0 if info["exact"] is not None else info["large_uncertainty"]
    logger.info("%s", info)
    write_table(with_provenance(df), csv)
    clean = {k: (None if isinstance(v, float) and not np.isfinite(v) else v)
             for k, v in info.items()}
    with atomic_path(json_path) as tmp:
        tmp.write_text(json.dumps(clean, indent=1, allow_nan=False))


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.params.example,  # noqa: F821
         snakemake.params.data, snakemake.params.reference_family,  # noqa: F821
         snakemake.input.series, snakemake.input.adaptive,  # noqa: F821
         snakemake.input.large,  # noqa: F821
         snakemake.output.csv, snakemake.output.json, snakemake.log[0])  # noqa: F821
