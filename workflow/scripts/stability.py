"""Stability study, Example 1: extreme s, strong grading, and anisotropic layers down to 1e-10.

Each case reports finite values and the expected structure (Galerkin bound,
positive definiteness, quadrature convergence) or the error it raised.  The
anisotropic part separates what limits the error on thin boundary layers:
approximation, quadrature (change under ``QuadratureOptions().raised()``),
conditioning (of A and of D^(-1/2) A D^(-1/2)) or round-off (two solves).
"""
import time

import numpy as np
import pandas as pd
import scipy.linalg as sla
from scipy.sparse.linalg import eigsh

import fracfem as ff
from fracfem.meshes import min_angle
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.plotstyle import ERROR_LABELS, plain_log_ticks, plt, save
from fracfem_workflow.report import markdown_table
from fracfem_workflow.runs import start

logger = script_logger("stability")

# anisotropic ring meshes disk_graded_rings(n, μ): the n-series at each μ, and at
# LAYER_N rings the series where only the layer at the circle thins (layer=δ)
GRADINGS = (2.0, 3.0, 4.0)
SERIES_N = (4, 8, 16)
LONGER = {4.0: (32,)}  # grading 4 continued until its own thinnest layer is below 1e-6
LAYER_N = 8
LAYERS = (1e-4, 1e-6, 1e-8, 1e-10)
DENSE_EIG = 3000      # dense eigvalsh up to this many DOFs, Lanczos (eigsh) above


def extreme_eigenvalues(A):
    """(λ_min, λ_max) of a symmetric positive definite matrix."""
    if len(A) <= DENSE_EIG:
        ev = np.linalg.eigvalsh(A)
        return ev[0], ev[-1]
    top = eigsh(A, k=1, which="LA", return_eigenvectors=False, tol=1e-6)[0]
    # shift-invert about 0: the smallest eigenvalue converges in a few steps
    low = eigsh(A, k=1, sigma=0.0, which="LM", return_eigenvectors=False, tol=1e-6)[0]
    return low, top


def mesh_columns(mesh):
    """DOFs, shortest edge, smallest angle, thinnest layer and largest aspect ratio."""
    p, t = mesh.p, mesh.t
    free = mesh.interior_nodes()
    e = np.stack([np.linalg.norm(p[:, t[(i + 1) % 3]] - p[:, t[i]], axis=0) for i in range(3)])
    d1, d2 = p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
    area2 = np.abs(d1[0] * d2[1] - d1[1] * d2[0])
    diam = e.max(axis=0)
    return {"dofs": len(free), "h_min": float(e.min()), "min_angle": min_angle(mesh),
            "thinnest_layer": float(1.0 - np.linalg.norm(p[:, free], axis=0).max()),
            # longest edge over smallest height
            "max_aspect": float((diam ** 2 / area2).max())}


def case(label, mesh, s, **extra):
    """One Example 1 solve with every check; the row of the table."""
    row = {"case": label, "s": s, **extra, **mesh_columns(mesh)}
    t0, c0 = time.perf_counter(), time.process_time()
    try:
        free = mesh.interior_nodes()
        b = ff.load_vector(mesh, 1.0)[free]
        A = ff.stiffness_matrix(mesh, s)[np.ix_(free, free)]
        x = np.linalg.solve(A, b)
        fu = float(b @ x)
        lo, hi = extreme_eigenvalues(A)
        # the same (f,u_h) through the Cholesky factor of D^(-1/2) A D^(-1/2)
        dg = np.sqrt(np.diag(A))
        S = A / dg[:, None] / dg[None, :]
        slo, shi = extreme_eigenvalues(S)
        fu_chol = float((b / dg) @ sla.cho_solve(sla.cho_factor(S), b / dg))
        residual = float(np.linalg.norm(b - A @ x) / np.linalg.norm(b))
        del S
        Ar = ff.stiffness_matrix(mesh, s, quadrature=ff.QuadratureOptions().raised())
        fu_raised = float(b @ np.linalg.solve(Ar[np.ix_(free, free)], b))
        del Ar
        err2 = ff.disk_energy(s) - fu
        ok = err2 > 0
        row.update(fu_h=fu, error=np.sqrt(err2) if ok else np.nan, galerkin_ok=bool(ok),
                   finite=bool(np.isfinite([fu, fu_chol, fu_raised]).all()),
                   lambda_min=lo, lambda_max=hi, spd=bool(lo > 0), cond=hi / lo,
                   cond_scaled=shi / slo,
                   quad_change_over_err2=abs(fu_raised - fu) / err2 if ok else np.nan,
                   roundoff_over_err2=abs(fu_chol - fu) / err2 if ok else np.nan,
                   residual=residual, status="ok")
    except (ValueError, np.linalg.LinAlgError) as err:
        row.update(status=f"refused: {err}")
    row["seconds"] = time.perf_counter() - t0
    row["cpu_seconds"] = time.process_time() - c0   # all threads; the wall time on a busy machine
    logger.info("%s, s = %g: %s, %.1f s (%.1f s CPU)", label, s, row["status"], row["seconds"],
                row["cpu_seconds"])
    return row


