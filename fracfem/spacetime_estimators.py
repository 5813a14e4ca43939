"""Space-time indicators of DG(0) runs (Theorem 6.18, Lemma 6.20, Section 7).

Per step k and fine element Δ (:func:`step_indicators`):

* space:   τ_k × the elliptic residual indicator of :func:`fracfem.estimators.estimate`
  (same localisation, contact nodes, boundary convention) with
  r = f̄_k − (u^k − u^{k−1})/τ_k − (−Δ)ˢu^k and λ^k.  (f − f̄_k, a data
  oscillation, is not included.)  With this r, ⟨r − λ^k, φ_i⟩ = 0 for every free
  node i (the orthogonality of Lemma 5.22), as in the elliptic case.
* time:    Σ_{i vertex of Δ, admitted} τ_k h_i^{−2s} ‖u^k − u^{k−1}‖²_{L²(S_i)} —
  the paper's display literally (for U the linear interpolant of Remark 6.15,
  ∫_{I_k}‖u^k − U‖² dt = τ_k/3 ‖u^k − u^{k−1}‖²: the paper drops the 1/3; so do we).
* initial: Σ_{i vertex of Δ, i interior} ‖u₀ − P_h u₀‖²_{L²(S_i)}, step 0 only
  (quadrature of ``order`` on the fine mesh; C_h = ∅ at t₀).
* contact: τ_k × the Lemma 5.21 / 6.20 term of :func:`fracfem.estimators.contact_terms`.

"Admitted" nodes are those of the space term of the same step (interior, not in
C_h).  With ``localisation='split'`` the time and initial terms give each element
its own part ‖·‖²_{L²(Δ)} of the patch norm instead of the whole patch.  The
global estimator counts each node once (as :func:`fracfem.estimators.estimate`):
η² = Σ_k (Σ_i τ_k η_{i,k}² + time_k + τ_k contact_k) + initial.
Thin problems are stepped but have no indicators (λ_H lives on Γ̃).

The runs are those of :mod:`fracfem.parabolic` (:class:`~fracfem.parabolic.TimeStep`
records); ``problem`` is anything :class:`~fracfem.parabolic.Stepper` accepts, or a
Stepper.
"""
from __future__ import annotations

import time

import numpy as np

from . import estimators
from .assembly import mesh_arrays
from .compressed import DEFAULT_TOL
from .parabolic import Source, TimeStep, _as_stepper, _is_real
from .pointwise import fractional_laplacian_qp, quadrature_points

# steps whose (−Δ)ˢu^k are evaluated in one batched call: their cost grows far
# more slowly than the count, the memory (Nt × nq × BATCH_STEPS values) linearly
BATCH_STEPS = 16

__all__ = [
    "initial_indicators",
    "step_indicators",
    "steps_indicators",
    "space_time_indicators",
]


def _element_l2sq(mesh, v) -> np.ndarray:
    """‖v‖²_{L²(T)} of the P1 function v (all nodes) on every element, exactly."""
    p, t = mesh_arrays(mesh)
    e1, e2 = p[t[:, 1]] - p[t[:, 0]], p[t[:, 2]] - p[t[:, 0]]
    area = 0.5 * np.abs(e1[:, 0] * e2[:, 1] - e1[:, 1] * e2[:, 0])
    vt = v[t]
    return area / 12.0 * (np.sum(vt ** 2, axis=1) + np.sum(vt, axis=1) ** 2)


def _localise(mesh, elem_sq, node_weight, admitted, localisation):
    """Node terms w_i ‖·‖²_{L²(S_i)} (admitted i) and their element indicators."""
    p, t = mesh_arrays(mesh)
    nv = len(p)
    patch = np.bincount(t.ravel(), weights=np.repeat(elem_sq, 3), minlength=nv)
    w = np.where(admitted, node_weight, 0.0)
    node_term = w * patch
    if localisation == "patch":
        eta2 = node_term[t].sum(axis=1)
    else:
        eta2 = w[t].sum(axis=1) * elem_sq
    return eta2, node_term


def _admitted_mask(mesh, nodes) -> np.ndarray:
    mask = np.zeros(mesh.p.shape[1], dtype=bool)
    mask[np.asarray(nodes, dtype=np.int64)] = True
    return mask


