"""Figure 10: Example 4 (u₀ = 1) at T on the last space-time adaptive mesh, with λ_H."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import plt, save  # noqa: E402


def main(npz, png, pdf):
    d = np.load(npz)
    p, t, u, lam = d["p"], d["t"], d["u"], d["lam"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], u, triangles=t.T, cmap="viridis", linewidth=0)
    ax.set_title(f"Example 4, $u_0=1$: $u_{{h\\tau}}$ at T = {float(d['T']):g}, adaptive "
                 f"({t.shape[1]} triangles)", fontsize=9)
    ax2 = fig.add_subplot(1, 2, 2)
    pc, tc = d["pc"], d["tc"]
    tp = ax2.tripcolor(pc[0], pc[1], tc.T, facecolors=lam, cmap="magma", edgecolors="none")
    fig.colorbar(tp, ax=ax2, label=r"$\lambda_H$ at T")
    ax2.set_title(rf"contact ($\lambda_H<0$): {int(np.sum(lam < 0))} coarse elements",
                  fontsize=9)
    ax2.set_aspect("equal")
    save(fig, png, pdf)


if __name__ == "__main__":
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
