"""A posteriori error indicators of Section 7 (Theorem 5.20, Lemmas 5.21, 5.22).

The estimate of Theorem 5.20 bounds ‖u − u_h‖²_H + ‖λ − λ_H‖²_{H⁻ˢ} by
‖r_h − λ_H‖²_{H⁻ˢ} + b(λ_H − λ, u − u_h), with the residual r_h = f − (−Δ)ˢu_h.
Section 7 makes both terms computable and local:

* the dual norm by the localisation of Lemma 5.22, node by node,

      η_i² = h_i^{2s} ‖(r_h − λ_H − r̄_i + λ̄_i) φ_i‖²_{L²(S_i)},
      r̄_i = ∫_{S_i} r_h φ_i / ∫_{S_i} φ_i,  λ̄_i likewise,

  S_i the patch (support of φ_i) of fine node i, h_i = diam(S_i), for the nodes
  not in the contact set C_h (:func:`residual_indicators`);
* the term b(λ_H − λ, u − u_h) by the computable bounds of Lemma 5.21, per coarse
  element (:func:`contact_terms`).

Conventions
-----------
* ``r_h − λ_H`` is the residual of the nodal system A u + B λ = b (vi, mixed):
  a(u_h, φ_i) + b(λ_H, φ_i) = ⟨f, φ_i⟩ means ⟨r_h − λ_H, φ_i⟩ = 0 for every free
  node i — the orthogonality Lemma 5.22 needs.  With exact integration r̄_i − λ̄_i
  would vanish at interior nodes; with quadrature it is the (small) quadrature
  defect of ⟨r_h − λ_H, φ_i⟩, and subtracting it makes the quadrature residual
  orthogonal to φ_i, as in the paper's formula.
* Negative part: x₋ = min(x, 0) ≤ 0 (and x₊ = max(x, 0)), so that x = x₊ + x₋.  This
  is the convention under which the proof of Lemma 5.21 (iii) closes:
  F + (|λ| − F)₊ = |λ| − (|λ| − F)₋.  The friction bound is then
  −b((|λ_H| − F)₋, |u_h|) = b(F − |λ_H|, |u_h|) ≥ 0 for λ_H ∈ Λ_H.

Which nodes enter η(Δ)
----------------------
The paper sums over the nodes with "S_i ∩ Δ ≠ ∅".  Read with closed sets this is
every node of every element that shares a point with Δ (a two-ring, ~19 nodes on a
uniform mesh): each node term would be spread over ~19 elements and the
indicators smeared over two layers.  We read it with the interior of Δ:
S_i ∩ int Δ ≠ ∅  ⟺  Δ ⊂ S_i  ⟺  i is a vertex of Δ.  These are the only nodes
whose φ_i does not vanish on Δ, i.e. whose weighted norm ‖(…)φ_i‖ sees Δ at all.
Two localisations are offered:

* ``localisation="patch"`` (default, the paper's formula literally): η(Δ)² is the
  sum of the full patch terms η_i² of the (admitted) vertices i of Δ.  Then
  Σ_Δ η(Δ)² = Σ_i n_i η_i² with n_i the number of elements of S_i.
* ``localisation="split"``: η(Δ)² takes of η_i² only the share of ‖(…)φ_i‖ that
  lies in Δ, so that Σ_Δ η(Δ)² = Σ_i η_i² exactly.

The total ``eta`` returned by :func:`estimate` counts each node once,
eta² = Σ_i η_i² + Σ (Lemma 5.21 terms), whatever the localisation (the global
estimator of Theorem 5.20 with Lemma 5.22); ``eta_elements`` = √(Σ_Δ η(Δ)²).

Boundary nodes
--------------
The paper's formula sets r̄_i = λ̄_i = 0 "otherwise", i.e. at boundary nodes,
which suggests that boundary nodes are in the sum with no mean subtracted (the
partition of unity Σ_i φ_i = 1 on Ω needs them).  By default we skip them
(``boundary=False``, the brief's reading); ``boundary=True`` adds
h_i^{2s}‖(r_h − λ_H)φ_i‖²_{L²(S_i)} for the boundary nodes.

s ≥ 3/4
-------
(−Δ)ˢu_h behaves like dist(x, e)^{1−2s} near every interior edge e where ∇u_h
jumps (and near the boundary edges), so r_h ∉ L²(Ω) for s ≥ 3/4 and the L²
norms above are infinite.  A fixed triangle rule (all points at distance
≥ δ·h from the edges, δ the smallest barycentric coordinate of the rule)
then computes a finite, rule-dependent number — in effect ‖r_h‖ sampled away
from the edges — that grows without limit as the rule's order (and so the
closeness of its points to the edges) rises; it is still a usable *indicator*
(it scales like the residual and is comparable between elements for a fixed
rule) but not a convergent approximation of a norm.  For 1/2 ≤ s < 3/4 the
norms are finite but the quadrature converges slowly; for s < 1/2 r_h is
Hölder continuous.  The paper's L^p remark after Lemma 5.22 replaces the term
by h_i^{2s + d(1 − 2/p)} ‖(…)φ_i‖²_{L^p(S_i)}, finite for p < 1/(2s − 1):
pass ``p`` for that variant (the weight exponent uses d = 2).  Quadrature of
the L^p norm with a fixed rule still converges slowly (the integrand is
singular at the edges), so ``order`` stays a parameter in every case.
"""
from __future__ import annotations

