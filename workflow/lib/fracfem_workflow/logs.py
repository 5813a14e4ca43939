"""The log file of a job: progress lines of fracfem and of the run script, written as
they happen.

Every script calls :func:`log_to` once with the rule's log file
(``snakemake.log[0]``); then ``tail -f`` on that file follows the job.
"""
from __future__ import annotations

import atexit
import logging
import os
import re
import sys
import time
from pathlib import Path

__all__ = ["log_to", "log_to_stderr", "script_logger", "FORMAT"]

FORMAT = "%(asctime)s %(levelname)s %(name)s: %(message)s"
DATEFMT = "%Y-%m-%d %H:%M:%S"
# libraries whose INFO lines are one per call (scikit-fem: two per assembly, i.e.
# several per time step): only their warnings go to the job log
QUIET = ("skfem",)


class _JobLog(logging.FileHandler):
    """The file handler installed by :func:`log_to` (one per process)."""


_state = {"start": None, "failed": False}
log = logging.getLogger("fracfem_workflow")


def log_to(path, level: int = logging.INFO) -> logging.Handler:
    """Send log records of ``level`` and above (fracfem's, the script's, warnings,
    an uncaught exception) to the file ``path``, one line per record with time and
    logger name; the first line names the script, the last one (at exit) says
    whether it finished or failed and after how long.

    The file is truncated (one job, one log) and each record is flushed as it is
    written.  A second call replaces the handler of the first.  Loggers of
    :data:`QUIET` only pass warnings.  Returns the handler.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    root = logging.getLogger()
    for old in [h for h in root.handlers if isinstance(h, _JobLog)]:
        root.removeHandler(old)
        old.close()
    handler = _attach(_JobLog(path, mode="w", encoding="utf-8"), level)
    _log_uncaught()
    if _state["start"] is None:
        _state["start"] = time.perf_counter()
        atexit.register(_finished)
    log.info("log of %s (pid %d)", _script_name(), os.getpid())
    return handler


def _script_name() -> str:
    """The running script's file name (Snakemake runs a copy named tmp<random>.<name>.py)."""
    name = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else "python"
    return re.sub(r"^tmp[^.]+\.(?=.+\.py$)", "", name)


def log_to_stderr(level: int = logging.INFO) -> logging.Handler:
    """The same lines on standard error, for a script run by a ``shell:`` rule whose
    output is redirected to its log (``> {log} 2>&1``); no exit line."""
    return _attach(logging.StreamHandler(sys.stderr), level)


def _attach(handler: logging.Handler, level: int) -> logging.Handler:
    """Format `handler`, add it to the root logger at `level`, quiet :data:`QUIET`
    and route warnings through logging."""
    root = logging.getLogger()
    handler.setFormatter(logging.Formatter(FORMAT, DATEFMT))
    root.addHandler(handler)
    root.setLevel(level)
    for name in QUIET:
        logging.getLogger(name).setLevel(max(level, logging.WARNING))
    logging.captureWarnings(True)
    return handler


def _finished() -> None:
    """The last line of the log (at interpreter exit), if it is still open."""
    if not any(isinstance(h, _JobLog) for h in logging.getLogger().handlers):
        return
    log.log(logging.ERROR if _state["failed"] else logging.INFO, "%s after %.1f s",
            "failed" if _state["failed"] else "finished",
            time.perf_counter() - _state["start"])


def script_logger(name: str) -> logging.Logger:
    """The logger of the run script ``name`` (its lines read ``workflow.<name>``)."""
    return logging.getLogger(f"workflow.{name}")


def _log_uncaught() -> None:
    """An exception that ends the script is written to the log too (then reported as
    before)."""
    previous = sys.excepthook
    if getattr(previous, "_logs_to_file", False):
        return

    def hook(kind, value, tb):
        _state["failed"] = True
        log.error("uncaught exception", exc_info=(kind, value, tb))
        previous(kind, value, tb)

    hook._logs_to_file = True
    sys.excepthook = hook