def aniso_rows():
    """The anisotropic study: n-series and thinning outer layer at μ = 2, 3, 4."""
    rows = []
    for mu in GRADINGS:
        for n in SERIES_N + LONGER.get(mu, ()):
            rows.append(case(f"disk_graded_rings({n}, {mu:g})", ff.disk_graded_rings(n, mu),
                             0.5, grading=mu, n=n, family="n-series"))
        for layer in LAYERS:
            if layer > 0.5 * LAYER_N ** -mu:
                continue
            rows.append(case(f"disk_graded_rings({LAYER_N}, {mu:g}, layer={layer:g})",
                             ff.disk_graded_rings(LAYER_N, mu, layer=layer), 0.5,
                             grading=mu, n=LAYER_N, family="outer layer"))
    return rows


def reading(df) -> str:
    """What limits the error on the anisotropic layers, stated from the table."""
    an = df[df.family.isin(["n-series", "outer layer"]) & (df.status == "ok")]
    if an.empty:
        return "No anisotropic case ran."
    lines = ["**Reading (anisotropic cases, s = 0.5).**", ""]
    for mu, g in an[an.family == "n-series"].groupby("grading"):
        g = g.sort_values("n")
        errs = ", ".join(f"{e:.3g}" for e in g.error)
        falls = bool((np.diff(g.error.to_numpy()) < 0).all())
        slope = np.polyfit(np.log(g.dofs.iloc[-2:]), np.log(g.error.iloc[-2:]), 1)[0]
        lines.append(f"- μ = {mu:g}, n = {', '.join(str(int(k)) for k in g.n)}: error {errs} "
                     f"({'falls at every step' if falls else 'stops falling'}; last slope "
                     f"against DOFs {slope:.2f}), thinnest layer down to "
                     f"{g.thinnest_layer.min():.2g}.")
    for mu, g in an[an.family == "outer layer"].groupby("grading"):
        base = an[(an.family == "n-series") & (an.grading == mu) & (an.n == g.n.iloc[0])]
        g = g.sort_values("thinnest_layer", ascending=False)
        plain = f"{base.error.iloc[0]:.3g} without the extra ring, " if len(base) else ""
        lines.append(f"- μ = {mu:g}, n = {int(g.n.iloc[0])}, outer layer δ = "
                     f"{', '.join(f'{d:.0e}' for d in g.thinnest_layer)}: error {plain}"
                     f"{', '.join(f'{e:.3g}' for e in g.error)}.")
    worst = an.loc[an.quad_change_over_err2.idxmax()]
    lines += [
        "",
        f"Largest quadrature change under `raised()`: {worst.quad_change_over_err2:.2g} of err² "
        f"({worst.case}; limit 1e-2). Largest cond(A): {an.cond.max():.3g}; largest "
        f"cond(D^(−1/2) A D^(−1/2)): {an.cond_scaled.max():.3g}; largest round-off: "
        f"{an.roundoff_over_err2.max():.2g} of err²; largest relative residual: "
        f"{an.residual.max():.2g}; largest aspect ratio: {an.max_aspect.max():.3g}.",
    ]
    clocks = df[df.family.isin(["n-series", "outer layer"])]    # refused cases too
    if {"seconds", "cpu_seconds"} <= set(clocks.columns):    # (a table from before: neither)
        wall, cpu = clocks.seconds.sum(), clocks.cpu_seconds.sum()
        lines.append(f"The anisotropic cases took {wall:.0f} s wall time and {cpu:.0f} s CPU "
                     f"time (all threads; {cpu / wall:.2f} CPU seconds per wall second): wall "
                     "seconds grow when other processes share the cores, CPU seconds less, so "
                     "compare cases by `cpu_seconds`.")
    ok = (an.quad_change_over_err2.max() < 1e-2 and an.roundoff_over_err2.max() < 1e-6
          and an.galerkin_ok.all() and an.spd.all())
    lines.append("Quadrature, conditioning and round-off stay far below the error in every case: "
                 "the error is limited by the approximation alone." if ok else
                 "At least one case is limited by quadrature, conditioning or round-off "
                 "(see the columns above).")
    return "\n".join(lines)


