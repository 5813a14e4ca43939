"""The figure scripts' own logic: DG(0) steps drawn on their intervals (Figure 11), a
decayed solution shown as zero (Figure 14), the friction figure end to end (Figure 8), the
reference energy of Examples 2 and 3 (vi_errors)."""
import importlib.util
from pathlib import Path

import hashlib
import json
import logging
import re
import shutil

import numpy as np
import pandas as pd
import pytest

import fracfem as ff
from fracfem_workflow import plotstyle
from pages import page_tables

ROOT = Path(__file__).resolve().parents[1]


def script(name):
    spec = importlib.util.spec_from_file_location(name, ROOT / "workflow" / "scripts"
                                                  / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_dg0_steps_start_at_the_initial_time():
    """End times 0.2, 0.5, 1 with lengths 0.2, 0.3, 0.5: the first step is (0, 0.2]."""
    fig11 = script("fig11")
    assert fig11.step_edges([0.2, 0.5, 1.0], [0.2, 0.3, 0.5]).tolist() == [0.0, 0.2, 0.5, 1.0]
    with pytest.raises(ValueError, match="not contiguous"):
        fig11.step_edges([0.2, 0.5, 1.0], [0.2, 0.2, 0.5])


@pytest.fixture
def captured():
    """The figures a script would save, kept open for inspection."""
    figures = []

    def keep(fig, *paths):
        figures.append(fig)
    yield figures, keep
    for fig in figures:
        plotstyle.plt.close(fig)


def friction_data(tmp_path, U, F):
    """A friction result on disk_uniform(2): T_H = T_h, λ_H with slip of both signs."""
    m = ff.disk_uniform(2)
    r = np.hypot(*m.p[:, m.t].mean(axis=1))
    lam = np.where(r < 0.4, F, np.where(r > 0.7, -F, 0.3 * F))
    path = tmp_path / "run.npz"
    np.savez(path, p=m.p, t=m.t, pc=m.p, tc=m.t, U=U(m.p), u=U(m.p)[1],
             LAM=np.array([lam] * (len(U(m.p)) - 1)), lam=lam,
             times=np.linspace(0.0, 1.0, len(U(m.p))), s=0.6)
    return path


def adaptive_data(tmp_path, run):
    """The same states as Algorithm C's last pass stores them (one mesh per output time)."""
    d = np.load(run)
    arrays = {"last_iteration": 3}
    for j, time in enumerate(d["times"]):
        arrays.update({f"time_last_{j}": time, f"p_last_{j}": d["p"],
                       f"t_last_{j}": d["t"], f"u_last_{j}": d["U"][j],
                       f"pc_last_{j}": d["pc"], f"tc_last_{j}": d["tc"]})
        if j > 0:
            arrays[f"lam_last_{j}"] = d["LAM"][j - 1]
    path = tmp_path / "adaptive.npz"
    np.savez(path, **arrays)
    return path


def test_figure14_says_a_decayed_solution_is_zero(tmp_path, monkeypatch, captured):
    """At t = 0.8 |u| ≈ 3e−12 ≤ 1e−10 max|u(0)|: that panel says u ≡ 0 (and draws no
    round-off); at t = 0.4 (|u| = 1e−9, above) it draws u; λ_H has a colour bar."""
    fig14 = script("fig14")
    figures, keep = captured
    monkeypatch.setattr(fig14, "save", keep)
    rng = np.random.default_rng(0)

    def U(p):
        bump = 0.6 * (1 - np.hypot(*p) ** 2)
        return np.array([bump, 0.1 * bump, 1e-9 * bump, 1e-10 * bump,
                         3e-12 * rng.standard_normal(p.shape[1]), np.zeros(p.shape[1])])
    npz = friction_data(tmp_path, U, F=0.1)
    fig14.main(adaptive_data(tmp_path, npz), npz, [0.0, 0.4, 0.8], 0.1, 1e-10, None, None,
               tmp_path / "t.md")
    titles = [ax.get_title() for ax in figures[0].axes]
    assert any("t = 0.80" in s and r"\equiv 0" in s for s in titles)
    assert not any("t = 0.40" in s and r"\equiv 0" in s for s in titles)
    bars = [c for ax in figures[0].axes for c in ax.child_axes]        # inset colour bars
    assert [c.get_ylabel() for c in bars] == [r"$\lambda_H$"]
    assert "pass 3" in figures[0].get_suptitle()
    with pytest.raises(ValueError, match="output times"):
        fig14.main(adaptive_data(tmp_path, npz), npz, [0.0, 0.5], 0.1, 1e-10, None, None,
                   tmp_path / "t.md")


def test_figure8_draws_the_slip_boundaries(tmp_path, monkeypatch, captured):
    """The edges of the two slip sets are drawn as mesh edges, solid around λ_H = F and
    dashed around λ_H = −F, in both panels, and the legend names them."""
    fig08 = script("fig08")
    figures, keep = captured
    monkeypatch.setattr(fig08, "save", keep)
    npz = friction_data(tmp_path, lambda p: np.array([np.zeros(p.shape[1]),
                                                      1 - np.hypot(*p) ** 2]), F=0.5)
    fig08.main(npz, "ex3-signchange", 0.5, None, None)
    fig = figures[0]
    lines = [c for ax in fig.axes for c in ax.collections
             if c.get_label().startswith("edge of the slip set")]
    assert len(lines) == 4 and len(lines[0].get_segments()) > 0
    assert [c.get_linestyle()[0][1] is None for c in lines] == [True, False] * 2
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    assert texts == [r"edge of the slip set $\lambda_H = F$",
                     r"edge of the slip set $\lambda_H = -F$"]


def test_reference_energy_is_the_limit_of_the_large_series():
    """E_ref: the large series' extrapolation (not a mesh family's); its uncertainty is the
    reference error; where the energy is exact that is used and the large limit checked
    against it; a large series of other data is refused."""
    vi_errors = script("vi_errors")
    from fracfem_workflow.report import energy_error, extrapolation_uncertainty
    N = 113.0 * 2.1 ** np.arange(9)
    E = -0.6 + 0.3 * N ** -1.0 + 2.0 * N ** -1.5
    large = pd.DataFrame({"dofs": N.astype(int), "energy": E, "eta": 0.9 * N ** -0.5,
                          "t_cumulative": np.cumsum(N) / 1e3, "peak_mem_mb": N / 10,
                          "data": json.dumps({"s": 0.5})})
    n = np.array([25.0, 113.0, 481.0, 1985.0])
    series = pd.DataFrame({"family": "uniform", "dofs": n, "energy": -0.58 + 0.2 * n ** -0.5})
    ref, info = vi_errors.reference_energy("ex2", None, "graded-sr", series, large)
    expected = extrapolation_uncertainty(large.dofs, large.energy)
    assert ref == expected["energy"] and abs(ref + 0.6) < 1e-6
    assert info["large_uncertainty"] == expected["uncertainty"] > 0
    assert info["extrapolated_uniform"] == pytest.approx(-0.58, abs=1e-9)   # cross-check only
    assert info["large_finest_error"] == pytest.approx(energy_error(E[-1], ref))
    assert info["large_seconds"] == pytest.approx(np.sum(N) / 1e3)
    assert info["large_peak_mb"] == pytest.approx(N[-1] / 10)
    ref, info = vi_errors.reference_energy("ex3-printed", -0.6, "graded-sr", series, large)
    assert ref == -0.6
    assert info["large_check"] == pytest.approx(energy_error(expected["energy"], -0.6))
    assert info["large_check"] <= info["large_uncertainty"]
    assert vi_errors.check_data(large, "ex2", {"s": 0.5}) is large
    with pytest.raises(ValueError, match="computed for"):
        vi_errors.check_data(large, "ex2", {"s": 0.4})


def test_figure6_names_the_paper_s_meshes(tmp_path, monkeypatch, captured):
    """Steps 0, 2, 7 and 9 of Algorithm B are the 1st, 3rd, 8th and 10th adaptive meshes;
    each panel names its T_H elements and T_h DOFs."""
    fig06 = script("fig06")
    figures, keep = captured
    monkeypatch.setattr(fig06, "save", keep)
    meshes = {k: ff.disk_uniform(level) for k, level in zip((0, 2, 7, 9), (1, 2, 3, 4))}
    last = meshes[9]
    arrays = {"steps": np.array(sorted(meshes)), "pc": last.p, "tc": last.t,
              "lam": -np.ones(last.t.shape[1])}
    for k, m in meshes.items():
        arrays.update({f"pc{k}": m.p, f"tc{k}": m.t, f"dofs{k}": 10 * k + 1})
    np.savez(tmp_path / "m.npz", **arrays)
    fig06.main(tmp_path / "m.npz", "x.png", "x.pdf")
    titles = [ax.get_title() for ax in figures[0].axes if ax.get_title()]
    assert [t.split(" mesh")[0] for t in titles] == ["1st", "3rd", "8th", "10th"]
    assert f"{meshes[7].t.shape[1]:,} elements of $T_H$" in titles[2]
    assert "71 DOFs" in titles[2]
    assert [fig06.ordinal(n) for n in (11, 12, 13, 21, 22, 23)] == ["11th", "12th", "13th",
                                                                     "21st", "22nd", "23rd"]


def test_parabolic_reference_copy_is_single_precision_and_keeps_what_is_used(tmp_path):
    """The committed copy of a parabolic reference: U in single precision (relative change
    below 1e−7), the mesh and times as they are, λ_H only for the problems that use it, and
    the run's row; the copy reads back as the same pieces."""
    from fracfem_workflow.runs import parabolic_pieces

    copy = script("para_reference_copy")
    mesh = ff.disk_uniform(2)
    rng = np.random.default_rng(0)
    U = rng.standard_normal((4, mesh.p.shape[1]))
    runs = {}
    for problem in ("ex4-u1", "ex5"):
        npz, row = tmp_path / f"{problem}.npz", tmp_path / f"{problem}.csv"
        np.savez(npz, p=mesh.p, t=mesh.t, pc=mesh.p, tc=mesh.t, times=np.linspace(0, 1, 4),
                 U=U, LAM=rng.standard_normal((3, mesh.t.shape[1])), s=0.5,
                 free=mesh.interior_nodes(), step_k=np.arange(3))
        pd.DataFrame([{"tag": "h0.025", "t_wall": 1.0}]).to_csv(row, index=False)
        runs[problem] = (str(npz), str(row), (str(tmp_path / f"c-{problem}-parabolic.npz"),
                                              str(tmp_path / f"c-{problem}-parabolic.csv")))
    error = tmp_path / "reference-error.csv"
    pd.DataFrame([{"reference_error": 0.07, "reference_d23": 0.04}]).to_csv(error, index=False)
    with pytest.raises(ValueError, match="committed"):
        copy.main("ex4-u1", *runs["ex4-u1"], multipliers=[], note=tmp_path / "n.txt",
                  error=error)
    for problem, (npz, row, committed) in runs.items():
        extra = {"error": error} if problem == "ex4-u1" else {}
        to = (*committed, str(tmp_path / f"c-{problem}-reference-error.csv")) if extra else committed
        copy.main(problem, npz, row, to, multipliers=["ex5"],
                  note=tmp_path / f"{problem}-note.txt", **extra)
    assert (tmp_path / "c-ex4-u1-reference-error.csv").read_text() == error.read_text()
    assert not (tmp_path / "c-ex5-reference-error.csv").exists()
    assert not (tmp_path / "n.txt").exists()
    for problem, (npz, row, (npz_to, row_to)) in runs.items():
        assert (tmp_path / f"{problem}-note.txt").read_text().startswith(f"{npz} (")
        d = np.load(npz_to)
        assert d["U"].dtype == np.float32
        assert np.max(np.abs(d["U"] - U) / np.abs(U).max()) < 1e-7
        assert ("LAM" in d.files) == (problem == "ex5") and "step_k" not in d.files
        pieces, _ = parabolic_pieces(npz_to)
        assert len(pieces) == 3 and pieces[-1][1] == 1.0
        assert Path(row_to).read_text() == Path(row).read_text()


def test_algorithm_c_table_rates_of_the_estimator_parts():
    """Each part of η gets the rate of its square root over the fitted passes; a part
    at round-off level (an obstacle run's contact term) gets none; the time share is
    that of the finest pass."""
    from fracfem_workflow.report import algorithm_c_table
    dofs = np.array([1e3, 4e3, 1.6e4, 6.4e4])
    time2 = 0.8 * dofs ** -0.5                       # √: rate −1/4
    space2 = 0.2 * dofs ** -1.0                      # √: rate −1/2
    df = pd.DataFrame({"problem": "p", "family": "adaptive", "spacetime_dofs": dofs,
                       "error": dofs ** -0.4, "eta2_time": time2, "eta2_space": space2,
                       "eta2_contact": 1e-20, "eta2_initial": 0.0,
                       "eta": np.sqrt(time2 + space2), "reference_error": 0.0})
    row = algorithm_c_table(df).iloc[0]
    assert row["η_time rate (same runs)"] == pytest.approx(-0.25, abs=1e-12)
    assert row["η_space rate (same runs)"] == pytest.approx(-0.5, abs=1e-12)
    assert np.isnan(row["η_contact rate (same runs)"])
    assert np.isnan(row["η_initial rate (same runs)"])
    assert row["time share of η² (finest)"] == pytest.approx(time2[-1] / (time2[-1] + space2[-1]))
    assert row["error rate (fitted runs)"] == pytest.approx(-0.4, abs=1e-12)


def algorithm_c_run(tmp_path, reference_error):
    """Four passes of a made-up Algorithm C run, error ∝ N^(−0.3), η = 2·error, and its
    reference's measured error, as para_adaptive and para_reference_error write them."""
    n = np.array([565.0, 4650.0, 13855.0, 94075.0])
    error = 0.5 * (n / n[0]) ** -0.3
    runs = pd.DataFrame({"problem": "ex4-u1", "example": 4, "variant": "u1",
                         "family": "adaptive", "tag": [f"it{k}" for k in range(4)], "s": 0.5,
                         "dofs": [113, 465, 1153, 5409], "slabs": [1, 2, 3, 7],
                         "steps": [5, 10, 15, 35], "spacetime_dofs": n, "error": error,
                         "eta": 2 * error, "eta2_time": 3 * error ** 2,
                         "eta2_space": error ** 2, "eta2_time_anorm": 2 * error ** 2,
                         "t_total": [1.0, 2.0, 4.0, 8.0], "t_wall": [1.0, 3.0, 7.0, 15.0],
                         # para_adaptive: all passes' measurements so far
                         "t_error_measurement": [5.0, 11.0, 18.0, 30.0],
                         "peak_mem_mb": 500.0})
    iterations, ref = tmp_path / "iterations.csv", tmp_path / "reference-error.csv"
    runs.sample(frac=1.0, random_state=1).to_csv(iterations, index=False)  # any row order
    pd.DataFrame([{"reference_spacetime_dofs": 10 ** 6, "reference_d12": 0.02,
                   "reference_d23": 0.01, "reference_ratio": 0.5,
                   "reference_error": reference_error}]).to_csv(ref, index=False)
    return runs, iterations, ref


def test_algorithm_c_passes_are_judged_by_the_reference_alone(tmp_path, captured):
    """Pass by pass: efficiency η/error, the margin over the reference's own error, which
    passes a rate is fitted through (error > 3× it), local slopes of error and η, rates
    over the fitted passes only; the figure draws the passes outside the fit hollow, against
    space-time DOFs and against wall time."""
    passes = script("para_passes")
    runs, iterations, ref = algorithm_c_run(tmp_path, reference_error=0.07)
    d = passes.passes(iterations, ref)
    table = passes.pass_table(d)
    assert table["pass"].tolist() == [0, 1, 2, 3]
    np.testing.assert_allclose(table.efficiency, 2.0)
    np.testing.assert_allclose(table["error / reference_error"], runs.error / 0.07)
    assert table["in fit"].tolist() == ["yes", "yes", "no", "no"]     # 3 × 0.07 = 0.21
    assert table.t_error_pass.tolist() == [5.0, 6.0, 7.0, 12.0]
    np.testing.assert_allclose(table["local slope"].iloc[1:], -0.3)
    np.testing.assert_allclose(table["local slope η"].iloc[1:], -0.3)
    rates = passes.algorithm_c_table(d).iloc[0]
    assert rates["fitted"] == 2 and rates["error rate (fitted runs)"] == pytest.approx(-0.3)
    figures, keep = captured
    passes.save = keep
    md = tmp_path / "out" / "ex4-u1-algorithm-c.md"
    md.parent.mkdir()
    passes.main(iterations, ref, md, tmp_path / "out" / "fig.png")
    text = md.read_text()
    assert "own error 0.07 " in text
    assert [r["in fit"] for r in page_tables(text)[0]] == ["yes", "yes", "no", "no"]
    (fig,) = figures
    left, right = fig.axes[:2]
    # the legend of Figures 13 and 15: the error's rate over the fitted passes and the
    # paper's, η's and η_a's over all passes
    labels = left.get_legend_handles_labels()[1]
    assert labels[0] == "adaptive: -0.300 (paper -0.319)"
    assert labels[1] == r"estimator $\eta$ (adaptive): -0.300"
    assert labels[2] == r"$\eta$ with its time term in the energy norm: -0.300"
    hollow = [ln for ln in left.lines if ln.get_gid() == plotstyle.LEFT_OUT]
    assert len(hollow) == 1 and hollow[0].get_xdata().tolist() == runs.spacetime_dofs[2:].tolist()
    assert right.lines[0].get_xdata().tolist() == runs.t_wall.tolist()
    (hollow,) = [ln for ln in right.lines if ln.get_gid() == plotstyle.LEFT_OUT]
    assert hollow.get_xdata().tolist() == runs.t_wall[2:].tolist()


def test_algorithm_c_passes_are_judged_by_their_own_uncertainty(tmp_path):
    """Errors extrapolated to the limit of the reference's family: each pass enters a fit
    by its own measured uncertainty, and by the reference run's error where none is
    measured (report.with_fit_bound); the page says which error it shows."""
    passes = script("para_passes")
    runs, iterations, ref = algorithm_c_run(tmp_path, reference_error=0.07)
    runs = runs.assign(error_uncertainty=[0.01, 0.2, 0.01, np.nan],
                       error_vs_reference=0.9 * runs.error)
    runs.to_csv(iterations, index=False)
    d = passes.passes(iterations, ref)
    np.testing.assert_allclose(d.reference_error, [0.01, 0.2, 0.01, 0.07])
    assert (d.reference_run_error == 0.07).all()
    table = passes.pass_table(d)
    # errors 0.5, 0.266, 0.190, 0.106 against 3× 0.01, 0.2, 0.01, 0.07
    assert table["in fit"].tolist() == ["yes", "no", "yes", "no"]
    np.testing.assert_allclose(table.error_vs_reference, 0.9 * runs.error)
    assert passes.algorithm_c_table(d).iloc[0]["fitted"] == 2
    text = passes.page(d)
    assert "its measured uncertainty" in text and "own error 0.07 " in text


def test_algorithm_c_pass_times_past_ten_thousand_seconds_print_in_full(tmp_path):
    """A paper-scale pass: its wall time and memory past 10^4 print as 10310.4 s and
    17040 MB, its space-time DOFs whole, not in exponent form; the other columns keep four
    significant digits."""
    passes = script("para_passes")
    runs, iterations, ref = algorithm_c_run(tmp_path, reference_error=0.01)
    runs.assign(t_wall=[1.0, 3.0, 7.0, 10310.44], peak_mem_mb=[500.0, 500.0, 500.0, 17040.3],
                eta=[2.0, 1.0, 0.5, 0.123456]).to_csv(iterations, index=False)
    text = passes.page(passes.passes(iterations, ref))
    table = page_tables(text)[0]
    last = table[3]
    assert last["t_wall"] == "10310.4"
    assert last["peak_mem_mb"] == "17040"
    assert last["eta"] == "0.1235"
    assert last["spacetime_dofs"] == "94075"
    assert not any("e+0" in cell for row in table for cell in [*row, *row.values()])


def test_reference_table_prints_the_large_series_size_time_and_memory_in_full():
    """A large Algorithm B series of 300,161 DOFs that took 12,345.6 s and 20,350.4 MB prints
    as 300161, 12346 and 20350, not as 3.002e+05, 1.235e+04 and 2.035e+04; a row without a
    large series leaves those cells blank or nan, and the energies keep four significant
    digits."""
    ref = script("reference_table")
    table = pd.DataFrame([
        {"problem": "ex1 (s=0.5)", "E_ref": -0.666667, "large DOFs": np.nan,
         "large time [s]": np.nan, "large peak MB": np.nan, "families": np.nan},
        {"problem": "ex2", "E_ref": -0.632812, "large DOFs": 300161.0,
         "large time [s]": 12345.6, "large peak MB": 20350.4, "families": 4.0}])
    ex1, ex2 = page_tables(ref.reference_table_markdown(table))[0]
    assert (ex2["large DOFs"], ex2["large time [s]"], ex2["large peak MB"]) == \
        ("300161", "12346", "20350")
    assert ex2["families"] == "4" and ex2["E_ref"] == "-0.6328"
    assert ex1["large DOFs"] == "" and ex1["large peak MB"] == "nan"
    with pytest.raises(ValueError, match="'large DOFs'"):
        ref.reference_table_markdown(table.assign(**{"large DOFs": [np.nan, 300161.5]}))


def test_algorithm_c_passes_refuse_another_table(tmp_path):
    passes = script("para_passes")
    runs, iterations, ref = algorithm_c_run(tmp_path, reference_error=0.05)
    for other in (runs.assign(family="uniform"), runs.drop(columns="spacetime_dofs"),
                  runs.drop(columns="family"), runs.iloc[:0]):
        other.to_csv(iterations, index=False)
        with pytest.raises(ValueError, match="not a table of Algorithm C's passes"):
            passes.passes(iterations, ref)


def test_larger_tier_reference_rows_are_named_by_their_file(tmp_path):
    """The finer references committed by a larger tier: one row per file, its problem
    read off the file name, the columns those of this tier's reference table."""
    summary = script("parabolic_summary")
    rows = {"reference_operator": "compressed", "reference_dofs": 113312,
            "reference_steps": 270, "reference_spacetime_dofs": 30594240,
            "reference_t_wall": 2429.0, "reference_peak_mem_mb": 2497.0, "reference_d12": 0.065,
            "reference_d23": 0.040, "reference_ratio": 0.62, "reference_error": 0.066}
    paths = []
    for problem, scale in (("ex4-u1", 1.0), ("ex4-u2", 2.0)):
        path = tmp_path / f"{problem}-reference-error.csv"
        pd.DataFrame([{**rows, "reference_error": 0.066 * scale}]).to_csv(path, index=False)
        paths.append(path)
    table = summary.larger_reference_table(paths)
    assert list(table.problem) == ["ex4-u1", "ex4-u2"]
    assert list(table.columns) == ["problem", *summary.REFERENCE_COLUMNS.values()]
    assert table.reference_error.tolist() == pytest.approx([0.066, 0.132])


def test_passes_against_a_larger_reference_are_shown_only_for_the_same_passes(tmp_path):
    """Each pass's error and local slope against both references, side by side; a
    committed table of other passes (another tag or size) is left out."""
    summary = script("parabolic_summary")
    n = np.array([565.0, 4650.0, 13855.0])
    ours = pd.DataFrame({"problem": "ex4-u1", "family": "adaptive", "tag": ["it0", "it1", "it2"],
                         "spacetime_dofs": n, "error": 0.5 * (n / n[0]) ** -0.3})
    df = pd.concat([ours, ours.assign(family="uniform", tag=["L2", "L3", "L4"])])
    same = tmp_path / "ex4-u1-coarser-tier-errors.csv"
    df.assign(error=df.error * 1.05).to_csv(same, index=False)
    table = summary.larger_reference_passes(df, [same])
    assert table["pass"].tolist() == [0, 1, 2]
    np.testing.assert_allclose(table["error (larger reference)"], 1.05 * ours.error)
    np.testing.assert_allclose(table["local slope"].iloc[1:], -0.3)
    np.testing.assert_allclose(table["local slope (larger reference)"].iloc[1:], -0.3)
    assert np.isnan(table["local slope"].iloc[0])
    other = tmp_path / "other" / "ex4-u1-coarser-tier-errors.csv"
    other.parent.mkdir()
    df.assign(spacetime_dofs=df.spacetime_dofs + 1).to_csv(other, index=False)
    assert summary.larger_reference_passes(df, [other]).empty


def test_time_split_page_fits_each_refinement_through_the_passes_above_the_margin():
    """Errors √(S² + (T/m)²) with a space part S ∝ N^(−0.2) and a time part T ∝ N^(−0.5):
    the page fits each m over the passes above 3× the reference's error, against the
    pass's own space-time DOFs, and reports the share of e² removed by τ/16."""
    split = script("para_time_split")
    N = np.array([1e3, 4e3, 1.6e4, 6.4e4])
    rows = []
    for p, n in enumerate(N):
        S, T = 0.1 * (n / 1e3) ** -0.2, 0.3 * (n / 1e3) ** -0.5
        for m in (1, 4, 16):
            rows.append({"pass": p, "m": m, "spacetime_dofs": n * m, "steps": 10 * m,
                         "dofs": 100, "error": np.hypot(S, T / m)})
    df = pd.DataFrame(rows)
    ref_error = df[(df["pass"] == 3) & (df.m == 16)].error.iloc[0] / 2.9   # pass 3 of τ/16 out
    page = split.report(df, ref_error, [1, 4, 16], paper=-0.323)
    fits, rows = page_tables(page)
    fits = {r["time steps"]: r for r in fits}
    e = {m: df[df.m == m].error.to_numpy() for m in (1, 4, 16)}
    keep = {m: e[m] > 3 * ref_error for m in (1, 4, 16)}
    assert keep[1].tolist() == [True] * 4 and keep[16].tolist() == [True, True, True, False]
    for m, label in ((1, "as the pass"), (4, "4× (τ/4)"), (16, "16× (τ/16)")):
        assert fits[label]["fitted passes"] == ", ".join(str(p) for p in np.flatnonzero(keep[m]))
        slope = np.polyfit(np.log(N[keep[m]]), np.log(e[m][keep[m]]), 1)[0]
        assert float(fits[label]["rate"]) == pytest.approx(slope, abs=5e-4)
    for p, row in enumerate(rows):
        assert int(row["spacetime_dofs"]) == N[p]
        assert float(row["error (τ/4)"]) == pytest.approx(e[4][p], rel=1e-3)
        assert float(row["error (τ/16)"]) == pytest.approx(e[16][p], rel=1e-3)
        assert float(row["1 − (e(τ/16)/e)²"]) == pytest.approx(1 - (e[16][p] / e[1][p]) ** 2,
                                                              rel=1e-3)
        if p:
            assert float(row["local slope (τ/16)"]) == pytest.approx(
                np.log(e[16][p] / e[16][p - 1]) / np.log(N[p] / N[p - 1]), rel=1e-3)
    assert "-0.323" in page and "1 − (e(τ/16)/e)²" in page


def test_ex5_uniform_cause_solves_the_uniform_runs_again_with_more_time_steps(tmp_path):
    """The τ/m case: Example 5's uniform runs on the same meshes with m× the steps (τ/m of
    the series' own τ, not of the family's), measured against Example 5's own family (not
    that of the change solved after it), its share of e² in a table of its own; a bad m is
    refused before any solve."""
    cause = script("ex5_uniform_cause")
    args = dict(data={"s": 0.6, "F": 0.1, "r0": 0.6}, changes={"u₀ = 1": {"u0": 1.0}},
                T=1.0, grading=2.0,
                uniform_levels=[2, 3], uniform_tau_factor=1.0, family_h=[0.4, 0.2, 0.1],
                reference_tau_factor=0.5, tol=1e-10, quadrature={},
                md=tmp_path / "page.md", csv=tmp_path / "runs.csv")
    for bad in ([1], [3, 3], [65]):
        with pytest.raises(ValueError, match=r"time_refinements.*\[2, 64\]"):
            cause.main(**args, time_refinements=bad)
    assert not (tmp_path / "page.md").exists()
    cause.main(**args, time_refinements=[3])
    df = pd.read_csv(tmp_path / "runs.csv")
    assert sorted(set(df.case)) == ["Example 5", "Example 5, τ/3", "u₀ = 1"]
    own, fine, other = (df[df.case == c].set_index("tag")
                        for c in ("Example 5", "Example 5, τ/3", "u₀ = 1"))
    # the same meshes, about three times the steps (τ/3 of the series', not of the
    # family's τ, which is half of it), the same family (its finest run's own error)
    ratio = fine.spacetime_dofs / own.spacetime_dofs
    assert ((ratio > 2.4) & (ratio < 3.6)).all()
    assert (fine.reference_run_error == own.reference_run_error).all()
    assert (fine.reference_run_error != other.reference_run_error).all()
    assert (fine.error < own.error).all()             # the time error shrinks
    text = (tmp_path / "page.md").read_text()
    assert text.count("| h0.1 ") == 2                # Example 5's family and u₀ = 1's
    share = 1 - (fine.error / own.error) ** 2
    (shares,) = [t for t in page_tables(text) if t and "least share" in t[0]]
    for tag in ("L2", "L3"):
        (row,) = [r for r in shares if r["tag"] == tag and r["m"] == "3"]
        assert float(row["1 − (e(τ/m)/e)²"]) == pytest.approx(share[tag], rel=1e-3)
        assert row["least share"] == "nan"     # a family of three measures no uncertainty


def test_ex5_uniform_share_table_bounds_the_share_by_the_uncertainties():
    """least share: 1 − ((e_m + u_m)/(e − u))², below the share; −inf once e − u ≤ 0 or
    u_m is infinite, nan without a measured uncertainty; rows follow the tags asked for."""
    cause = script("ex5_uniform_cause")
    df = pd.DataFrame({
        "case": ["Example 5"] * 4 + ["Example 5, τ/4"] * 4 + ["u₀ = 1"] * 4,
        "tag": ["L2", "L3", "L4", "L5"] * 3,
        "error": [0.04, 0.02, 0.01, 0.005, 0.02, 0.008, 0.004, 0.001, 0.5, 0.4, 0.3, 0.2],
        "error_uncertainty": [0.004, 0.02, np.nan, 0.001, 0.002, 0.001, 0.001, np.inf,
                              0.1, 0.1, 0.1, 0.1]})
    t = cause.share_table(df, ["L3", "L2", "L4", "L5"], 4).set_index("tag")
    assert list(t.index) == ["L3", "L2", "L4", "L5"] and (t.m == 4).all()
    assert t.loc["L5", "least share"] == -np.inf          # the finer error unbounded
    assert t.loc["L2", "1 − (e(τ/m)/e)²"] == pytest.approx(1 - (0.02 / 0.04) ** 2)
    assert t.loc["L2", "least share"] == pytest.approx(1 - (0.022 / 0.036) ** 2)
    assert t.loc["L2", "least share"] < t.loc["L2", "1 − (e(τ/m)/e)²"]
    assert t.loc["L3", "least share"] == -np.inf          # e − u = 0
    assert np.isnan(t.loc["L4", "least share"])           # e's uncertainty not measured


def _algorithm_b_steps(dofs, errors, theta=0.5, start_level=2):
    """A made-up Algorithm B table of Example 1 as ex1_adaptive writes it."""
    errors = np.asarray(errors, dtype=float)
    return pd.DataFrame({"s": 0.5, "dofs": dofs, "error": errors, "eta": 0.9 * errors,
                         "efficiency": 0.9, "marked": 7, "innermost marked radius": 0.9,
                         "theta": theta, "start_level": start_level,
                         "marking": "maximum", "operator": "auto", "quadrature_edge": 8})


def _distance_rows(case, dofs, energies, distances, dips, theta=0.5, start_level=2,
                   reference=(3, 6400, -1.0 + 0.05 ** 2 / 2)):
    """Made-up rows of vi_adaptive_distances for one series."""
    step, ref_dofs, ref_energy = reference
    return pd.DataFrame({"case": case, "theta": theta, "start_level": start_level,
                         "step": np.arange(len(dofs)), "dofs": dofs, "energy": energies,
                         "eta": 0.5 * np.asarray(distances), "distance": distances,
                         "dip": dips, "reference_step": step, "reference_dofs": ref_dofs,
                         "reference_step_energy": ref_energy})


def test_ex2_adaptive_rate_fits_each_measure_above_its_own_reference_error(tmp_path,
                                                                         monkeypatch,
                                                                         captured):
    """Energy error √(2|E − E_ref|) fitted above 3× E_ref's uncertainty and not below
    E_ref; the distance above 3× u_ref's own error (its energy error plus that
    uncertainty), never at u_ref itself; each series cut at max_dofs."""
    page = script("ex2_adaptive_rate")
    e_ref, unc = -1.0, 0.002
    # unchanged: energy error 0.4 (N/100)^(-1/2), distance the same; u_ref = step 3
    dofs = np.array([100, 400, 1600, 6400])
    err = 0.4 * (dofs / 100.0) ** -0.5
    base = _distance_rows("as configured", dofs, e_ref + err ** 2 / 2,
                          np.r_[err[:3], 0.0], [0.01, 0.0, 0.0, 0.0])
    # a coarse start: its energies below E_ref at step 1, distances falling as N^(-1/4)
    d = 0.6 * (np.array([25, 100, 400, 1600]) / 25.0) ** -0.25
    coarse = _distance_rows("start_level = 1", [25, 100, 400, 1600],
                            [e_ref + 0.05, e_ref - 0.01, e_ref + 0.01, e_ref + 0.005], d,
                            [0.3, 0.3, 0.2, 0.01], start_level=1)
    rows = pd.concat([base, coarse], ignore_index=True)
    steps, r_ref = page.step_table(rows, e_ref, unc)
    assert r_ref == pytest.approx(0.05 + unc)          # u_ref's energy error + E_ref's
    s = steps.set_index(["case", "step"])
    assert not s.loc[("start_level = 1", 1), "error fitted"]        # below E_ref
    assert s.loc[("start_level = 1", 1), "below E_ref"]
    assert not s.loc[("as configured", 3), "distance fitted"]       # u_ref itself
    assert list(steps.u_ref) == [False, False, False, True] + [False] * 4
    # 3 r_ref = 0.156: the unchanged distances 0.4 and 0.2 above it, 0.1 not
    assert list(s.loc["as configured", "distance fitted"]) == [True, True, False, False]
    summary = page.summary_table(steps, max_dofs=1000).set_index("case")
    assert list(summary["last dofs"]) == [1600, 1600]
    assert summary.loc["as configured", "rate (energy error)"] == pytest.approx(-0.5)
    assert summary.loc["as configured", "rate (distance to u_ref)"] == pytest.approx(-0.5)
    assert summary.loc["as configured", "fitted (distance to u_ref)"] == 2
    assert summary.loc["start_level = 1", "rate (distance to u_ref)"] == pytest.approx(-0.25)
    assert summary.loc["start_level = 1", "steps below E_ref"] == 1
    # both fitted: the coarse start's steps 0, 2, 3 (step 1 lies below E_ref)
    assert summary.loc["start_level = 1", "both fitted"] == 3
    assert summary.loc["start_level = 1", "rate (distance, both fitted)"] == pytest.approx(
        np.polyfit(np.log([25, 400, 1600]), np.log(d[[0, 2, 3]]), 1)[0])
    assert summary.loc["as configured", "rate (energy error, both fitted)"] == pytest.approx(
        -0.5)
    # distance² + e(u_ref)² against the energy error²: 1 + (e(u_ref)/error)² here, where
    # the made-up distances equal the energy errors
    p = s[page.PYTHAGORAS]["as configured"].to_numpy()[:3]
    np.testing.assert_allclose(p, np.sqrt(1 + (0.05 / err[:3]) ** 2))
    # u_ref inside the unchanged series' cut (the default tier): its step is not fitted
    inside = page.summary_table(steps[steps.case == "as configured"], max_dofs=6400)
    inside = inside.set_index("case")
    assert inside.loc["as configured", "last dofs"] == 6400
    assert inside.loc["as configured", "fitted (distance to u_ref)"] == 2
    assert inside.loc["as configured", "rate (energy error)"] == pytest.approx(-0.5)
    assert summary.loc["start_level = 1", "largest dip"] == pytest.approx(0.3)
    assert summary.loc["start_level = 1", "smallest η / distance"] == pytest.approx(0.5)
    with pytest.raises(ValueError, match="against 2 references"):
        page.step_table(rows.assign(reference_step_energy=[-1.0] * 4 + [-0.9] * 4), e_ref,
                        unc)
    # the page: both tables, the unchanged series' reference step left out
    rows.to_csv(tmp_path / "d.csv", index=False)
    pd.DataFrame({"s": [0.5], "reference_energy": [e_ref], "reference_error": [unc]}).to_csv(
        tmp_path / "errors.csv", index=False)
    page.main(tmp_path / "d.csv", tmp_path / "errors.csv", 1000, tmp_path / "p.md",
              tmp_path / "p.png", series_max_dofs=1000)
    text = (tmp_path / "p.md").read_text()
    assert "as the rate table's series" in text
    assert "-0.363" in text and "start_level = 1" in text and (tmp_path / "p.png").exists()
    assert "| as configured   |      3 |" not in text
    # u_ref inside the cut: the figure's energy-error line runs through u_ref's step, as the
    # rate table's series does, so its legend gives the page's rate; its distance line not
    figs, keep = captured
    monkeypatch.setattr(page, "save", keep)
    base.to_csv(tmp_path / "d2.csv", index=False)
    page.main(tmp_path / "d2.csv", tmp_path / "errors.csv", 6400, tmp_path / "q.md",
              tmp_path / "q.png", series_max_dofs=6400)
    (dist_ax, err_ax) = figs[0].axes[:2]
    summary = page.summary_table(page.step_table(base, e_ref, unc)[0], 6400).set_index("case")
    for ax, col in [(dist_ax, "rate (distance to u_ref)"), (err_ax, "rate (energy error)")]:
        label = next(t for t in ax.get_legend_handles_labels()[1]
                     if t.startswith("as configured"))
        assert label.endswith(f": {summary.loc['as configured', col]:.3f}")
    x = {ax: ax.get_lines()[0].get_xdata() for ax in (dist_ax, err_ax)}
    assert list(x[err_ax]) == [100, 400, 1600, 6400] and list(x[dist_ax]) == [100, 400, 1600]


def test_ex1_adaptive_rate_compares_series_cut_at_the_same_size(tmp_path):
    """Every series is cut after its first step with at least max_dofs DOFs; rate fitted
    through all steps kept; each step's error over the unchanged series' at its DOFs
    (log-log interpolation of the whole unchanged series, NaN beyond it); a table run with
    other settings is refused."""
    page = script("ex1_adaptive_rate")
    # the unchanged series: error 0.4 (N/25)^(-1/2)
    base = _algorithm_b_steps([25, 100, 400, 1600, 6400], [0.4, 0.2, 0.1, 0.05, 0.025])
    # a finer start: twice the unchanged series' error at its first step, on it afterwards
    finer = _algorithm_b_steps([400, 800, 1600, 3200, 6400],
                               [0.2, 0.1 / np.sqrt(2), 0.05, 0.05 / np.sqrt(2), 0.025],
                               start_level=4)
    # ends beyond the unchanged series' cut, within its steps: 10 % below it there
    lower = _algorithm_b_steps([25, 100, 400, 3200], [0.4, 0.2, 0.1, 0.9 * 0.4 / np.sqrt(128)],
                               theta=0.75)
    summary, steps = page.change_tables({"as configured": base, "start_level = 4": finer,
                                         "theta = 0.75": lower}, max_dofs=1000)
    summary = summary.set_index("case")
    assert list(summary["last dofs"]) == [1600, 1600, 3200]   # the first ≥ 1000
    assert summary.loc["as configured", "rate"] == pytest.approx(-0.5)
    # through (400, 0.2), (800, 0.2/√8), (1600, 0.05): slopes −1.5 and −0.5, fitted −1
    assert summary.loc["start_level = 4", "rate"] == pytest.approx(-1.0)
    ratio = steps.set_index(["case", "step"])["error / unchanged at the same DOFs"]
    assert ratio["start_level = 4"].to_numpy() == pytest.approx([2.0, 1.0, 1.0])
    assert ratio["theta = 0.75", 3] == pytest.approx(0.9)   # beyond the unchanged cut
    slope = steps.set_index(["case", "step"])["local slope"]
    assert np.isnan(slope["start_level = 4", 0]) and np.isnan(slope["theta = 0.75", 0])
    assert slope["start_level = 4", 1] == pytest.approx(-1.5)
    # beyond the unchanged series' last step: no comparison
    longer = _algorithm_b_steps([25, 100, 400, 1600, 12800], [0.4, 0.2, 0.1, 0.05, 0.01])
    _, steps = page.change_tables({"as configured": base, "theta = 0.25": longer}, 5000)
    r = steps[steps.case == "theta = 0.25"]["error / unchanged at the same DOFs"].to_numpy()
    assert np.isnan(r[-1]) and np.isfinite(r[:-1]).all()
    with pytest.raises(ValueError, match="max_dofs=10000 is beyond the series"):
        page.change_tables({"as configured": base}, max_dofs=10000)
    with pytest.raises(ValueError, match="reached by the start mesh of the series "
                                         "'start_level = 4'"):
        page.change_tables({"as configured": base, "start_level = 4": finer}, max_dofs=300)
    # the change's table must hold the unchanged series' settings but the changed one
    base.to_csv(tmp_path / "base.csv", index=False)
    finer.assign(quadrature_edge=6).to_csv(tmp_path / "finer.csv", index=False)
    with pytest.raises(ValueError, match="quadrature_edge = 8"):
        page.main(tmp_path / "base.csv", [tmp_path / "finer.csv"],
                  {"start_level = 4": {"start_level": 4}}, 1000, tmp_path / "p.md",
                  tmp_path / "p.png")
    assert not (tmp_path / "p.md").exists()
    finer.to_csv(tmp_path / "finer.csv", index=False)
    page.main(tmp_path / "base.csv", [tmp_path / "finer.csv"],
              {"start_level = 4": {"start_level": 4}}, 1000, tmp_path / "p.md",
              tmp_path / "p.png")
    text = (tmp_path / "p.md").read_text()
    assert "-0.510" in text and "start_level = 4" in text and (tmp_path / "p.png").exists()


def test_time_split_page_adds_the_graded_series_in_the_order_of_its_dofs():
    """The graded runs (tags whose alphabetical order is not their size's) get their own
    rates per m, fitted against each run's own space-time DOFs in order of size, and the
    share of e² removed by τ/16; each run's own uncertainty bounds its fit."""
    split = script("para_time_split")
    passes = pd.DataFrame([{"pass": p, "m": m, "spacetime_dofs": 1e3 * 4 ** p * m,
                            "steps": 5 * m, "dofs": 100, "error": 0.5 * 4.0 ** (-0.25 * p),
                            "reference_error": 0.01} for p in range(3) for m in (1, 4, 16)])
    N = {"h0.4": 1e3, "h0.2": 4e3, "h0.1": 3e4}
    rows = []
    for tag, n in N.items():
        S, T = 0.2 * (n / 1e3) ** -0.4, 0.3 * (n / 1e3) ** -0.1   # a slow time part
        for m in (1, 4, 16):
            rows.append({"tag": tag, "m": m, "tau_factor": 0.5, "spacetime_dofs": n * m,
                         "steps": 8 * m, "dofs": 132, "error": np.hypot(S, T / m),
                         "reference_error": 0.03 if tag == "h0.1" and m == 16 else 1e-3})
    graded = pd.DataFrame(rows)
    page = split.report(passes, None, [1, 4, 16], graded=graded, paper_graded=-0.325)
    tables = page_tables(page)
    assert len(tables) == 4 and "-0.325" in page
    fits, runs = tables[2:]
    fits = {r["time steps"]: r for r in fits}
    assert [r["tag"] for r in runs] == ["h0.4", "h0.2", "h0.1"]
    n = np.array(list(N.values()))
    for m, label in ((1, "as the run"), (16, "16× (τ/16)")):
        e = graded[graded.m == m].error.to_numpy()
        keep = e > 3 * graded[graded.m == m].reference_error.to_numpy()
        assert fits[label]["fitted tag"] == ", ".join(np.array(list(N))[keep])
        slope = np.polyfit(np.log(n[keep]), np.log(e[keep]), 1)[0]
        assert float(fits[label]["rate"]) == pytest.approx(slope, abs=5e-4)
    assert fits["16× (τ/16)"]["fitted tag"] == "h0.4, h0.2"       # h0.1 within 3× its bound
    assert float(fits["16× (τ/16)"]["rate"]) < float(fits["as the run"]["rate"]) - 0.1
    e1, e16 = (graded[(graded.tag == "h0.1") & (graded.m == m)].error.iloc[0] for m in (1, 16))
    assert float(runs[2]["1 − (e(τ/16)/e)²"]) == pytest.approx(1 - (e16 / e1) ** 2, rel=1e-3)


def test_rate_explanations_cite_only_the_time_split_tables_made():
    """The rate table explains a parabolic adaptive row by its time-split table only where
    parabolic.time_split.problems makes that table; otherwise by the reference alone."""
    rates = script("rates")
    rows = pd.DataFrame({"example": [4, 4, 5], "variant": ["u1", "u2", ""],
                         "family": ["adaptive"] * 3, "rate": [-0.15, -0.15, -0.49],
                         "paper_rate": [-0.319, -0.319, -0.323], "n_points": [2, 2, 4],
                         "n_excluded": [0, 0, 0], "rate_min": [-0.2, -0.35, -0.5],
                         "rate_max": [-0.1, -0.1, -0.4], "reference_error": [0.01, 0.01, 0]})
    made = rates.differences(rows, time_split=["ex4-u2", "ex5"])
    assert "time-split" not in made[0] and rates.REF_PARA in made[0]
    # whether the reference's own error can make the difference (rate_min … rate_max)
    assert "rates from -0.200 to -0.100; the paper's rate lies outside it" in made[0]
    assert "rates from -0.350 to -0.100; the paper's rate lies inside" in made[1]
    assert "Moving each" not in made[2]                  # an exact reference: no range
    assert "`ex4-u2-time-split.md`" in made[1] and "ex4-u1" not in made[1]
    assert "`ex5-time-split.md`" in made[2]
    assert not any("time-split" in line for line in rates.differences(rows))
    graded = rows.assign(family="graded", paper_rate=[-0.325, -0.325, -0.322])
    made = rates.differences(graded, time_split=["ex4-u2", "ex5"])
    assert "not explained yet" in made[0]
    assert "`ex4-u2-time-split.md` solves each graded run again" in made[1]
    assert "`ex5-time-split.md` solves each graded run again" in made[2]


def test_rate_explanations_name_a_run_sharing_a_mesh_with_the_reference_family():
    """A run left out because it shares its space mesh with a member of the reference's
    family (no measured uncertainty: held to the reference run's error) is named as such,
    not as a reference too coarse; a run left out within 3× its measured uncertainty, a
    run whose error is not finite, and a family that measures no uncertainty at all are
    not counted so. Example 5 has no variant (NaN in its tables)."""
    from fracfem_workflow.report import rate_table, with_fit_bound
    rates = script("rates")

    def table(variant, error, unc):
        return with_fit_bound(pd.DataFrame({
            "example": 4 if variant == "u2" else 5, "variant": variant, "family": "graded",
            "s": 0.5 if variant == "u2" else 0.6, "tag": ["h0.4", "h0.2", "h0.1", "h0.05"],
            "dofs": [1e3, 4e3, 3e4, 2e5], "error": error, "error_uncertainty": unc,
            "reference_error": 0.14}))

    runs = pd.concat([table("u2", [0.8, 0.6, 0.4, 0.1], [0.03, 0.035, np.nan, 0.05]),
                      table(np.nan, [0.8, 0.6, 0.4, 0.3], [0.03, 0.035, np.nan, 0.05])],
                     ignore_index=True)
    assert rates.unmeasured_exclusions(runs) == {(4, "u2", "graded", 0.5): 1,
                                                 (5, "", "graded", 0.6): 1}
    assert rates.unmeasured_exclusions(runs.assign(error=runs.error.where(
        runs.error_uncertainty.notna()))) == {}                   # e² ≤ 0: not finite
    three = with_fit_bound(runs.assign(error_uncertainty=np.nan).drop(
        columns="reference_error").rename(columns={"reference_run_error": "reference_error"}))
    assert rates.unmeasured_exclusions(three) == {}                # a family of three
    made = rates.differences(rate_table(runs), unmeasured=rates.unmeasured_exclusions(runs))
    (ex4,) = [m for m in made if m.startswith("- Example 4")]
    (ex5,) = [m for m in made if m.startswith("- Example 5")]
    assert "1 of its 4 runs shares its space mesh with a member of the reference's" in ex4
    assert "as is 1 more within 3× its measured uncertainty" in ex4
    assert "rests on 2" in ex4
    assert "1 of its 4 runs shares its space mesh" in ex5 and "more within" not in ex5
    plain = rates.differences(rate_table(runs))
    assert not any("space mesh" in m for m in plain)
    assert all("a finer reference is needed" in m for m in plain)


def test_pipeline_cost_sums_the_jobs_of_all_and_reads_gnu_time(tmp_path):
    """The cost table's total counts only the jobs of `all` (not a benchmark outside it, not
    a file left by an earlier configuration); the wall time and peak memory come from
    /usr/bin/time -v's own lines, in either of its formats."""
    cost = script("pipeline_cost")
    bench = tmp_path / "results" / "benchmarks"
    for rel, s, rss in [("ex1/a.tsv", 30.0, 100.0), ("para/b.tsv", 90.0, 300.0),
                        ("stability.tsv", 1000.0, 5000.0), ("ex1/old.tsv", 475.0, 4000.0)]:
        (bench / rel).parent.mkdir(parents=True, exist_ok=True)
        (bench / rel).write_text(f"s\tmax_rss\tcpu_time\n{s}\t{rss}\t{0.8 * s}\n")
    log = tmp_path / "time.log"
    log.write_text("\tCommand being timed: \"snakemake --cores 2\"\n"
                   "\tElapsed (wall clock) time (h:mm:ss or m:ss): 1:02:03\n"
                   "\tMaximum resident set size (kbytes): 2097152\n")
    assert cost.gnu_time(log) == (3723.0, 2048.0)
    cost.main(tmp_path / "results", tmp_path, log, in_all={"ex1/a.tsv", "para/b.tsv"})
    text = (tmp_path / "pipeline-cost.md").read_text()
    assert "1 h 02 min 03 s wall time" in text and "2.00 GiB" in text
    assert cost._hms(3439.4) == "57 min 19 s"      # no "0 h" under an hour
    assert "sum to 2 minutes" in text
    assert re.search(r"total of `all`\s+\|\s+2 \|\s+120\.0 \|\s+96\.0 \|\s+300\.0", text)
    assert "1 thread per job" in text        # config.yaml's job_threads
    assert re.search(r"not in `all`\s+\|\s+2 \|\s+1475\.0", text)
    log.write_text("\tElapsed (wall clock) time (h:mm:ss or m:ss): 2:03.45\n"
                   "\tMaximum resident set size (kbytes): 1024\n")
    assert cost.gnu_time(log) == pytest.approx((123.45, 1.0))
    log.write_text("not a time log\n")
    with pytest.raises(SystemExit, match="time -v"):
        cost.gnu_time(log)


class _TimeLimit(Exception):
    """Stands for the end of a job's allotted time."""


def _ends_after_pass(steps, n):
    """fracfem.algorithm_c_steps (``steps``) ended after pass n, as by a time limit."""
    def ended(*a, **k):
        for rec in steps(*a, **k):
            yield rec
            if rec.iteration == n:
                raise _TimeLimit
    return ended


def _small_algorithm_c_job(tmp_path):
    """(mesh, U, reference file, para_adaptive.main's arguments) of a three-pass Example 4
    (u₀ = 2) job measured against a reference of three random steps on disk_uniform(2)."""
    m = ff.disk_uniform(2)
    U = np.random.default_rng(1).standard_normal((3, m.p.shape[1]))
    ref = tmp_path / "ref.npz"
    np.savez(ref, p=m.p, t=m.t, times=np.array([0.0, 0.5, 1.0]), U=U, s=0.5)
    args = dict(problem="ex4-u2", example="ex4",
                data={"s": 0.5, "u0": 2.0, "height": 1.0, "slope": 4.0}, T=1.0, theta=0.5,
                start_level=1, c_tau=1.0, max_spacetime_dofs=10 ** 9, max_iterations=3,
                figure_iterations=[1], output_times=[0.0, 0.4, 1.0], tol=1e-10,
                quadrature={}, ref=str(ref), operator="dense")
    return m, U, ref, args


def test_algorithm_c_job_continues_from_its_checkpoint(tmp_path, monkeypatch, caplog):
    """para_adaptive ended after pass 1 (as by a time limit) and started again continues
    from its checkpoint: the table and arrays are those of the job run through (errors,
    η, DOFs to round-off), the continued pass is marked by `invocation`, and the
    checkpoint goes once the outputs are written; the log gives the size of the pass to
    come when a pass is saved and when the job continues.  A checkpoint of other
    settings is not continued."""
    para_adaptive = script("para_adaptive")
    m, U, ref, args = _small_algorithm_c_job(tmp_path)

    def outputs(d, **kw):
        d.mkdir()
        para_adaptive.main(**args, table=d / "it.csv", npz=d / "m.npz", **kw)
        return pd.read_csv(d / "it.csv"), dict(np.load(d / "m.npz"))

    caplog.set_level(logging.INFO)
    whole, whole_arrays = outputs(tmp_path / "whole")
    real = ff.algorithm_c_steps

    ends_after_pass_1 = _ends_after_pass(real, 1)
    ckpt = tmp_path / "cont" / "checkpoint.npz"

    def announced():
        return [r.getMessage() for r in caplog.records if " will have " in r.getMessage()]

    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass_1)
    caplog.clear()
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "cont", checkpoint=ckpt)
    assert ckpt.exists() and not (tmp_path / "cont" / "it.csv").exists()
    # each saved pass announces the next one with the size it then has
    assert [m.split(":")[0] for m in announced()] == [
        f"pass {k} will have {whole.spacetime_dofs[k]} space-time DOFs" for k in (1, 2)]
    monkeypatch.setattr(ff, "algorithm_c_steps", real)
    caplog.clear()
    cont, cont_arrays = outputs(tmp_path / "cont2", checkpoint=ckpt)
    assert not ckpt.exists()
    # the continued job announces the pass it continues with, once
    assert [m.split(":")[0] for m in announced()] == [
        f"pass 2 will have {whole.spacetime_dofs[2]} space-time DOFs"]
    assert cont.tag.tolist() == whole.tag.tolist() == ["it0", "it1", "it2"]
    assert cont.invocation.tolist() == [0, 0, 1] and whole.invocation.tolist() == [0, 0, 0]
    assert cont.spacetime_dofs.tolist() == whole.spacetime_dofs.tolist()
    np.testing.assert_allclose(cont.eta, whole.eta, rtol=1e-12)
    np.testing.assert_allclose(cont.error, whole.error, rtol=1e-10)
    assert sorted(cont_arrays) == sorted(whole_arrays)
    for k in ("iterations", "figure_iterations", "t_it2", "p_it1_1", "p_last_2"):
        np.testing.assert_array_equal(cont_arrays[k], whole_arrays[k], err_msg=k)
    np.testing.assert_allclose(cont_arrays["u"], whole_arrays["u"], rtol=0, atol=1e-12)
    # a checkpoint made with other settings is not continued
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass_1)
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "other", checkpoint=ckpt)
    monkeypatch.setattr(ff, "algorithm_c_steps", real)
    args["theta"] = 0.6
    again, _ = outputs(tmp_path / "other2", checkpoint=ckpt)
    assert again.invocation.tolist() == [0, 0, 0] and not ckpt.exists()
    # nor one holding a pass at which a run with a lower limit would have stopped
    args["theta"] = 0.5
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass_1)
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "limit", checkpoint=ckpt)
    monkeypatch.setattr(ff, "algorithm_c_steps", real)
    args["max_spacetime_dofs"] = int(whole.spacetime_dofs.iloc[1])
    short, _ = outputs(tmp_path / "limit2", checkpoint=ckpt)
    assert short.tag.tolist() == ["it0", "it1"] and short.invocation.tolist() == [0, 0]
    assert not ckpt.exists()
    # integers stay integers in the continued table (the saved rows are JSON)
    ints = [c for c in whole if whole[c].dtype.kind == "i"]
    assert {"dofs", "spacetime_dofs", "slabs", "steps"} <= set(ints)
    assert [c for c in ints if cont[c].dtype.kind != "i"] == []


