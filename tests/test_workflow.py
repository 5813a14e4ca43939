"""The Snakemake workflow: targets, config overrides, schema (dry runs)."""
import re
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("snakemake") is None,
                                reason="snakemake is not installed")


def dry_run(*args, ok=True):
    out = subprocess.run(["snakemake", "-n", "--nolock", "--cores", "2", *args], cwd=ROOT,
                         capture_output=True, text=True, timeout=300)
    text = out.stdout + out.stderr
    if ok:
        assert out.returncode == 0, text
    return out.returncode, text


def job_counts(text):
    """The 'Job stats' table of a dry run as {rule: count}."""
    table = text.split("Job stats:")[1].split("total")[0]
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^(\w+)\s+(\d+)\s*$", table, re.M)}


def kept_dry_run(tmp_path, section, kept, target, extra=""):
    """(job counts, text) of a paper-scale dry run for ``target`` under its output root in
    tmp_path, with ``section``.kept_errors set to ``kept`` and the YAML ``extra`` added."""
    cfg = tmp_path / "s.yaml"
    cfg.write_text(f"{section}:\n  kept_errors: {kept}\n" + extra)
    _, text = dry_run("--configfile", "config/paper.yaml", str(cfg), "--config",
                      f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o", "--",
                      f"{tmp_path}/o/{target}")
    return job_counts(text), text


def test_one_figure_runs_only_its_jobs(tmp_path):
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig02-ex1-error.png")
    jobs = job_counts(text)
    # Figure 2: the s = 0.5 uniform, graded, graded-sr and adaptive series, nothing else
    import yaml
    ex1 = yaml.safe_load((ROOT / "config.yaml").read_text())["example1"]
    runs = len(ex1["uniform_levels"]) + len(ex1["graded_h"]) + len(ex1["graded_sr_h"])
    assert set(jobs) == {"ex1_solve", "ex1_adaptive", "fig02"}
    assert jobs["ex1_solve"] == runs == 14 and jobs["ex1_adaptive"] == 1
    assert "s0.25" not in text and "benchmark_assembly" not in text


def test_new_s_values_from_the_command_line_go_to_their_own_root():
    # Snakemake passes lists as strings; the workflow parses them
    _, text = dry_run("--config", "s_values=[0.3, 0.6]")
    assert "ex1/uniform/s0.3/L2.csv" in text and "ex1/graded/s0.6/h0.1.csv" in text
    outputs = re.findall(r"^\s+output: (.*)$", text, re.M)
    assert outputs and not any("paper-figures/" in line for line in outputs)
    assert re.search(r"results/custom-[0-9a-f]{10}/figures/rates.csv", text)


def test_changed_science_of_the_paper_scale_tier_does_not_overwrite_its_committed_root():
    _, text = dry_run("--configfile", "config/paper.yaml", "--forceall", "--config",
                      "s_values=[0.3]")
    outputs = re.findall(r"^\s+output: (.*)$", text, re.M)
    assert outputs and not any("paper-figures/" in line for line in outputs)
    assert re.search(r"results-paper/custom-[0-9a-f]{10}/figures/fig13-ex4-error.png", text)


def test_comma_separated_and_scalar_overrides():
    _, text = dry_run("--config", "s_values=0.35,0.65")
    assert "s0.35/" in text and "s0.65/" in text
    _, text = dry_run("--config", "s_values=0.45")
    assert "s0.45/" in text


def test_default_config_targets_the_paper_figures():
    """With the config as committed, every paper figure is written to paper-figures/
    (--forceall: the jobs are listed whether or not their outputs are up to date)."""
    _, text = dry_run("--forceall")
    for num in range(1, 16):
        assert re.search(rf"(?<![\w/])paper-figures/fig{num:02d}-[\w-]+\.png", text), num
    assert "custom-" not in text
    jobs = job_counts(text)
    assert jobs["all"] == 1 and jobs["fig02"] == 1 and jobs["ex1_solve"] >= 10


@pytest.mark.parametrize("override, message", [
    ("s_values=[1.5]", "s_values"),
    ("s_values=[0]", "s_values"),
    ("example1={'grading': 9}", "example1"),
])
def test_config_failing_the_schema_is_refused(override, message):
    code, text = dry_run("--config", override, ok=False)
    assert code != 0
    assert message in text


