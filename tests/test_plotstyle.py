"""The figure style of the workflow: saving the same figure twice gives the same bytes, so
re-running a figure rule on unchanged data leaves the committed figures untouched."""
import time

import numpy as np
import pytest

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


def _overlap(a, b):
    """Whether two display-space boxes overlap (touching edges do not count)."""
    return a.x0 < b.x1 and b.x0 < a.x1 and a.y0 < b.y1 and b.y0 < a.y1


@pytest.mark.parametrize("figsize", [(10, 4.2), (5, 7), (12, 3)])
def test_colorbar_never_runs_into_the_title(figsize):
    """A long title over an equal-aspect map with a colour bar whose end tick labels sit
    at the very ends: in wide, tall and flat figures the title and the colour bar
    (with its tick labels) stay apart."""
    from fracfem_workflow.plotstyle import colorbar, map_axes

    fig, ax = plt.subplots(figsize=figsize)
    x, y = np.meshgrid(np.linspace(-1, 1, 6), np.linspace(-1, 1, 6))
    tp = ax.tripcolor(x.ravel(), y.ravel(), np.linspace(-2.0, 0.0, 36), vmin=-2, vmax=0)
    cb = colorbar(fig, tp, ax, r"$\lambda_H$")
    map_axes(ax)
    ax.set_title(r"$\lambda_H$; contact where $\lambda_H < 0$: 84 of 1024 elements, "
                 "a title as long as the panel")
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    title = ax.title.get_window_extent(renderer)
    bar = cb.ax.get_tightbbox(renderer)
    assert not _overlap(title, bar)
    assert bar.y1 < ax.get_window_extent(renderer).y1 + 1       # not above the map
    plt.close(fig)


def test_interface_segments_are_the_edges_between_labels():
    """Unit square cut into 2×2 squares, each into two triangles: labelling the left
    column 1 gives exactly the two edges on x = 1/2; one label everywhere gives none."""
    from fracfem_workflow.plotstyle import interface_segments

    x, y = np.meshgrid([0.0, 0.5, 1.0], [0.0, 0.5, 1.0])
    p = np.vstack([x.ravel(), y.ravel()])
    t = []
    for j in range(2):
        for i in range(2):
            a, b, c, d = 3 * j + i, 3 * j + i + 1, 3 * (j + 1) + i, 3 * (j + 1) + i + 1
            t += [[a, b, d], [a, d, c]]
    t = np.array(t).T
    centroid_x = p[0, t].mean(axis=0)
    seg = interface_segments(p, t, (centroid_x < 0.5).astype(int))
    assert seg.shape == (2, 2, 2)
    assert np.allclose(seg[:, :, 0], 0.5)                        # both ends on x = 1/2
    assert sorted(seg[:, :, 1].sum(axis=1)) == [0.5, 1.5]        # (0→½) and (½→1)
    assert interface_segments(p, t, np.zeros(t.shape[1], int)).shape == (0, 2, 2)


def test_friction_states():
    from fracfem_workflow.plotstyle import friction_states

    lam = np.array([0.5, 0.5 * (1 - 1e-9), 0.49, 0.0, -0.49, -0.5])
    assert friction_states(lam, 0.5).tolist() == [1, 1, 0, 0, 0, -1]


def test_problem_titles_are_the_papers_words():
    from fracfem_workflow.plotstyle import problem_title

    assert problem_title("ex4-u1") == "Example 4, $u_0 = 1$"
    assert problem_title("ex4-u2") == r"Example 4, $\tilde u_0 = 2$"
    assert problem_title("ex3-printed") == "Example 3, $f = 1$"
    assert problem_title("ex5") == "Example 5"
    assert problem_title("ex3-mydata") == "Example 3 (mydata)"     # a data set of a config


def test_plain_log_ticks_label_a_short_range_without_overlap():
    """0.3 s to 5 s: labels 0.5, 1, 2, 5 as plain numbers, no two of them overlapping."""
    from fracfem_workflow.plotstyle import plain_log_ticks

    fig, ax = plt.subplots(figsize=(4, 3))
    ax.loglog([0.3, 5.0], [0.4, 0.2])
    plain_log_ticks(ax.xaxis)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    labels = [lab for lab in ax.get_xticklabels(which="both")
              if lab.get_text() and lab.get_visible()
              and 0.3 <= lab.get_position()[0] <= 5.0]
    assert [lab.get_text() for lab in labels] == ["0.5", "1", "2", "5"]
    boxes = [lab.get_window_extent(renderer) for lab in labels]
    assert not any(_overlap(a, b) for i, a in enumerate(boxes) for b in boxes[i + 1:])
    plt.close(fig)


