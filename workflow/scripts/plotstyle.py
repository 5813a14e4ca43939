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
