"""What the run scripts share: log and threads of a job, the parameter columns of a
result row, and the time steps stored by a parabolic run."""
from __future__ import annotations

import dataclasses
import json
import logging

import numpy as np

from .logs import log_to

__all__ = ["start", "parameter_columns", "parameter_names", "parabolic_pieces",
           "mismatched_parameters", "stored_reference", "stored_family",
           "save_reference_operator", "load_reference_operator", "save_reference_family"]

# scalar parameters recorded in result rows (besides the quadrature_<field> columns)
PARAMETERS = ("grading", "theta", "marking", "start_level", "max_dofs", "solver", "cross_check",
              "tol", "maxiter", "T", "tau_factor", "c_tau", "operator", "data")


def start(log: str | None = None, threads: int | None = None,
          operator_cache: bool = True) -> None:
    """Log to ``log`` (the rule's log file, :func:`fracfem_workflow.logs.log_to`) and
    give numba at most ``threads`` threads.  operator_cache=False: this job neither reads
    nor keeps operators in the pipeline's operator cache (fracfem.opcache): the adaptive
    algorithms, whose meshes are their own and whose pages time each step."""
    if log is not None:
        log_to(log)
    if not operator_cache:
        import os

        from fracfem.opcache import ENV
        os.environ.pop(ENV, None)
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


def key_differences(made: str, key: str, same=None) -> list[str]:
    """The top-level settings in which the JSON record ``made`` (a checkpoint's key, a kept
    table's settings) differs from ``key``, sorted; ``same``: {setting: function of the two
    values saying whether they agree} for settings not compared by equality."""
    a, b = json.loads(made), json.loads(key)
    same = same or {}
    return sorted(k for k in set(a) | set(b)
                  if not same.get(k, lambda x, y: x == y)(a.get(k), b.get(k)))


def mismatched_parameters(recorded: dict, expected: dict) -> list[str]:
    """The keys of ``expected`` (parameters a run would record, e.g. by
    :func:`parameter_columns`) whose value differs from, or is missing in, ``recorded``
    (a result row read back from its CSV): empty when the recorded run is the one
    these parameters would produce."""
    return [k for k, v in expected.items() if k not in recorded or not _same(recorded[k], v)]


def parameter_names(columns) -> list[str]:
    """The parameter columns among ``columns``, in their order."""
    return [c for c in columns if c in PARAMETERS or c.startswith("quadrature_")]


def stored_reference(npz, quadrature, operator=None):
    """(SpaceTimeReference, s) of a stored parabolic reference run: its pieces and its
    operator on the free nodes ('auto': compressed when large) to measure runs against;
    quadrature: the fracfem.QuadratureOptions of the runs it judges.  operator: a file of
    save_reference_operator for this run and quadrature, read instead of assembling
    (checked: same mesh, s and quadrature, and one product as when it was saved)."""
    from fracfem.transfer import SpaceTimeReference

    pieces, A, free, s = _stored_reference(npz, quadrature, operator)
    return SpaceTimeReference(pieces, A, free), s


def _stored_reference(npz, quadrature, operator=None):
    """(pieces, A, free, s) of a stored reference run: stored_reference's parts."""
    pieces, d = parabolic_pieces(npz)
    s = float(d["s"])
    log = logging.getLogger("fracfem_workflow")
    log.info("reference solution %s: %d time steps on %d nodes", npz, len(pieces),
             pieces[0][2].p.shape[1])
    if operator is None:
        A, free = _reference_operator(pieces, s, quadrature)
    else:
        A, free = load_reference_operator(operator, pieces, s, quadrature)
        log.info("its operator read from %s", operator)
    return pieces, A, free, s


def stored_family(npz, coarser, quadrature, operator=None, saved=None):
    """(ReferenceFamily, s): the reference run of stored_reference with the coarser runs
    of its family (npz files, coarsest first), to measure runs against the family's limit
    (fracfem.transfer.ReferenceFamily; all distances in the reference's a-norm); with no
    coarser runs, the reference's SpaceTimeReference alone.  saved: a file of
    save_reference_family for these runs and quadrature, read instead of building it
    (checked: the same runs, and one distance as when it was saved)."""
    from fracfem.transfer import ReferenceFamily

    if not coarser:
        return stored_reference(npz, quadrature, operator)
    if saved is not None:
        return _load_family(saved, npz, coarser, quadrature)
    pieces, A, free, s = _stored_reference(npz, quadrature, operator)
    members = [parabolic_pieces(c)[0] for c in coarser] + [pieces]
    family = ReferenceFamily(members, A, free)
    logging.getLogger("fracfem_workflow").info(
        "reference family of %d runs: consecutive distances %s", len(members),
        ", ".join(f"{d:.4g}" for d in family.steps))
    return family, s


def _family_key(npz, coarser, quadrature):
    """What a saved reference family must have been made from: the reference run's
    operator key and each run's stored values (shape and sum)."""
    pieces, d = parabolic_pieces(npz)
    key = {"reference": _operator_key(pieces, float(d["s"]), quadrature), "runs": []}
    for c in [*coarser, npz]:
        U = np.load(c)["U"]
        key["runs"].append([list(U.shape), float(np.asarray(U, dtype=float).sum())])
    return key, pieces