def test_parabolic_figure_runs_only_its_jobs(tmp_path):
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig13-ex4-error.png")
    jobs = job_counts(text)
    # Figure 13: Example 4 (both initial values): series, the reference's family (and the
    # reference's operator, once: both have s = 1/2 and the same reference mesh),
    # Algorithm C, errors; the family, built once per problem for its jobs
    assert set(jobs) == {"para_solve", "para_reference_solve", "para_reference_operator",
                         "para_reference_family", "para_adaptive", "para_reference_error",
                         "para_errors", "fig_para_error"}
    assert jobs["para_adaptive"] == 2 and jobs["para_errors"] == 2
    assert jobs["para_reference_operator"] == 1 and jobs["para_reference_error"] == 2
    assert jobs["para_reference_family"] == 2
    assert "ex4-u1/reference-operator.pkl" in text
    assert "ex4-u2/reference-operator.pkl" not in text
    assert "ex5" not in text and "ex1_solve" not in text and "vi_solve" not in text


def test_algorithm_c_page_runs_without_the_series(tmp_path):
    """Algorithm C pass by pass needs its run and its reference's measured error: none of
    the uniform and graded runs of Figures 13 and 15, nor their error measurement."""
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/ex4-u1-algorithm-c.md")
    jobs = job_counts(text)
    assert set(jobs) == {"para_reference_solve", "para_reference_operator",
                         "para_reference_family", "para_adaptive", "para_reference_error",
                         "para_passes"}
    assert jobs["para_adaptive"] == 1 and jobs["para_passes"] == 1


def test_reference_error_is_measured_without_algorithm_c(tmp_path):
    """The reference's own error is a target of its own: its family's runs, the reference's
    operator and the distances, none of Algorithm C's passes."""
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/r/para/ex4-u1/reference-error.csv")
    jobs = job_counts(text)
    assert set(jobs) == {"para_reference_solve", "para_reference_operator",
                         "para_reference_error"}
    assert jobs["para_reference_error"] == 1
    # the two coarser runs of the family (the reference itself is the committed copy)
    assert jobs["para_reference_solve"] == 2 and "ex4-u2" not in text


def test_every_paper_figure_is_a_default_target(tmp_path):
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o")
    for num in range(1, 16):
        assert re.search(rf"{tmp_path}/o/fig{num:02d}-[\w-]+\.png", text), f"Figure {num}"


def test_reference_family_needs_three_meshes(tmp_path):
    """The Example 2/3 reference is extrapolated through three runs of one family: a config
    with fewer is refused before any job, naming the key."""
    (tmp_path / "short.yaml").write_text("example2:\n  graded_sr_h: [0.8, 0.56]\n"
                                         "reference:\n  family: graded-sr\n")
    code, text = dry_run("--configfile", str(tmp_path / "short.yaml"), ok=False)
    assert code != 0
    assert "example2.graded_sr_h=[0.8, 0.56] must list at least 3 meshes" in text


def test_figure7_reuses_the_committed_large_reference(tmp_path):
    """With the committed data, Figure 7 runs the pipeline's series and the committed large
    Algorithm B run stands in for the reference (no job recomputes it)."""
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig07-ex2-error.png")
    jobs = job_counts(text)
    assert "vi_adaptive_large" not in jobs and jobs["vi_errors"] == 1
    assert "workflow/data/reference/ex2.csv" in text


@pytest.mark.parametrize("change", ["example2:\n  s: 0.4\n",
                                    "reference:\n  large:\n    theta: 0.4\n",
                                    "quadrature:\n  kappa_order: 6\n"])