def test_checkpoint_of_other_coarser_runs_says_why_they_can_differ(tmp_path):
    """A checkpoint whose family's coarser runs differ beyond round-off is not continued,
    and the reason says so; another setting gets no such remark."""
    para_adaptive = script("para_adaptive")
    key = para_adaptive.checkpoint_key(theta=0.5, coarser=["a", "b"])
    path = tmp_path / "c.npz"
    np.savez(path, checkpoint_key=np.array(key), checkpoint_iteration=np.array(2),
             checkpoint_rows=np.array('[{"spacetime_dofs": 10}]'))
    assert para_adaptive.why_not(path, key, 100, 5) == (2, None)
    _, why = para_adaptive.why_not(path, para_adaptive.checkpoint_key(
        theta=0.5, coarser=["a", "c"]), 100, 5)
    assert "['coarser']" in why and "beyond round-off" in why
    _, why = para_adaptive.why_not(path, para_adaptive.checkpoint_key(
        theta=0.6, coarser=["a", "b"]), 100, 5)
    assert "['theta']" in why and "round-off" not in why


def test_a_run_is_identified_up_to_round_off(tmp_path):
    """run_fingerprint/same_run: a run whose values moved by round-off (1e-14 relative) is
    the same run; one moved by 1e-7 of its norm in one entry, with two triangles swapped, with
    a NaN, with an array more or of another shape or value is another."""
    para_adaptive = script("para_adaptive")
    rng = np.random.default_rng(5)
    U = rng.standard_normal((3, 50))
    tri = np.arange(30).reshape(10, 3)

    def fp(name, **arrays):
        np.savez(tmp_path / name, **{"U": U, "t": tri, "s": 0.5, **arrays})
        return para_adaptive.run_fingerprint(tmp_path / name)

    base = fp("base.npz")
    assert para_adaptive.same_run(base, fp("again.npz"))
    assert para_adaptive.same_run(base, fp("roundoff.npz", U=U * (1 + 1e-14)))
    moved = U.copy()
    moved[1, 7] += 1e-7 * np.linalg.norm(U)
    t2 = tri.copy()
    t2[[0, 1]] = t2[[1, 0]]
    nan = U.copy()
    nan[2, 3] = np.nan
    for other in (fp("moved.npz", U=moved), fp("renumbered.npz", t=t2),
                  fp("nan.npz", U=nan), fp("more.npz", extra=np.zeros(2)),
                  fp("shape.npz", U=U.T), fp("s.npz", s=0.6)):
        assert not para_adaptive.same_run(base, other)
        assert not para_adaptive.same_run(other, base)
    # per-step solver records (an active set's size, iterations) may move by one
    assert para_adaptive.same_run(fp("steps1.npz", step_contact=np.array([3, 4])),
                                  fp("steps2.npz", step_contact=np.array([3, 5])))
    # an older key's SHA-256 of the bits: the same bits only
    assert para_adaptive.same_run(base["sha256"], fp("again2.npz"))
    assert para_adaptive.same_run(fp("again3.npz"), base["sha256"])
    assert not para_adaptive.same_run(base["sha256"], fp("roundoff3.npz", U=U * (1 + 1e-14)))
    # an array longer than one block of weights, moved in its last entry
    big = rng.standard_normal(2 ** 20 + 5)
    last = big.copy()
    last[-1] += 1e-7 * np.linalg.norm(big)
    assert para_adaptive.same_run(fp("big.npz", B=big), fp("big2.npz", B=big * (1 + 1e-14)))
    assert not para_adaptive.same_run(fp("big3.npz", B=big), fp("big4.npz", B=last))
    # a NaN where the other run has one too is the same run
    assert para_adaptive.same_run(fp("nan1.npz", U=nan), fp("nan2.npz", U=nan * (1 + 1e-14)))
    # the checkpoint's key: the coarser runs by same_run, in the family's order
    r = fp("roundoff2.npz", U=U * (1 - 1e-14))
    made = para_adaptive.checkpoint_key(theta=0.5, coarser=[base, fp("s2.npz", s=0.6)])
    assert para_adaptive.checkpoint_differences(made, para_adaptive.checkpoint_key(
        theta=0.5, coarser=[r, fp("s3.npz", s=0.6)])) == []
    assert para_adaptive.checkpoint_differences(made, para_adaptive.checkpoint_key(
        theta=0.5, coarser=[fp("s4.npz", s=0.6), r])) == ["coarser"]
    assert para_adaptive.checkpoint_differences(made, para_adaptive.checkpoint_key(
        theta=0.5, coarser=[r])) == ["coarser"]


