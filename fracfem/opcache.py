"""A directory of assembled dense stiffness matrices: a program (or a pipeline of
programs) that needs the same operator twice assembles it once.

Off unless a directory is given, by :func:`operator_cache` or by the environment variable
``FRACFEM_OPERATOR_CACHE``.  :func:`fracfem.discretise` then keeps the free-node block
``A[free, free]`` of every dense matrix it assembles (``<key>.npy``) with the seconds its
assembly took (``<key>.json``), and reads it back when the same operator is asked for
again.  The key is a SHA-256 of everything the matrix depends on: the nodes, triangles
and free nodes, s, the quadrature options, the number of parallel chunks of the far field
(their sums differ in round-off), the source of fracfem itself and the machine type and
versions of numpy, scipy and numba, so that an entry is only read back by the code that
wrote it and the result is the matrix that would have been assembled, bit for bit.

An entry is written under a temporary name and renamed: a reader sees a whole entry or
none.  Two processes that miss at the same time both assemble and write the same bytes.
An entry that cannot be read is assembled again.  The cache never deletes anything; a
pipeline removes its directory when it is done with it.

Usage::

    with fracfem.operator_cache("results/operators"):
        d1 = fracfem.discretise(mesh, 0.5, 1.0)     # assembled, kept
        d2 = fracfem.discretise(mesh, 0.5, 0.0)     # read back: d2.info["cache"] == "hit"
"""
from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import logging
import os
import tempfile
import time
from pathlib import Path

import numpy as np

__all__ = ["operator_cache", "cache_directory", "ENV"]

ENV = "FRACFEM_OPERATOR_CACHE"
FORMAT = 1                       # bumped when an entry's layout changes

logger = logging.getLogger(__name__)
_override: list = []             # operator_cache's directories, innermost last
_source: list = []               # the source hash, computed once


def _checked(directory, name: str) -> Path:
    path = Path(directory)
    if path.exists() and not path.is_dir():
        raise ValueError(f"{name}={str(directory)!r} must be a directory (it is a file)")
    return path


def cache_directory() -> Path | None:
    """The directory in use: the innermost :func:`operator_cache`, else
    ``$FRACFEM_OPERATOR_CACHE``, else None (no cache)."""
    if _override:
        return _override[-1]
    value = os.environ.get(ENV, "")
    return _checked(value, ENV) if value else None


@contextlib.contextmanager
def operator_cache(directory):
    """Keep and reuse dense operators in ``directory`` (created when needed) within the
    ``with`` block; ``None`` turns the cache off there, whatever the environment says."""
    path = None if directory is None else _checked(directory, "directory")
    _override.append(path)
    try:
        yield path
    finally:
        _override.pop()


def _source_hash() -> str:
    if not _source:
        h = hashlib.sha256()
        for f in sorted(Path(__file__).parent.glob("*.py")):
            h.update(f.name.encode())
            h.update(f.read_bytes())
        _source.append(h.hexdigest())
    return _source[0]


def _plain(value):
    """A quadrature field as JSON the same for equal values: numbers as floats (8 and 8.0,
    numpy scalars), sequences as lists."""
    if isinstance(value, (list, tuple, np.ndarray)):
        return [_plain(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, float, np.integer, np.floating)):
        return float(value)
    return value


def _platform() -> str:
    import platform

    import numba
    import scipy
    return " ".join([platform.machine(), np.__version__, scipy.__version__, numba.__version__])


def entry_key(p, t, free, s, quadrature, nchunks) -> str:
    """SHA-256 of what the free-node block of the dense matrix depends on."""
    h = hashlib.sha256()
    h.update(f"fracfem-operator {FORMAT} {_source_hash()} {_platform()} ".encode())
    for a in (np.ascontiguousarray(p, dtype=np.float64), np.ascontiguousarray(t, dtype=np.int64),
              np.ascontiguousarray(free, dtype=np.int64)):
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    h.update(float(s).hex().encode())
    fields = {f.name: _plain(getattr(quadrature, f.name))
              for f in dataclasses.fields(quadrature)}
    h.update(json.dumps(fields, sort_keys=True).encode())
    h.update(str(int(nchunks)).encode())
    return h.hexdigest()


