"""Figure 14: Example 5, u_hτ and λ_H at several times; where λ_H switches sign."""
import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, save


def slip_regions(pc, tc, lam, F, rtol=1e-6):
    """Counts of slip (λ = ±F) and stick elements and the radii bounding the slip sets."""
    r = np.hypot(*pc[:, tc].mean(axis=1))
    plus = lam >= F * (1 - rtol)
    minus = lam <= -F * (1 - rtol)
    return {"slip+ (λ=F)": int(plus.sum()), "slip− (λ=−F)": int(minus.sum()),
            "stick": int((~plus & ~minus).sum()),
            "slip+ outer radius": float(r[plus].max()) if plus.any() else np.nan,
            "slip− inner radius": float(r[minus].min()) if minus.any() else np.nan}


def main(npz, times_shown, F, png, pdf, md):
    d = np.load(npz)
    p, t, U, LAM, times = d["p"], d["t"], d["U"], d["LAM"], d["times"]
    pc, tc = d["pc"], d["tc"]
    fig = plt.figure(figsize=(3.3 * len(times_shown), 6.4))
    for j, ts in enumerate(times_shown):
        k = int(np.argmin(np.abs(times - ts)))
        ax = fig.add_subplot(2, len(times_shown), j + 1, projection="3d")
        ax.plot_trisurf(p[0], p[1], U[k], triangles=t.T, cmap="viridis", linewidth=0)
        ax.set_title(f"$u_{{h\\tau}}$, t = {times[k]:.2f}", fontsize=9)
        ax2 = fig.add_subplot(2, len(times_shown), len(times_shown) + j + 1)
        if k > 0:
            ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=LAM[k - 1], cmap="coolwarm",
                          vmin=-F, vmax=F, edgecolors="none")
            ax2.set_title(rf"$\lambda_H$, t = {times[k]:.2f}", fontsize=9)
        else:
            ax2.set_title(r"t = 0: no $\lambda_H$ (initial value $P_h u_0$)", fontsize=8)
        ax2.set_aspect("equal")
        ax2.set_axis_off()
    fig.suptitle(f"Example 5 ({t.shape[1]} triangles, {len(times) - 1} steps)")
    save(fig, png, pdf)
    rows = [{"t": float(times[k + 1]), **slip_regions(pc, tc, LAM[k], F)}
            for k in range(len(LAM))]
    table = pd.DataFrame(rows)
    keep = np.unique(np.linspace(0, len(table) - 1, 12).round().astype(int))
    with atomic_path(md) as tmp:
        tmp.write_text(f"Example 5 (F = {F:g}): slip and stick sets of λ_H over time; the "
                       "free boundary is where λ_H jumps between them (radii of element "
                       "centroids):\n\n"
                       + table.iloc[keep].to_markdown(
                           index=False, floatfmt=(".3g", "g", "g", "g", ".3g", ".3g")) + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.params.times, snakemake.params.F,  # noqa: F821
         snakemake.output.png, snakemake.output.pdf, snakemake.output.md)  # noqa: F821