def test_a_run_at_another_thread_count_is_the_same_run(tmp_path):
    """para_solve's run on one numba thread and on two: the checkpoint key's same_run takes
    them for one run (their floating arrays differ by round-off, far below RUN_RTOL; on the
    machine this was written on, their bits differ), a run with other time steps for
    another."""
    import numba

    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("numba has one thread here")
    para_adaptive, solve = script("para_adaptive"), script("para_solve")
    data, threads = {"s": 0.6, "F": 0.1, "r0": 0.6}, numba.get_num_threads()

    def run(name, n, tau_factor=0.5):
        solve.main("ex5", "reference", "L3", "ex5", data, 2.0, 0.2, tau_factor, 1e-10, {},
                   tmp_path / f"{name}.csv", tmp_path / f"{name}.npz", threads=n)
        return tmp_path / f"{name}.npz"

    try:
        one, two, other = run("one", 1), run("two", 2), run("other", 1, tau_factor=0.25)
    finally:
        numba.set_num_threads(threads)
    fp = {k: para_adaptive.run_fingerprint(v) for k, v in
          {"one": one, "two": two, "other": other}.items()}
    assert para_adaptive.same_run(fp["one"], fp["two"])
    assert not para_adaptive.same_run(fp["one"], fp["other"])
    with np.load(one) as a, np.load(two) as b:
        for k in a.files:
            if a[k].dtype.kind == "f" and np.linalg.norm(a[k]) > 0:
                diff = np.linalg.norm(a[k] - b[k]) / np.linalg.norm(a[k])
                assert diff < 1e-4 * para_adaptive.RUN_RTOL, (k, diff)
            elif not k.startswith("step_"):     # per-step solver records may move by one
                np.testing.assert_array_equal(a[k], b[k])


