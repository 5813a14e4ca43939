"""Progress lines of long computations (the ``logging`` module; silent by default).

Levels, chosen so that INFO stays readable on long runs:

* adaptive loops (Algorithms B and C): one INFO line per step / iteration;
* DG(0) time stepping: one INFO line per time step when at least
  :data:`STEP_SECONDS` passed since the previous one, and for the last step of
  a grid; the other steps at DEBUG;
* iterative solvers (PCG, PDAS, Uzawa): one summary line at the end, INFO for
  a top-level call and DEBUG inside time stepping (:func:`inner_solves`), and
  DEBUG lines per outer iteration; a solve running longer than
  :data:`SOLVER_SECONDS` also reports at INFO every ``SOLVER_SECONDS``.
"""
from __future__ import annotations

import contextlib
import contextvars
import logging
import time

STEP_SECONDS = 1.0     # at most about one INFO line per second of time stepping
SOLVER_SECONDS = 10.0  # INFO lines of a solve running longer than this

_inner = contextvars.ContextVar("fracfem_inner_solves", default=False)


@contextlib.contextmanager
def inner_solves():
    """Within the block, solver summaries are DEBUG (the enclosing loop reports)."""
    token = _inner.set(True)
    try:
        yield
    finally:
        _inner.reset(token)


def solver_level() -> int:
    """The level of a solver's summary line: INFO, or DEBUG inside :func:`inner_solves`."""
    return logging.DEBUG if _inner.get() else logging.INFO


class Ticker:
    """Wall clock of a loop: elapsed seconds, and whether an INFO line is due."""

    def __init__(self, seconds: float):
        self.seconds = seconds
        self.start = self.last = time.perf_counter()

    @property
    def elapsed(self) -> float:
        return time.perf_counter() - self.start

    def due(self) -> bool:
        """True (and the clock of the last line reset) when ``seconds`` have passed."""
        now = time.perf_counter()
        if now - self.last >= self.seconds:
            self.last = now
            return True
        return False
