"""Figure 4: Example 2 solution on a uniform mesh, with the contact set."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import plt, save  # noqa: E402


def main(npz, png, pdf):
    d = np.load(npz)
    p, t, u, pc, tc, lam = d["p"], d["t"], d["u"], d["pc"], d["tc"], d["lam"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], u, triangles=t.T, cmap="viridis", linewidth=0)
    ax.set_title(f"Example 2: $u_h$ ({t.shape[1]} triangles)")
    ax2 = fig.add_subplot(1, 2, 2)
    tp = ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=lam, cmap="magma", edgecolors="none")
    fig.colorbar(tp, ax=ax2, label=r"$\lambda_H$")
    ax2.set_aspect("equal")
    ax2.set_title(rf"$\lambda_H$ (contact where $\lambda_H<0$: {int(np.sum(lam < 0))} elements)")
    save(fig, png, pdf)


if __name__ == "__main__":
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
