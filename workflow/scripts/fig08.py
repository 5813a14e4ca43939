"""Figure 8: Example 3, u_h (left) and λ_H (right)."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import plt, save  # noqa: E402


def main(npz, title, png, pdf):
    d = np.load(npz)
    p, t, u, pc, tc, lam = d["p"], d["t"], d["u"], d["pc"], d["tc"], d["lam"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], u, triangles=t.T, cmap="coolwarm", linewidth=0)
    ax.set_title(f"{title}: $u_h$, s = {float(d['s']):g}")
    ax2 = fig.add_subplot(1, 2, 2)
    tp = ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=lam, cmap="coolwarm", edgecolors="none")
    ax2.tricontour(p[0], p[1], t.T, u, levels=[0.0], colors="k", linewidths=1)
    fig.colorbar(tp, ax=ax2, label=r"$\lambda_H$")
    ax2.set_aspect("equal")
    ax2.set_title(r"$\lambda_H$ and the zero level of $u_h$ (black)")
    save(fig, png, pdf)


if __name__ == "__main__":
    main(snakemake.input.npz, snakemake.params.title, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
