"""Figure 3: the obstacle χ (Examples 2 and 4)."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import plt, save  # noqa: E402

import fracfem as ff  # noqa: E402
from fracfem.examples import paraboloid_obstacle  # noqa: E402


def main(obstacle, png, pdf):
    m = ff.disk_uniform(5)
    chi = paraboloid_obstacle(**obstacle)(m.p)
    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    ax.plot_trisurf(m.p[0], m.p[1], chi, triangles=m.t.T, cmap="coolwarm", linewidth=0)
    ax.set_title(rf"Obstacle $\chi = {obstacle['height']:g} - {obstacle['slope']:g}|x|^2$")
    save(fig, png, pdf)


if __name__ == "__main__":
    main(snakemake.params.obstacle, snakemake.output.png, snakemake.output.pdf)  # noqa: F821
