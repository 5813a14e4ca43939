"""Algorithm C: space-time adaptivity for the parabolic obstacle and friction problems.

A list of time slabs, each with its own coarse mesh; DG(0) steps on each slab
(:mod:`fracfem.parabolic`), prism indicators per (slab, coarse element) from the
space-time indicators (:mod:`fracfem.spacetime_estimators`), spatial refinement
of marked prisms and bisection of slabs whose time part dominates.  One pass is
SOLVE and ESTIMATE slab by slab (:class:`_SolveEstimate`), MARK over all prisms
(:func:`_mark_prisms`), REFINE and bisect (:func:`_refine_slabs`); the design
decisions are listed in :func:`algorithm_c`.  Algorithm B, the elliptic
counterpart, is :mod:`fracfem.adaptive`.

Progress: one INFO line per iteration (logger ``fracfem.spacetime_adaptive``:
slabs, time steps, DOFs, η, solver iterations, seconds), one DEBUG line per
slab; the time steps themselves report through ``fracfem.parabolic``.
"""
from __future__ import annotations

import logging
import math
import numbers
import time
from collections import OrderedDict
from dataclasses import dataclass, field
from typing import Iterator

import numpy as np

from . import estimators
from ._progress import Ticker
from .adaptive import MARKINGS, _check_theta
from .exact import check_s
from .memory import GIB
from .meshes import element_diameters, refine_disk
from .parabolic import (Source, Stepper, _check_solver, _is_real, _positive,
                        _positive_int, time_steps)
from .spacetime_estimators import BATCH_STEPS, initial_indicators, steps_indicators
from .stepsize import time_step
from .transfer import transfer
from .vi import MixedProblem

__all__ = [
    "Slab",
    "IterationRecord",
    "algorithm_c_steps",
    "algorithm_c",
    "solve_slabs",
    "save_slabs",
    "load_slabs",
    "pass_size",
]

logger = logging.getLogger(__name__)


@dataclass
class Slab:
    """A time slab [a, b] with its coarse multiplier mesh T_H^j.

    Filled in when solved: ``fine`` = refine_disk(coarse), ``h_max`` (largest
    fine element diameter), ``n_steps`` uniform steps of length ``tau``,
    ``n_free`` free fine nodes.
    """

    a: float
    b: float
    coarse: object
    fine: object = None
    h_max: float = float("nan")
    n_steps: int = 0
    tau: float = float("nan")
    n_free: int = 0


@dataclass
class IterationRecord:
    """One SOLVE → ESTIMATE (→ MARK → REFINE) pass of Algorithm C."""

    iteration: int
    slabs: list                      # list of Slab solved on (with n_steps, tau, …)
    dofs: int                        # space-time DOFs Σ_j n_steps_j × n_free_j
    eta: float                       # global estimator (each node once)
    eta_parts: dict                  # squared totals: space, time, contact, initial
    steps: dict                      # per time step (arrays): see algorithm_c
    slab_totals: list                # per slab dict: space, time, contact, initial, total
    prism_eta2: list                 # per slab: η(j, T)² per coarse element of T_H^j
    outputs: dict                    # t_out → snapshot dict (see algorithm_c)
    final: dict                      # snapshot at T
    first_contact_time: float | None  # obstacle: first t_k with some λ^k < 0
    marked: list | None = None       # per slab: marked coarse elements
    bisected: list | None = None     # indices (this iteration) of bisected slabs
    timings: dict = field(default_factory=dict)  # assemble, solve, estimate, mark, refine
    stop: str | None = None
    pieces: list | None = None       # keep_steps=True: (t_{k−1}, t_k, fine mesh, u^k)
    next_slabs: list | None = None   # the space-time mesh of the next pass (None: it stops)


def _snapshot(t_out, step, slab_index, st):
    return dict(t=float(t_out), t_step=float(step.t), k=int(step.k), slab=int(slab_index),
                u=np.array(step.u), lam=None if step.lam is None else np.array(step.lam),
                mesh=st.mesh, coarse=st.coarse)


def _check_output_times(output_times, T):
    out = np.atleast_1d(np.asarray(output_times, dtype=float))
    if out.ndim != 1 or not np.all(np.isfinite(out)) or np.any(out < 0) or np.any(out > T):
        raise ValueError(f"output_times must be finite times in [0, T] = [0, {T}]; "
                         f"got {output_times!r}")
    return sorted(set(out.tolist()))


@dataclass
class _Settings:
    """The checked arguments of :func:`algorithm_c_steps` that SOLVE and ESTIMATE use."""

    T: float
    u0: object
    source: Source
    solver: str
    solver_options: dict | None
    time_quadrature: int
    order: int
    c_tau: float | None              # None: each slab keeps its own n_steps (solve_slabs)
    n_min: int
    outs: list                       # output times, sorted
    est_opts: dict                   # keywords of step_indicators
    loc_opts: dict                   # the ones initial_indicators takes too
    keep_steps: bool


