"""Commit a problem's error table: a parabolic one (para_errors) beside its reference's
committed copy (rule para_errors_commit; with config/ex4-paper-reference.yaml, the errors of
the default tier's runs against the paper-scale tier's references, which the default tier's
parabolic-runs.md compares with its own), or as the kept copy that a tier's figures and
tables read instead of computing it (rule para_errors_keep, parabolic.kept_errors; rule
vi_errors_keep, reference.kept_errors: an elliptic problem's table and its reference's
record)."""
import shutil
from pathlib import Path

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to, script_logger

logger = script_logger("para_errors_copy")


def main(csv, committed, note, log=None, settings=None):
    """Copy ``csv`` to ``committed`` (each a path, or lists of paths of one length: file
    by file); settings: the JSON of what they were made with, written beside the first
    copy as ``.json`` (the keep rules; none for para_errors_commit); note: what was copied
    where.  The old settings are removed first and the new ones written last: a copy
    interrupted in between leaves no settings, and a kept table without them is computed
    again, never read as this configuration's."""
    if log is not None:
        log_to(log)
    sources = [csv] if isinstance(csv, (str, Path)) else list(csv)
    targets = [committed] if isinstance(committed, (str, Path)) else list(committed)
    if len(sources) != len(targets):
        raise ValueError(f"{len(sources)} files to copy to {len(targets)} places")
    Path(targets[0]).parent.mkdir(parents=True, exist_ok=True)
    record = Path(targets[0]).with_suffix(".json")
    if settings is not None:
        record.unlink(missing_ok=True)
    for source, target in zip(sources, targets):
        with atomic_path(target) as tmp:
            shutil.copyfile(source, tmp)
        logger.info("%s -> %s", source, target)
    if settings is not None:
        with atomic_path(record) as tmp:
            Path(tmp).write_text(settings + "\n")
    with atomic_path(note) as tmp:
        Path(tmp).write_text("".join(f"{a} -> {b}\n" for a, b in zip(sources, targets)))


if __name__ == "__main__":
    main([snakemake.input.csv, snakemake.input.json]  # noqa: F821
         if "json" in snakemake.input.keys() else snakemake.input.csv,  # noqa: F821
         snakemake.params.committed,  # noqa: F821
         snakemake.output.note, snakemake.log[0],  # noqa: F821
         snakemake.params.get("settings"))  # noqa: F821
