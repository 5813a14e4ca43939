"""Replace the committed copies of the large reference runs (rule reference_large): each
problem's table of steps, and for Figure 6 the kept multiplier meshes of one problem,
without the fine meshes and the solution (a few MB less)."""
import shutil

import numpy as np

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("reference_copy")

MESH_KEYS = ("steps", "pc", "tc", "lam", "s")


def main(problems, tables, npzs, committed, meshes_problem, log=None):
    """committed: {problem: (table path, meshes path)}."""
    if log is not None:
        log_to(log)
    for problem, table, npz in zip(problems, tables, npzs):
        table_to, meshes_to = committed[problem]
        with atomic_path(table_to) as tmp:
            shutil.copyfile(table, tmp)
        logger.info("%s -> %s", table, table_to)
        if problem != meshes_problem:
            continue
        d = np.load(npz)
        keep = {k: d[k] for k in d.files
                if k in MESH_KEYS or k.startswith(("pc", "tc", "dofs"))}
        with atomic_path(meshes_to) as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **keep)
        logger.info("%s (%s) -> %s", npz, ", ".join(sorted(keep)), meshes_to)


if __name__ == "__main__":
    main(snakemake.params.problems, list(snakemake.input.tables),  # noqa: F821
         list(snakemake.input.meshes), snakemake.params.committed,  # noqa: F821
         snakemake.params.meshes_problem, snakemake.log[0])  # noqa: F821