# ------------------------------------------------------------------ SOLVE


def _stepper(slab, cache: OrderedDict, make_problem, cache_bytes: float, order: list,
             position: int) -> Stepper:
    """The :class:`Stepper` of the slab's coarse mesh, assembled once per mesh
    while it stays in the cache.

    ``cache``: id(coarse) → (coarse, Stepper); slabs sharing a mesh share one
    entry.  After an insertion, and again after each slab's steps (:func:`_sweep`:
    they add factorisations or preconditioners for new τ), entries other than the
    one in use are dropped until the steppers hold at most ``cache_bytes``
    (:attr:`Stepper.nbytes`), in the order of :func:`_trim` (``order``: the mesh
    keys of the sweep's slabs, ``position``: the slab being solved).
    """
    key = id(slab.coarse)
    if key in cache:
        cache.move_to_end(key)
        return cache[key][1]
    prob = make_problem(slab.coarse)
    if not isinstance(prob, MixedProblem) or prob.kind not in ("obstacle", "friction"):
        raise TypeError("make_problem must return a vi.MixedProblem of kind "
                        "'obstacle' or 'friction'")
    cache[key] = (slab.coarse, Stepper(prob))
    _trim(cache, cache_bytes, order, position)
    return cache[key][1]


def _sweep(run, slabs, cache: OrderedDict, make_problem, cache_bytes) -> "_SolveEstimate":
    """SOLVE and ESTIMATE on the slabs in order (steppers from ``cache``)."""
    sweep = _SolveEstimate(run)
    order = [id(sl.coarse) for sl in slabs]
    for j, slab in enumerate(slabs):
        t0 = time.perf_counter()
        st = _stepper(slab, cache, make_problem, cache_bytes, order, j)
        sweep.timings["assemble"] += time.perf_counter() - t0
        sweep.slab(j, slab, st)
        _trim(cache, cache_bytes, order, j)   # the slab's steps may have grown its stepper
    return sweep


def _next_use(order, position: int) -> dict:
    """{mesh key: how many slabs ahead it is needed next}: later in this sweep
    (1 … n − position − 1), else in the next sweep at its first slab, if the
    mesh is kept unrefined (n − position + first index)."""
    n = len(order)
    ahead = {}
    for i, key in enumerate(order):
        ahead.setdefault(key, n - position + i)      # the next sweep
    for i in range(n - 1, position, -1):              # this sweep, nearest last
        ahead[order[i]] = i - position
    return ahead


def _trim(cache: OrderedDict, cache_bytes: float, order: list, position: int) -> None:
    """Drop steppers beyond ``cache_bytes``, never the newest (the one in use).

    ``order``: the mesh keys of the sweep's slabs, solved in that order;
    ``position``: the slab in use.  The stepper needed furthest ahead goes first
    (:func:`_next_use`; meshes of no slab before any): Belady's rule, with the
    next sweep's order taken to be this one's (refinement changes it) and sizes
    in bytes rather than equal.  The sweeps visit the slabs in time order, so
    when the steppers exceed the budget, dropping the least recently used would
    drop each one just before it is needed again and assemble every mesh again
    on every pass.
    """
    held = sum(st.nbytes for _, st in cache.values())
    if held <= cache_bytes or len(cache) <= 1:
        return
    newest = next(reversed(cache))
    ahead = _next_use(order, position)
    victims = sorted((k for k in cache if k != newest), key=lambda k: -ahead.get(k, np.inf))
    for k in victims:
        if held <= cache_bytes:
            break
        _, st = cache.pop(k)
        held -= st.nbytes


def _slab_times(slab, st, c_tau, n_min) -> np.ndarray:
    """Fill in the slab's fine mesh and step count; return its uniform time grid.

    n_j = max(n_min, n_j inherited, ⌈(b − a)/(c_tau h_max^{2s})⌉): τ never grows;
    c_tau None: n_j = max(n_min, n_j inherited) (the slab's own steps).
    """
    slab.fine, slab.n_free = st.mesh, st.n_free
    slab.h_max = float(element_diameters(st.mesh).max())
    slab.n_steps = _n_steps(slab, slab.h_max, st.s, c_tau, n_min)
    slab.tau = (slab.b - slab.a) / slab.n_steps
    return np.linspace(slab.a, slab.b, slab.n_steps + 1)


def _n_steps(slab, h_max, s, c_tau, n_min) -> int:
    """The slab's step count in a pass: max(n_min, inherited, ⌈(b − a)/(c_tau h_max^{2s})⌉)
    (inherited: τ never grows; c_tau None: no rule)."""
    rule = 0 if c_tau is None else math.ceil((slab.b - slab.a) / time_step(h_max, s, c_tau)
                                               - 1e-9)
    return max(n_min, slab.n_steps, rule)