WORKFLOW_DATA = Path(__file__).parents[1] / "workflow" / "data"


def _committed_checkpoint(problem):
    """The key and next pass of the paper-scale tier's committed checkpoint of a problem."""
    path = WORKFLOW_DATA / "checkpoints" / "paper-scale" / f"{problem}-adaptive.npz"
    with np.load(path, allow_pickle=False) as d:
        return json.loads(str(d["checkpoint_key"])), int(d["checkpoint_iteration"])


def _committed_reference(para_adaptive, problem):
    """run_fingerprint of the paper-scale tier's committed reference of a problem."""
    return para_adaptive.run_fingerprint(WORKFLOW_DATA / "reference" / "paper-scale"
                                         / f"{problem}-parabolic.npz")


@pytest.mark.parametrize("problem, other, next_pass",
                         [("ex5", "ex4-u1", 10), ("ex4-u1", "ex5", 10),
                          ("ex4-u2", "ex4-u1", 10)])
def test_committed_checkpoint_key_is_a_fingerprint_of_its_reference(problem, other, next_pass):
    """The committed checkpoints of Examples 5 and 4 (u₀ = 1 and 2) hold the current key:
    run_fingerprint records of the reference and of the family's three coarser runs; the
    reference is the problem's committed one up to round-off (not the other problem's),
    and the next pass is the one they were kept before."""
    para_adaptive = script("para_adaptive")
    key, nxt = _committed_checkpoint(problem)
    assert isinstance(key["ref"], dict) and len(key["coarser"]) == 3
    assert all(isinstance(c, dict) and c["arrays"] for c in key["coarser"])
    assert para_adaptive.same_run(key["ref"], _committed_reference(para_adaptive, problem))
    assert not para_adaptive.same_run(key["ref"], _committed_reference(para_adaptive, other))
    assert nxt == next_pass


