"""workflow/scripts/profile_resources.py: benchmark files -> per-rule SLURM resources."""
import importlib.util
import shutil
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "profile_resources", ROOT / "workflow" / "scripts" / "profile_resources.py")
pr = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(pr)

# margins fixed here so the expected numbers do not follow the script's defaults
MARGINS = dict(mem_factor=1.5, mem_overhead=512, mem_floor=1024, runtime_factor=3.0,
               runtime_overhead=5, runtime_floor=10)
HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time\n"

RULES = [
    pr.RuleInfo("solve", "ex1/{family,uniform|graded}_s{s,[0-9.]+}_{tag,L[0-9]+|h[0-9.e-]+}.tsv",
                threads=2),
    pr.RuleInfo("adaptive", "ex1/adaptive_s{s,[0-9.]+}.tsv", threads=2),
    pr.RuleInfo("fig", "figures/fig{num,07|09}-{slug}.tsv", threads=1, local=True),
    pr.RuleInfo("never_run", "other/never.tsv", threads=2),
]


def bench(path, s, rss, cpu=None, rows=1):
    path.parent.mkdir(parents=True, exist_ok=True)
    cpu = s if cpu is None else cpu
    line = f"{s}\t0:00:01\t{rss}\t1\t1\t1\t0\t0\t50\t{cpu}\n"
    path.write_text(HEADER + line * rows)


def test_pattern_regex_respects_constraints_and_repeats():
    rx = pr.pattern_regex("vi/{problem,ex2|ex3-\\w+}_{family,uniform|graded}_{tag}.tsv")
    m = rx.match("vi/ex3-printed_graded_h0.28.tsv")
    assert m and m["problem"] == "ex3-printed" and m["tag"] == "h0.28"
    assert rx.match("vi/ex2_adaptive.tsv") is None           # family constraint
    assert rx.match("vi/ex2_uniform_L3.tsv.bak") is None      # anchored at the end
    assert rx.match("xvi/ex2_uniform_L3.tsv") is None         # literal text escaped
    assert pr.pattern_regex("a/{x,[0-9]{2}}.tsv").match("a/12.tsv")   # braces in a constraint
    assert not pr.pattern_regex("a/{x,[0-9]{2}}.tsv").match("a/123.tsv")
    rep = pr.pattern_regex("{a}/{a}.tsv")
    assert rep.match("x/x.tsv") and not rep.match("x/y.tsv")
    with pytest.raises(ValueError):
        pr.pattern_regex("a/{x.tsv")


def test_assign_maps_each_file_to_its_rule_and_reports_strays():
    files = ["ex1/uniform_s0.5_L2.tsv", "ex1/adaptive_s0.5.tsv", "figures/fig07-ex2-error.tsv",
             "ex1/foo.tsv"]
    by_rule, unmatched = pr.assign(files, RULES)
    assert by_rule["solve"] == ["ex1/uniform_s0.5_L2.tsv"]
    assert by_rule["adaptive"] == ["ex1/adaptive_s0.5.tsv"]
    assert by_rule["fig"] == ["figures/fig07-ex2-error.tsv"]
    assert by_rule["never_run"] == []
    assert unmatched == ["ex1/foo.tsv"]


def test_a_file_claimed_by_two_rules_is_an_error():
    rules = [pr.RuleInfo("a", "x/{name}.tsv"), pr.RuleInfo("b", "x/{id,[0-9]+}.tsv")]
    with pytest.raises(ValueError, match="matches rules a, b"):
        pr.assign(["x/12.tsv"], rules)


def test_read_benchmark_takes_the_max_over_repeats_and_skips_missing_values(tmp_path):
    f = tmp_path / "b.tsv"
    f.write_text(HEADER + "3.0\t-\t100\t1\t1\t1\t0\t0\t50\t2.0\n"
                 "5.0\t-\tNA\t1\t1\t1\t0\t0\t50\t9.0\n")
    s, rss, cpu = pr.read_benchmark(f)
    assert (s, rss, cpu) == (5.0, 100.0, 9.0)
    (tmp_path / "bad.tsv").write_text("s\th:m:s\n1\t0\n")
    with pytest.raises(ValueError, match="max_rss"):
        pr.read_benchmark(tmp_path / "bad.tsv")