class _SolveEstimate:
    """SOLVE → ESTIMATE of one pass: the slabs in order, each step followed by its
    indicators; collects what :class:`IterationRecord` holds."""

    def __init__(self, settings: _Settings):
        self.run = settings
        self.timings = dict(assemble=0.0, solve=0.0, estimate=0.0, mark=0.0, refine=0.0)
        self.rows = dict(t=[], tau=[], slab=[], space=[], time=[], contact=[], total=[],
                         n_active=[], time_anorm=[])
        self.slab_totals, self.prism, self.snaps = [], [], {}
        self.first_contact = None
        self.pieces = [] if settings.keep_steps else None
        self.initial = 0.0
        self.last = None              # (last step, its slab index, its Stepper)
        self.iterations = 0           # solver iterations of all steps (progress lines)

    def slab(self, j, slab, st) -> None:
        """Steps of slab j from the end of slab j − 1 (u₀ for j = 0), with indicators."""
        run = self.run
        par = estimators.parents(st.coarse, st.mesh)
        times = _slab_times(slab, st, run.c_tau, run.n_min)
        if j == 0:
            start = run.u0
        else:
            step_end, _, st_end = self.last
            start = transfer(st_end.mesh, step_end.u, st.mesh)
        eta2 = np.zeros(st.coarse.t.shape[1])
        tot = dict(space=0.0, time=0.0, contact=0.0, initial=0.0)
        gen = time_steps(st, start, times, f=run.source, solver=run.solver,
                         solver_options=run.solver_options,
                         time_quadrature=run.time_quadrature)
        prev = None
        pending = []                  # solved steps k ≥ 1 awaiting their indicators
        while True:
            t0 = time.perf_counter()
            step = next(gen, None)
            self.timings["solve"] += time.perf_counter() - t0
            t0 = time.perf_counter()
            if step is not None and step.k == 0:      # the slab's start, first of all
                prev = step
                if j == 0:
                    fine = self._initial(j, slab, st, step, tot)
                    eta2 += np.bincount(par, fine, minlength=len(eta2))
            elif step is not None:
                pending.append(step)
            if pending and (step is None or len(pending) == BATCH_STEPS):
                # the steps' (−Δ)ˢu^k in one batched evaluation (steps_indicators)
                for fine in self._steps(j, st, prev, pending, times, tot):
                    eta2 += np.bincount(par, fine, minlength=len(eta2))
                prev, pending = pending[-1], []
            self.timings["estimate"] += time.perf_counter() - t0
            if step is None:
                break
        tot["total"] = sum(tot.values())
        logger.debug("slab %d [%g, %g]: %d steps of τ = %.4g, %d DOFs, squared indicator "
                     "%.4e", j, slab.a, slab.b, slab.n_steps, slab.tau, slab.n_free,
                     tot["total"])
        self.slab_totals.append(tot)
        self.prism.append(eta2)
        self.last = (prev, j, st)

    # ---------------------------------------------------------------- ESTIMATE

    def _initial(self, j, slab, st, step, tot) -> np.ndarray:
        """The initial term at t₀ (first slab, k = 0) per fine element; snapshots at t₀."""
        ini = initial_indicators(st, self.run.u0, step.u, **self.run.loc_opts)
        tot["initial"] = self.initial = ini["total"]
        for t_out in self.run.outs:
            if t_out <= slab.a:
                self.snaps[t_out] = _snapshot(t_out, step, j, st)
        return ini["eta2_fine"]

    def _steps(self, j, st, prev, steps, times, tot) -> Iterator[np.ndarray]:
        """Indicators of consecutive steps k ≥ 1 (after ``prev``) per fine element."""
        run = self.run
        inds = steps_indicators(st, prev.u, steps, f=run.source, order=run.order,
                                time_quadrature=run.time_quadrature, **run.est_opts)
        for step, ind in zip(steps, inds):
            yield self._step(j, st, step, ind, float(times[step.k - 1]), tot)

    def _step(self, j, st, step, ind, t_prev, tot) -> np.ndarray:
        """Step k ≥ 1 with its indicators ``ind``: its row, contact set, snapshots;
        returns the indicators per fine element."""
        run, rows = self.run, self.rows
        for part in ("space", "time", "contact"):
            tot[part] += ind[part + "_total"]
            rows[part].append(ind[part + "_total"])
        rows["total"].append(ind["total"])
        rows["time_anorm"].append(ind["time_anorm_total"])
        rows["t"].append(step.t)
        rows["tau"].append(step.tau)
        rows["slab"].append(j)
        iterations = step.info.get("iterations")
        if isinstance(iterations, numbers.Integral):
            self.iterations += int(iterations)
        if st.kind == "obstacle":
            n_act = int(np.count_nonzero(step.lam < 0))
            if n_act and self.first_contact is None:
                self.first_contact = float(step.t)
        else:
            n_act = int(np.count_nonzero(np.abs(step.lam) < st.cset.upper))
        rows["n_active"].append(n_act)
        if run.keep_steps:
            self.pieces.append((t_prev, float(step.t), st.mesh, np.array(step.u)))
        for t_out in run.outs:
            if t_out not in self.snaps and step.t >= t_out - 1e-12 * run.T:
                self.snaps[t_out] = _snapshot(t_out, step, j, st)
        return ind["eta2_fine"]

    def record(self, iteration, slabs) -> IterationRecord:
        """The :class:`IterationRecord` of the pass (global η counts each node once)."""
        rows = self.rows
        parts = dict(space=float(np.sum(rows["space"])), time=float(np.sum(rows["time"])),
                     contact=float(np.sum(rows["contact"])), initial=float(self.initial))
        eta = float(np.sqrt(max(sum(parts.values()), 0.0)))
        dofs = int(sum(sl.n_steps * sl.n_free for sl in slabs))
        last_step, last_slab, last_st = self.last
        return IterationRecord(
            iteration=iteration, slabs=[Slab(**vars(sl)) for sl in slabs], dofs=dofs,
            eta=eta, eta_parts=parts, steps={k: np.asarray(v) for k, v in rows.items()},
            slab_totals=self.slab_totals, prism_eta2=self.prism, outputs=self.snaps,
            final=_snapshot(self.run.T, last_step, last_slab, last_st),
            first_contact_time=self.first_contact, timings=self.timings,
            pieces=self.pieces)


