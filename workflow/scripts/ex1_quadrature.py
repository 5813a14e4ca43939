"""Quadrature check: every order raised changes (f, u_h) by how much of err²?"""

import pandas as pd

import fracfem as ff
from fracfem_workflow.io import write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import parameter_columns, start

logger = script_logger("ex1_quadrature")


def main(family, tag, grading, quadrature, run, row, log=None, threads=None):
    start(log, threads)
    base = pd.read_csv(run).iloc[0]
    # the run's own operator (dense, or compressed with its tolerance): the change is the
    # quadrature's alone; the compressed one keeps its Taylor rule for the farthest class
    operator = base.get("operator", "dense")
    if not isinstance(operator, str):        # a row made before runs recorded it (NaN)
        operator = "dense"
    raised = ff.QuadratureOptions(**quadrature).raised(keep_taylor=operator == "compressed")
    logger.info("%s %s s=%g: raised quadrature, %d DOFs, %s operator", family, tag, base.s,
                base.dofs, operator)
    disc = ff.Example1(float(base.s)).problem(ff.series_mesh(tag, grading), raised,
                                              operator=operator)
    fu = float(disc.b @ ff.solve_laplace(disc))
    err2 = float(base.fu_exact - base.fu_h)
    result = {"family": family, "s": base.s, "tag": tag, "dofs": int(base.dofs),
              "fu_h": base.fu_h, "fu_h_raised": fu, "change": fu - base.fu_h,
              "error_squared": err2, "change_over_error_squared": abs(fu - base.fu_h) / err2,
              "t_assembly_raised": disc.timings["assembly"], "operator": operator,
              **parameter_columns(quadrature=raised)}
    logger.info("%s", result)
    write_table(pd.DataFrame([result]), row)


if __name__ == "__main__":
    main(snakemake.wildcards.family, snakemake.wildcards.tag,  # noqa: F821
         snakemake.params.grading, snakemake.params.quadrature,  # noqa: F821
         snakemake.input.row, snakemake.output.row, snakemake.log[0],  # noqa: F821
         snakemake.threads)  # noqa: F821
