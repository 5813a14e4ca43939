"""Thin obstacle / thin friction demonstration: u_h and λ_H along Γ̃."""
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import plt, save  # noqa: E402


def main(npz, png):
    d = np.load(npz)
    p, t, u, pc, lam, edges = d["p"], d["t"], d["u"], d["pc"], d["lam"], d["edges"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], u, triangles=t.T, cmap="viridis", linewidth=0)
    ax.set_title(f"$u_h$, s = {float(d['s']):g}")
    ax2 = fig.add_subplot(1, 2, 2)
    xm = pc[0, edges].mean(axis=0)
    order = np.argsort(xm)
    on = np.abs(p[1]) < 1e-12
    ax2.plot(np.sort(p[0, on]), u[on][np.argsort(p[0, on])], "k.-", ms=3, label=r"$u_h$ on $y=0$")
    ax2.step(xm[order], lam[order], where="mid", label=r"$\lambda_H$ on $\tilde\Gamma$")
    ax2.set_xlabel("$x_1$")
    ax2.legend()
    save(fig, png)


if __name__ == "__main__":
    main(snakemake.input.npz, snakemake.output.png)  # noqa: F821