# ------------------------------------------------------------------ MARK, REFINE


def _mark_prisms(prism, theta, mark) -> list:
    """Mark all prisms together; the marked coarse elements of each slab."""
    offsets = np.cumsum([0] + [len(e) for e in prism])
    marked_all = mark(np.maximum(np.concatenate(prism), 0.0), theta)
    return [marked_all[(marked_all >= offsets[j]) & (marked_all < offsets[j + 1])]
            - offsets[j] for j in range(len(prism))]


def _refine_slabs(slabs, marked, slab_totals, bisect_fraction):
    """Refine each slab's T_H at its marked elements; bisect it when its time part is
    at least ``bisect_fraction`` of its total.  Returns (new slabs, bisected indices).

    Every new slab keeps the step count n of its parent, so a bisected half has τ/2.
    """
    new, bisected = [], []
    for j, (slab, m) in enumerate(zip(slabs, marked)):
        n = slab.n_steps
        if m.size == 0:
            new.append(Slab(slab.a, slab.b, slab.coarse, n_steps=n))
            continue
        coarse = refine_disk(slab.coarse, m)
        tt = slab_totals[j]
        if tt["total"] > 0 and tt["time"] >= bisect_fraction * tt["total"]:
            mid = 0.5 * (slab.a + slab.b)   # each half keeps n steps: τ/2
            new += [Slab(slab.a, mid, coarse, n_steps=n),
                    Slab(mid, slab.b, coarse, n_steps=n)]
            bisected.append(j)
        else:
            new.append(Slab(slab.a, slab.b, coarse, n_steps=n))
    return new, bisected


def _slab_list(slabs, hint: str = "") -> list:
    """``slabs`` as a list, refused unless a non-empty list of :class:`Slab`."""
    slabs = list(slabs)
    if not slabs or not all(isinstance(sl, Slab) for sl in slabs):
        raise ValueError(f"slabs must be a non-empty list of Slab{hint}")
    return slabs


def _check_slabs(slabs, T, min_steps) -> list:
    """The slabs as a list, checked: :class:`Slab` objects, contiguous, covering [0, T],
    each with an integer ``n_steps`` ≥ ``min_steps``."""
    slabs = _slab_list(slabs, " (IterationRecord.slabs)")
    ends = np.array([[sl.a, sl.b] for sl in slabs], dtype=float)
    gaps = np.abs(ends[1:, 0] - ends[:-1, 1])
    tol = 1e-12 * T
    if (not np.all(np.isfinite(ends)) or abs(ends[0, 0]) > tol
            or abs(ends[-1, 1] - T) > tol or np.any(gaps > tol)
            or np.any(ends[:, 1] <= ends[:, 0])):
        raise ValueError(f"slabs must be contiguous and cover [0, T] = [0, {T}]; "
                         f"got [a, b] = {ends.tolist()}")
    bad = [j for j, sl in enumerate(slabs) if not (isinstance(sl.n_steps, numbers.Integral)
                                                    and sl.n_steps >= min_steps)]
    if bad:
        raise ValueError(f"slabs {bad} have n_steps < {min_steps}: pass the slabs of a "
                         "solved pass (IterationRecord.slabs or .next_slabs)")
    return slabs