def test_algorithm_c_job_continues_from_a_committed_checkpoint(tmp_path, monkeypatch):
    """A checkpoint kept in the repository (keep_checkpoint: deflated, same slabs and
    records; an earlier one does not replace it) is where a job without one of its own
    starts; the run through it equals the run through from pass 0, and the committed file
    is only read.  One made with other settings, or not further on than the job's own
    checkpoint, is not used, and the job's own stays.  A reference is identified by its
    arrays up to round-off: the same arrays written again, compressed and moved by
    round-off, are the same run; moved by 1e-6 of their size, another."""
    para_adaptive = script("para_adaptive")
    m, U, ref, args = _small_algorithm_c_job(tmp_path)
    again = tmp_path / "ref-again.npz"
    np.savez_compressed(again, s=0.5, U=U * (1 + 1e-14), times=np.array([0.0, 0.5, 1.0]),
                        t=m.t, p=m.p)
    assert para_adaptive.same_run(para_adaptive.run_fingerprint(again),
                                  para_adaptive.run_fingerprint(ref))
    np.savez(tmp_path / "ref-other.npz", p=m.p, t=m.t, times=np.array([0.0, 0.5, 1.0]),
             U=U * (1 + 1e-6), s=0.5)
    assert not para_adaptive.same_run(para_adaptive.run_fingerprint(tmp_path / "ref-other.npz"),
                                      para_adaptive.run_fingerprint(ref))

    def outputs(d, **kw):
        d.mkdir()
        para_adaptive.main(**args, table=d / "it.csv", npz=d / "m.npz", **kw)
        return pd.read_csv(d / "it.csv")

    whole = outputs(tmp_path / "whole")
    real = ff.algorithm_c_steps

    def ends_after_pass(n):
        return _ends_after_pass(real, n)

    # an earlier allocation: passes 0 and 1, kept after each
    first = tmp_path / "alloc1" / "checkpoint.npz"
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass(0))
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "alloc1", checkpoint=first)
    assert para_adaptive.next_pass(first) == 1
    kept1 = tmp_path / "data" / "pass1.npz"
    para_adaptive.cli(["--keep", str(first), str(kept1)])
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass(1))
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "alloc1b", checkpoint=first)
    kept = tmp_path / "data" / "ex4-u2-adaptive.npz"
    para_adaptive.cli(["--keep", str(first), str(kept)])
    s1, a1 = ff.load_slabs(first)
    s2, a2 = ff.load_slabs(kept)
    assert [(x.a, x.b, x.n_steps, x.coarse.p.shape) for x in s1] == [
        (x.a, x.b, x.n_steps, x.coarse.p.shape) for x in s2]
    assert sorted(a1) == sorted(a2) and str(a1["checkpoint_key"]) == str(a2["checkpoint_key"])
    assert kept.stat().st_size < first.stat().st_size
    # a copy further on is not replaced by an earlier one without --force
    with pytest.raises(SystemExit):
        para_adaptive.cli(["--keep", str(tmp_path / "alloc1" / "none.npz"), str(kept)])
    shutil.copyfile(kept1, tmp_path / "pass1-job.npz")
    with pytest.raises(ValueError, match="continues with pass 2.*--force"):
        para_adaptive.keep_checkpoint(tmp_path / "pass1-job.npz", kept)
    digest = hashlib.sha256(kept.read_bytes()).hexdigest()
    # a fresh clone: no checkpoint of its own, the reference written again
    monkeypatch.setattr(ff, "algorithm_c_steps", real)
    args["ref"] = str(again)
    own = tmp_path / "alloc2" / "checkpoint.npz"
    cont = outputs(tmp_path / "alloc2", checkpoint=own, committed=kept)
    assert cont.invocation.tolist() == [0, 1, 2]
    assert cont.spacetime_dofs.tolist() == whole.spacetime_dofs.tolist()
    np.testing.assert_allclose(cont.eta, whole.eta, rtol=1e-12)
    np.testing.assert_allclose(cont.error, whole.error, rtol=1e-10)
    assert not own.exists() and hashlib.sha256(kept.read_bytes()).hexdigest() == digest
    # the job's own checkpoint at the same pass as the committed one, or further on, stays
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass(1))
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "a3", checkpoint=own)               # own: pass 2 next
    key = str(np.load(own)["checkpoint_key"])
    mtime = own.stat().st_mtime_ns
    for behind in (kept1, kept):                               # pass 1, pass 2 next
        assert not para_adaptive.seed_checkpoint(own, behind, key, 10 ** 9, 3)
    assert own.stat().st_mtime_ns == mtime
    own.unlink()
    # a committed checkpoint of other settings is not continued, and the job's own
    # checkpoint (behind it, but its own settings) is the one continued
    args["theta"] = 0.6
    monkeypatch.setattr(ff, "algorithm_c_steps", ends_after_pass(0))
    with pytest.raises(_TimeLimit):
        outputs(tmp_path / "a4", checkpoint=own)               # own: pass 1 next, θ = 0.6
    monkeypatch.setattr(ff, "algorithm_c_steps", real)
    other = outputs(tmp_path / "a4b", checkpoint=own, committed=kept)
    assert other.invocation.tolist() == [0, 1, 1] and not own.exists()
    assert hashlib.sha256(kept.read_bytes()).hexdigest() == digest
    # nor with a reference of other values
    args["theta"], args["ref"] = 0.5, str(tmp_path / "ref-other.npz")
    other = outputs(tmp_path / "a5", checkpoint=own, committed=kept)
    assert other.invocation.tolist() == [0, 0, 0]
    assert hashlib.sha256(kept.read_bytes()).hexdigest() == digest
    made = str(np.load(kept)["checkpoint_key"])
    older = {**json.loads(made), "ref": "0" * 64}     # an older key's SHA-256 of the reference
    assert para_adaptive.checkpoint_differences(made, json.dumps(older)) == ["ref"]


