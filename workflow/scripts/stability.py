"""Stability study, Example 1: extreme s and strong grading (issue 6, part 1).

Each case reports finite values and the expected structure (Galerkin bound,
positive definiteness, quadrature convergence) or the error it raised.
"""
import time

import numpy as np
import pandas as pd

import fracfem as ff
from fracfem.meshes import min_angle
from fracfem_workflow.io import atomic_path, with_provenance, write_table
from fracfem_workflow.logs import script_logger
from fracfem_workflow.plotstyle import plt, save
from fracfem_workflow.runs import start

logger = script_logger("stability")


def case(label, mesh, s):
    row = {"case": label, "s": s, "dofs": len(mesh.interior_nodes()),
           "min_angle": min_angle(mesh)}
    p, t = mesh.p, mesh.t
    e = np.stack([np.linalg.norm(p[:, t[(i + 1) % 3]] - p[:, t[i]], axis=0) for i in range(3)])
    row["h_min"] = float(e.min())
    t0 = time.perf_counter()
    try:
        free = mesh.interior_nodes()
        b = ff.load_vector(mesh, 1.0)[free]
        fu = []
        for q in (ff.QuadratureOptions(), ff.QuadratureOptions().raised()):
            A = ff.stiffness_matrix(mesh, s, quadrature=q)[np.ix_(free, free)]
            fu.append(float(b @ np.linalg.solve(A, b)))
            if len(fu) == 1:
                ev = np.linalg.eigvalsh(A)
                row.update(lambda_min=ev[0], cond=ev[-1] / ev[0])
        exact = ff.disk_energy(s)
        err2 = exact - fu[0]
        row.update(fu_h=fu[0], error=np.sqrt(err2) if err2 > 0 else np.nan,
                   galerkin_ok=bool(0 < err2), finite=bool(np.isfinite(fu).all()),
                   spd=bool(row["lambda_min"] > 0),
                   quad_change_over_err2=abs(fu[1] - fu[0]) / err2 if err2 > 0 else np.nan,
                   status="ok")
    except (ValueError, np.linalg.LinAlgError) as err:
        row.update(status=f"refused: {err}")
    row["seconds"] = time.perf_counter() - t0
    logger.info("%s, s = %g: %s, %.1f s", label, s, row["status"], row["seconds"])
    return row


def plot(df, png):
    """Quadrature change and conditioning across s (left), quadrature change across the
    grading exponent (right)."""
    fig, axs = plt.subplots(1, 2, figsize=(10, 4))
    sw = df[df.case.str.startswith("s sweep")]
    for lab, g in sw.groupby("case"):
        mesh = "uniform mesh, level " + lab.split("(")[1].rstrip(")")
        axs[0].semilogy(g.s, g.quad_change_over_err2, "o-",
                        label=f"{mesh}: quadrature change / err²")
        axs[0].semilogy(g.s, g.cond / g.cond.max(), "s--",
                        label=f"{mesh}: condition number / its maximum")
    axs[0].set_xlabel("$s$")
    axs[0].set_ylabel("relative size")
    axs[0].legend()
    axs[0].set_title("Example 1 at extreme $s$")
    gr = df[df.case.str.startswith("grading")]
    for kind, g in gr.groupby(gr.case.str.contains("rings")):
        axs[1].semilogy([float(c.split()[1][:-1]) for c in g.case], g.quad_change_over_err2,
                        "o-", label="anisotropic rings" if kind else "shape-regular")
    axs[1].axhline(0.01, color="k", lw=0.8, ls=":", label="1% of err²")
    axs[1].set_xlabel(r"grading exponent $\mu$")
    axs[1].set_ylabel("quadrature change / err²")
    axs[1].legend()
    axs[1].set_title("Strong grading, $s = 0.5$")
    save(fig, png)


def main(md, png, csv, log=None, threads=None):
    start(log, threads)
    rows = []
    for s in (0.01, 0.05, 0.1, 0.5, 0.9, 0.95, 0.99):
        for level in (3, 4):
            rows.append(case(f"s sweep, disk_uniform({level})", ff.disk_uniform(level), s))
    for mu in (1.0, 2.0, 3.0, 4.0):
        rows.append(case(f"grading {mu:g}, disk_graded(0.3)", ff.disk_graded(0.3, mu), 0.5))
        rows.append(case(f"grading {mu:g}, disk_graded_rings(12)",
                         ff.disk_graded_rings(12, mu), 0.5))
    df = pd.DataFrame(rows)
    write_table(with_provenance(df), csv)
    cols = ["case", "s", "dofs", "h_min", "min_angle", "error", "galerkin_ok", "spd", "cond",
            "quad_change_over_err2", "status"]
    with atomic_path(md) as tmp:
        tmp.write_text(df[cols].to_markdown(index=False, floatfmt=".3g") + "\n")
    plot(df, png)


if __name__ == "__main__":
    main(snakemake.output.md, snakemake.output.png, snakemake.output.csv,  # noqa: F821
         snakemake.log[0], snakemake.threads)  # noqa: F821
