"""Example 2's adaptive series measured in the energy norm, as the paper measures them.

The unchanged Algorithm B series (vi_adaptive's settings, to a step with at least
`reference_dofs` fine DOFs: vi_adaptive's own series where that is where vi_adaptive stops,
else vi_adaptive_change's) gives the reference u_ref: its last step.
Every step of it, and of each changed series, is measured by its distance
‖u_h − u_ref‖_a (fracfem.transfer.energy_distance: u_h interpolated onto the reference
mesh, the norm of the reference's operator, assembled again here), and by its largest
nodal dip below the obstacle, max(χ − u_h) at its fine nodes: the mixed form constrains
only u_h's means on T_H.
"""
import json

import numpy as np
import pandas as pd
from skfem import MeshTri

import fracfem as ff
from fracfem.transfer import energy_distance
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import (mismatched_parameters, parameter_columns, parameter_names,
                                   start)

logger = script_logger("vi_adaptive_distances")

def solutions(npz):
    """The steps kept by vi_adaptive.main(every_step=True): [(step, mesh, u_h)], and the
    last step's multiplier mesh T_H."""
    with np.load(npz) as z:
        return ([(int(k), MeshTri(z[f"p{k}"], z[f"t{k}"]), z[f"u{k}"]) for k in z["steps"]],
                MeshTri(z["pc"], z["tc"]))


def measure(series, reference, chi):
    """Rows (case, step, distance, dip) of every step of series {case: (steps table,
    solutions)}, against reference = (Discretisation, u_ref)."""
    rows = []
    for case, (table, sols) in series.items():
        if [k for k, _, _ in sols] != list(range(len(table))):
            raise ValueError(f"the solutions of {case!r} do not match its steps table "
                             f"({len(sols)} solutions, {len(table)} steps)")
        for (k, mesh, u), (_, row) in zip(sols, table.iterrows()):
            rows.append({"case": case, "theta": row.theta, "start_level": row.start_level,
                         "step": k, "dofs": row.dofs, "energy": row.energy, "eta": row.eta,
                         "distance": energy_distance(mesh, u, reference),
                         "dip": float(np.max(chi(mesh.p) - u, initial=0.0))})
        logger.info("%s: %d steps measured", case, len(sols))
    return pd.DataFrame(rows)


def check_settings(tables: dict, changes: dict, own: dict) -> None:
    """Each series was run with the unchanged series' (the first) recorded settings but
    its change ({case: {setting: value}}) and where it stops (max_dofs), and the
    unchanged series with this job's own (``own``: the recorded form of the data,
    quadrature and operator it assembles u_ref's operator with): ValueError."""
    base = next(iter(tables.values())).iloc[0]
    differ = mismatched_parameters(base.to_dict(), own)
    if differ:
        raise ValueError(f"the unchanged series was not run with {differ[0]} = "
                         f"{own[differ[0]]}, the setting its reference's operator is "
                         "assembled with")
    settings = [c for c in parameter_names(base.index) if c != "max_dofs"]
    for case, df in tables.items():
        expected = {key: changes.get(case, {}).get(key, base[key]) for key in settings}
        differ = mismatched_parameters(df.iloc[0].to_dict(), expected)
        if differ:
            raise ValueError(f"the series {case!r} was not run with {differ[0]} = "
                             f"{expected[differ[0]]} (the unchanged series' settings, with "
                             "its change)")


def main(example, data, quadrature, tables, npz, changes, out, log=None, threads=None,
         operator="auto"):
    """tables, npz: {case: file} of vi_adaptive_change or vi_adaptive (every_step=True),
    the unchanged series first (its last step is the reference); changes: {case: {setting:
    value}} of the others."""
    start(log, threads)
    if list(tables) != list(npz) or not tables:
        raise ValueError(f"one steps table and one solutions file per series: {list(tables)} "
                         f"and {list(npz)}")
    ex = ff.example(example, **data)
    frames = {case: pd.read_csv(f) for case, f in tables.items()}
    quad = ff.QuadratureOptions(**quadrature)
    check_settings(frames, changes, parameter_columns(
        quadrature=quad, operator=operator, data=json.dumps(data, sort_keys=True)))
    sols = {case: solutions(f) for case, f in npz.items()}
    series = {case: (frames[case], sols[case][0]) for case in tables}
    unchanged = next(iter(series))
    last, mesh, u_ref = series[unchanged][1][-1]
    coarse = sols[unchanged][1]
    prob = ex.problem(coarse, quad, operator=operator)
    if not np.array_equal(prob.fine.p, mesh.p):
        raise RuntimeError("the reference step's fine mesh was not rebuilt from its T_H")
    logger.info("reference: %s step %d, %d DOFs", unchanged, last, len(prob.disc.free))
    rows = measure(series, (prob.disc, u_ref), ex.obstacle)
    ref = series[unchanged][0].iloc[-1]
    rows = rows.assign(reference_step=last, reference_dofs=int(ref.dofs),
                       reference_step_energy=float(ref.energy))
    write_table(rows, out)


if __name__ == "__main__":
    main(snakemake.params.example, snakemake.params.data,  # noqa: F821
         snakemake.params.quadrature,  # noqa: F821
         dict(zip(snakemake.params.cases, snakemake.input.tables)),  # noqa: F821
         dict(zip(snakemake.params.cases, snakemake.input.npz)),  # noqa: F821
         snakemake.params.changes, snakemake.output.csv, snakemake.log[0], snakemake.threads,  # noqa: F821
         snakemake.params.operator)  # noqa: F821
