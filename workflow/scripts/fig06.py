"""Figure 6: Example 2's adaptive multiplier meshes T_H: the paper's 1st, 3rd and 8th
adaptive meshes and the last one of the large Algorithm B series."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, problem_title, save


def ordinal(n):
    return f"{n}{'th' if 10 <= n % 100 <= 20 else {1: 'st', 2: 'nd', 3: 'rd'}.get(n % 10, 'th')}"


def main(npz, png, pdf):
    d = np.load(npz)
    steps = [int(k) for k in d["steps"]]
    fig, axes = plt.subplots(1, len(steps), figsize=(3.3 * len(steps), 3.7), squeeze=False)
    contact = d["lam"] < 0
    for ax, k in zip(axes[0], steps):
        pc, tc = d[f"pc{k}"], d[f"tc{k}"]
        # thinner lines where the mesh is fine, so the grading stays visible; fine meshes
        # rasterised (as vectors, 10⁵ edges make a PDF of several MB)
        n = tc.shape[1]
        ax.triplot(pc[0], pc[1], tc.T, lw=0.4 * min(1.0, (500 / n) ** 0.35), color="k",
                   rasterized=n > 5000)
        ax.tripcolor(d["pc"][0], d["pc"][1], d["tc"][:, contact].T,
                     facecolors=np.ones(contact.sum()), cmap="Reds", vmin=0, vmax=2,
                     alpha=0.35, edgecolors="none", rasterized=True)
        last = " (the last)" if k == steps[-1] else ""     # the series' last mesh is kept
        ax.set_title(f"{ordinal(k + 1)} mesh{last}: {tc.shape[1]:,} elements of $T_H$\n"
                     f"{int(d[f'dofs{k}']):,} DOFs of $T_h$", fontsize=9)
        ax.set_aspect("equal")
        ax.set_axis_off()
    fig.suptitle(f"{problem_title('ex2')}, Algorithm B: adaptive meshes $T_H$ "
                 r"(shaded: final contact set $\{\lambda_H < 0\}$)")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