import numbers
import time

import numpy as np

from .assembly import mesh_arrays
from .compressed import DEFAULT_TOL
from .exact import check_s
from .meshes import triangle_areas, validates
from .pointwise import (PointwiseOptions, check_method, fractional_laplacian_qp,
                        quadrature_points)
from .quadrature import triangle_rule

__all__ = [
    "residual_indicators",
    "node_residual_terms",
    "patch_diameters",
    "abs_integrals",
    "contact_terms",
    "contact_set_nodes",
    "estimate",
    "estimate_laplace",
    "parents",
]

LOCALISATIONS = ("patch", "split")


# ------------------------------------------------------------------ mesh helpers


def parents(coarse, fine) -> np.ndarray:
    """Coarse parent of each fine element of T_h = T_H.refined(): e mod n_H."""
    n_h, n_H = fine.t.shape[1], coarse.t.shape[1]
    if n_h != 4 * n_H:
        raise ValueError(f"fine must be the uniform refinement of coarse: "
                         f"{n_h} fine elements != 4 × {n_H} coarse elements")
    return np.arange(n_h) % n_H


def patch_diameters(mesh) -> np.ndarray:
    """h_i = diam(S_i) for every node i (S_i the union of the elements at i).

    The diameter of a union of triangles is the largest distance between two
    of their vertices, i.e. between two nodes of {i} ∪ neighbours(i).
    """
    p, t = mesh_arrays(mesh)
    nv = len(p)
    e = np.vstack([t[:, [0, 1]], t[:, [1, 2]], t[:, [2, 0]]])
    e = np.unique(np.sort(e, axis=1), axis=0)
    a = np.concatenate([e[:, 0], e[:, 1]])
    b = np.concatenate([e[:, 1], e[:, 0]])
    order = np.argsort(a, kind="stable")
    a, b = a[order], b[order]
    deg = np.bincount(a, minlength=nv)
    start = np.concatenate([[0], np.cumsum(deg)[:-1]])
    slot = np.arange(len(a)) - start[a]
    nb = np.repeat(np.arange(nv)[:, None], deg.max() + 1, axis=1)  # pad with i itself
    nb[a, slot] = b
    x = p[nb]                                           # (nv, K, 2)
    d2 = np.zeros(nv)
    for k in range(x.shape[1] - 1):                     # pairs (k, > k), O(nv K) memory
        d2 = np.maximum(d2, np.sum((x[:, k + 1:] - x[:, k:k + 1]) ** 2, axis=-1).max(1))
    return np.sqrt(d2)


