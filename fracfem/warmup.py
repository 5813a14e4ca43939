"""Compile fracfem's numba kernels ahead of the work that times them.

numba compiles a kernel at its first call and keeps the machine code in its cache
(``cache=True``); a later process loads it in a fraction of a second.  The first process
on a fresh installation pays the compilation, tens of seconds, inside whatever it times
first.  :func:`warm_up` runs each path once on tiny meshes (dense assembly on shape-regular
and anisotropic meshes, the compressed operator, its product with a block of columns and
its solver, the obstacle and friction solvers and indicators, a space-time adaptive pass)
so that the cache holds every kernel before timed work starts; it leaves a stamp
(:func:`stamp`) and ``python -m fracfem.warmup`` does nothing while the stamp is there.
The pipeline runs that before its first job::

    python -m fracfem.warmup
"""
from __future__ import annotations

import logging
import os
import time
from pathlib import Path

__all__ = ["warm_up"]

logger = logging.getLogger(__name__)


def stamp() -> Path:
    """The file :func:`warm_up` leaves beside numba's cache of this code (fracfem's source,
    numba's version): while it exists the kernels are compiled and :func:`is_warm` is
    True."""
    import numba

    from .opcache import _source_hash
    base = Path(os.environ.get("NUMBA_CACHE_DIR") or Path(__file__).parent / "__pycache__")
    return base / f"fracfem-warm-{_source_hash()[:16]}-numba{numba.__version__}"


def is_warm() -> bool:
    return stamp().exists()


def warm_up() -> float:
    """Run every kernel once (no operator cache); returns the seconds it took."""
    import numpy as np

    import fracfem as ff
    from fracfem import pointwise

    t0 = time.perf_counter()
    with ff.operator_cache(None):
        ex1 = ff.Example1(0.5)
        ff.discretise(ff.disk_graded_aniso(0.5), 0.5)
        d = ff.discretise(ff.disk_uniform(4), 0.5, operator="compressed")
        ff.solve_laplace(d)
        d.A @ np.ones((d.A.shape[0], 2))      # a block of columns (reference distances)
        mesh = ff.disk_uniform(3)             # the pointwise (−Δ)ˢu_h's compressed path
        pointwise.fractional_laplacian_qp(mesh, 1.0 - (mesh.p ** 2).sum(axis=0), 0.5, 4,
                                          method="compressed")
        ff.algorithm_b(lambda m: ex1.problem(m), ff.disk_uniform(1), theta=0.5, steps=2,
                       marking="maximum", f=ex1.f)
        for ex in (ff.Example2(), ff.Example3()):
            ff.algorithm_b(lambda c, ex=ex: ex.problem(c), ff.disk_uniform(1), theta=0.5,
                           steps=2, marking="maximum", solver="pdas", f=ex.f)
        ff.vi.solve(ff.Example2().problem(ff.disk_uniform(2)), "uzawa")   # Algorithm A
        for ex in (ff.Example4(), ff.Example5()):
            ff.algorithm_c(lambda c, ex=ex: ex.problem(c), ff.disk_uniform(1),
                           ex.initial_value, T=0.1, theta=0.5, iterations=2)
    seconds = time.perf_counter() - t0
    logger.info("numba kernels compiled or loaded in %.1f s", seconds)
    path = stamp()
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(f"{seconds:.1f} s\n")
    except OSError as err:                      # a read-only installation: warm next time too
        logger.warning("could not write %s (%s)", path, err)
    return seconds


if __name__ == "__main__":
    logging.basicConfig(level=logging.INFO,
                        format="%(asctime)s %(levelname)s %(name)s: %(message)s")
    if is_warm():
        logger.info("numba kernels already compiled (%s)", stamp())
    else:
        warm_up()
