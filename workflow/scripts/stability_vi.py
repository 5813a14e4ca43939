"""Stability study, obstacle/friction part (issue 6): time steps from 1e−6 to 1e3 with
the constraints, and elliptic VI edge cases.  Each row: finite results and the
expected structure, or the error raised."""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem import examples, vi
from fracfem.meshes import min_angle
from fracfem.solvers import ConvergenceError
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import start

logger = script_logger("stability_vi")

CHI = examples.paraboloid_obstacle(1.0, 4.0)


def parabolic_case(kind, tau, coarse):
    """5 DG(0) steps of Example 4 (ũ₀ = 2) or 5 with step τ; PDAS and Uzawa per step."""
    if kind == "obstacle":
        prob = vi.mixed_problem("obstacle", coarse, 0.5, 0.0, chi=CHI)
        u0 = 2.0
    else:
        prob = vi.mixed_problem("friction", coarse, 0.6, 0.0, F=0.1)
        u0 = examples.ring_initial(0.6)
    times = np.linspace(0.0, 5 * tau, 6)
    st = ff.Stepper(prob)
    runs = {"pdas": ff.solve_parabolic(st, u0, times, solver="pdas",
                                              solver_options={"tol": 1e-10})}
    uzawa = _uzawa(lambda: ff.solve_parabolic(
        st, u0, times, solver="uzawa", solver_options={"tol": 1e-10, "maxiter": 200000}))
    steps = runs["pdas"][1:]
    E = np.array([ff.discrete_energy(prob, s.u) for s in steps])
    y = [prob.cset.B.T @ s.u[prob.disc.free] - prob.cset.g for s in steps]
    lam = [s.lam for s in steps]
    if kind == "obstacle":
        feas = min(float(v.min()) for v in y)
        compl = max(float(np.abs(v * l).max()) for v, l in zip(y, lam))
        in_set = all(np.all(l <= 0) for l in lam)
    else:
        feas = 0.0
        compl = max(float(np.abs(np.abs(l) - 0.1)[np.abs(v) > 1e-9].max(initial=0)) for v, l
                    in zip(y, lam))   # slip: |λ| = F wherever the mean moves
        in_set = all(np.all(np.abs(l) <= 0.1 * (1 + 1e-12)) for l in lam)
    if isinstance(uzawa, str):
        du, uz_it = np.nan, uzawa
    else:
        du = max(float(np.abs(a.u - b.u).max()) for a, b in zip(runs["pdas"], uzawa))
        uz_it = str(max(s.info.get("iterations", 0) for s in uzawa[1:]))
    scale = max(E.max(), 1e-300)
    return {"case": f"{kind}, τ = {tau:g}, 5 steps", "dofs": len(prob.disc.free),
            "finite": bool(np.all(np.isfinite(E))),
            "energy growth": float(max(np.diff(E).max(initial=0.0), 0.0) / scale),
            "min gap": feas, "complementarity": compl, "λ in set": in_set,
            "pdas iterations (max)": max(s.info.get("iterations", 0) for s in steps),
            "uzawa": uz_it, "max |u_pdas − u_uzawa|": du}


def _done(row):
    """One log line per case."""
    logger.info("%s: %s, %.1f s", row["case"], row.get("status", "ok"), row["seconds"])


def _uzawa(run):
    """Uzawa's result, or the reason it stopped (it is the cross-check, PDAS the solver)."""
    try:
        return run()
    except ConvergenceError as err:
        return f"not converged: residual {err.residual:.2g} after {err.iterations} it."


def elliptic_case(label, make, check):
    prob = make()
    u, lam, info = vi.solve(prob, "pdas", tol=1e-10)
    uz = _uzawa(lambda: vi.solve(prob, "uzawa", tol=1e-10, maxiter=200000))
    out = {"case": label, "dofs": len(prob.disc.free), "finite": bool(np.all(np.isfinite(u))),
           "pdas iterations (max)": info["iterations"],
           "uzawa": uz if isinstance(uz, str) else str(uz[2]["iterations"]),
           "max |u_pdas − u_uzawa|": np.nan if isinstance(uz, str)
           else float(np.abs(u - uz[0]).max()),
           "min angle [°]": min_angle(prob.fine)}
    out.update(check(prob, u, lam))
    return out


def free_solution(prob):
    return prob.disc.extend(np.linalg.solve(prob.disc.A, prob.disc.b))


