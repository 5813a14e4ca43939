"""Quadrature check: every order raised changes (f, u_h) by how much of err²?"""
import logging

import numba
import pandas as pd

import fracfem as ff
from fracfem.io import write_table

from ex1_solve import make_mesh


def main(family, tag, grading, quadrature, row_in, row_out, threads):
    numba.set_num_threads(max(1, min(threads, numba.config.NUMBA_NUM_THREADS)))
    base = pd.read_csv(row_in).iloc[0]
    mesh = make_mesh(family, tag, grading)
    raised = ff.QuadratureOptions(**quadrature).raised()
    disc = ff.discretise(mesh, float(base.s), 1.0, quadrature=raised)
    fu = float(disc.b @ ff.solve_laplace(disc))
    err2 = float(base.fu_exact - base.fu_h)
    row = {"family": family, "s": base.s, "tag": tag, "dofs": int(base.dofs),
           "fu_h": base.fu_h, "fu_h_raised": fu, "change": fu - base.fu_h,
           "error_squared": err2, "change_over_error_squared": abs(fu - base.fu_h) / err2,
           "t_assembly_raised": disc.timings["assembly"]}
    logging.info("%s", row)
    write_table(pd.DataFrame([row]), row_out)


if __name__ == "__main__":
    logging.basicConfig(filename=snakemake.log[0], level=logging.INFO)  # noqa: F821
    main(snakemake.wildcards.family, snakemake.wildcards.tag, snakemake.params.grading,  # noqa: F821
         snakemake.params.quadrature, snakemake.input.row, snakemake.output.row,  # noqa: F821
         snakemake.threads)  # noqa: F821