def save_slabs(path, slabs, *, compress: bool = False, **arrays) -> None:
    """Write a space-time mesh (a list of :class:`Slab`: a, b, n_steps, coarse mesh)
    to the ``.npz`` file ``path``, each distinct coarse mesh once, so that slabs
    sharing a mesh share it again when read by :func:`load_slabs` (they pass u^k
    unchanged).  ``arrays``: further arrays to store beside it (names not starting
    with ``slab_`` or ``coarse_``, and not ``compress``).  ``compress``: deflate the
    file (``numpy.savez_compressed``: a copy to keep; Algorithm C's checkpoints shrink
    about fivefold, and take longer to write).  What a pass needs to continue
    Algorithm C from (:func:`algorithm_c` with ``slabs=`` and ``first_iteration=``)."""
    slabs = _slab_list(slabs)
    clash = [k for k in arrays if k.startswith(("slab_", "coarse_"))]
    if clash:
        raise ValueError(f"array names {clash} are reserved for the slabs")
    index, meshes = {}, []
    for sl in slabs:
        if id(sl.coarse) not in index:
            index[id(sl.coarse)] = len(meshes)
            meshes.append(sl.coarse)
    out = dict(slab_a=np.array([sl.a for sl in slabs], dtype=float),
               slab_b=np.array([sl.b for sl in slabs], dtype=float),
               slab_n_steps=np.array([sl.n_steps for sl in slabs], dtype=np.int64),
               slab_mesh=np.array([index[id(sl.coarse)] for sl in slabs], dtype=np.int64))
    for m, mesh in enumerate(meshes):
        out[f"coarse_p{m}"] = np.asarray(mesh.p, dtype=float)
        out[f"coarse_t{m}"] = np.asarray(mesh.t, dtype=np.int64)
    (np.savez_compressed if compress else np.savez)(path, **out, **arrays)


def load_slabs(path) -> tuple[list, dict]:
    """(slabs, arrays) written by :func:`save_slabs`: the slabs with their step counts
    and coarse meshes (one object per distinct mesh), and the other arrays."""
    from skfem import MeshTri
    with np.load(path, allow_pickle=False) as d:
        data = {k: d[k] for k in d.files}
    meshes, m = [], 0
    while f"coarse_p{m}" in data:
        meshes.append(MeshTri(data.pop(f"coarse_p{m}"), data.pop(f"coarse_t{m}")))
        m += 1
    a, b = data.pop("slab_a"), data.pop("slab_b")
    n, which = data.pop("slab_n_steps"), data.pop("slab_mesh")
    slabs = [Slab(float(a[j]), float(b[j]), meshes[int(which[j])], n_steps=int(n[j]))
             for j in range(len(a))]
    return slabs, data


def pass_size(slabs, s: float, *, c_tau: float | None = 1.0, n_min: int = 1) -> dict:
    """The size of an Algorithm C pass on ``slabs`` before it is solved.

    Each slab's fine mesh is ``refine_disk(coarse)``, its free nodes the fine mesh's
    interior nodes, and its step count the one the pass takes (n_j = max(n_min,
    n_j inherited, ⌈(b − a)/(c_tau h_max^{2s})⌉), as in the pass itself; ``c_tau``
    None: the slab's own count).  For the slabs a checkpoint holds (:func:`load_slabs`)
    this is the next pass's size, known before hours of solving it; for
    ``IterationRecord.slabs`` it is that pass's ``dofs``.

    Returns a dict: ``spacetime_dofs`` (Σ_j n_j × free_j), ``max_dofs_per_step``,
    ``steps`` (Σ_j n_j) and ``slabs``.
    """
    slabs = _slab_list(slabs)
    s = check_s(s)
    if c_tau is not None:
        c_tau = _positive("c_tau", c_tau)
    n_min = _positive_int("n_min", n_min)
    sizes = {}                               # slabs sharing a coarse mesh share its size
    total = steps = largest = 0
    for sl in slabs:
        if id(sl.coarse) not in sizes:
            fine = refine_disk(sl.coarse)
            sizes[id(sl.coarse)] = (len(fine.interior_nodes()),
                                    float(element_diameters(fine).max()))
        n_free, h_max = sizes[id(sl.coarse)]
        n = _n_steps(sl, h_max, s, c_tau, n_min)
        total += n * n_free
        steps += n
        largest = max(largest, n_free)
    return dict(spacetime_dofs=int(total), max_dofs_per_step=int(largest), steps=int(steps),
                slabs=len(slabs))


# ------------------------------------------------------------------ Algorithm C


def _cache_bytes(value) -> float:
    """The assembled-problem cache's budget in bytes (see :func:`algorithm_c`)."""
    from .memory import _parse_bytes, available_memory
    if value is None:
        avail = available_memory()
        return max(GIB, 0.25 * avail) if avail is not None else 4.0 * GIB
    return _parse_bytes(value, "cache_bytes")