def test_recommend_takes_the_max_over_wildcards_with_the_margins(tmp_path):
    bench(tmp_path / "ex1/uniform_s0.5_L2.tsv", 10.0, 200)
    bench(tmp_path / "ex1/graded_s0.5_h0.1.tsv", 700.0, 3000, cpu=1300.0)
    bench(tmp_path / "ex1/adaptive_s0.5.tsv", 30.0, 100)
    bench(tmp_path / "figures/fig09-ex3-error.tsv", 2.0, 150)
    recs, unmatched = pr.compute(RULES, tmp_path, **MARGINS)
    assert unmatched == []
    solve = recs["solve"]
    # mem: 1.5 * 3000 + 512 = 5012 -> 5120 (256 steps); runtime: ceil(3 * 700 / 60) + 5 = 40
    assert (solve.threads, solve.mem_mb, solve.runtime) == (2, 5120, 40)
    assert len(solve.measured.files) == 2 and solve.measured.max_load == pytest.approx(13 / 7)
    # small jobs get the floors: 1024 MB and 10 minutes
    assert (recs["adaptive"].mem_mb, recs["adaptive"].runtime) == (1024, 10)
    assert recs["fig"].threads == 1
    # no file: conservative defaults, flagged as unmeasured
    never = recs["never_run"]
    assert never.measured is None
    assert (never.threads, never.mem_mb, never.runtime) == (2, pr.DEFAULT_MEM_MB,
                                                             pr.DEFAULT_RUNTIME)


def test_fit_threads_lowers_only_long_serial_rules(tmp_path):
    bench(tmp_path / "ex1/uniform_s0.5_L2.tsv", 100.0, 200, cpu=105.0)   # serial, long
    bench(tmp_path / "ex1/adaptive_s0.5.tsv", 20.0, 200, cpu=20.0)       # serial, too short
    recs, _ = pr.compute(RULES, tmp_path, fit_threads=True)
    assert recs["solve"].threads == 1
    assert recs["adaptive"].threads == 2
    recs, _ = pr.compute(RULES, tmp_path)                                # off by default
    assert recs["solve"].threads == 2


def test_the_block_replaces_only_itself_and_is_valid_yaml(tmp_path):
    bench(tmp_path / "ex1/uniform_s0.5_L2.tsv", 10.0, 200)
    recs, _ = pr.compute(RULES, tmp_path, **MARGINS)
    block = pr.render_block(recs, RULES, source="fake run", margins="m")
    profile = ("# fill in\ndefault-resources:\n  slurm_account: \"${ACC}\"\n"
               "executor: slurm\n")
    once = pr.replace_block(profile, block)
    assert once.startswith(profile)
    twice = pr.replace_block(once + "jobs: 5\n", block)      # text after the block is kept
    assert twice == once + "jobs: 5\n"
    changed = pr.replace_block(once, block.replace("mem_mb: 1024", "mem_mb: 2048", 1))
    assert changed != once and changed.count(pr.BEGIN) == 1
    data = yaml.safe_load(once)
    assert data["default-resources"]["slurm_account"] == "${ACC}"
    assert set(data["set-threads"]) == {r.name for r in RULES}
    assert data["set-resources"]["solve"] == {"mem_mb": 1024, "runtime": 10}
    assert data["set-resources"]["never_run"] == {"mem_mb": pr.DEFAULT_MEM_MB,
                                                  "runtime": pr.DEFAULT_RUNTIME}
    assert "without a benchmark file (conservative defaults): adaptive, fig, never_run" in once
    with pytest.raises(ValueError, match="damaged"):
        pr.replace_block(profile + pr.BEGIN + "\n", block)


@pytest.mark.skipif(shutil.which("snakemake") is None, reason="snakemake is not installed")
def test_every_rule_of_the_workflow_has_a_benchmark_pattern_and_the_profile_covers_it(
        monkeypatch):
    import os
    monkeypatch.delenv("FRACFEM_OPERATOR_CACHE", raising=False)
    rules = pr.load_rules(ROOT / "Snakefile", [ROOT / "config" / "ci.yaml"], ROOT)
    # reading the workflow turns no operator cache on in the reader (only a run's onstart)
    assert "FRACFEM_OPERATOR_CACHE" not in os.environ
    names = {r.name for r in rules}
    assert {"ex1_solve", "vi_solve", "para_solve", "fig02", "rates"} <= names
    assert "all" not in names
    assert all(r.pattern for r in rules), [r.name for r in rules if not r.pattern]
    assert {r.name for r in rules if r.local} >= {"fig02", "rates"}
    assert not any(r.local for r in rules if r.name.endswith("_solve"))
    # the committed profile has threads, mem_mb and runtime for every rule
    profile = yaml.safe_load((ROOT / "profiles" / "slurm" / "config.yaml").read_text())
    assert set(profile["set-threads"]) == names
    for name in names:
        assert set(profile["set-resources"][name]) == {"mem_mb", "runtime"}, name
    assert set(profile["default-resources"]) >= {"slurm_account", "slurm_partition"}