# the page's two tables: extreme s and grading exponent, then the anisotropic cases
COLUMNS = ["case", "s", "dofs", "h_min", "min_angle", "error", "galerkin_ok", "spd", "cond",
           "quad_change_over_err2", "status"]
ANISO_COLUMNS = ["case", "dofs", "thinnest_layer", "max_aspect", "error",
                 "quad_change_over_err2", "cond", "cond_scaled", "roundoff_over_err2",
                 "residual", "seconds", "cpu_seconds", "status"]
# the clocks to a tenth of a second (to three significant digits a case of 1640 s printed as
# 1.64e+03), every other number to three significant digits
FIXED_COLUMNS = {"seconds": ".1f", "cpu_seconds": ".1f"}


def page(df) -> str:
    """stability.md: the two tables (COLUMNS, ANISO_COLUMNS) and the reading."""
    an = df.family.notna()
    tables = [markdown_table(df.loc[rows, cols], fixed=FIXED_COLUMNS, digits=".3g")
              for rows, cols in ((~an, COLUMNS), (an, ANISO_COLUMNS))]
    return "\n\n".join(tables + [reading(df)]) + "\n"


# the measures of the figure in symbols: the change of (f, u_h) when every quadrature order
# is raised (QuadratureOptions.raised()), relative to the squared energy error
QUAD_CHANGE = r"$|\Delta(f,u_h)| / \|u-u_h\|_a^2$, quadrature raised"
ONE_PERCENT = r"1 % of $\|u-u_h\|_a^2$"

