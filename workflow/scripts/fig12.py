"""Figure 12: Example 4 (u₀ = 1), slices of the space-time adaptive meshes."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, problem_title, save


RASTER_TRIANGLES = 50_000     # meshes with more triangles are drawn rasterized


def slices(d, key):
    out, j = [], 0
    while f"p_{key}_{j}" in d:
        out.append((float(d[f"time_{key}_{j}"]), d[f"p_{key}_{j}"], d[f"t_{key}_{j}"]))
        j += 1
    return out


def main(npz, png, pdf):
    d = np.load(npz)
    keys = [f"it{k}" for k in d["figure_iterations"]] + ["last"]
    rows = [(k, slices(d, k)) for k in keys if slices(d, k)]
    ncol = max(len(s) for _, s in rows)
    fig, axes = plt.subplots(len(rows), ncol, figsize=(2.6 * ncol, 2.7 * len(rows)),
                             squeeze=False)
    last_it = int(d["iterations"][-1])
    for r, (key, sl) in enumerate(rows):
        for c, (t_out, p, t) in enumerate(sl):
            ax = axes[r][c]
            # a mesh of the paper-scale tier (10⁵–10⁶ triangles) as vector lines makes a
            # PDF of tens of MB: drawn as an image inside the PDF instead
            ax.triplot(p[0], p[1], t.T, lw=0.15, color="k",
                       rasterized=t.shape[1] > RASTER_TRIANGLES)
            name = f"pass {last_it}" if key == "last" else f"pass {key[2:]}"
            ax.set_title(f"{name}, $t = {t_out:g}$: {t.shape[1]} triangles")
            ax.set_aspect("equal")
            ax.set_axis_off()
        for c in range(len(sl), ncol):
            axes[r][c].set_axis_off()
    fig.suptitle(f"{problem_title('ex4-u1')}: meshes $T_h$ of the time slabs containing $t$")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