def test_a_rule_left_out_of_a_later_run_keeps_its_earlier_measurement(tmp_path):
    """The block of a run where 'adaptive' was measured, then a run without it: 'adaptive'
    keeps its resources, marked as from an earlier run; a rule never measured stays at
    the defaults."""
    bench(tmp_path / "b1" / "ex1" / "adaptive_s0.5.tsv", 1200.0, 9000.0)
    bench(tmp_path / "b1" / "ex1" / "uniform_s0.5_L3.tsv", 10.0, 500.0)
    recs, _ = pr.compute(RULES, tmp_path / "b1", **MARGINS)
    first = pr.render_block(recs, RULES, source="run 1", margins="m")
    bench(tmp_path / "b2" / "ex1" / "uniform_s0.5_L3.tsv", 12.0, 520.0)
    recs2, _ = pr.compute(RULES, tmp_path / "b2", **MARGINS)
    earlier = pr.previous_measurements(first)
    assert set(earlier) == {"adaptive", "solve"}
    assert recs2["adaptive"].measured is None
    kept = pr.recommend(RULES[1], earlier["adaptive"], **MARGINS)
    assert (kept.mem_mb, kept.runtime) == (recs["adaptive"].mem_mb, recs["adaptive"].runtime)
    recs2["adaptive"] = kept
    second = pr.render_block(recs2, RULES, source="run 2", margins="m")
    assert "# rules measured in an earlier run, kept: adaptive" in second
    assert "never_run" in second.split("kept:")[0]          # still without a benchmark
    assert pr.previous_measurements(second)["adaptive"].max_rss == 9000.0


def test_keep_larger_keeps_an_earlier_runs_larger_maxima_and_only_those(tmp_path):
    """A run whose 'solve' jobs were all small after one with a large job: by default the
    new measurement replaces the old; with keep_larger the rule keeps the earlier maxima
    (marked, and read back from the block), while a rule that grew keeps its new ones."""
    bench(tmp_path / "b1" / "ex1" / "uniform_s0.5_L5.tsv", 2600.0, 2500.0)
    bench(tmp_path / "b1" / "ex1" / "adaptive_s0.5.tsv", 100.0, 800.0)
    recs1, _ = pr.compute(RULES, tmp_path / "b1", **MARGINS)
    earlier = pr.previous_measurements(pr.render_block(recs1, RULES, source="1", margins="m"))
    bench(tmp_path / "b2" / "ex1" / "uniform_s0.5_L3.tsv", 120.0, 480.0)
    bench(tmp_path / "b2" / "ex1" / "adaptive_s0.5.tsv", 200.0, 1600.0)
    recs2, _ = pr.compute(RULES, tmp_path / "b2", **MARGINS)

    plain = pr.with_earlier(recs2, RULES, earlier, **MARGINS)
    assert plain["solve"] == recs2["solve"] and plain["adaptive"] == recs2["adaptive"]
    larger = pr.with_earlier(recs2, RULES, earlier, keep_larger=True, **MARGINS)
    assert (larger["solve"].mem_mb, larger["solve"].runtime) == (
        recs1["solve"].mem_mb, recs1["solve"].runtime)
    assert larger["solve"].mem_mb > recs2["solve"].mem_mb
    assert larger["adaptive"] == recs2["adaptive"]            # grew: its own maxima
    block = pr.render_block(larger, RULES, source="2", margins="m")
    assert "(--keep-larger): solve" in block
    assert "this run's and an earlier run's, the larger" in block
    back = pr.previous_measurements(block)
    assert (back["solve"].max_s, back["solve"].max_rss) == (2600.0, 2500.0)
    assert (back["adaptive"].max_s, back["adaptive"].max_rss) == (200.0, 1600.0)
    assert len(back["solve"].files) == 1          # this run's jobs, not a sum over runs


def test_keep_larger_takes_each_maximum_from_its_own_run_and_is_idempotent(tmp_path):
    """Earlier run longer but leaner than this one: the merge keeps the earlier time and
    this run's memory; a profile regenerated from the same benchmarks is the same
    profile, although the block records its maxima rounded (0.1 s, 1 MB)."""
    bench(tmp_path / "b1" / "ex1" / "uniform_s0.5_L5.tsv", 2600.0, 900.0)
    recs1, _ = pr.compute(RULES, tmp_path / "b1", **MARGINS)
    earlier = pr.previous_measurements(pr.render_block(recs1, RULES, source="1", margins="m"))
    bench(tmp_path / "b2" / "ex1" / "uniform_s0.5_L3.tsv", 120.0, 3000.0)
    recs2, _ = pr.compute(RULES, tmp_path / "b2", **MARGINS)
    mixed = pr.with_earlier(recs2, RULES, earlier, keep_larger=True, **MARGINS)["solve"]
    assert (mixed.measured.max_s, mixed.measured.max_rss) == (2600.0, 3000.0)
    assert mixed.runtime == recs1["solve"].runtime and mixed.mem_mb == recs2["solve"].mem_mb

    bench(tmp_path / "b3" / "ex1" / "adaptive_s0.5.tsv", 1.37, 85.6)   # rounds up in the block
    recs3, _ = pr.compute(RULES, tmp_path / "b3", **MARGINS)
    blocks = [pr.render_block(recs3, RULES, source="3", margins="m")]
    for _ in range(2):
        again = pr.with_earlier(recs3, RULES, pr.previous_measurements(blocks[-1]),
                                keep_larger=True, **MARGINS)
        blocks.append(pr.render_block(again, RULES, source="3", margins="m"))
    assert blocks[0] == blocks[1] == blocks[2]