def _settings(*, T, u0, f, f_time, solver, solver_options, time_quadrature, order, c_tau,
              n_min, output_times, estimator_options, keep_steps) -> _Settings:
    """The checked arguments that SOLVE and ESTIMATE share (c_tau checked by the caller)."""
    T = _positive("T", T)
    n_min = _positive_int("n_min", n_min)
    _check_solver(solver)
    if _is_real(u0) and not np.isfinite(u0):
        raise ValueError(f"u0={u0!r} must be finite")
    if not (_is_real(u0) or callable(u0)):
        raise ValueError("u0 must be a number or a callable u0(x) (the meshes change)")
    est_opts = dict(estimator_options or {})
    return _Settings(T=T, u0=u0, source=Source(f, f_time), solver=solver,
                     solver_options=solver_options, time_quadrature=time_quadrature,
                     order=order, c_tau=c_tau, n_min=n_min,
                     outs=_check_output_times(output_times, T), est_opts=est_opts,
                     loc_opts={k: est_opts[k] for k in ("localisation", "boundary")
                               if k in est_opts},
                     keep_steps=keep_steps)


def solve_slabs(make_problem, slabs, u0, *, T: float, time_refinement: int = 1,
                solver: str = "pdas", f=0.0, f_time: bool | None = None, order: int = 4,
                output_times=(), time_quadrature: int = 3,
                solver_options: dict | None = None, estimator_options: dict | None = None,
                keep_steps: bool = True, cache_bytes: float | str | None = None,
                iteration: int = 0) -> IterationRecord:
    """SOLVE and ESTIMATE on a given space-time mesh, its time steps refined.

    ``slabs``: the :class:`Slab` list of a pass of Algorithm C
    (``IterationRecord.slabs``), or slabs set up by hand: contiguous, covering
    [0, T], each with ``n_steps`` ≥ 1.  Each slab keeps its coarse mesh (so its
    fine mesh) and gets ``time_refinement`` × its ``n_steps`` uniform steps;
    everything else is as in :func:`algorithm_c`, whose keywords these are,
    except that ``keep_steps`` defaults to True (the steps are what one
    measures).  The input slabs are not changed.  ``time_refinement`` = 1
    repeats the pass; larger values separate the time discretisation's part of
    the error from the rest (the space meshes stay, τ falls).

    Returns the :class:`IterationRecord` of the pass (``marked`` None,
    ``timings`` with ``total``), ``iteration`` its number.
    """
    time_refinement = _positive_int("time_refinement", time_refinement)
    run = _settings(T=T, u0=u0, f=f, f_time=f_time, solver=solver,
                    solver_options=solver_options, time_quadrature=time_quadrature,
                    order=order, c_tau=None, n_min=1, output_times=output_times,
                    estimator_options=estimator_options, keep_steps=keep_steps)
    slabs = _check_slabs(slabs, run.T, min_steps=1)
    cache_bytes = _cache_bytes(cache_bytes)
    t_start = time.perf_counter()
    mine = [Slab(sl.a, sl.b, sl.coarse, n_steps=time_refinement * int(sl.n_steps))
            for sl in slabs]
    sweep = _sweep(run, mine, OrderedDict(), make_problem, cache_bytes)
    rec = sweep.record(iteration, mine)
    rec.timings["total"] = time.perf_counter() - t_start
    logger.info("solve_slabs: %d slabs, %d time steps (× %d), %d space-time DOFs, eta %.4e",
                len(mine), sum(sl.n_steps for sl in mine), time_refinement, rec.dofs, rec.eta)
    return rec


