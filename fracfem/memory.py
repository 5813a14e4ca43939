"""Memory guard of the dense paths: refuse a problem before allocating what cannot fit.

The dense stiffness matrix of N nodes needs 8 N² bytes (its far field is assembled
into it, no copy per thread), so N = 1.3·10⁵ asks for about 130 GiB.  Without a guard
numpy allocates until it fails (or the system swaps); :func:`check_dense` refuses such
a problem at once.

The limit is the memory available now (``MemAvailable`` of /proc/meminfo, else
free physical pages, and no more than the process's control group leaves: the memory limit
that a batch scheduler such as SLURM or a container sets, less what the group uses), or the
value of the environment variable
``FRACFEM_MEMORY_LIMIT`` (bytes, or with a suffix K, M, G, T: ``"2G"``), or a
``memory_limit`` argument where a function offers one.
"""
from __future__ import annotations

import logging
import os
import re
from pathlib import Path

log = logging.getLogger(__name__)

__all__ = ["DenseMemoryError", "available_memory", "node_available", "cgroup_available",
           "memory_limit", "check_dense", "ENV"]

ENV = "FRACFEM_MEMORY_LIMIT"
GIB = 2.0 ** 30
_UNITS = {"": 1, "K": 2 ** 10, "M": 2 ** 20, "G": 2 ** 30, "T": 2 ** 40}


class DenseMemoryError(MemoryError, ValueError):
    """A dense problem larger than the memory limit, raised before anything is allocated.

    A MemoryError (what it is) and a ValueError (the input is refused like any other
    bad input, so callers that catch bad input catch it too).
    """


def node_available() -> int | None:
    """Bytes of memory the machine has available now: MemAvailable of /proc/meminfo, else
    free physical pages; None if neither can be read."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):
        return None


def available_memory() -> int | None:
    """Bytes of memory available now: :func:`node_available`, at most what the process's
    control group leaves (:func:`cgroup_available`)."""
    avail, group = node_available(), cgroup_available()
    if group is None:
        return avail
    return group if avail is None else min(avail, group)


# a cgroup v1 limit this large means no limit (the kernel prints about 2**63)
_NO_LIMIT = 2 ** 60


def _read_int(path: Path) -> int | None:
    try:
        text = path.read_text().strip()
    except OSError:
        return None
    return int(text) if text.isdigit() else None        # "max": no limit


def _inactive_file(path: Path, key: str) -> int:
    """Reclaimable page cache of a group (its memory.stat), counted as available."""
    try:
        for line in (path / "memory.stat").read_text().splitlines():
            name, _, value = line.partition(" ")
            if name == key and value.strip().isdigit():
                return int(value)
    except OSError:
        pass
    return 0


def _group_room(base: Path, path: str, limit_name: str, usage_name: str, cache_key: str):
    """limit − (usage − inactive page cache) of the group and each ancestor with a limit."""
    group = base / path.strip("/")
    if not group.is_dir():       # a container's mount: its own group is the mount's root
        group = base
    while True:                  # the group, then each ancestor up to the hierarchy's root
        limit = _read_int(group / limit_name)
        usage = _read_int(group / usage_name)
        if limit is not None and limit < _NO_LIMIT and usage is not None:
            used = max(usage - _inactive_file(group, cache_key), 0)
            yield max(limit - used, 0)
        if group == base or base not in group.parents:
            return
        group = group.parent


def cgroup_available(proc_cgroup: str | Path = "/proc/self/cgroup",
                     root: str | Path = "/sys/fs/cgroup") -> int | None:
    """Bytes the process's memory control group and its ancestors leave: the least of
    limit − (usage − inactive page cache) over the groups that set a limit, None when
    none does (or no control group is readable).

    A SLURM job whose memory is enforced, or a container, runs in such a group: its limit,
    not the node's free memory, is what the process may use. Both cgroup v2 (``0::path``,
    ``memory.max`` and ``memory.current`` under ``root``) and v1 (the ``memory``
    controller's line, ``memory.limit_in_bytes`` and ``memory.usage_in_bytes`` under
    ``root/memory``) are read.
    """
    try:
        lines = Path(proc_cgroup).read_text().splitlines()
    except (OSError, ValueError):
        return None
    root = Path(root)
    found = []
    for line in lines:
        ident, _, rest = line.partition(":")
        controllers, _, path = rest.partition(":")
        if ident == "0" and controllers == "":
            files, base = ("memory.max", "memory.current", "inactive_file"), root
        elif "memory" in controllers.split(","):
            files, base = (("memory.limit_in_bytes", "memory.usage_in_bytes",
                            "total_inactive_file"), root / "memory")
        else:
            continue
        try:                  # an unreadable group limits nothing that can be known
            found.extend(_group_room(base, path, *files))
        except (OSError, ValueError):
            continue
    return min(found) if found else None


def _parse_bytes(value, name) -> float:
    """A positive number of bytes from a number or a string such as '2G' or '512M'."""
    if isinstance(value, str):
        m = re.fullmatch(r"\s*([0-9.eE+]+)\s*([KMGT]?)(i?B)?\s*", value.upper())
        try:
            num = float(m.group(1)) * _UNITS[m.group(2)] if m else float("nan")
        except ValueError:
            num = float("nan")
    else:
        try:
            num = float(value)
        except (TypeError, ValueError):
            num = float("nan")
    if not num > 0 or num == float("inf"):
        raise ValueError(f"{name}={value!r} must be a positive number of bytes "
                         f"(a number, or a string such as '2G' or '512M')")
    return num


def memory_limit(limit=None) -> tuple[float | None, str]:
    """(bytes a dense path may use, where that number comes from).

    ``limit`` if given, else ``$FRACFEM_MEMORY_LIMIT``, else :func:`available_memory`
    (None if it cannot be read: no guard).
    """
    if limit is not None:
        return _parse_bytes(limit, "memory_limit"), "allowed by memory_limit="
    env = os.environ.get(ENV)
    if env:
        return _parse_bytes(env, ENV), f"allowed by {ENV}"
    avail = available_memory()
    return avail, "available (MemAvailable, or less where the control group limits memory)"


def check_dense(nbytes: float, *, what: str, advice: str, limit=None) -> None:
    """Raise :class:`DenseMemoryError` if ``what`` needs more than the memory limit.

    Parameters
    ----------
    nbytes : the estimated peak bytes of the dense path
    what : what is built and its size, e.g. "the dense stiffness matrix for N = 9 nodes"
    advice : the alternative offered in the message
    limit : an explicit limit in bytes (see :func:`memory_limit`)
    """
    lim, source = memory_limit(limit)
    if lim is None:
        log.debug("memory available unknown; %s needs %.3g GiB", what, nbytes / GIB)
        return
    if nbytes > lim:
        raise DenseMemoryError(f"{what} needs about {nbytes / GIB:.3g} GiB, but only "
                               f"{lim / GIB:.3g} GiB are {source}; {advice}")
    log.debug("%s: %.3g GiB of %.3g GiB %s", what, nbytes / GIB, lim / GIB, source)