@pytest.mark.parametrize("height", [2.2, 3.0, 5.0])
def test_error_legend_lies_below_the_axis_label_and_names_open_markers(height):
    """legend_below keeps the legend clear of the x label whatever the axes' height, and
    adds one entry for the hollow markers of runs left out of a fit only when there are
    such runs (rate_series draws them)."""
    from fracfem_workflow.plotstyle import SPACETIME_DOFS, legend_below, rate_series
    for reference_error, open_entry in ((0.0, False), (0.05, True)):
        fig, ax = plt.subplots(figsize=(5, height))
        rate_series(ax, [1e2, 1e3, 1e4, 1e5], [0.5, 0.3, 0.18, 0.12], "adaptive",
                    reference_error=reference_error)
        ax.set_xlabel(SPACETIME_DOFS)
        legend_below(ax)
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()
        legend = ax.get_legend()
        texts = [t.get_text() for t in legend.get_texts()]
        assert any(t.startswith("open markers") for t in texts) == open_entry
        label_box = ax.xaxis.label.get_window_extent(renderer)
        ticks_box = max(t.get_window_extent(renderer).y0 for t in ax.get_xticklabels()
                        if t.get_text())
        assert legend.get_window_extent(renderer).y1 < label_box.y0 < ticks_box
        # the rule that leaves them out, when the figure gives it, and only on that entry
        legend_below(ax, why="below the 3× line")
        texts = [t.get_text() for t in ax.get_legend().get_texts()]
        assert [t for t in texts if "3× line" in t] == (
            ["open markers: runs left out of the fit (below the 3× line)"] if open_entry
            else [])
        plt.close(fig)


def test_change_label_names_the_start_mesh_by_its_triangles_and_the_unchanged_settings():
    """disk_uniform(L) has 4^(L+1) triangles (4 refined L times); θ for theta; the
    unchanged series carries its own settings."""
    import pandas as pd
    from fracfem_workflow.plotstyle import UNCHANGED, change_label

    steps = pd.DataFrame({"theta": [0.5], "start_level": [2]})
    assert change_label("start_level = 3", steps) == "start mesh uniform, 256 triangles"
    assert change_label("start_level = 1", steps) == "start mesh uniform, 16 triangles"
    assert change_label("theta = 0.75", steps) == "θ = 0.75"
    assert change_label(UNCHANGED, steps) == \
        f"{UNCHANGED}: θ = 0.5, start mesh uniform, 64 triangles"


def test_slip_legend_names_only_the_kinds_of_slip_edge_some_panel_draws():
    """Slip at λ_H = F in one panel, stick everywhere in the other: one legend entry (the
    solid edge); slip of both signs: both, F first, also where a panel drawn before has
    only −F; no slip anywhere: no legend."""
    from fracfem import disk_uniform
    from fracfem_workflow.plotstyle import slip_boundaries, slip_legend

    m, F = disk_uniform(2), 0.1
    r = np.hypot(*m.p[:, m.t].mean(axis=1))
    one_sign = np.where(r < 0.4, F, 0.3 * F)
    both = np.where(r > 0.7, -F, one_sign)
    stick = np.full(m.t.shape[1], 0.3 * F)
    minus_only = np.where(r > 0.7, -F, 0.3 * F)

    def legend(*panels):
        fig, axes = plt.subplots(1, len(panels))
        slip_legend(fig, [h for ax, lam in zip(axes, panels)
                          for h in slip_boundaries(ax, m.p, m.t, lam, F)])
        texts = [[t.get_text() for t in lg.get_texts()] for lg in fig.legends]
        plt.close(fig)
        return texts

    assert legend(one_sign, stick) == [[r"edge of the slip set $\lambda_H = F$"]]
    assert legend(stick, both) == [[r"edge of the slip set $\lambda_H = F$",
                                    r"edge of the slip set $\lambda_H = -F$"]]
    assert legend(minus_only, one_sign) == legend(stick, both)
    assert legend(minus_only, stick) == [[r"edge of the slip set $\lambda_H = -F$"]]
    assert legend(stick, stick) == []
