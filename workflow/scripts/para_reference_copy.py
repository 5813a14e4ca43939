"""Replace the committed copy of a parabolic reference run (rule para_reference_commit, one
problem; para_reference_large, all): the time steps in single precision (U; λ_H only where
a table needs it), and the run's row.

Single precision changes u_ref by a relative 6·10⁻⁸, orders of magnitude below the
reference's own error and the errors it measures (parabolic-runs.md)."""
import shutil
from pathlib import Path

import numpy as np

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("para_reference_copy")

KEEP = ("p", "t", "pc", "tc", "times", "s", "free")


def main(problem, npz, row, committed, multipliers, note, log=None, error=None):
    """Copy the reference run of ``problem`` (npz, its row) to ``committed`` (npz path, row
    path, and the path of its measured error when ``error``, para_reference_error's row, is
    given); multipliers: the problems whose λ_H is kept; note: what was copied where."""
    if log is not None:
        log_to(log)
    npz_to, row_to = committed[:2]
    if error is not None and len(committed) != 3:
        raise ValueError(f"committed must name three paths when error is given; got {committed}")
    d = np.load(npz)
    keep = {k: d[k] for k in KEEP}
    keep["U"] = d["U"].astype(np.float32)
    if problem in multipliers:
        keep["LAM"] = d["LAM"].astype(np.float32)
    with atomic_path(npz_to) as tmp:
        with open(tmp, "wb") as f:
            np.savez_compressed(f, **keep)
    copies = [(row, row_to)] + ([(error, committed[2])] if error is not None else [])
    for src, dst in copies:
        with atomic_path(dst) as tmp:
            shutil.copyfile(src, tmp)
    logger.info("%s (%s) -> %s", npz, ", ".join(sorted(keep)), npz_to)
    with atomic_path(note) as tmp:
        Path(tmp).write_text(f"{npz} ({', '.join(sorted(keep))}) -> {npz_to}\n"
                             + "".join(f"{src} -> {dst}\n" for src, dst in copies))


if __name__ == "__main__":
    main(snakemake.wildcards.problem, snakemake.input.npz, snakemake.input.row,  # noqa: F821
         snakemake.params.committed, snakemake.params.multipliers,  # noqa: F821
         snakemake.output.note, snakemake.log[0], snakemake.input.error)  # noqa: F821