def test_other_data_recompute_the_large_reference(tmp_path, change):
    """A committed reference computed for other data or settings is not used: changing
    Example 2's order, the large run's θ or the quadrature schedules the large run of
    Example 2 for Figure 7."""
    (tmp_path / "s.yaml").write_text(change)
    _, text = dry_run("--configfile", str(tmp_path / "s.yaml"), "--config",
                      f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig07-ex2-error.png")
    jobs = job_counts(text)
    assert jobs["vi_adaptive_large"] == 1
    assert f"{tmp_path}/r/vi/ex2/adaptive-large/steps.csv" in text


def test_figure13_reuses_the_committed_parabolic_references(tmp_path):
    """With the committed data, Figure 13 runs the series, Algorithm C and the reference's
    two coarser runs; the committed reference runs stand in for the reference."""
    _, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig13-ex4-error.png")
    assert "workflow/data/reference/ex4-u1-parabolic.npz" in text
    assert "workflow/data/reference/ex4-u2-parabolic.npz" in text
    assert "reference/h0.025.npz" not in text       # the reference run itself: not run
    assert "ex4-u1/reference/h0.05.npz" in text and "ex4-u1/reference/h0.1.npz" in text


@pytest.mark.parametrize("change", ["parabolic:\n  examples:\n    ex4-u1: {s: 0.5, u0: 1.5}\n",
                                    "solver:\n  tol: 1.0e-8\n"])
def test_other_data_recompute_the_parabolic_reference(tmp_path, change):
    """A committed parabolic reference made for other data or settings is not used."""
    (tmp_path / "s.yaml").write_text(change)
    _, text = dry_run("--configfile", str(tmp_path / "s.yaml"), "--config",
                      f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/fig13-ex4-error.png")
    assert f"{tmp_path}/r/para/ex4-u1/reference/h0.025.npz" in text


def test_paper_scale_tier_has_its_own_root_and_the_paper_sizes():
    """config/paper.yaml computes everything under results-paper/ and writes its figures
    and tables to paper-figures/paper-scale/, runs Algorithm C and the
    finer Example 4 reference (or reuses this tier's committed copy of it, never the
    default tier's), reuses the committed elliptic references, takes Example 5's from
    its own copy made with its parabolic quadrature (or recomputes it), also for the
    family of ex5-uniform-rate.md, and its rate table takes the default tier's committed
    rates.csv as input."""
    _, text = dry_run("--configfile", "config/paper.yaml", "--forceall")
    outputs = re.findall(r"^\s+output: (.*)$", text, re.M)
    assert outputs and all(o.startswith(("results-paper/", "paper-figures/paper-scale/"))
                           for line in outputs for o in line.split(", "))
    assert "paper-figures/paper-scale/fig13-ex4-error.png" in text
    for problem in ("ex4-u1", "ex4-u2"):
        copy = f"workflow/data/reference/paper-scale/{problem}-parabolic.npz"
        fresh = f"results-paper/para/{problem}/reference/h0.0125.npz"
        assert (copy if (ROOT / copy).exists() else fresh) in text
        assert f"workflow/data/reference/{problem}-parabolic.npz" not in text
    assert "vi_adaptive_large" not in job_counts(text)
    # its parabolic jobs' own quadrature (parabolic.quadrature): Example 5's reference is
    # this tier's copy or its own run, never the default tier's copy (config.yaml's
    # quadrature), also where its reference family's finest run is the reference
    # (ex5_uniform_cause); the elliptic ones are the committed copies
    copy = "workflow/data/reference/paper-scale/ex5-parabolic.npz"
    assert (copy if (ROOT / copy).exists()
            else "results-paper/para/ex5/reference/h0.025.npz") in text
    assert "workflow/data/reference/ex5-parabolic.npz" not in text
    cause = text.split("rule ex5_uniform_cause:")[1].split("output:")[0]
    assert (copy if (ROOT / copy).exists() else "reference/h0.025.npz") in cause
    assert "results-paper/para/ex5/uniform/L6.npz" in cause   # one level beyond the series
    rates = text.split("rule rates:")[1].split("output:")[0]
    assert "paper-figures/rates.csv" in rates


def test_rate_table_reads_another_tier_only_where_it_exists(tmp_path):
    (tmp_path / "other.csv").write_text("example\n")
    (tmp_path / "s.yaml").write_text(f"tiers:\n  other: {tmp_path}/other.csv\n"
                                     f"  absent: {tmp_path}/nothing.csv\n")
    _, text = dry_run("--configfile", str(tmp_path / "s.yaml"), "--config",
                      f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                      "--", f"{tmp_path}/o/rates.csv")
    rates = text.split("rule rates:")[1].split("output:")[0]
    assert f"{tmp_path}/other.csv" in rates and "nothing.csv" not in rates


def test_rate_table_reads_another_tiers_elliptic_table_until_its_full_one_exists(tmp_path):
    """A tier whose parabolic series are unfinished has only rates-elliptic.csv (rule
    rates_elliptic): the other tiers read it in place of its rates.csv, and its full
    table once that exists."""
    other = tmp_path / "other"
    other.mkdir()
    (other / "rates-elliptic.csv").write_text("example\n")
    (tmp_path / "s.yaml").write_text(f"tiers:\n  other: {other}/rates.csv\n")
    args = ("--configfile", str(tmp_path / "s.yaml"), "--config",
            f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
            "--", f"{tmp_path}/o/rates.csv")

    def read():
        _, text = dry_run(*args)
        return text.split("rule rates:")[1].split("output:")[0]
    assert f"{other}/rates-elliptic.csv" in read()
    # with its finished parabolic problems' table (rule rates_parabolic) beside it: both
    (other / "rates-parabolic.csv").write_text("example\n")
    assert f"{other}/rates-elliptic.csv" in read() and f"{other}/rates-parabolic.csv" in read()
    (other / "rates.csv").write_text("example\n")
    assert f"{other}/rates.csv" in read() and f"{other}/rates-elliptic" not in read()
    assert f"{other}/rates-parabolic" not in read()
    # the elliptic table of this tier alone needs no parabolic run
    _, text = dry_run(*args[:-1], f"{tmp_path}/o/rates-elliptic.csv")
    assert "para_" not in text and "rule rates_elliptic" in text


def test_rate_table_of_the_kept_parabolic_problems_runs_nothing_else(tmp_path):
    """rates_parabolic fits the kept error tables this configuration reads (the paper-scale
    tier: the committed Example 5 table) and schedules no run; a tier without kept tables
    (the default's parabolic.kept_errors is null) is told so before anything runs."""
    target = "paper-figures/paper-scale/rates-parabolic.csv"
    _, text = dry_run("--configfile", "config/paper.yaml", "--forceall", "--", target)
    assert job_counts(text) == {"rates_parabolic": 1}
    inputs = text.split("rule rates_parabolic:")[1].split("output:")[0]
    assert "workflow/data/tables/paper-scale/ex5-errors.csv" in inputs
    assert "paper-figures/rates.csv" in inputs        # the default tier's rates beside them
    code, text = dry_run("--config", f"results_dir={tmp_path}/r", f"output_root={tmp_path}/o",
                         "--", f"{tmp_path}/o/rates-parabolic.csv", ok=False)
    assert code != 0 and "parabolic.kept_errors is null" in text
    (tmp_path / "kept").mkdir()
    (tmp_path / "k.yaml").write_text(f"parabolic:\n  kept_errors: {tmp_path}/kept\n")
    code, text = dry_run("--configfile", "config/paper.yaml", str(tmp_path / "k.yaml"),
                         "--", "rates_parabolic", ok=False)
    assert code != 0 and "holds no <problem>-errors.csv of ex4-u1, ex4-u2, ex5" in text


def test_time_split_of_a_kept_problem_reruns_its_first_passes_only():
    """para_time_split reruns Algorithm C's first passes itself and reads only the reference
    error and graded runs of the errors table: with Example 5's kept table (paper-scale
    tier) it needs the reference's family, not Algorithm C's run nor the series."""
    _, text = dry_run("--configfile", "config/paper.yaml", "--forceall", "--",
                      "paper-figures/paper-scale/ex5-time-split.md")
    jobs = job_counts(text)
    assert jobs["para_time_split"] == 1 and "para_reference_family" in jobs
    assert not {"para_adaptive", "para_errors", "para_solve"} & set(jobs)
    split = text.split("rule para_time_split:")[1].split("output:")[0]
    assert "workflow/data/tables/paper-scale/ex5-errors.csv" in split


def test_kept_error_tables_replace_the_runs_they_were_made_from(tmp_path):
    """parabolic.kept_errors: Figure 15 of the paper-scale tier reads Example 5's kept error
    table (the committed one, with the settings it was made with beside it) where it exists
    and this configuration would make the same, and then runs none of Example 5's jobs.
    Without it, with any setting that decides its rows changed (Algorithm C's, its limits,
    the series' time steps, the reference's family), without its settings record, with
    other series runs, or damaged, the table is computed and the log says why; keeping one
    without that folder is refused, naming the key."""
    import pandas as pd
    committed = ROOT / "workflow" / "data" / "tables" / "paper-scale" / "ex5-errors.csv"
    kept = tmp_path / "kept"

    def jobs(extra=""):
        return kept_dry_run(tmp_path, "parabolic", kept, "fig15-ex5-error.png", extra)
    counts, _ = jobs()
    assert counts["para_errors"] == 1 and counts["para_adaptive"] == 1
    kept.mkdir()
    for suffix in (".csv", ".json"):
        shutil.copyfile(committed.with_suffix(suffix), kept / f"ex5-errors{suffix}")
    counts, text = jobs()
    assert counts == {"fig_para_error": 1} and f"{kept}/ex5-errors.csv" in text
    for extra, named in [("  adaptive:\n    theta: 0.6\n", "adaptive"),
                         ("  adaptive:\n    max_iterations: 5\n", "adaptive"),
                         ("  tau_factor: {uniform: 2.0, graded: 0.5, graded-sr: 0.5}\n",
                          "tau_factor"),
                         ("  reference:\n    tau_factor: 0.1\n", "reference")]:
        counts, text = jobs(extra)
        assert counts["para_errors"] == 1, extra
        assert f"differs from this configuration in {named}" in text, extra
    d = pd.read_csv(committed)
    d[d.tag != "L5"].to_csv(kept / "ex5-errors.csv", index=False)
    counts, text = jobs()
    assert counts["para_errors"] == 1 and "series runs" in text
    (kept / "ex5-errors.csv").write_text("example\n1\n")           # no family column
    counts, text = jobs()
    assert counts["para_errors"] == 1 and "unreadable" in text
    shutil.copyfile(committed, kept / "ex5-errors.csv")
    (kept / "ex5-errors.json").unlink()
    counts, text = jobs()
    assert counts["para_errors"] == 1 and "unreadable" in text
    code, text = dry_run("--config", f"results_dir={tmp_path}/r", "--",
                         f"{tmp_path}/r/para/ex5/errors-kept.txt", ok=False)
    assert code != 0 and "parabolic.kept_errors=None" in text


def test_kept_elliptic_error_tables_replace_the_runs_they_were_made_from(tmp_path):
    """reference.kept_errors: elliptic-errors.md of the paper-scale tier reads Examples 2 and
    3's kept error tables and reference records (the committed ones, with the settings they
    were made with beside them) where this configuration would make the same, and then runs
    only Example 1's jobs. With a setting that decides their rows changed (Algorithm B's,
    Example 3's series, the solver's), without a settings record, the reference record or
    the table, or with a damaged table, a problem's errors are computed and the log says why;
    keeping one without that folder is refused, naming the key."""
    committed = ROOT / "workflow" / "data" / "tables" / "paper-scale"
    problems = ["ex2", "ex3-printed", "ex3-signchange"]
    kept = tmp_path / "kept"

    def jobs(extra=""):
        return kept_dry_run(tmp_path, "reference", kept, "elliptic-errors.md", extra)
    counts, _ = jobs()
    assert counts["vi_errors"] == 3 and counts["vi_adaptive"] == 3
    kept.mkdir()
    for problem in problems:
        for name in ("vi-errors.csv", "vi-errors.json", "vi-reference.json"):
            shutil.copyfile(committed / f"{problem}-{name}", kept / f"{problem}-{name}")
    counts, text = jobs()
    assert set(counts) == {"ex1_solve", "ex1_adaptive", "ex1_table", "reference_table"}
    assert f"{kept}/ex2-vi-errors.csv" in text and f"{kept}/ex3-printed-vi-reference.json" in text
    for extra, named, computed in [("vi_adaptive:\n  theta: 0.6\n", "adaptive", 3),
                                   ("example3:\n  graded_h: [0.4, 0.2]\n", "series", 2),
                                   ("solver:\n  tol: 1.0e-9\n", "solver", 3)]:
        counts, text = jobs(extra)
        assert counts.get("vi_errors") == computed, extra
        assert re.search(rf"differs from this configuration in [^:]*\b{named}\b", text), extra
    (kept / "ex2-vi-reference.json").unlink()
    counts, text = jobs()
    assert counts["vi_errors"] == 1 and "no reference record" in text
    (kept / "ex3-printed-vi-errors.json").unlink()
    counts, text = jobs()
    assert counts["vi_errors"] == 2 and "unreadable" in text
    (kept / "ex3-signchange-vi-errors.csv").write_text("example\n1\n")     # no family column
    counts, text = jobs()
    assert counts["vi_errors"] == 3 and "no family column" in text
    (kept / "ex3-signchange-vi-errors.csv").unlink()                      # no table at all
    counts, text = jobs()
    assert counts["vi_errors"] == 3 and "unreadable" in text
    code, text = dry_run("--config", f"results_dir={tmp_path}/r", "--",
                         f"{tmp_path}/r/vi/ex2/errors-kept.txt", ok=False)
    assert code != 0 and "reference.kept_errors=None" in text


@pytest.mark.parametrize("choice, checked", [
    ({"graded-sr": 3}, {"uniform": "L5", "graded": "h0.05", "graded-sr": "r0.2"}),
    ({"uniform": 1, "graded": 1, "graded-sr": 1},
     {"uniform": "L6", "graded": "h0.025", "graded-sr": "r0.1"}),
    ({"graded": 4}, {"uniform": "L5", "graded": "h0.2", "graded-sr": "r0.2"}),
    ({"graded-sr": 2}, {"uniform": "L5", "graded": "h0.05", "graded-sr": "r0.14"}),
])
def test_quadrature_check_mesh(tmp_path, choice, checked):
    """example1.quadrature_check gives per family the rank (from the finest) of the run the
    quadrature check repeats; a family the extra configuration does not name keeps
    config.yaml's rank (2: the second finest; 3 for the shape-regular graded-sr)."""
    import yaml
    cfg = tmp_path / "q.yaml"
    cfg.write_text(yaml.safe_dump({"example1": {"quadrature_check": choice},
                                   "results_dir": f"{tmp_path}/r",
                                   "output_root": f"{tmp_path}/o"}))
    _, text = dry_run("--configfile", str(cfg), "--", f"{tmp_path}/o/ex1-quadrature-check.md")
    found = dict(re.findall(r"ex1-quadrature/([\w-]+)/s0\.5/([\w.]+)\.csv", text))
    assert found == checked


def test_quadrature_check_rank_beyond_the_series_is_refused(tmp_path):
    cfg = tmp_path / "q.yaml"
    cfg.write_text("example1:\n  quadrature_check: {graded-sr: 6}\n")
    code, text = dry_run("--configfile", str(cfg), ok=False)
    assert code != 0
    assert "example1.quadrature_check.graded-sr=6 must be a rank from 1 (the finest) to 5" in text



@pytest.mark.parametrize("changes, message", [
    ("{start_level: [5], theta: [], max_dofs: 1500}",
     "adaptive_changes.max_dofs=1500 must exceed the DOFs of every start mesh: "
     "disk_uniform(5) has 1985"),
    ("{start_level: [3], theta: [], max_dofs: 20000}",
     "adaptive_changes.max_dofs=20000 must be at most example1.adaptive.max_dofs=15000"),
])
def test_adaptive_changes_that_cannot_be_compared_are_refused(tmp_path, changes, message):
    """ex1-adaptive-rate.md fits a rate through every series from its start mesh, and cuts
    the unchanged series at the changed ones' size: refused before any job runs."""
    cfg = tmp_path / "a.yaml"
    cfg.write_text(f"example1:\n  adaptive_changes: {changes}\n")
    code, text = dry_run("--configfile", str(cfg), ok=False)
    assert code != 0 and message in text


@pytest.mark.parametrize("rings", ["[8, 15]", "[20, 3]"])
def test_graded_rings_that_miss_the_series_are_refused(tmp_path, rings):
    """ex2-graded-rings.md needs the graded series' ring counts (3 … 20 for graded_h 0.4 …
    0.05) among the ring counts it runs: refused before any job runs."""
    cfg = tmp_path / "a.yaml"
    cfg.write_text(f"example2:\n  graded_rings: {rings}\n")
    code, text = dry_run("--configfile", str(cfg), ok=False)
    assert code != 0
    assert (f"example2.graded_rings={rings} must be [first, last] ring counts, first <= "
            "last, holding the graded series' ring counts [3, 4, 5, 8, 10, 15, 20]") in text


@pytest.mark.parametrize("changes, message", [
    ("{max_dofs: 15000, reference_dofs: 14999}",
     "example2.adaptive_changes.reference_dofs=14999 must be at least its max_dofs=15000"),
    ("{start_level: [5], max_dofs: 5000}",       # T_H has 1985 interior nodes, T_h 8065
     "example2.adaptive_changes.max_dofs=5000 must exceed the DOFs of every start mesh: "
     "T_H = disk_uniform(5) gives T_h with 8065"),
])
def test_ex2_adaptive_changes_that_leave_nothing_to_measure_are_refused(tmp_path, changes,
                                                                        message):
    """ex2-adaptive-rate.md needs its reference step at or beyond the steps it measures,
    and two steps in every series: refused before any job runs."""
    cfg = tmp_path / "a.yaml"
    cfg.write_text(f"example2:\n  adaptive_changes: {changes}\n")
    code, text = dry_run("--configfile", str(cfg), ok=False)
    assert code != 0 and message in text


@pytest.mark.parametrize("changes, own", [
    ("{}", True),                                    # config.yaml: reference_dofs = max_dofs
    ("{reference_dofs: 20000}", False),              # runs on beyond vi_adaptive (paper tier)
])
def test_ex2_unchanged_series_is_vi_adaptives_where_it_stops_there(tmp_path, changes, own):
    """ex2-adaptive-rate.md's unchanged series: vi_adaptive's own (with every step's u_h)
    where it stops where vi_adaptive does, so no job solves its steps twice; its own
    vi_adaptive_change job where it runs on."""
    cfg = tmp_path / "a.yaml"
    cfg.write_text(f"example2:\n  adaptive_changes: {changes}\n"
                   f"results_dir: {tmp_path}/r\noutput_root: {tmp_path}/o\n")
    _, text = dry_run("--configfile", str(cfg), "--", f"{tmp_path}/o/ex2-adaptive-rate.md")
    jobs = job_counts(text)
    changed = 3   # config.yaml: start_level [1, 3], theta [0.75]
    assert jobs["vi_adaptive_change"] == changed + (not own)
    assert jobs["vi_adaptive"] == 1
    distances = text.split("rule vi_adaptive_distances:")[1].split("output:")[0]
    assert (f"{tmp_path}/r/vi/ex2/adaptive/meshes.npz" in distances) == own
    assert (f"{tmp_path}/r/vi/ex2/adaptive-changes/unchanged.npz" in distances) == (not own)


def test_jobs_needing_one_operator_assemble_it_once(tmp_path):
    """Example 4's two initial values on one mesh: the second job reads the operator the
    first assembled (fracfem.opcache), with the same matrix, so the same t_assembly and
    solution; its t_wall still counts the assembly; the cache goes after the run."""
    import numpy as np
    import pandas as pd
    import os
    res = tmp_path / "r"
    targets = [f"{res}/para/{p}/uniform/L4.csv" for p in ("ex4-u1", "ex4-u2")]
    env = {k: v for k, v in os.environ.items() if k != "FRACFEM_OPERATOR_CACHE"}
    out = subprocess.run(["snakemake", "--cores", "1", "--nolock", "--config",
                          f"results_dir={res}", f"output_root={tmp_path}/o", "--", *targets],
                         cwd=ROOT, capture_output=True, text=True, timeout=600, env=env)
    assert out.returncode == 0, out.stdout + out.stderr
    logs = [(res / "logs" / "para" / f"{p}_uniform_L4.log").read_text()
            for p in ("ex4-u1", "ex4-u2")]
    hit = ["operator cache" in text and "read back" in text for text in logs]
    assert sorted(hit) == [False, True]
    rows = [pd.read_csv(t).iloc[0] for t in targets]
    assert rows[0].t_assembly == rows[1].t_assembly > 0.1
    # the job that read the operator back still counts its assembly in its wall time
    r = rows[hit.index(True)]
    assert r.t_wall >= r.t_assembly + r.t_factorisation + r.t_steps
    assert not (res / "operators").exists()
    u = [np.load(t.replace(".csv", ".npz"))["U"] for t in targets]
    assert u[0].shape == u[1].shape and not np.allclose(u[0], u[1])   # two problems, one A
