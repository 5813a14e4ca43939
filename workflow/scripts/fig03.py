"""Figure 3: the obstacle χ (Examples 2 and 4)."""
import fracfem as ff
from fracfem.examples import paraboloid_obstacle
from fracfem_workflow.logs import log_to
from fracfem_workflow.plotstyle import plt, save, surface


def main(height, slope, png, pdf):
    m = ff.disk_uniform(5)
    chi = paraboloid_obstacle(height, slope)(m.p)
    fig = plt.figure(figsize=(6, 4.5))
    ax = fig.add_subplot(projection="3d")
    surface(ax, m.p, m.t, chi, cmap="coolwarm")
    ax.set_title(rf"Obstacle $\chi = {height:g} - {slope:g}|x|^2$")
    save(fig, png, pdf)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(snakemake.params.height, snakemake.params.slope, snakemake.output.png,  # noqa: F821
         snakemake.output.pdf)  # noqa: F821
