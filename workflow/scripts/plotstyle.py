"""Shared matplotlib settings of the workflow's figures."""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

plt.rcParams.update({"figure.dpi": 120, "savefig.dpi": 150, "font.size": 10,
                     "axes.grid": True, "grid.alpha": 0.3})
MARKERS = {"uniform": "o", "graded": "s", "adaptive": "^"}


def save(fig, *paths):
    for path in paths:
        fig.savefig(path, bbox_inches="tight")
    plt.close(fig)


def solution_figure(npz_path, title, cmap="viridis"):
    """Load a mixed-problem result; left panel the surface of u_h.

    Returns (data, fig, right axes) for the caller's second panel.
    """
    import numpy as np
    d = np.load(npz_path)
    p, t = d["p"], d["t"]
    fig = plt.figure(figsize=(10, 4.2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax.plot_trisurf(p[0], p[1], d["u"], triangles=t.T, cmap=cmap, linewidth=0)
    ax.set_title(title.format(s=float(d["s"]), triangles=t.shape[1]))
    return d, fig, fig.add_subplot(1, 2, 2)


def multiplier_panel(fig, ax, d, cmap):
    """λ_H as a piecewise constant on the coarse mesh, with a colour bar."""
    pc, tc = d["pc"], d["tc"]
    tp = ax.tripcolor(pc[0], pc[1], tc.T, facecolors=d["lam"], cmap=cmap, edgecolors="none")
    fig.colorbar(tp, ax=ax, label=r"$\lambda_H$")
    ax.set_aspect("equal")