def test_committed_results_page_holds_the_committed_pages_as_they_stand():
    """paper-figures/RESULTS.md is what results_page makes of the committed figures and
    tables with config.yaml's problems: a page rendered again by its own rule alone, without
    the results page after it, shows here."""
    import yaml
    page = script("results_page")
    para = yaml.safe_load((ROOT / "config.yaml").read_text())["parabolic"]
    expected = page.render(ROOT / "paper-figures", para["time_split"]["problems"],
                           list(para["examples"]), para["self_reference"]["problems"])
    assert (ROOT / "paper-figures" / "RESULTS.md").read_text() == expected


def test_results_page_names_one_file_per_problem_of_each_list(tmp_path):
    """"{problem}" stands for the problems of parabolic.time_split, "{para}" for every
    parabolic problem; a file the page names but the run did not make is an error."""
    page = script("results_page")
    assert page.expand("{problem}-time-split.md", ["ex5"], ["ex4-u1", "ex5"]) == [
        "ex5-time-split.md"]
    assert page.expand("{para}-algorithm-c.md", ["ex5"], ["ex4-u1", "ex5"]) == [
        "ex4-u1-algorithm-c.md", "ex5-algorithm-c.md"]
    assert page.expand("rates.md", ["ex5"], ["ex4-u1"]) == ["rates.md"]
    names = {n for _, _, figures, tables in page.SECTIONS for entry in figures + tables
             for n in page.expand(entry, ["ex5"], ["ex4-u1", "ex5"])}
    for name in names:
        (tmp_path / name).write_text(f"table {name}")
    text = page.render(tmp_path, ["ex5"], ["ex4-u1", "ex5"])
    assert "![extra-ex4-u1-algorithm-c.png]" in text and "table ex5-algorithm-c.md" in text
    assert "ex4-u1-time-split.md" not in text
    (tmp_path / "extra-ex5-algorithm-c.png").unlink()
    with pytest.raises(FileNotFoundError, match="extra-ex5-algorithm-c.png is missing"):
        page.render(tmp_path, ["ex5"], ["ex4-u1", "ex5"])