def abs_integrals(mesh, u) -> tuple[np.ndarray, np.ndarray]:
    """(∫_T u_h, ∫_T |u_h|) for every element T of the P1 function u (all nodes).

    Exact: the element is split at the zero line of u_h, in closed form.  With
    sorted vertex values v₁ ≤ v₂ ≤ v₃ and only v₃ > 0 the positive part lives on
    a triangle of area fraction v₃²/((v₃−v₁)(v₃−v₂)) on which u_h has mean v₃/3,
    so ∫_T u₊ = |T| v₃³/(3(v₃−v₁)(v₃−v₂)); with only v₁ < 0 the same for
    (−u)₊ gives ∫_T u₊ = ∫_T u + |T| (−v₁)³/(3(v₂−v₁)(v₃−v₁)).  Then
    ∫|u| = 2∫u₊ − ∫u.
    """
    p, t = mesh_arrays(mesh)
    u = np.asarray(u, dtype=float)
    if u.shape != (len(p),):
        raise ValueError(f"u must have one value per mesh node, shape ({len(p)},), "
                         f"got {u.shape}")
    area = triangle_areas(p.T, t.T)
    v = np.sort(u[t], axis=1)
    v1, v2, v3 = v[:, 0], v[:, 1], v[:, 2]
    integral = area * (v1 + v2 + v3) / 3.0
    pos = np.where(v1 >= 0.0, integral, 0.0)
    one_pos = (v3 > 0.0) & (v2 <= 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        pos = np.where(one_pos, area * v3 ** 3 / (3.0 * (v3 - v1) * (v3 - v2)), pos)
        one_neg = (v1 < 0.0) & (v2 > 0.0)
        pos = np.where(one_neg,
                       integral + area * (-v1) ** 3 / (3.0 * (v2 - v1) * (v3 - v1)), pos)
    return integral, 2.0 * pos - integral


def _check_u(mesh, u, free=None):
    u = np.asarray(u, dtype=float)
    nv = mesh.p.shape[1]
    if free is not None and u.shape == (len(free),) and len(free) != nv:
        full = np.zeros(nv)
        full[free] = u
        u = full
    if u.shape != (nv,):
        raise ValueError(f"u must have one value per fine node ({nv},)"
                         + (f" or per free node ({len(free)},)" if free is not None else "")
                         + f", got shape {u.shape}")
    if not np.all(np.isfinite(u)):
        raise ValueError("u has non-finite values")
    return u


def _check_order(order):
    if not isinstance(order, numbers.Integral) or isinstance(order, bool) or order < 1:
        raise ValueError(f"order={order!r} must be a positive integer (triangle rule)")
    X, W = triangle_rule(int(order))
    if np.any(W < 0):
        raise ValueError(f"order={order}: the triangle rule of this order has negative "
                         f"weights, which can make squared norms negative; use another "
                         f"order (e.g. 2, 4, 5, 6)")
    return int(order)


def _check_p(p):
    if not isinstance(p, numbers.Real) or isinstance(p, bool) or not (1.0 <= p < np.inf):
        raise ValueError(f"p={p!r} must be a number in [1, ∞) (the L^p variant)")
    return float(p)


# ------------------------------------------------------------------ residual term


@validates("fine")
def node_residual_terms(fine, u, s, f, lam_fine=None, *, order: int = 4,
                        p: float = 2.0, options: PointwiseOptions | None = None,
                        rh_extra=None, method: str = "auto", tol: float = DEFAULT_TOL,
                        _lap=None):
    """Node terms η_i² of Lemma 5.22 and their element shares.

    Returns a dict with
    ``term`` (Nv,): h_i^{2s + 2(1 − 2/p)} ‖(R − R̄_i) φ_i‖²_{L^p(S_i)} with
    R = r_h − λ_H and R̄_i = r̄_i − λ̄_i for interior nodes, R̄_i = 0 at boundary
    nodes (every node computed; the caller decides which enter);
    ``share`` (Nt, 3): the fraction of ‖(R − R̄_i)φ_i‖^p_{L^p(S_i)} on element T for
    its local vertex k (rows sum to 1 over the patch of each node);
    ``mean`` (Nv,): R̄_i; ``h`` (Nv,): diam(S_i); ``rh`` (Nt, nq): r_h at the points;
    ``seconds_pointwise``.

    ``rh_extra`` (optional, (Nt, nq) at the points of ``triangle_rule(order)`` in
    the order of :func:`fracfem.pointwise.quadrature_points`) is added to r_h, e.g.
    −(u^k − u^{k−1})/τ for the parabolic residual f − ∂_tU − (−Δ)ˢu (Theorem 6.18).
    ``options``, ``method`` ("dense", "compressed" or "auto") and ``tol`` choose
    how (−Δ)ˢu_h is evaluated (:func:`fracfem.pointwise.fractional_laplacian_at`).
    ``_lap`` (internal): (−Δ)ˢu_h at those points, already evaluated for this
    ``u`` (one column of a batched :func:`fracfem.pointwise.fractional_laplacian_qp`,
    see :func:`fracfem.spacetime_estimators.steps_indicators`).
    """
    s = check_s(s)
    order = _check_order(order)
    p_exp = _check_p(p)
    P, T = mesh_arrays(fine)
    nv, nt = len(P), len(T)
    u = _check_u(fine, u)
    check_method(method, tol)
    X, _ = triangle_rule(order)
    bary = np.column_stack([1.0 - X[:, 0] - X[:, 1], X[:, 0], X[:, 1]])  # (nq, 3)
    t0 = time.perf_counter()
    if _lap is None:
        lap, pts, wts = fractional_laplacian_qp(fine, u, s, order, options=options,
                                                method=method, tol=tol)
    else:
        pts, wts, _ = quadrature_points(fine, order)
        lap = np.asarray(_lap, dtype=float)
        if lap.shape != wts.shape:
            raise ValueError(f"_lap must have shape {wts.shape} (elements × quadrature "
                             f"points), got {lap.shape}")
    x = np.moveaxis(pts, -1, 0)                                        # (2, Nt, nq)
    fx = np.broadcast_to(np.asarray(f(x) if callable(f) else f, dtype=float), lap.shape)
    if not np.all(np.isfinite(fx)):
        raise ValueError("f returned non-finite values at quadrature points")
    rh = fx - lap
    if rh_extra is not None:
        rh_extra = np.asarray(rh_extra, dtype=float)
        if rh_extra.shape != rh.shape:
            raise ValueError(f"rh_extra must have shape {rh.shape} (elements × "
                             f"quadrature points), got {rh_extra.shape}")
        if not np.all(np.isfinite(rh_extra)):
            raise ValueError("rh_extra has non-finite values")
        rh = rh + rh_extra
    t_pw = time.perf_counter() - t0
    lam = np.zeros(nt) if lam_fine is None else np.asarray(lam_fine, dtype=float)
    if lam.shape != (nt,):
        raise ValueError(f"lam_fine must have one value per fine element ({nt},), "
                         f"got {lam.shape}")
    R = rh - lam[:, None]                                              # (Nt, nq)
    area = wts.sum(axis=1)
    # R̄_i = ∫ R φ_i / ∫ φ_i over S_i (interior nodes), 0 at boundary nodes
    num = np.bincount(T.ravel(), weights=np.einsum("tq,tq,qk->tk", wts, R, bary).ravel(),
                      minlength=nv)
    den = np.bincount(T.ravel(), weights=np.repeat(area / 3.0, 3), minlength=nv)
    mean = num / den
    boundary = np.asarray(fine.boundary_nodes(), dtype=np.int64)
    mean[boundary] = 0.0
    D = np.abs(R[:, None, :] - mean[T][:, :, None])                    # (Nt, 3, nq)
    local = np.einsum("tq,tkq,qk->tk", wts, D ** p_exp, bary ** p_exp)  # ∫_T |..|^p φ^p
    total = np.bincount(T.ravel(), weights=local.ravel(), minlength=nv)
    with np.errstate(divide="ignore", invalid="ignore"):
        share = np.where(total[T] > 0, local / total[T], 0.0)
    h = patch_diameters(fine)
    term = h ** (2.0 * s + 2.0 * (1.0 - 2.0 / p_exp)) * total ** (2.0 / p_exp)
    return dict(term=term, share=share, mean=mean, h=h, rh=rh,
                seconds_pointwise=t_pw)


@validates("fine")
def residual_indicators(fine, u, s, f, lam_fine=None, contact_nodes=None, order: int = 4,
                        *, p: float = 2.0, localisation: str = "patch",
                        boundary: bool = False, options: PointwiseOptions | None = None,
                        full_output: bool = False, rh_extra=None, method: str = "auto",
                        tol: float = DEFAULT_TOL, _lap=None):
    """The residual part of η(Δ)² (Section 7) on every fine element Δ.

    η(Δ)² = Σ_{i vertex of Δ, i interior, i ∉ C_h}
              h_i^{2s} ‖(r_h − λ_H − r̄_i + λ̄_i) φ_i‖²_{L²(S_i)}

    Parameters
    ----------
    fine : skfem.MeshTri, the mesh of u_h (T_h)
    u : (Nv,) nodal values of u_h over all nodes (zero on ∂Ω)
    s : order in (0, 1)
    f : callable f(x), x of shape (2, ...), or a number
    lam_fine : (Nt,) λ_H on the fine elements (the value of the parent coarse
        element); None means λ_H = 0 (unconstrained problem)
    contact_nodes : node indices of C_h (excluded), or None (C_h = ∅)
    order : degree of the triangle rule at whose points (−Δ)ˢu_h is evaluated
        (:func:`fracfem.pointwise.fractional_laplacian_qp`); for s ≥ 3/4 the
        result depends on it (module docstring)
    p : L^p variant of the paper's remark after Lemma 5.22: the node term becomes
        h_i^{2s+2(1−2/p)} ‖(…)φ_i‖²_{L^p(S_i)}; p = 2 is the formula above
    localisation : 'patch' (each vertex's full patch term, the paper's formula) or
        'split' (each element gets its share; Σ_Δ η(Δ)² = Σ_i η_i²); see module doc
    boundary : also include boundary nodes with r̄_i = λ̄_i = 0 (module doc)
    full_output : also return the dict of :func:`node_residual_terms` with the
        admitted nodes (key ``nodes``)
    rh_extra : optional (Nt, nq) values added to r_h at the quadrature points
        (:func:`node_residual_terms`)
    options, method, tol : how (−Δ)ˢu_h is evaluated: quadrature of the edge
        integrals, "dense", "compressed" or "auto" (compressed on large meshes)
        and the compressed path's relative accuracy
        (:func:`fracfem.pointwise.fractional_laplacian_at`)

    Returns
    -------
    eta2 (Nt,) [, details]
    """
    if localisation not in LOCALISATIONS:
        raise ValueError(f"localisation={localisation!r} must be one of {LOCALISATIONS}")
    res = node_residual_terms(fine, u, s, f, lam_fine, order=order, p=p, options=options,
                              rh_extra=rh_extra, method=method, tol=tol, _lap=_lap)
    nv = fine.p.shape[1]
    admitted = np.zeros(nv, dtype=bool)
    admitted[np.asarray(fine.interior_nodes(), dtype=np.int64)] = True
    if boundary:
        admitted[:] = True
    if contact_nodes is not None:
        cn = np.asarray(contact_nodes)
        if cn.dtype == bool:
            if cn.shape != (nv,):
                raise ValueError(f"contact_nodes as a mask must have shape ({nv},)")
            cn = np.flatnonzero(cn)
        if cn.size and (cn.min() < 0 or cn.max() >= nv):
            raise ValueError(f"contact_nodes must be node indices in [0, {nv - 1}]")
        admitted[cn.astype(np.int64)] = False
    term = np.where(admitted, res["term"], 0.0)
    T = np.asarray(fine.t.T, dtype=np.int64)
    if localisation == "patch":
        eta2 = term[T].sum(axis=1)
    else:
        eta2 = (term[T] * res["share"]).sum(axis=1)
    if full_output:
        res["term"] = term
        res["nodes"] = np.flatnonzero(admitted)
        return eta2, res
    return eta2


# ------------------------------------------------------------------ Lemma 5.21


@validates("prob.fine", "prob.coarse")
def contact_terms(prob, u, lam) -> dict:
    """The computable bounds of b(λ_H − λ, u − u_h) of Lemma 5.21.

    Obstacle (i): b(λ_H, χ − u_h) = Σ_j λ_j (g_j − (Bᵀu)_j) with g_j = ⟨μ_j, χ⟩
    from the constraint set.  λ_j ≤ 0 and (Bᵀu − g)_j ≥ 0 make every term ≥ 0,
    and complementarity λ_j (Bᵀu − g)_j = 0 makes it vanish at an exact
    discrete solution: what remains is the solver's residual.  Per coarse
    element; the fine share is a quarter of it for each child (g is known only
    per coarse element).

    Friction (iii), per fine element e with parent T_j (x₋ = min(x, 0)):
    minus = −(|λ_j| − F_j)₋ ∫_e |u_h| ≥ 0,  abs = |λ_j| ∫_e |u_h| − λ_j ∫_e u_h ≥ 0,
    plus = H_j^{2s} ‖(|λ_H| − F)₊‖²_{L²(e)} (the (|λ|−F)₊ term after Young's
    inequality with ‖μ‖_{H⁻ˢ} ≈ H^s‖μ‖_{L²}, H_j the coarse diameter; 0 for
    λ_H ∈ Λ_H).  The integrals of |u_h| are exact (:func:`abs_integrals`).
    minus + abs = F_j∫|u_h| − λ_j∫u_h for |λ_j| ≤ F_j, so the friction term is
    j(u_h) − b(λ_H, u_h) ≥ 0 with j(u_h) = Σ F_j ∫_{T_j} |u_h|; it does *not*
    vanish at a discrete solution where u_h changes sign inside a coarse element
    (the discrete problem only sees the means ∫_{T_j} u_h).

    Returns a dict with ``fine`` (Nt_fine,), ``coarse`` (N_H,) and the parts.
    """
    fine, coarse = prob.fine, prob.coarse
    par = parents(coarse, fine)
    u = _check_u(fine, u, prob.disc.free)
    lam = np.asarray(lam, dtype=float)
    n_H = coarse.t.shape[1]
    if lam.shape != (n_H,):
        raise ValueError(f"lam must have one value per coarse element ({n_H},), "
                         f"got {lam.shape}")
    cs = prob.cset
    if prob.kind == "obstacle":
        y = cs.B.T @ u[prob.disc.free]
        coarse_term = lam * (cs.g - y)
        fine_term = coarse_term[par] / 4.0
        return dict(kind="obstacle", coarse=coarse_term, fine=fine_term,
                    gap=y - cs.g)
    if prob.kind == "friction":
        F = np.asarray(cs.upper, dtype=float)
        integral, absint = abs_integrals(fine, u)
        lj, Fj = lam[par], F[par]
        minus = -np.minimum(np.abs(lj) - Fj, 0.0) * absint
        absterm = np.abs(lj) * absint - lj * integral
        Pc, Tc = mesh_arrays(coarse)
        H = np.max([np.linalg.norm(Pc[Tc[:, a]] - Pc[Tc[:, b]], axis=1)
                    for a, b in ((0, 1), (1, 2), (2, 0))], axis=0)
        Pf, Tf = mesh_arrays(fine)
        plus = H[par] ** (2 * prob.disc.s) * np.maximum(np.abs(lj) - Fj, 0.0) ** 2 \
            * triangle_areas(Pf.T, Tf.T)
        fine_term = minus + absterm + plus
        return dict(kind="friction", coarse=np.bincount(par, fine_term, minlength=n_H),
                    fine=fine_term, minus=minus, abs=absterm, plus=plus,
                    j_u=float(np.sum(Fj * absint)), b_lam_u=float(np.sum(lj * integral)))
    raise ValueError(f"estimate supports kinds 'obstacle' and 'friction', "
                     f"got {prob.kind!r}")


def contact_set_nodes(fine, active_fine) -> np.ndarray:
    """Fine nodes all of whose elements lie in the contact set (λ_H < 0 there)."""
    T = np.asarray(fine.t.T, dtype=np.int64)
    nv = fine.p.shape[1]
    n_all = np.bincount(T.ravel(), minlength=nv)
    n_act = np.bincount(T.ravel(), weights=np.repeat(active_fine.astype(float), 3),
                        minlength=nv)
    return np.flatnonzero((n_all > 0) & (n_act == n_all))


# ------------------------------------------------------------------ drivers


def _problem_f(obj, f):
    if f is not None:
        return f
    for holder in (obj, getattr(obj, "disc", None)):
        g = getattr(holder, "f", None)
        if g is not None:
            return g
    raise ValueError("the load f is needed for the residual r_h = f − (−Δ)ˢu_h and "
                     "the problem does not store it: pass f=")


@validates("prob.fine", "prob.coarse")
def estimate(prob, u, lam, order: int = 4, *, f=None, contact_nodes=None,
             p: float = 2.0, localisation: str = "patch", boundary: bool = False,
             options: PointwiseOptions | None = None, rh_extra=None,
             method: str = "auto", tol: float = DEFAULT_TOL, _lap=None) -> dict:
    """Indicators of Algorithm B for a :class:`fracfem.vi.MixedProblem`.

    η(Δ)² = (residual term of :func:`residual_indicators`)
            + (the Lemma 5.21 term of :func:`contact_terms`, fine share)

    Parameters
    ----------
    prob : MixedProblem of kind 'obstacle' or 'friction'
    u : nodal values over all fine nodes (or over the free nodes)
    lam : λ_H per coarse element
    order : triangle rule for (−Δ)ˢu_h (see the module docstring for s ≥ 3/4)
    f : the load (MixedProblem does not store it; also looked up as ``prob.f``)
    contact_nodes : C_h; default for the obstacle problem the fine nodes whose whole
        patch lies in coarse elements with λ_H < 0 (nodes *inside* the contact
        region; nodes on the free boundary keep their term, where λ_H jumps and the
        error concentrates); for friction C_h = ∅
    p, localisation, boundary, options, rh_extra, method, tol : see
        :func:`residual_indicators`

    Returns
    -------
    dict with ``eta2_fine`` (Nt_h,), ``eta2_coarse`` (N_H,: sums over the four
    children), ``eta`` (√(Σ_i η_i² + Σ Lemma 5.21 terms), each node once),
    ``eta_elements`` (√Σ η²_fine), ``parts`` and ``timings``.  ``parts`` holds
    ``residual`` (Σ_i η_i², squared), ``residual_nodes`` (η_i² per node, 0 where
    not admitted), ``residual_fine`` (residual part of η(Δ)²), ``contact`` (the
    dict of :func:`contact_terms`), ``contact_total`` (Σ of the Lemma 5.21 terms,
    unclipped; the fine shares enter η(Δ)² clipped at 0 against round-off),
    ``contact_nodes``, ``admitted_nodes``, ``h_nodes``, ``mean`` (R̄_i), ``rh``
    (r_h at the quadrature points, (Nt, nq)).
    """
    t0 = time.perf_counter()
    if prob.kind not in ("obstacle", "friction"):
        raise ValueError(f"estimate supports kinds 'obstacle' and 'friction', "
                         f"got {prob.kind!r}")
    f = _problem_f(prob, f)
    fine, coarse = prob.fine, prob.coarse
    par = parents(coarse, fine)
    u = _check_u(fine, u, prob.disc.free)
    lam = np.asarray(lam, dtype=float)
    if lam.shape != (coarse.t.shape[1],):
        raise ValueError(f"lam must have one value per coarse element "
                         f"({coarse.t.shape[1]},), got {lam.shape}")
    lam_fine = lam[par]
    if contact_nodes is None:
        if prob.kind == "obstacle":
            contact_nodes = contact_set_nodes(fine, lam_fine < 0.0)
        else:
            contact_nodes = np.empty(0, dtype=np.int64)
    res_eta2, det = residual_indicators(fine, u, prob.disc.s, f, lam_fine, contact_nodes,
                                        order, p=p, localisation=localisation,
                                        boundary=boundary, options=options,
                                        full_output=True, rh_extra=rh_extra,
                                        method=method, tol=tol, _lap=_lap)
    t1 = time.perf_counter()
    ct = contact_terms(prob, u, lam)
    # round-off can leave Lemma 5.21 terms at −1e−17; they are ≥ 0 in exact arithmetic
    eta2_fine = res_eta2 + np.maximum(ct["fine"], 0.0)
    eta2_coarse = np.bincount(par, eta2_fine, minlength=coarse.t.shape[1])
    res_total = float(det["term"].sum())
    contact_total = float(ct["coarse"].sum())
    t2 = time.perf_counter()
    parts = dict(residual_fine=res_eta2, residual_nodes=det["term"],
                 residual=res_total, contact=ct, contact_total=contact_total,
                 contact_nodes=np.asarray(contact_nodes, dtype=np.int64),
                 admitted_nodes=det["nodes"], h_nodes=det["h"], mean=det["mean"],
                 rh=det["rh"], order=order, p=p, localisation=localisation)
    return dict(eta2_fine=eta2_fine, eta2_coarse=eta2_coarse,
                eta=float(np.sqrt(max(res_total + max(contact_total, 0.0), 0.0))),
                eta_elements=float(np.sqrt(eta2_fine.sum())), parts=parts,
                timings=dict(pointwise=det["seconds_pointwise"],
                             residual=t1 - t0, contact=t2 - t1, total=t2 - t0))


@validates("disc.mesh")
def estimate_laplace(disc, u, f, order: int = 4, *, p: float = 2.0,
                     localisation: str = "patch", boundary: bool = False,
                     options: PointwiseOptions | None = None, method: str = "auto",
                     tol: float = DEFAULT_TOL) -> dict:
    """Indicators for the unconstrained problem (Example 1): λ_H = 0, C_h = ∅.

    ``disc`` is a :class:`fracfem.laplace.Discretisation`; ``u`` over all nodes or
    the free nodes; the keywords as in :func:`estimate`.  Returns a dict like
    :func:`estimate` with ``eta2_fine`` (one value per element of ``disc.mesh``)
    and no coarse level.
    """
    t0 = time.perf_counter()
    mesh = disc.mesh
    u = _check_u(mesh, u, disc.free)
    eta2, det = residual_indicators(mesh, u, disc.s, f, None, None, order, p=p,
                                    localisation=localisation, boundary=boundary,
                                    options=options, full_output=True, method=method,
                                    tol=tol)
    total = float(det["term"].sum())
    t1 = time.perf_counter()
    parts = dict(residual_fine=eta2, residual_nodes=det["term"], residual=total,
                 admitted_nodes=det["nodes"], h_nodes=det["h"], mean=det["mean"],
                 rh=det["rh"], order=order, p=p, localisation=localisation)
    return dict(eta2_fine=eta2, eta2_coarse=None, eta=float(np.sqrt(total)),
                eta_elements=float(np.sqrt(eta2.sum())), parts=parts,
                timings=dict(pointwise=det["seconds_pointwise"], residual=t1 - t0,
                             total=t1 - t0))