def algorithm_c_steps(make_problem, coarse0, u0, *, T: float, theta: float,
                      iterations: int, c_tau: float = 1.0, marking: str = "maximum",
                      solver: str = "pdas", f=0.0, f_time: bool | None = None,
                      order: int = 4, tol: float | None = None, output_times=(),
                      n_min: int = 1, bisect_fraction: float = 0.5,
                      time_quadrature: int = 3, solver_options: dict | None = None,
                      estimator_options: dict | None = None,
                      callback=None, keep_steps: bool = False,
                      cache_bytes: float | str | None = None,
                      slabs: list | None = None, first_iteration: int = 0
                      ) -> Iterator[IterationRecord]:
    """Algorithm C as a generator of :class:`IterationRecord` (see :func:`algorithm_c`)."""
    theta = _check_theta(theta)
    if marking not in MARKINGS:
        raise ValueError(f"marking={marking!r} must be one of {tuple(MARKINGS)}")
    mark = MARKINGS[marking]
    iterations = _positive_int("iterations", iterations)
    c_tau = _positive("c_tau", c_tau)
    if not (_is_real(bisect_fraction) and 0.0 < bisect_fraction <= 1.0):
        raise ValueError(f"bisect_fraction={bisect_fraction!r} must be in (0, 1]")
    if tol is not None and not (_is_real(tol) and tol >= 0):
        raise ValueError(f"tol={tol!r} must be a number >= 0 or None")
    run = _settings(T=T, u0=u0, f=f, f_time=f_time, solver=solver,
                    solver_options=solver_options, time_quadrature=time_quadrature,
                    order=order, c_tau=c_tau, n_min=n_min, output_times=output_times,
                    estimator_options=estimator_options, keep_steps=keep_steps)
    cache_bytes = _cache_bytes(cache_bytes)
    if not (isinstance(first_iteration, numbers.Integral)
            and 0 <= first_iteration < iterations):
        raise ValueError(f"first_iteration={first_iteration!r} must be an integer in "
                         f"[0, iterations) = [0, {iterations})")
    if slabs is None:
        if first_iteration:
            raise ValueError(f"first_iteration={first_iteration} needs the slabs of that "
                             "pass (slabs=IterationRecord.next_slabs or load_slabs(...))")
        slabs = [Slab(0.0, run.T, coarse0)]
    else:                                   # continue: that pass's mesh, τ never grows
        slabs = [Slab(sl.a, sl.b, sl.coarse, n_steps=int(sl.n_steps))
                 for sl in _check_slabs(slabs, run.T, min_steps=0)]

    cache: OrderedDict = OrderedDict()      # id(coarse) → (coarse, Stepper), in use last
    clock = Ticker(0.0)
    logger.info("Algorithm C: at most %d iterations on [0, %g], marking %s, theta %g, "
                "c_tau %g, tol %s; assembled problems cached up to %.2f GiB", iterations,
                run.T, marking, theta, c_tau, tol, cache_bytes / GIB)
    for it in range(first_iteration, iterations):
        t_iter = time.perf_counter()
        sweep = _sweep(run, slabs, cache, make_problem, cache_bytes)
        rec = sweep.record(it, slabs)
        tim = rec.timings
        if tol is not None and rec.eta <= tol:
            rec.stop = "tol"
        elif it == iterations - 1:
            rec.stop = "iterations"
        else:
            t0 = time.perf_counter()
            rec.marked = _mark_prisms(rec.prism_eta2, theta, mark)
            tim["mark"] = time.perf_counter() - t0
            if all(m.size == 0 for m in rec.marked):
                rec.stop = "nothing marked"
            else:
                t0 = time.perf_counter()
                slabs, rec.bisected = _refine_slabs(slabs, rec.marked, rec.slab_totals,
                                                    bisect_fraction)
                keep = {id(sl.coarse) for sl in slabs}
                cache = OrderedDict((k, v) for k, v in cache.items() if k in keep)
                tim["refine"] = time.perf_counter() - t0
                rec.next_slabs = [Slab(sl.a, sl.b, sl.coarse, n_steps=sl.n_steps)
                                  for sl in slabs]
        tim["total"] = time.perf_counter() - t_iter
        logger.info("Algorithm C iteration %d: %d slabs, %d time steps, %d DOFs per step "
                    "(max), %d space-time DOFs, eta %.4e, %d solver iterations, %s marked, "
                    "%d bisected, %.2f s (elapsed %.1f s)", it, len(rec.slabs),
                    sum(sl.n_steps for sl in rec.slabs), max(sl.n_free for sl in rec.slabs),
                    rec.dofs, rec.eta, sweep.iterations,
                    "-" if rec.marked is None else sum(len(m) for m in rec.marked),
                    len(rec.bisected or ()), tim["total"], clock.elapsed)
        if callback is not None and callback(rec) and rec.stop is None:
            rec.stop = "callback"
        if rec.stop is not None:
            rec.next_slabs = None
            logger.info("Algorithm C stops after iteration %d: %s", it, rec.stop)
        yield rec
        if rec.stop is not None:
            return


