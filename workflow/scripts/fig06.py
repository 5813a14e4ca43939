"""Figure 6: Example 2 adaptive meshes T_h after several refinements, coarse indicators."""
import numpy as np

from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, problem_title, save


def main(npz, png, pdf):
    d = np.load(npz)
    steps = [int(k) for k in d["steps"]]
    fig, axes = plt.subplots(1, len(steps), figsize=(3.4 * len(steps), 3.6), squeeze=False)
    for ax, k in zip(axes[0], steps):
        p, t = d[f"p{k}"], d[f"t{k}"]
        ax.triplot(p[0], p[1], t.T, lw=0.2, color="k")
        ax.set_title(f"after {k} refinement{'' if k == 1 else 's'}: {t.shape[1]} triangles")
        ax.set_aspect("equal")
        ax.set_axis_off()
    pc, tc, lam = d["pc"], d["tc"], d["lam"]
    contact = lam < 0
    for ax in axes[0]:
        ax.tripcolor(pc[0], pc[1], tc.T, facecolors=np.where(contact, 1.0, np.nan),
                     cmap="Reds", vmin=0, vmax=2, alpha=0.35, edgecolors="none")
    fig.suptitle(f"{problem_title('ex2')}, Algorithm B: meshes $T_h$ "
                 r"(shaded: final contact set $\{\lambda_H < 0\}$)")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.input.npz, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