def test_pipeline_cost_states_the_machine_speed_of_the_day(tmp_path):
    """--assembly: the day's finest assembly time beside the committed benchmark's, and
    their ratio; a level the committed benchmark lacks is refused."""
    cost = script("pipeline_cost")
    committed = tmp_path / "committed.csv"
    pd.DataFrame({"level": [5, 6], "dofs": [1985, 8065], "threads": [2, 2],
                  "assembly_s": [1.0, 8.0]}).to_csv(committed, index=False)
    day = tmp_path / "day.csv"
    pd.DataFrame({"level": [6], "dofs": [8065], "threads": [2],
                  "assembly_s": [12.0]}).to_csv(day, index=False)
    note = cost.speed_note(day, committed)
    assert "level 6 (8,065 DOFs, 2 threads) in 12.00 s" in note
    assert "took 8.00 s" in note and "1.50× as long" in note
    pd.DataFrame({"level": [7], "dofs": [1], "threads": [2],
                  "assembly_s": [1.0]}).to_csv(day, index=False)
    with pytest.raises(SystemExit, match="level 7"):
        cost.speed_note(day, committed)


def test_vi_runs_page_shows_counts_whole_and_blank_where_a_problem_has_none(tmp_path):
    vi_runs = script("vi_runs_md")
    obstacle, friction = tmp_path / "ex2.csv", tmp_path / "ex3.csv"
    pd.DataFrame({"problem": "ex2", "family": "uniform", "dofs": [1985],
                  "multipliers": [1024], "h_max": [0.0575], "contact": [84]}).to_csv(obstacle)
    pd.DataFrame({"problem": "ex3", "family": "graded", "dofs": [3860],
                  "multipliers": [1977], "h_max": [0.0737], "slip_plus": [1977],
                  "stick": [0]}).to_csv(friction)
    md = tmp_path / "vi-runs.md"
    vi_runs.main([obstacle, friction], md)
    (rows,) = page_tables(md.read_text())
    cell = {(r["problem"], h): v for r in rows for h, v in r.items()}
    assert cell["ex3", "slip_plus"] == "1977"                 # not 1.98e+03
    assert cell["ex2", "slip_plus"] == "" and cell["ex3", "contact"] == ""
    assert cell["ex2", "contact"] == "84" and cell["ex3", "stick"] == "0"
    assert cell["ex2", "h_max"] == "0.0575"                   # not a count


def test_rate_table_shows_a_tier_from_its_partial_tables(tmp_path):
    """A tier whose parabolic series are unfinished is read from its partial tables
    (rates-elliptic.csv, rates-parabolic.csv): each row's rate comes from the one that
    holds it, and the note names both."""
    rates = script("rates")
    ours, ex5 = tmp_path / "ex1.csv", tmp_path / "ex5.csv"
    pd.DataFrame({"example": 1, "family": "uniform", "s": 0.5, "dofs": [100, 400, 1600],
                  "error": [0.4, 0.2, 0.1]}).to_csv(ours, index=False)
    pd.DataFrame({"example": 5, "family": "uniform", "s": 0.5,
                  "spacetime_dofs": [10**3, 10**4], "error": [0.1, 0.05],
                  "reference_error": 0.001}).to_csv(ex5, index=False)

    def fitted(example, variant, rate):
        return {"example": example, "variant": variant, "family": "uniform", "s": 0.5,
                "rate": rate, "n_points": 3, "dof_max": 10**6, "smallest_error": 0.01}
    other = tmp_path / "big"
    other.mkdir()
    pd.DataFrame([fitted(1, "", -0.51)]).to_csv(other / "rates-elliptic.csv", index=False)
    pd.DataFrame([fitted(5, "", -0.2)]).to_csv(other / "rates-parabolic.csv", index=False)
    parts = [other / "rates-elliptic.csv", other / "rates-parabolic.csv"]
    md = tmp_path / "rates.md"
    rates.main([ours, ex5], tmp_path / "rates.csv", md, tmp_path / "rates.tex",
               tiers={"big": parts})
    out = pd.read_csv(tmp_path / "rates.csv")
    assert out["rate"].round(3).tolist() == [-0.5, -0.301]
    assert out["rate_big"].tolist() == [-0.51, -0.2]          # one row from each part
    note = md.read_text()
    rows = [r for r in note.splitlines() if r.startswith("|") and "uniform" in r]
    assert rows and all(len(re.findall(r"\|\s*1000000\s*\|", r)) == 1 and "e+06" not in r
                        for r in rows)                          # dof_max_big, whole
    wide = rates.shown_counts(out.assign(dof_max_big=[16440205, None]))
    assert re.search(r"\|\s*16440205\s*\|", wide.to_markdown(index=False, floatfmt="g"))
    assert (f"from `{parts[0]}` and `{parts[1]}` (the big tier's Examples 1–3 and parabolic "
            "problems whose error tables are kept; its other parabolic series") in note
    # its elliptic table alone: Example 5 has no rate of that tier, and no "other"
    rates.main([ours, ex5], tmp_path / "rates.csv", md, tmp_path / "rates.tex",
               tiers={"big": [parts[0]]})
    assert pd.read_csv(tmp_path / "rates.csv")["rate_big"].isna().tolist() == [False, True]
    assert "(the big tier's Examples 1–3; its parabolic series are not" in md.read_text()
    # dof_max_big is a float column now (Example 5 has none): still shown whole, blank there
    shown = [r for r in md.read_text().splitlines() if r.startswith("|") and "uniform" in r]
    assert len(re.findall(r"\|\s*1000000\s*\|", shown[0])) == 1 and "e+06" not in shown[0]
    assert "nan |" not in shown[1].split("|", 16)[-1]           # the big tier's columns
    # its full table (one path): no note on partial tables
    full = other / "rates.csv"
    full.write_bytes(parts[0].read_bytes())
    rates.main([ours], tmp_path / "rates.csv", md, tmp_path / "rates.tex",
               tiers={"big": str(full)})
    assert "not finished" not in md.read_text()
    # the same row in both partial tables is refused (join_tiers: repeats a row)
    pd.DataFrame([fitted(1, "", -0.4)]).to_csv(parts[1], index=False)
    with pytest.raises(ValueError, match="repeats a row"):
        rates.main([ours], tmp_path / "rates.csv", md, tmp_path / "rates.tex",
                   tiers={"big": parts})


def test_self_reference_page_measures_the_passes_against_the_last(tmp_path):
    """Algorithm C's passes before the last against the reference run and against the last
    pass: every such pass has a finite distance to the last, the last none; the page fits
    the three rates through the passes it names; too few passes for a rate are refused."""
    page, solve = script("para_self_reference"), script("para_solve")
    quad, data, T = {}, {"s": 0.5, "u0": 2.0}, 0.3
    ref = tmp_path / "ref.npz"
    solve.main("ex4-u2", "reference", "L3", "ex4", data, 2.0, T, 0.5, 1e-10, quad,
               tmp_path / "ref.csv", ref)
    ref_error = tmp_path / "ref-error.csv"
    pd.DataFrame({"reference_error": [0.01]}).to_csv(ref_error, index=False)
    csv, md = tmp_path / "self.csv", tmp_path / "self.md"
    args = ("ex4-u2", "ex4", data, T, 0.5, 1, 1.0)
    page.main(*args, 3000, 4, 1e-10, quad, ref, ref_error, csv, md)
    df = pd.read_csv(csv)
    assert df["pass"].tolist() == list(range(len(df))) and len(df) >= 3
    assert np.all(np.isfinite(df.error_vs_last.iloc[:-1])) and np.isnan(df.error_vs_last.iloc[-1])
    assert np.all(df.error_vs_last.iloc[:-1] > 0) and np.all(df.error_uncertainty.isna())
    text = md.read_text()
    before = df.iloc[:-1]
    for column, row in [("error_vs_last", "slab by slab on its own meshes"),
                        ("error_vs_last_on_reference", "on that run's mesh"),
                        ("error_vs_reference", "the family's finest run alone")]:
        rate = np.polyfit(np.log(before.spacetime_dofs), np.log(before[column]), 1)[0]
        assert re.search(rf"{re.escape(row)}[^|]*every pass\s*\|\s*{rate:.3f}\s*\|", text), \
            (column, text)
    assert text.count("| 0, 1") == 5 and "the paper's adaptive rate is -0.319" in text
    with pytest.raises(ValueError, match=r"max_spacetime_dofs=100 gives 2 passes \(Algorithm "
                                         r"C stopped: callback\)"):
        page.main(*args, 100, 4, 1e-10, quad, ref, ref_error, csv, md)
    assert pd.read_csv(csv).equals(df) and md.read_text() == text   # nothing written


def test_time_split_refuses_a_graded_error_measured_against_another_family(tmp_path):
    """The graded run of an errors table is solved again and measured against the job's
    reference: the table's own error passes and becomes the m = 1 row; a table measured
    against another reference (its error off by 10⁻⁴ relative) is refused, naming the run."""
    from fracfem_workflow.runs import parabolic_pieces, stored_reference

    split, solve = script("para_time_split"), script("para_solve")
    quad, data, T = {}, {"s": 0.5, "u0": 2.0}, 0.3
    ref, run = tmp_path / "ref.npz", tmp_path / "run.npz"
    solve.main("ex4-u2", "reference", "L3", "ex4", data, 2.0, T, 0.5, 1e-10, quad,
               tmp_path / "ref.csv", ref)
    solve.main("ex4-u2", "graded", "h0.4", "ex4", data, 2.0, T, 0.5, 1e-10, quad,
               tmp_path / "run.csv", run)
    options = ff.QuadratureOptions(**quad)
    reference, _ = stored_reference(ref, options)
    ex = ff.example("ex4", **data)

    def prob_of(mesh, operator="compressed"):    # the run's own: dense (para_solve's)
        return ex.problem(mesh, options, operator=operator)

    stored = reference.distance(parabolic_pieces(run)[0])
    known = pd.read_csv(tmp_path / "run.csv").assign(error=stored, error_uncertainty=np.nan,
                                                      error_vs_reference=stored)
    graded = split.graded_series(prob_of, ex, known, [0.4], 2.0, 0.5, T, [1, 4], 1e-10,
                                 reference, "ex4-u2")
    assert graded.m.tolist() == [1, 4]
    assert graded.error.iloc[0] == pytest.approx(stored, rel=1e-9)
    assert graded.error.iloc[1] != pytest.approx(stored, rel=1e-3)   # τ/4 changes it
    with pytest.raises(ValueError, match=r"graded run h0\.4: error .* another family"):
        split.graded_series(prob_of, ex, known.assign(error=stored * (1 + 1e-4)), [0.4],
                            2.0, 0.5, T, [1, 4], 1e-10, reference, "ex4-u2")


def _ring_rows(ns, dofs, energy, lifted, contact=12, radius=0.2):
    return pd.DataFrame({"problem": "ex2", "n": ns, "dofs": dofs, "energy": energy,
                         "lifted energy": lifted, "largest dip": 0.01,
                         "contact elements": contact, "contact radius": radius,
                         "grading": 2.0})