def _check_localisation(localisation):
    if localisation not in estimators.LOCALISATIONS:
        raise ValueError(f"localisation={localisation!r} must be one of "
                         f"{estimators.LOCALISATIONS}")


def initial_indicators(problem, u0, u0h=None, *, order: int = 6,
                       localisation: str = "patch", boundary: bool = False) -> dict:
    """The initial term ‖u₀ − P_h u₀‖²_{L²(S_i)} of Theorem 6.18 per fine element.

    ``u0h`` (all fine nodes) defaults to
    :func:`~fracfem.parabolic.initial_projection`.  The element norms use a
    triangle rule of ``order`` (exact for P1 arrays with order ≥ 2).
    Nodes: interior nodes (all nodes with ``boundary=True``); C_h = ∅ at t₀.

    Returns dict ``eta2_fine`` (Nt,), ``elements`` (‖u₀ − P_h u₀‖²_{L²(T)}),
    ``nodes`` (node terms), ``total`` (Σ node terms), ``l2sq`` (‖u₀ − P_h u₀‖²_{L²(Ω_h)}).
    """
    _check_localisation(localisation)
    st = _as_stepper(problem)
    mesh = st.mesh
    if u0h is None:
        u0h = st.disc.extend(st.project(u0, order=order))
    u0h = np.asarray(u0h, dtype=float)
    pts, wts, bary = quadrature_points(mesh, order)
    _, t = mesh_arrays(mesh)
    uh_q = u0h[t] @ bary.T                                           # (Nt, nq)
    if _is_real(u0) or callable(u0):
        x = np.moveaxis(pts, -1, 0)
        u_q = np.broadcast_to(np.asarray(u0(x) if callable(u0) else u0, dtype=float),
                              uh_q.shape)
    else:
        arr = np.asarray(u0, dtype=float)
        if arr.shape == (st.n_free,) and st.n_free != mesh.p.shape[1]:
            arr = st.disc.extend(arr)
        u_q = arr[t] @ bary.T
    elem = np.einsum("tq,tq->t", wts, (u_q - uh_q) ** 2)
    nv = mesh.p.shape[1]
    admitted = np.ones(nv, bool) if boundary else _admitted_mask(mesh,
                                                                 mesh.interior_nodes())
    eta2, node_term = _localise(mesh, elem, np.ones(nv), admitted, localisation)
    return dict(eta2_fine=eta2, elements=elem, nodes=node_term,
                total=float(node_term.sum()), l2sq=float(elem.sum()))


def step_indicators(problem, u_prev, step: TimeStep, *, f=0.0, f_time=None,
                    order: int = 4, time_quadrature: int = 3,
                    localisation: str = "patch", boundary: bool = False,
                    p: float = 2.0, contact_nodes=None, options=None,
                    method: str = "auto", tol: float = DEFAULT_TOL) -> dict:
    """Space-time indicators of one DG(0) step k ≥ 1 on every fine element.

    Parameters
    ----------
    problem : MixedProblem (obstacle or friction), Discretisation or Stepper
    u_prev : u^{k−1} over all fine nodes
    step : the :class:`~fracfem.parabolic.TimeStep` k (u^k, λ^k, t_k, τ_k)
    f, f_time : the load (f̄_k = time mean over I_k enters the residual)
    order, localisation, boundary, p, contact_nodes, options, method, tol : as in
        :func:`fracfem.estimators.estimate` (method and tol: how (−Δ)ˢu^k is
        evaluated, :func:`fracfem.pointwise.fractional_laplacian_at`)

    Returns
    -------
    dict with per-element arrays (Nt,) ``space`` (τ_k × residual part), ``time``
    (τ_k h_i^{−2s}‖u^k − u^{k−1}‖²_{L²(S_i)} summed over admitted vertices),
    ``contact`` (τ_k × Lemma 5.21/6.20 fine share, clipped at 0), ``eta2_fine``
    (their sum); totals ``space_total`` (τ_k Σ_i η_i²), ``time_total``,
    ``contact_total`` (τ_k × unclipped Lemma 5.21 sum), ``total``; ``k``, ``t``,
    ``tau``; ``n_contact_nodes``; ``seconds``; and, a diagnostic outside η,
    ``time_anorm_total`` = τ_k a(u^k − u^{k−1}, u^k − u^{k−1}): the time term with the
    energy norm that h_i^{−2s}‖·‖²_{L²} stands in for (inverse estimate).
    """
    return steps_indicators(problem, u_prev, [step], f=f, f_time=f_time, order=order,
                            time_quadrature=time_quadrature, localisation=localisation,
                            boundary=boundary, p=p, contact_nodes=contact_nodes,
                            options=options, method=method, tol=tol)[0]


