"""What the run scripts share: log and threads of a job, the parameter columns of a
result row, and the time steps stored by a parabolic run."""
from __future__ import annotations

import dataclasses
import json
import logging

import numpy as np

from .logs import log_to

__all__ = ["start", "parameter_columns", "parameter_names", "parabolic_pieces",
           "mismatched_parameters"]

# scalar parameters recorded in result rows (besides the quadrature_<field> columns)
PARAMETERS = ("grading", "theta", "marking", "start_level", "max_dofs", "solver", "cross_check",
              "tol", "maxiter", "T", "tau_factor", "c_tau", "operator", "data")


def start(log: str | None = None, threads: int | None = None) -> None:
    """Log to ``log`` (the rule's log file, :func:`fracfem_workflow.logs.log_to`) and
    give numba at most ``threads`` threads."""
    if log is not None:
        log_to(log)
    if threads is not None:
        import numba
        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
        logging.getLogger("fracfem_workflow").info("numba threads: %d",
                                                   numba.get_num_threads())


def _cell(value):
    """A value as one CSV cell: sequences and mappings as JSON text (keys sorted)."""
    if isinstance(value, (list, tuple)):
        return json.dumps(list(value))
    if isinstance(value, dict):
        return json.dumps(value, sort_keys=True)
    return value


def parameter_columns(quadrature=None, **parameters) -> dict:
    """The parameters that produced a result row, as its columns.

    quadrature: the fracfem.QuadratureOptions used (one column per field,
    ``quadrature_<field>``); parameters: further scalars (θ, τ factor, solver,
    tolerances, the example's data), sequences and mappings written as JSON.
    """
    cols = {k: _cell(v) for k, v in parameters.items()}
    if quadrature is not None:
        cols.update({f"quadrature_{f.name}": _cell(getattr(quadrature, f.name))
                     for f in dataclasses.fields(quadrature)})
    return cols


def _same(recorded, expected) -> bool:
    """One recorded cell (as read back from CSV) against the value a run would record."""
    if isinstance(expected, (dict, list, tuple)) or (isinstance(expected, str)
                                                     and expected.startswith(("[", "{"))):
        try:
            rec = json.loads(recorded) if isinstance(recorded, str) else recorded
            exp = json.loads(expected) if isinstance(expected, str) else expected
        except (TypeError, ValueError):
            return False
        return rec == (list(exp) if isinstance(exp, tuple) else exp)
    if isinstance(expected, (bool, np.bool_)) or isinstance(recorded, (bool, np.bool_)):
        return str(recorded) == str(expected)
    try:
        return bool(np.isclose(float(recorded), float(expected), rtol=1e-12, atol=0.0))
    except (TypeError, ValueError):
        return str(recorded) == str(expected)


def mismatched_parameters(recorded: dict, expected: dict) -> list[str]:
    """The keys of ``expected`` (parameters a run would record, e.g. by
    :func:`parameter_columns`) whose value differs from, or is missing in, ``recorded``
    (a result row read back from its CSV): empty when the recorded run is the one
    these parameters would produce."""
    return [k for k, v in expected.items() if k not in recorded or not _same(recorded[k], v)]


def parameter_names(columns) -> list[str]:
    """The parameter columns among ``columns``, in their order."""
    return [c for c in columns if c in PARAMETERS or c.startswith("quadrature_")]


def stored_reference(npz, quadrature):
    """(SpaceTimeReference, s) of a stored parabolic reference run: its pieces and its
    operator on the free nodes ('auto': compressed when large) to measure runs against;
    quadrature: the fracfem.QuadratureOptions of the runs it judges."""
    import fracfem as ff
    from fracfem.transfer import SpaceTimeReference

    pieces, d = parabolic_pieces(npz)
    s = float(d["s"])
    logging.getLogger("fracfem_workflow").info(
        "reference solution %s: %d time steps on %d nodes; assembling its operator",
        npz, len(pieces), pieces[0][2].p.shape[1])
    disc = ff.discretise(pieces[0][2], s, 0.0, quadrature=quadrature, operator="auto")
    return SpaceTimeReference(pieces, disc.A, disc.free), s


def parabolic_pieces(npz):
    """[(t_{k−1}, t_k, mesh, u_k)] of a stored parabolic run, and the loaded file."""
    from skfem import MeshTri

    d = np.load(npz)
    mesh = MeshTri(d["p"], d["t"])
    times, U = d["times"], d["U"]
    return [(times[k - 1], times[k], mesh, U[k]) for k in range(1, len(times))], d