def algorithm_c(make_problem, coarse0, u0, *, T: float, theta: float, iterations: int,
                **kwargs) -> list[IterationRecord]:
    """Algorithm C (space-time adaptivity) for the parabolic obstacle/friction problem.

    SOLVE → ESTIMATE → MARK → REFINE on a space-time mesh of time slabs.

    Design (the paper leaves it open; these are our decisions)
    ----------------------------------------------------------
    * Space-time mesh: contiguous slabs [a_j, b_j] covering [0, T], each with its
      own coarse multiplier mesh T_H^j (fine mesh T_h^j = refine_disk(T_H^j)) and
      n_j uniform DG(0) steps.  Start: one slab [0, T] on ``coarse0``.
    * Time step: n_j uniform steps, n_j = max(n_min, n_j^inherited,
      ⌈(b_j − a_j)/(c_tau h_j^{2s})⌉), so τ_j ≤ c_tau·h_j^{2s} with h_j the largest
      fine element diameter of the slab (the paper's rule τ ≈ 0.5 h_max^{2s} for
      graded meshes: τ/h^{2s} fixed), and τ_j never grows: a slab keeps its n_j
      when refined in space, and each half of a bisected slab keeps n_j, so
      bisection halves τ — this is the time refinement.  (Recomputing n_j from
      h_max alone was tried first: with local refinement h_max stays put, τ did
      not fall, the time term τ h_i^{−2s}‖u^k − u^{k−1}‖² grew on the refined
      elements and η went up: 2.38, 1.94, 1.95, 2.37 on the test case.)
    * Transfer between slabs: u at the end of slab j−1 is interpolated nodally onto
      the fine mesh of slab j (P1 evaluation at the new nodes, 0 outside the old
      polygon and on the new boundary; :func:`fracfem.transfer.transfer`), and
      slab j starts from it (it lies in V_h of slab j, so its projection is
      itself).  Slabs sharing a
      mesh pass u^k unchanged.  The interpolation error (nonzero where slab j's
      mesh is coarser than slab j−1's) is not part of the indicators.
    * Indicators: prism η(j, T)² = Σ over the steps of slab j of the fine-element
      indicators (:func:`~fracfem.spacetime_estimators.step_indicators`: space +
      time + contact) of the four children of coarse element T, plus the initial
      term for slab 0.
    * Marking: all prisms together, η(j, T) > θ max η ('maximum', the paper) or
      Dörfler ('doerfler').
    * Refinement: T_H^j is refined at its marked elements (``refine_disk``); slab j
      is bisected in time (both halves get the refined mesh) when its time part
      is at least ``bisect_fraction`` (default ½) of its total indicator.  Slabs
      without marked prisms keep their mesh and length.
    * Assembled problems are cached by mesh identity (slabs sharing a mesh and
      unchanged slabs of the previous iteration assemble once); beyond
      ``cache_bytes`` (default: a quarter of the memory available at the start,
      at least 1 GiB) the problem needed furthest ahead in the sweeps is dropped
      first, and a dropped mesh is assembled again when met.

    Parameters
    ----------
    make_problem : ``make_problem(coarse)`` → vi.MixedProblem ('obstacle' or
        'friction'), e.g. ``lambda c: vi.mixed_problem("obstacle", c, 0.5, 0.0, chi=chi)``
    coarse0 : initial T_H
    u0 : number or callable u0(x)
    T : final time; theta : marking parameter in (0, 1); iterations : max passes
    c_tau, n_min, bisect_fraction : the time-step and bisection rules above
    marking : 'maximum' or 'doerfler'; solver : 'pdas' or 'uzawa'
    f, f_time : the load (:mod:`fracfem.parabolic`); order : triangle rule of the residual
    tol : stop when η ≤ tol; output_times : times in [0, T] at which to keep u, λ
    estimator_options : keywords of
        :func:`~fracfem.spacetime_estimators.step_indicators` (localisation, boundary, p,
        method and tol of the pointwise (−Δ)ˢu_h)
    callback : called with each record; a truthy return stops after it
    cache_bytes : bytes (a number, or a string such as '4G') the cached assembled
        problems may hold; None: the default above
    slabs, first_iteration : continue a run instead of starting it: ``slabs`` is
        the space-time mesh of pass ``first_iteration`` (``IterationRecord.next_slabs``
        of the pass before it, or read back with :func:`load_slabs` after
        :func:`save_slabs`), ``coarse0`` is then not used; ``iterations`` still
        counts from pass 0.  The passes that follow are those of the uninterrupted
        run: the same meshes and steps, and values to round-off (the cache of
        assembled problems starts empty, as with a small ``cache_bytes``)

    Returns
    -------
    list of :class:`IterationRecord` with fields
    ``iteration``, ``slabs`` (list of :class:`Slab`: a, b, coarse, fine, h_max,
    n_steps, tau, n_free), ``dofs`` (Σ_j n_steps_j × n_free_j), ``eta``,
    ``eta_parts`` (squared totals 'space', 'time', 'contact', 'initial'),
    ``steps`` (dict of arrays over all time steps in order: 't', 'tau', 'slab',
    'space', 'time', 'contact', 'total' (squared indicator totals of the step),
    'n_active' (obstacle: multipliers with λ < 0; friction: with |λ| < F, stick),
    'time_anorm' (τ_k a(u^k − u^{k−1}, ·): the time term in the energy norm, a
    diagnostic outside η)),
    ``slab_totals`` (per slab dict 'space', 'time', 'contact', 'initial', 'total'),
    ``prism_eta2`` (per slab, η(j, T)² per coarse element), ``outputs`` (dict
    t_out → snapshot), ``final`` (snapshot at T), ``first_contact_time``
    (obstacle), ``marked`` (per slab, coarse element indices; None on the last
    record), ``bisected`` (slab indices), ``timings`` ('assemble', 'solve',
    'estimate', 'mark', 'refine', 'total' seconds), ``stop`` ('iterations',
    'tol', 'nothing marked', 'callback' or None), ``next_slabs`` (the refined
    space-time mesh the next pass solves on; None when this pass is the last).
    A snapshot is a dict 't' (requested), 't_step' (t_k of the step whose
    interval (t_{k−1}, t_k] holds t; t_0 for t = 0), 'k', 'slab', 'u' (all fine
    nodes), 'lam' (None at t = 0), 'mesh' (fine), 'coarse'.
    """
    return list(algorithm_c_steps(make_problem, coarse0, u0, T=T, theta=theta,
                                  iterations=iterations, **kwargs))