def steps_indicators(problem, u_prev, steps, *, f=0.0, f_time=None, order: int = 4,
                     time_quadrature: int = 3, localisation: str = "patch",
                     boundary: bool = False, p: float = 2.0, contact_nodes=None,
                     options=None, method: str = "auto", tol: float = DEFAULT_TOL) -> list:
    """:func:`step_indicators` of consecutive steps on one mesh, in one pass.

    ``steps``: TimeStep records k, k + 1, … of one run on the mesh of
    ``problem``; ``u_prev``: u^{k−1}.  (−Δ)ˢu of all of them is evaluated in one
    batched call (:func:`fracfem.pointwise.fractional_laplacian_qp` with one
    column per step), which shares the kernel values, trees and near-field
    rules among the steps; the indicators are those of :func:`step_indicators`
    step by step (the same up to round-off, tested).  Returns one dict per step.
    """
    _check_localisation(localisation)
    st = _as_stepper(problem)
    if st.kind not in ("obstacle", "friction", "heat"):
        raise ValueError(f"indicators support kinds 'obstacle', 'friction' and the "
                         f"unconstrained problem, got {st.kind!r}")
    steps = list(steps)
    if not steps:
        return []
    for i, step in enumerate(steps):
        if step.k < 1:
            raise ValueError("step_indicators needs a step k >= 1 (k = 0 has "
                             "initial_indicators)")
        if i and step.k != steps[i - 1].k + 1:
            raise ValueError(f"steps must be consecutive, got k = {steps[i - 1].k} "
                             f"followed by k = {step.k}")
    t0 = time.perf_counter()
    mesh = st.mesh
    free = st.disc.free
    us = [estimators._check_u(mesh, step.u, free) for step in steps]
    prevs = [estimators._check_u(mesh, u_prev, free)] + us[:-1]
    lap, _, _ = fractional_laplacian_qp(mesh, np.column_stack(us), st.s, order,
                                        options=options, method=method, tol=tol)
    t_lap = (time.perf_counter() - t0) / len(steps)
    out = []
    for r, step in enumerate(steps):
        row = _one_step(st, prevs[r], us[r], step, lap[..., r], f, f_time, order,
                        time_quadrature, localisation, boundary, p, contact_nodes,
                        options, method, tol)
        row["seconds"] += t_lap
        out.append(row)
    return out