def save_reference_family(npz, coarser, quadrature, operator, out):
    """Build stored_family once and write it (pickle, with what it was made from and the
    distance of the coarsest run to it) for the jobs that measure runs against it."""
    import pickle

    from .io import atomic_path

    family, s = stored_family(npz, coarser, quadrature, operator)
    key, _ = _family_key(npz, coarser, quadrature)
    coarsest = parabolic_pieces(coarser[0])[0]
    data = {"key": key, "family": family, "s": s,
            "check": np.asarray(family.distances(coarsest), dtype=float)}
    with atomic_path(out) as tmp:
        with open(tmp, "wb") as f:
            pickle.dump(data, f, protocol=pickle.HIGHEST_PROTOCOL)


def _load_family(path, npz, coarser, quadrature):
    import pickle

    with open(path, "rb") as f:
        data = pickle.load(f)
    key, _ = _family_key(npz, coarser, quadrature)
    if data["key"] != key:
        raise ValueError(f"{path} was made from other runs or another quadrature than "
                         f"{npz} with {list(coarser)}: delete it to rebuild")
    family = data["family"]
    d = np.asarray(family.distances(parabolic_pieces(coarser[0])[0]), dtype=float)
    if not np.allclose(d, data["check"], rtol=1e-12, atol=0.0):
        raise ValueError(f"{path}: the saved family's distances differ from those saved "
                         "with it: delete it to rebuild")
    logging.getLogger("fracfem_workflow").info(
        "reference family of %d runs read from %s: consecutive distances %s",
        len(family.references), path, ", ".join(f"{x:.4g}" for x in family.steps))
    return family, data["s"]


def family_error(family, pieces) -> dict:
    """A run's error columns against a ReferenceFamily: ``error``, the distance to the
    family's limit (extrapolated), ``error_uncertainty``, its measured uncertainty (NaN
    with three members to extrapolate through, infinite if unconfirmed), and ``error_vs_reference``, the distance to the finest member.
    ``family`` may be a single SpaceTimeReference: then the error is the distance to it."""
    if not hasattr(family, "error"):
        d = family.distance(pieces)
        return {"error": d, "error_uncertainty": float("nan"), "error_vs_reference": d}
    out = family.error(pieces)
    return {"error": out["error"], "error_uncertainty": out["uncertainty"],
            "error_vs_reference": float(out["distances"][-1])}


def _reference_operator(pieces, s, quadrature):
    import fracfem as ff

    logging.getLogger("fracfem_workflow").info("assembling the reference's operator")
    disc = ff.discretise(pieces[0][2], s, 0.0, quadrature=quadrature, operator="auto")
    return disc.A, np.asarray(disc.free)


def _operator_key(pieces, s, quadrature):
    """What a saved reference operator must have been made for."""
    mesh = pieces[0][2]
    return {"s": float(s), "quadrature": json.dumps(dataclasses.asdict(quadrature),
                                                    sort_keys=True),
            "nodes": int(mesh.p.shape[1]), "triangles": int(mesh.t.shape[1]),
            "p_sum": float(np.asarray(mesh.p, dtype=float).sum())}


def save_reference_operator(npz, quadrature, out):
    """Assemble the operator of a stored reference run once and write it (pickle) with
    what it was made for and one product, for the jobs that measure runs against it."""
    import pickle

    from .io import atomic_path

    pieces, d = parabolic_pieces(npz)
    s = float(d["s"])
    A, free = _reference_operator(pieces, s, quadrature)
    x = np.asarray(pieces[-1][3], dtype=float)[free]
    data = {"key": _operator_key(pieces, s, quadrature), "A": A, "free": free,
            "check": (x, np.asarray(A @ x, dtype=float))}
    with atomic_path(out) as tmp:
        with open(tmp, "wb") as f:
            pickle.dump(data, f, protocol=pickle.HIGHEST_PROTOCOL)


def load_reference_operator(path, pieces, s, quadrature):
    """(A, free) of save_reference_operator's file, after checking that it was made for
    this reference run and quadrature and that it still gives the product it gave."""
    import pickle

    with open(path, "rb") as f:
        data = pickle.load(f)
    key = _operator_key(pieces, s, quadrature)
    if data["key"] != key:
        differ = sorted(k for k in key if data["key"].get(k) != key[k])
        raise ValueError(f"{path} was made for another reference run or quadrature "
                         f"(differs in {differ}): delete it to reassemble")
    x, y = data["check"]
    if not np.allclose(np.asarray(data["A"] @ x, dtype=float), y, rtol=1e-12,
                       atol=1e-12 * float(np.abs(y).max())):
        raise ValueError(f"{path}: the stored operator's product differs from the one "
                         "saved with it: delete it to reassemble")
    return data["A"], np.asarray(data["free"])


def solved_pieces(prob, u0, times, tol):
    """[(t_{k−1}, t_k, mesh, u_k)] of one DG(0) run of prob on its fine mesh over the time
    grid times (k = 1 … M; the PDAS solver to tol), as parabolic_pieces gives a stored one."""
    import fracfem as ff

    steps = ff.time_steps(ff.Stepper(prob), u0, times, solver="pdas",
                          solver_options={"tol": tol})
    return [(st.t - st.tau, st.t, prob.fine, st.u) for st in steps if st.k > 0]


def parabolic_pieces(npz):
    """[(t_{k−1}, t_k, mesh, u_k)] of a stored parabolic run, and the loaded file."""
    from skfem import MeshTri

    d = np.load(npz)
    mesh = MeshTri(d["p"], d["t"])
    times, U = d["times"], d["U"]
    return [(times[k - 1], times[k], mesh, U[k]) for k in range(1, len(times))], d