def test_ex2_graded_rings_fits_every_window_and_both_measures():
    """Errors on one power law give that rate in every window and family; the dip's share
    is (E(ũ) − E(u_h)) / (E(ũ) − E_ref), nan below E_ref; a ring count with an energy
    below E_ref, or an error within 3× the reference's, is not fitted (each measure
    apart)."""
    page = script("vi_graded_rings_page")
    ns = np.arange(4, 17)
    dofs = 25 * ns ** 2
    e_ref = -1.0
    err = 0.5 * dofs.astype(float) ** -0.5          # error 0.5 N^(-1/2) = 0.1/n
    lifted_err = 2 * err                            # lifted: twice, same rate
    energy = e_ref + err ** 2 / 2
    lifted = e_ref + lifted_err ** 2 / 2
    energy[0] = e_ref - 0.1                         # n = 4 below the reference
    rings = _ring_rows(ns, dofs, energy, lifted)
    table = page.ring_table(rings, e_ref, 1e-4, 0.25, [4, 8, 16])
    assert not table.fitted.iloc[0] and table.fitted.iloc[1:].all()
    assert table["lifted fitted"].all()             # its energy lies above E_ref
    assert table.error.iloc[1:].to_numpy() == pytest.approx(err[1:])
    assert table["lifted error"].to_numpy() == pytest.approx(lifted_err)
    # E(ũ) − E_ref = 4 (E(u_h) − E_ref): the dip takes off three quarters
    assert np.isnan(table["dip's share"].iloc[0])
    assert table["dip's share"].iloc[1:].to_numpy() == pytest.approx(0.75)
    assert np.isnan(table["local slope"].iloc[1])   # its smaller neighbour is not fitted
    assert table["local slope"].iloc[2:].to_numpy() == pytest.approx(-0.5)
    assert table["lifted local slope"].iloc[1:].to_numpy() == pytest.approx(-0.5)
    assert table["contact radius / reference"].to_numpy() == pytest.approx(0.8)
    rates = page.window_rates(table, [4, 8, 16]).set_index("fitted through")
    assert rates.loc["graded series", "ring counts"] == "8, 16"   # 4 is not fitted
    # the lift is fitted at n = 4 too, but the rows fit the error's ring counts
    assert rates.loc["graded series", "lifted points"] == 2
    assert rates.rate.to_numpy() == pytest.approx(-0.5)
    assert rates["lifted rate"].to_numpy() == pytest.approx(-0.5)
    assert rates.loc["n = 5, 10, … (h halved)", "ring counts"] == "5, 10"
    assert rates.loc["n = 6, 12, … (h halved)", "points"] == 2
    # a family is named by its smallest fitted member: 5, 10 but not 10 alone, nor 8, 16
    # (4 is not fitted, so 8 starts it)
    assert rates.loc["n = 8, 16, … (h halved)", "points"] == 2
    assert "n = 10, 20, … (h halved)" not in rates.index
    assert "n = 9, 18, … (h halved)" not in rates.index         # 18 is not run
    # every window from n on keeps at least four ring counts, n among them
    assert rates.loc["every ring count from n = 13", "points"] == 4
    assert "every ring count from n = 14" not in rates.index
    # a reference error of 0.004: the errors 0.1/n above 0.012 (n <= 8) are fitted
    strict = page.ring_table(rings, e_ref, 0.004, 0.25, [4, 8, 16])
    assert strict.n[strict.fitted].tolist() == [5, 6, 7, 8]
    assert strict.n[strict["lifted fitted"]].tolist() == list(range(4, 17))


def test_ex2_graded_rings_checks_the_series_runs_are_among_them():
    """The graded series' run of h is the ring-count run n = ceil(1/h): same DOFs and
    energy, else ValueError; a series ring count outside the range is refused."""
    page = script("vi_graded_rings_page")
    rings = _ring_rows([8, 9, 10], [1076, 1354, 1700], [-0.62, -0.63, -0.631],
                       [-0.61, -0.62, -0.63])
    series = pd.DataFrame({"tag": ["h0.14", "h0.1"], "dofs": [1076, 1700],
                           "energy": [-0.62, -0.631]})
    assert list(page.series_rings(series, rings)) == [8, 10]
    with pytest.raises(ValueError, match="is not the ring-count run n = 10"):
        page.series_rings(series.assign(energy=[-0.62, -0.6312]), rings)
    with pytest.raises(ValueError, match=r"ring counts \[20\] lie outside"):
        page.series_rings(pd.DataFrame({"tag": ["h0.05"], "dofs": [6963],
                                        "energy": [-0.63]}), rings)


def test_vi_graded_rings_records_the_lift_and_the_contact_set(tmp_path):
    """Two small ring counts: the series' DOFs; E(ũ_h) ≥ E(u_h) here; the lift is χ where
    u_h dips below it and u_h elsewhere at the free nodes, 0 on ∂Ω; the contact set is
    there; a problem without an obstacle is refused before any solve."""
    run = script("vi_graded_rings")
    out = tmp_path / "rings.csv"
    run.main("ex2", "ex2", {"s": 0.5, "height": 1.0, "slope": 4.0}, [5, 6], 2.0, 1e-10, {},
             str(out))
    df = pd.read_csv(out)
    assert df.n.tolist() == [5, 6]
    assert df.dofs.tolist() == [401, 591]                # the graded series' h0.2 has 401
    assert (df["lifted energy"] >= df.energy).all()
    assert (df["largest dip"] > 0).all()                 # u_h dips below χ on these meshes
    # the lift itself: χ at the nodes where u_h dips, u_h elsewhere, 0 on ∂Ω
    prob = ff.example("ex2").problem(ff.disk_graded_rings(5))
    u, _, _ = ff.vi.solve(prob, "pdas", tol=1e-10)
    chi = ff.example("ex2").obstacle(prob.fine.p)
    lift, dip = run.lifted(prob, u, ff.example("ex2").obstacle)
    free = prob.disc.free
    boundary = np.setdiff1d(np.arange(len(u)), free)
    assert np.all(lift[free] >= chi[free]) and np.all(lift[boundary] == 0.0)
    assert np.array_equal(lift[free], np.maximum(u[free], chi[free]))
    assert dip == pytest.approx((chi[free] - u[free]).max()) and dip > 0
    assert (df["contact elements"] > 0).all() and (df["contact radius"] > 0).all()
    with pytest.raises(ValueError, match="problem='ex3-printed' .* has no obstacle"):
        run.main("ex3-printed", "ex3", {"s": 0.6, "a": 1.0, "b": 0.0, "F": 0.5}, [5, 6],
                 2.0, 1e-10, {}, str(tmp_path / "x.csv"))
    with pytest.raises(ValueError, match=r"rings=\[6, 5\] must be"):
        run.main("ex2", "ex2", {"s": 0.5}, [6, 5], 2.0, 1e-10, {}, str(tmp_path / "x.csv"))
    assert not (tmp_path / "x.csv").exists()


def test_ex1_h_rates_separates_the_error_in_h_from_the_growth_of_the_dofs():
    """A graded series with error = h exactly and N = 10 h^(-2.2): rate in h 1, p −2.2,
    rate against DOFs −1/2.2; uniform runs are left out."""
    extra = script("ex1_extra")
    h = np.array([0.2, 0.1, 0.05, 0.025])
    df = pd.DataFrame({"s": 0.5, "family": "graded", "tag": [f"h{x:g}" for x in h],
                       "dofs": 10 * h ** -2.2, "error": h})
    uniform = pd.DataFrame({"s": 0.5, "family": "uniform", "tag": ["L2", "L3"],
                            "dofs": [25, 113], "error": [0.4, 0.3]})
    got = extra.h_rates(pd.concat([df, uniform], ignore_index=True))
    assert got.family.tolist() == ["graded"]
    row = got.iloc[0]
    assert row["rate in h"] == pytest.approx(1.0)
    assert row["dofs ~ h^p"] == pytest.approx(-2.2)
    assert row.rate == pytest.approx(-1 / 2.2)
    assert row.h == "0.2 … 0.025" and row.runs == 4


def test_vi_adaptive_distances_measures_every_step_against_the_unchanged_series_last(tmp_path):
    """Two short Algorithm B series of Example 2 (every step kept): each step's distance
    to the unchanged series' last step, 0 at that step itself, a dip ≥ 0; a series whose
    recorded settings are not its change's is refused before anything is measured."""
    adaptive = script("vi_adaptive")
    page = script("vi_adaptive_distances")
    data = {"s": 0.5, "height": 1.0, "slope": 4.0}
    quad = {}
    for name, start_level, max_dofs in (("u", 2, 400), ("c", 1, 90)):
        adaptive.main("ex2", "ex2", data, 0.5, start_level, max_dofs, 10, [], 1e-10, quad,
                      tmp_path / f"{name}.csv", tmp_path / f"{name}.npz", operator="dense",
                      every_step=True)
    tables = {"as configured": tmp_path / "u.csv", "start_level = 1": tmp_path / "c.csv"}
    npz = {"as configured": tmp_path / "u.npz", "start_level = 1": tmp_path / "c.npz"}
    with pytest.raises(ValueError, match="'start_level = 1' was not run with start_level = 3"):
        page.main("ex2", data, quad, tables, npz, {"start_level = 1": {"start_level": 3}},
                  tmp_path / "d.csv", operator="dense")
    assert not (tmp_path / "d.csv").exists()
    page.main("ex2", data, quad, tables, npz, {"start_level = 1": {"start_level": 1}},
              tmp_path / "d.csv", operator="dense")
    d = pd.read_csv(tmp_path / "d.csv")
    steps = {case: len(pd.read_csv(f)) for case, f in tables.items()}
    assert d.groupby("case", sort=False).size().to_dict() == steps
    ref = d[(d.case == "as configured") & (d.step == d.reference_step)]
    assert len(ref) == 1 and ref.distance.iloc[0] < 1e-10
    assert (d.distance.drop(ref.index) > 1e-3).all() and (d.dip >= 0).all()


@pytest.mark.parametrize("operator", ["dense", "compressed"])
def test_example1_run_and_its_quadrature_check_keep_the_operator(tmp_path, operator):
    """ex1_solve records the operator it used (config example1.operator) and the quadrature
    check repeats the run with that operator: the compressed one with its Taylor rule kept
    (raised(keep_taylor=True)), which the plain raised() rules would make it refuse. Both
    energies lie below the exact one, and the compressed run's lies within 1e-4 of the
    squared error of the dense one's."""
    solve, check = script("ex1_solve"), script("ex1_quadrature")
    quad = {"far_orders": [0, 2, 4, 8], "far_thresholds": [8.0, 4.0, 2.0]}
    rows = {}
    for op in {"dense", operator}:
        rows[op] = tmp_path / f"{op}.csv"
        solve.main("graded", "h0.2", 0.5, 2.0, quad, rows[op], tmp_path / f"{op}.npz",
                   operator=op)
    run = pd.read_csv(rows[operator]).iloc[0]
    dense = pd.read_csv(rows["dense"]).iloc[0]
    assert run.operator == operator and run.operator_setting == operator
    assert (run.pcg_iterations > 0) == (operator == "compressed")
    err2 = dense.fu_exact - dense.fu_h
    assert 0 < err2 and abs(run.fu_h - dense.fu_h) < 1e-4 * err2
    check.main("graded", "h0.2", 2.0, quad, rows[operator], tmp_path / "check.csv")
    out = pd.read_csv(tmp_path / "check.csv").iloc[0]
    assert out.operator == operator
    assert json.loads(out.quadrature_far_orders)[0] == (0 if operator == "compressed" else 2)
    assert out.change_over_error_squared < 0.01


def test_kept_tables_are_copied_with_their_settings_written_last(tmp_path, monkeypatch):
    """para_errors_copy (the keep rules): a table and its reference's record copied file by
    file, the settings written beside the first copy; the old settings go first, so that a
    copy that fails half-way leaves no settings (a kept table without them is computed again)
    rather than old settings beside a new table."""
    copy = script("para_errors_copy")
    (tmp_path / "errors.csv").write_text("a\n1\n")
    (tmp_path / "reference.json").write_text('{"E": 1}')
    kept = tmp_path / "kept"
    targets = [kept / "ex2-vi-errors.csv", kept / "ex2-vi-reference.json"]
    copy.main([tmp_path / "errors.csv", tmp_path / "reference.json"], targets,
              tmp_path / "note.txt", settings='{"x": 1}')
    assert targets[0].read_text() == "a\n1\n" and targets[1].read_text() == '{"E": 1}'
    assert (kept / "ex2-vi-errors.json").read_text() == '{"x": 1}\n'
    assert (tmp_path / "note.txt").read_text().count(" -> ") == 2
    (tmp_path / "errors.csv").write_text("a\n2\n")
    calls, real = [], shutil.copyfile

    def fail_on_the_record(source, target):
        calls.append(Path(source).name)
        if Path(source).name == "reference.json":
            raise OSError("disk full")
        real(source, target)
    monkeypatch.setattr(copy.shutil, "copyfile", fail_on_the_record)
    with pytest.raises(OSError, match="disk full"):
        copy.main([tmp_path / "errors.csv", tmp_path / "reference.json"], targets,
                  tmp_path / "note.txt", settings='{"x": 2}')
    assert calls == ["errors.csv", "reference.json"]
    assert not (kept / "ex2-vi-errors.json").exists()        # no settings: not read as kept
    with pytest.raises(ValueError, match="2 files to copy to 1 places"):
        copy.main([tmp_path / "errors.csv", tmp_path / "reference.json"], targets[:1],
                  tmp_path / "note.txt")