def _one_step(st, u_prev, u, step, lap, f, f_time, order, time_quadrature, localisation,
              boundary, p, contact_nodes, options, method, tol) -> dict:
    """The indicators of one step from (−Δ)ˢu^k at the quadrature points (``lap``)."""
    t0 = time.perf_counter()
    mesh = st.mesh
    tau = float(step.info.get("tau_used", step.tau))
    du = u - u_prev
    _, T = mesh_arrays(mesh)
    _, _, bary = quadrature_points(mesh, order)
    rh_extra = -(du[T] @ bary.T) / tau
    fbar = Source(f, f_time).mean(step.t - step.tau, step.t, time_quadrature)
    if st.kind == "heat":
        res, det = estimators.residual_indicators(
            mesh, u, st.s, fbar, None, contact_nodes, order, p=p,
            localisation=localisation, boundary=boundary, options=options,
            full_output=True, rh_extra=rh_extra, method=method, tol=tol, _lap=lap)
        res_total = float(det["term"].sum())
        contact = np.zeros_like(res)
        contact_total = 0.0
        admitted = det["nodes"]
        n_contact = 0 if contact_nodes is None else len(np.atleast_1d(contact_nodes))
    else:
        est = estimators.estimate(st.problem, u, step.lam, order, f=fbar,
                                  contact_nodes=contact_nodes, p=p,
                                  localisation=localisation, boundary=boundary,
                                  options=options, rh_extra=rh_extra, method=method,
                                  tol=tol, _lap=lap)
        parts = est["parts"]
        res, res_total = parts["residual_fine"], parts["residual"]
        contact = np.maximum(parts["contact"]["fine"], 0.0)
        contact_total = parts["contact_total"]
        admitted = parts["admitted_nodes"]
        n_contact = len(parts["contact_nodes"])
    h = estimators.patch_diameters(mesh)
    time_el, time_nodes = _localise(mesh, _element_l2sq(mesh, du), tau * h ** (-2 * st.s),
                                    _admitted_mask(mesh, admitted), localisation)
    space = tau * res
    contact = tau * contact
    du_free = du[st.free]
    out = dict(k=step.k, t=step.t, tau=tau, space=space, time=time_el, contact=contact,
               eta2_fine=space + time_el + contact,
               space_total=tau * res_total, time_total=float(time_nodes.sum()),
               contact_total=tau * contact_total, n_contact_nodes=n_contact,
               # diagnostic, not part of η: the time term with the energy norm in place of
               # its inverse-estimate proxy Σ_i h_i^{−2s}‖·‖²_{L²(S_i)}
               time_anorm_total=tau * float(du_free @ (st.disc.A @ du_free)))
    out["total"] = out["space_total"] + out["time_total"] + out["contact_total"]
    out["seconds"] = time.perf_counter() - t0
    return out


def space_time_indicators(problem, steps, u0, *, f=0.0, f_time=None, order: int = 4,
                          keep_elements: bool = True, **kwargs) -> dict:
    """Indicators of a whole run (Theorem 6.18, Lemma 6.20, Section 7).

    ``steps``: the list of :class:`~fracfem.parabolic.TimeStep` from
    :func:`~fracfem.parabolic.solve_parabolic` (k = 0 first); ``u0``: the initial
    value given to it (for the initial term).  Further keywords go to
    :func:`step_indicators`.

    Returns dict with
    ``t``, ``tau`` (M,), per-step totals ``space``, ``time``, ``contact``,
    ``total`` (M,), ``initial`` (scalar), per-element arrays (if
    ``keep_elements``) ``space_fine``, ``time_fine``, ``contact_fine``
    (M, Nt) and ``initial_fine`` (Nt,), ``eta2_fine`` (Nt: summed over steps,
    + initial), ``eta`` (global, each node once), ``eta_parts`` (squared totals
    of the four parts), ``seconds``.
    """
    st = _as_stepper(problem)
    if len(steps) < 2 or steps[0].k != 0:
        raise ValueError("steps must start with the k = 0 record and hold at least "
                         "one step (use solve_parabolic)")
    t0 = time.perf_counter()
    ini = initial_indicators(st, u0, steps[0].u,
                             localisation=kwargs.get("localisation", "patch"),
                             boundary=kwargs.get("boundary", False))
    rows = []
    for i in range(1, len(steps), BATCH_STEPS):
        rows += steps_indicators(st, steps[i - 1].u, steps[i:i + BATCH_STEPS], f=f,
                                 f_time=f_time, order=order, **kwargs)
    out = dict(t=np.array([r["t"] for r in rows]), tau=np.array([r["tau"] for r in rows]))
    for part in ("space", "time", "contact"):
        out[part] = np.array([r[part + "_total"] for r in rows])
    out["total"] = np.array([r["total"] for r in rows])
    out["initial"] = ini["total"]
    out["eta2_fine"] = ini["eta2_fine"] + np.sum([r["eta2_fine"] for r in rows], axis=0)
    if keep_elements:
        for part in ("space", "time", "contact"):
            out[part + "_fine"] = np.array([r[part] for r in rows])
        out["initial_fine"] = ini["eta2_fine"]
    out["eta_parts"] = dict(space=float(out["space"].sum()), time=float(out["time"].sum()),
                            contact=float(out["contact"].sum()), initial=ini["total"])
    out["eta"] = float(np.sqrt(max(sum(out["eta_parts"].values()), 0.0)))
    out["seconds"] = time.perf_counter() - t0
    return out
