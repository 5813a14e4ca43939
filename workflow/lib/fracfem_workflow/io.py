"""Result files of the workflow: atomic writes and provenance (no partial file is ever
left)."""
from __future__ import annotations

import json
import logging
import os
import platform
import resource
import subprocess
import tempfile
from datetime import datetime, timezone
from pathlib import Path

import numpy as np

__all__ = ["provenance", "write_table", "save_arrays", "peak_memory_mb", "atomic_path"]

log = logging.getLogger(__name__)


def _git_commit() -> str:
    here = Path(__file__).resolve().parent
    try:
        # the full hash: a short one can be all digits, and is then read back as a number
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here,
                             capture_output=True, text=True, timeout=5)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"],
                               cwd=here, capture_output=True, text=True, timeout=5)
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    if out.returncode != 0:
        return "unknown"
    return out.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")


def provenance(config: dict | None = None) -> dict:
    """Versions, git commit, time and (optionally) the config as JSON."""
    import numba
    import scipy
    import skfem

    from fracfem import __version__
    info = {
        "fracfem_version": __version__,
        "git_commit": _git_commit(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
        "numba": numba.__version__,
        "skfem": getattr(skfem, "__version__", "unknown"),
        "created": datetime.now(timezone.utc).isoformat(timespec="seconds"),
    }
    if config is not None:
        info["config"] = json.dumps(config, sort_keys=True, default=str)
    return info


def with_provenance(df, config: dict | None = None):
    """``df`` with the :func:`provenance` columns added (the same value in every row)."""
    return df.assign(**provenance(config))


def peak_memory_mb() -> float:
    """Peak resident memory of this process in MB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


class atomic_path:
    """Context manager yielding a temporary path renamed onto ``path`` on success."""

    def __init__(self, path, suffix=""):
        self.path = Path(path)
        self.suffix = suffix

    def __enter__(self):
        self.path.parent.mkdir(parents=True, exist_ok=True)
        # a temporary file of this target left by a killed writer (SIGKILL cannot be
        # cleaned up after) goes when the target is written again
        for stale in self.path.parent.glob(f".tmp-{self.path.name}-*"):
            stale.unlink(missing_ok=True)
        fd, tmp = tempfile.mkstemp(dir=self.path.parent, prefix=f".tmp-{self.path.name}-",
                                   suffix=self.suffix or self.path.suffix)
        os.close(fd)
        self.tmp = Path(tmp)
        return self.tmp

    def __exit__(self, exc_type, exc, tb):
        if exc_type is None:
            os.replace(self.tmp, self.path)
            log.info("wrote %s", self.path)
        else:
            self.tmp.unlink(missing_ok=True)
        return False


def write_table(df, path) -> None:
    """Write a pandas DataFrame as CSV atomically."""
    with atomic_path(path) as tmp:
        df.to_csv(tmp, index=False)


def save_arrays(path, **arrays) -> None:
    """np.savez_compressed atomically."""
    with atomic_path(path, suffix=".npz") as tmp:
        np.savez_compressed(tmp, **arrays)
