"""Figure 1: Example 1 solution on a 2-graded mesh, as a surface."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, save


def main(npz, png, pdf):
    d = np.load(npz)
    p, t, u = d["p"], d["t"], d["u"]
    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    ax.plot_trisurf(p[0], p[1], u, triangles=t.T, cmap="viridis", linewidth=0.1,
                    edgecolor="k", antialiased=True)
    ax.set_title(f"Example 1: $u_h$ on a 2-graded mesh (s = {float(d['s']):g}, "
                 f"{t.shape[1]} triangles)")
    ax.set_xlabel("$x_1$")
    ax.set_ylabel("$x_2$")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
