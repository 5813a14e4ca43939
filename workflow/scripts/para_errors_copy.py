"""Commit a parabolic problem's error table (para_errors): beside its reference's committed
copy (rule para_errors_commit; with config/ex4-paper-reference.yaml, the errors of the
default tier's runs against the paper-scale tier's references, which the default tier's
parabolic-runs.md compares with its own), or as the kept copy that a tier's figures and
tables read instead of computing it (rule para_errors_keep, parabolic.kept_errors)."""
import shutil
from pathlib import Path

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("para_errors_copy")


def main(csv, committed, note, log=None, settings=None):
    """Copy ``csv`` to ``committed``; settings: the JSON of what it was made with, written
    beside it as ``.json`` (para_errors_keep; none for para_errors_commit); note: what was
    copied where."""
    if log is not None:
        log_to(log)
    Path(committed).parent.mkdir(parents=True, exist_ok=True)
    if settings is not None:
        with atomic_path(Path(committed).with_suffix(".json")) as tmp:
            Path(tmp).write_text(settings + "\n")
    with atomic_path(committed) as tmp:
        shutil.copyfile(csv, tmp)
    logger.info("%s -> %s", csv, committed)
    with atomic_path(note) as tmp:
        Path(tmp).write_text(f"{csv} -> {committed}\n")


if __name__ == "__main__":
    main(snakemake.input.csv, snakemake.params.committed,  # noqa: F821
         snakemake.output.note, snakemake.log[0],  # noqa: F821
         snakemake.params.get("settings"))  # noqa: F821
