"""Replace the committed copies of the parabolic reference runs (rule para_reference_large):
the time steps in single precision (U; λ_H only where a table needs it), and the run's row.

Single precision changes u_ref by a relative 6·10⁻⁸, orders of magnitude below the
reference's own error and the errors it measures (parabolic-runs.md)."""
import shutil

import numpy as np

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("para_reference_copy")

KEEP = ("p", "t", "pc", "tc", "times", "s", "free")


def main(problems, npzs, rows, committed, multipliers, log=None):
    """problems, npzs, rows, committed [(npz path, row path)]: in one order; multipliers:
    the problems whose λ_H is kept."""
    if log is not None:
        log_to(log)
    for problem, npz, row, (npz_to, row_to) in zip(problems, npzs, rows, committed):
        d = np.load(npz)
        keep = {k: d[k] for k in KEEP}
        keep["U"] = d["U"].astype(np.float32)
        if problem in multipliers:
            keep["LAM"] = d["LAM"].astype(np.float32)
        with atomic_path(npz_to) as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **keep)
        with atomic_path(row_to) as tmp:
            shutil.copyfile(row, tmp)
        logger.info("%s (%s) -> %s", npz, ", ".join(sorted(keep)), npz_to)


if __name__ == "__main__":
    main(snakemake.params.problems, list(snakemake.input.npz),  # noqa: F821
         list(snakemake.input.rows),  # noqa: F821
         snakemake.params.committed, snakemake.params.multipliers,  # noqa: F821
         snakemake.log[0])  # noqa: F821
