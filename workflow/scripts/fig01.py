"""Figure 1: Example 1 solution on a 2-graded mesh, as a surface."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, save, surface


def main(npz, png, pdf):
    d = np.load(npz)
    p, t, u = d["p"], d["t"], d["u"]
    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    surface(ax, p, t, u, linewidth=0.1, edgecolor="k", antialiased=True)
    ax.set_title(f"Example 1: $u_h$ on a 2-graded mesh ($s = {float(d['s']):g}$, "
                 f"{t.shape[1]} triangles)")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
