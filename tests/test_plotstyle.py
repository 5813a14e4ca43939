"""The figure style of the workflow: saving the same figure twice gives the same bytes, so
re-running a figure rule on unchanged data leaves the committed figures untouched."""
import time

import numpy as np

from fracfem_workflow.plotstyle import plt, save


def draw(directory):
    """A small figure with the kinds of artists the paper figures use."""
    fig = plt.figure(figsize=(4, 2))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    x, y = np.meshgrid(np.linspace(-1, 1, 5), np.linspace(-1, 1, 5))
    ax.plot_trisurf(x.ravel(), y.ravel(), (1 - x ** 2 - y ** 2).ravel(), cmap="viridis")
    ax.set_title(r"$u_h$, s = 0.5")
    ax2 = fig.add_subplot(1, 2, 2)
    ax2.loglog([10, 100, 1000], [0.3, 0.1, 0.03], marker="o", label="uniform")
    ax2.legend()
    save(fig, directory / "f.png", directory / "f.pdf")


def test_saving_twice_gives_identical_files(tmp_path, monkeypatch):
    monkeypatch.delenv("SOURCE_DATE_EPOCH", raising=False)
    (tmp_path / "a").mkdir()
    (tmp_path / "b").mkdir()
    draw(tmp_path / "a")
    time.sleep(1.1)        # a PDF creation date would now differ (it has whole seconds)
    draw(tmp_path / "b")
    for name in ("f.png", "f.pdf"):
        first, second = ((tmp_path / d / name).read_bytes() for d in "ab")
        assert first == second, name
    pdf = (tmp_path / "a" / "f.pdf").read_bytes()
    assert b"/CreationDate" not in pdf and b"/ModDate" not in pdf
    assert plt.get_fignums() == []             # save closes the figure