def main(md, csv, log=None, threads=None):
    start(log, threads)
    coarse = ff.disk_uniform(3)
    rows = []
    for kind in ("obstacle", "friction"):
        for tau in (1e-6, 1e-3, 1.0, 1e3):
            t0 = time.perf_counter()
            try:
                row = parabolic_case(kind, tau, coarse)
            except (ValueError, RuntimeError) as err:
                row = {"case": f"{kind}, τ = {tau:g}", "status": f"refused: {err}"}
            row["seconds"] = time.perf_counter() - t0
            rows.append(row)
            _done(row)

    def rel_to_free(prob, u, lam):
        w = free_solution(prob)
        return {"|u − u_free| / |u_free|": float(np.abs(u - w).max() / np.abs(w).max()),
                "max |λ|": float(np.abs(lam).max())}

    def means(prob, u, lam):
        y = prob.cset.B.T @ u[prob.disc.free]
        area = np.asarray(prob.cset.B.sum(axis=0)).ravel()     # ∫_T φ summed = |T| (free)
        return {"max |coarse mean of u|": float(np.abs(y / area).max()),
                "max |λ|": float(np.abs(lam).max())}

    def contact(prob, u, lam):
        y = prob.cset.B.T @ u[prob.disc.free] - prob.cset.g
        return {"contact fraction": float(np.mean(lam < 0)), "min gap": float(y.min()),
                "complementarity": float(np.abs(lam * y).max())}

    cases = [
        ("friction F = 1e−12 (→ 0)", lambda: vi.mixed_problem(
            "friction", coarse, 0.6, 1.0, F=1e-12), rel_to_free),
        ("friction F = 1e6 (huge)", lambda: vi.mixed_problem(
            "friction", coarse, 0.6, 1.0, F=1e6), means),
        ("obstacle active nowhere (χ = −1 − |x|²)", lambda: vi.mixed_problem(
            "obstacle", coarse, 0.5, 1.0, chi=lambda x: -1.0 - x[0] ** 2 - x[1] ** 2),
         rel_to_free),
        ("obstacle active almost everywhere (f = −1, χ = 0.2(1 − |x|²))",
         lambda: vi.mixed_problem("obstacle", coarse, 0.5, -1.0,
                                  chi=lambda x: 0.2 * (1 - x[0] ** 2 - x[1] ** 2)), contact),
        ("obstacle on a ring mesh, min angle ≈ 1° (disk_graded_rings(8, 3))",
         lambda: vi.mixed_problem("obstacle", ff.disk_graded_rings(8, 3.0), 0.5, 1.0, chi=CHI),
         contact),
        ("friction on a ring mesh, min angle ≈ 1° (disk_graded_rings(8, 3))",
         lambda: vi.mixed_problem("friction", ff.disk_graded_rings(8, 3.0), 0.6,
                                  examples.radial_load(1.0, 3.0), F=0.5),
         lambda prob, u, lam: {"max |λ|": float(np.abs(lam).max())}),
    ]
    for label, make, check in cases:
        t0 = time.perf_counter()
        try:
            row = elliptic_case(label, make, check)
        except (ValueError, RuntimeError) as err:
            row = {"case": label, "status": f"refused: {err}"}
        row["seconds"] = time.perf_counter() - t0
        rows.append(row)
        _done(row)
    # u₀ = χ: the parabolic obstacle problem started on the obstacle
    t0 = time.perf_counter()
    prob = vi.mixed_problem("obstacle", coarse, 0.5, 0.0, chi=CHI)
    steps = ff.solve_parabolic(prob, CHI, T=0.25, tau=0.05)
    y = [prob.cset.B.T @ s.u[prob.disc.free] - prob.cset.g for s in steps[1:]]
    rows.append({"case": "u₀ = χ (parabolic obstacle, τ = 0.05, 5 steps)",
                 "dofs": len(prob.disc.free),
                 "finite": bool(all(np.all(np.isfinite(s.u)) for s in steps)),
                 "min gap": float(min(v.min() for v in y)),
                 "max gap at t = τ": float(y[0].max()),
                 "contact fraction": float(np.mean(steps[1].lam < 0)),
                 "seconds": time.perf_counter() - t0})
    _done(rows[-1])
    df = pd.DataFrame(rows)
    if "status" not in df:
        df["status"] = "ok"
    df["status"] = df["status"].fillna("ok")
    write_table(with_provenance(df), csv)
    with atomic_path(md) as tmp:
        # a "|" in a header or cell would split the markdown column: escape it
        md_df = df.rename(columns=lambda c: c.replace("|", "\\|"))
        md_df = md_df.map(lambda v: v.replace("|", "\\|") if isinstance(v, str) else v)
        tmp.write_text(md_df.to_markdown(index=False, floatfmt=".3g") + "\n")


if __name__ == "__main__":
    main(snakemake.output.md, snakemake.output.csv, snakemake.log[0],  # noqa: F821
         snakemake.threads)  # noqa: F821
