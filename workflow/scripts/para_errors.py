"""Errors of Examples 4, 5 in L²(0,T; H^s): ‖I u_hτ − u_ref‖ against the reference run.

I is nodal interpolation onto the reference's fine mesh (zero outside a run's
polygon); both functions are piecewise constant in time, the time integral is
exact on the union of the two time grids (fracfem.transfer.space_time_distance);
the norm is the a-norm of the reference mesh.
"""
import logging

import numba
import numpy as np
import pandas as pd
from skfem import MeshTri

import fracfem as ff
from fracfem.io import write_table
from fracfem.report import fit_rate
from fracfem.transfer import space_time_distance


def pieces(npz):
    d = np.load(npz)
    mesh = MeshTri(d["p"], d["t"])
    times, U = d["times"], d["U"]
    return [(times[k - 1], times[k], mesh, U[k]) for k in range(1, len(times))], d


def main(rows, npzs, ref_npz, adaptive_csv, quadrature, out_csv, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    ref, d = pieces(ref_npz)
    s = float(d["s"])
    disc = ff.discretise(ref[0][2], s, 0.0, quadrature=ff.QuadratureOptions(**quadrature))
    df = pd.concat([pd.read_csv(r) for r in rows], ignore_index=True)
    errors = {}
    for npz in npzs:
        run, _ = pieces(npz)
        errors[npz] = space_time_distance(run, ref, disc.A, disc.free)
        logging.info("%s: %.6e", npz, errors[npz])
    df["error"] = [errors[n] for n in npzs]
    df = pd.concat([df, pd.read_csv(adaptive_csv)], ignore_index=True)  # errors computed there
    ref_dofs = len(disc.free) * len(ref)
    # the reference's own error, extrapolated along the graded series' rate
    g = df[df.family == "graded"].sort_values("spacetime_dofs")
    rate = fit_rate(g.spacetime_dofs, g.error)
    df["reference_spacetime_dofs"] = ref_dofs
    df["reference_error_estimate"] = g.error.iloc[-1] * (ref_dofs / g.spacetime_dofs.iloc[-1]) ** rate
    if not np.all(np.isfinite(df.error)):
        raise RuntimeError("a parabolic error is not finite")
    write_table(df, out_csv)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(list(snakemake.input.rows), list(snakemake.input.npz), snakemake.input.ref,  # noqa: F821
         snakemake.input.adaptive, snakemake.params.quadrature, snakemake.output.csv, snakemake.threads)  # noqa: F821