def figure(df, png):
    """Top: extreme s and grading exponent; bottom: the anisotropic layers."""
    fig, axs = plt.subplot_mosaic([["s", "s", "s", "g", "g", "g"],
                                   ["err", "err", "quad", "quad", "cond", "cond"]],
                                  figsize=(14, 8.5), layout="constrained")
    sw = df[df.case.str.startswith("s sweep")]
    ax = axs["s"]
    for colour, (lab, g) in zip(("C0", "C3"), sw.groupby("case")):
        lab = "uniform mesh, level " + lab.removeprefix("s sweep, disk_uniform(").rstrip(")")
        ax.semilogy(g.s, g.quad_change_over_err2, "o-", color=colour,
                    label=f"{lab}: {QUAD_CHANGE}")
        ax.semilogy(g.s, g.cond / g.cond.max(), "s--", color=colour, mfc="none",
                    label=f"{lab}: " + r"$\mathrm{cond}(A)$ / its largest over $s$")
    ax.set_xlabel("$s$")
    ax.set_ylabel(r"quadrature change; normalised $\mathrm{cond}(A)$")
    ax.legend(fontsize=7)
    ax.set_title("(a) Example 1 at extreme $s$, uniform meshes")
    ax = axs["g"]
    sr = df[df.case.str.startswith("grading")]
    ax.semilogy(sr.grading, sr.quad_change_over_err2, "o-",
                label=r"shape-regular graded mesh, $h = 0.3$")
    an = df[(df.family == "n-series") & (df.n == SERIES_N[-1])]
    ax.semilogy(an.grading, an.quad_change_over_err2, "s-",
                label=f"anisotropic graded mesh, {SERIES_N[-1]} rings")
    ax.axhline(0.01, color="k", lw=0.8, ls=":", label=ONE_PERCENT)
    ax.set_xlabel("grading exponent $\\mu$")
    ax.set_ylabel(QUAD_CHANGE)
    ax.legend(fontsize=8)
    ax.set_title("(b) strong grading, $s = 0.5$")
    colours = dict(zip(GRADINGS, ("C0", "C1", "C2")))
    an = df[df.family.isin(["n-series", "outer layer"])]
    for (mu, fam), g in an.groupby(["grading", "family"]):
        if fam == "outer layer":  # the thinning layer starts from the plain mesh
            base = an[(an.family == "n-series") & (an.grading == mu) & (an.n == LAYER_N)]
            g = pd.concat([base, g])
        g = g.sort_values("thinnest_layer", ascending=False)
        style = dict(color=colours[mu], marker="o" if fam == "n-series" else "^",
                     ls="-" if fam == "n-series" else "--")
        name = (f"$\\mu = {mu:g}$: $n$ = {', '.join(str(int(k)) for k in sorted(g.n))} rings"
                if fam == "n-series" else
                f"$\\mu = {mu:g}$: $n = {LAYER_N}$ rings, outer layer $\\delta$")
        axs["err"].loglog(g.thinnest_layer, g.error, label=name, **style)
        axs["quad"].loglog(g.thinnest_layer, g.quad_change_over_err2, label=name, **style)
        axs["cond"].semilogx(g.thinnest_layer, g.cond, **style)
        axs["cond"].semilogx(g.thinnest_layer, g.cond_scaled, color=colours[mu],
                             marker=style["marker"], ls=":", mfc="none")
    axs["quad"].axhline(0.01, color="k", lw=0.8, ls=":", label=ONE_PERCENT)
    axs["cond"].plot([], [], "k-", marker="o", label=r"$\mathrm{cond}(A)$, free nodes")
    axs["cond"].plot([], [], "k:", marker="o", mfc="none", label=r"cond($D^{-1/2} A D^{-1/2}$)")
    plain_log_ticks(axs["err"].yaxis)     # 10^k and decimal labels side by side overlap
    for key, ylabel, title in (
            ("err", ERROR_LABELS["elliptic"], "(c) energy error, $s = 0.5$"),
            ("quad", QUAD_CHANGE, "(d) quadrature change, $s = 0.5$"),
            ("cond", "condition number (colours as in (c))", "(e) conditioning, $s = 0.5$")):
        ax = axs[key]
        ax.set_xlabel(r"thinnest layer $1 - \max|x|$ (interior nodes)")
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.invert_xaxis()
        ax.legend(fontsize=7)
    save(fig, png)


def main(md, png, csv, log=None, threads=None):
    start(log, threads)
    rows = []
    for s in (0.01, 0.05, 0.1, 0.5, 0.9, 0.95, 0.99):
        for level in (3, 4):
            rows.append(case(f"s sweep, disk_uniform({level})", ff.disk_uniform(level), s))
    for mu in (1.0, 2.0, 3.0, 4.0):
        rows.append(case(f"grading {mu:g}, disk_graded(0.3)", ff.disk_graded(0.3, mu), 0.5,
                         grading=mu))
    rows += aniso_rows()
    df = pd.DataFrame(rows)
    write_table(with_provenance(df), csv)
    with atomic_path(md) as tmp:
        tmp.write_text(page(df))
    figure(df, png)


if __name__ == "__main__":
    main(snakemake.output.md, snakemake.output.png, snakemake.output.csv,  # noqa: F821
         snakemake.log[0], snakemake.threads)  # noqa: F821