def _write(directory: Path, key: str, A: np.ndarray, seconds: float) -> None:
    made = []
    try:                                                # a full disk costs the reuse only
        directory.mkdir(parents=True, exist_ok=True)
        for suffix in (".json", ".npy"):                # unique names, also across machines
            fd, name = tempfile.mkstemp(prefix=f".tmp-{key[:16]}-", suffix=suffix,
                                        dir=directory)
            os.close(fd)
            made.append(Path(name))
        meta, arr = made
        meta.write_text(json.dumps({"seconds": seconds, "shape": list(A.shape)}))
        with open(arr, "wb") as fh:
            np.save(fh, A)
        os.replace(meta, directory / f"{key}.json")    # the .npy last: it marks a whole entry
        os.replace(arr, directory / f"{key}.npy")
    except OSError as err:
        logger.warning("operator cache: could not keep %s in %s (%s)", key[:12], directory, err)
        for f in made:
            f.unlink(missing_ok=True)


def _read(directory: Path, key: str, n: int):
    arr = directory / f"{key}.npy"
    if not arr.exists():
        return None
    try:
        seconds = float(json.loads((directory / f"{key}.json").read_text())["seconds"])
        A = np.load(arr)
        if A.shape != (n, n) or A.dtype != np.float64:
            raise ValueError(f"shape {A.shape}, dtype {A.dtype}")
    except (OSError, ValueError, KeyError, TypeError, EOFError) as err:
        logger.warning("operator cache: entry %s in %s unreadable (%s); assembling again",
                       key[:12], directory, err)
        return None
    return A, seconds


def free_block_in_place(A: np.ndarray, free) -> np.ndarray:
    """A[free, free] without a second matrix: its rows written into the first
    len(free)² entries of A's own buffer, which is then shrunk to them (A itself
    becomes the block and is returned).  A: square, C-contiguous, owning its data and
    with no other views (they would point into freed memory); ``free``: ascending,
    unique integer indices within range."""
    n = A.shape[0] if A.ndim == 2 else -1
    if n < 0 or A.shape[1] != n or not A.flags.c_contiguous or not A.flags.owndata:
        raise ValueError(f"A of shape {A.shape} must be a square C-contiguous array that "
                         "owns its data")
    free = np.asarray(free)
    if free.size and not np.issubdtype(free.dtype, np.integer):
        raise ValueError(f"free must be integer indices, not {free.dtype}")
    free = free.astype(np.int64)
    if free.ndim != 1 or (len(free) and (free[0] < 0 or free[-1] >= n
                                         or np.any(np.diff(free) <= 0))):
        raise ValueError(f"free must be ascending unique indices in [0, {n}); got "
                         f"{len(free)} indices")
    m = len(free)
    flat = A.reshape(-1)
    # row i goes to flat[i m:(i + 1) m], read from row free[i] >= i, which starts at or
    # after it; a later row's source (free[j] n >= (i + 1) m for j > i) is not reached,
    # and row i's own source is gathered before it is written
    for i in range(m):
        flat[i * m:(i + 1) * m] = A[free[i], free]
    del flat
    A.resize((m, m), refcheck=False)      # the first m² entries kept; the rest given back
    return A


def dense_free_block(mesh, s, free, quadrature, assemble):
    """(A[free, free], timings, info) of the dense matrix: read back from the cache when
    it holds it, else ``assemble()`` (the full matrix, with its timings) and kept there.
    ``timings['total']`` is always the seconds of the assembly itself, also on a hit (the
    cost of the operator, whichever job paid it); ``timings['load']`` the read on a hit."""
    directory = cache_directory()
    if directory is None:
        A, tim = assemble()
        return free_block_in_place(A, free), tim, {}
    import numba
    key = entry_key(mesh.p, mesh.t, free, s, quadrature, numba.get_num_threads())
    t0 = time.perf_counter()
    found = _read(directory, key, len(free))
    if found is not None:
        A, seconds = found
        load = time.perf_counter() - t0
        logger.info("operator cache: %d x %d matrix (s=%g) read back in %.2f s (assembled "
                    "in %.2f s)", len(free), len(free), s, load, seconds)
        return A, {"total": seconds, "load": load}, {"cache": "hit"}
    A, tim = assemble()
    Af = free_block_in_place(A, free)
    _write(directory, key, Af, tim["total"])
    return Af, tim, {"cache": "miss"}
