"""Sum Snakemake's per-job benchmark files into a cost table (run after the pipeline).

    python workflow/scripts/pipeline_cost.py [--results results] [--out paper-figures]
                                             [--time-log FILE] [--configfile FILE]

Every job wrote seconds and peak RSS to results/benchmarks/ (its `benchmark:`
file).  The elliptic part is Examples 1–3 and the assembly benchmark, the parabolic
part Examples 4–5; figures and tables are the jobs that only read results.  The total
counts the jobs of `all` only (a dry run with --forceall lists their benchmark files; the
configuration is --configfile's): files of other targets or of earlier configurations
are listed as "not in `all`".  With `--cores 2` and the configuration's `job_threads: 1`
two jobs run at once, so the pipeline's wall time, which `/usr/bin/time -v` measures
(--time-log), is close to half the sum of job seconds.

--assembly: the CSV of `benchmarks/bench_assembly.py` run on the same machine the same day,
so that a reader can scale the times to another day's speed of a shared machine (its
finest level's assembly seconds are stated beside the committed benchmark's).

--time-log: the stderr of `/usr/bin/time -v snakemake --cores 2` (a run from an empty
results directory): its wall time and its largest process's peak memory are stated above
the table.
"""
import argparse
import re
import subprocess
from pathlib import Path

import pandas as pd

PARTS = {"ex1": "elliptic", "ex1-quadrature": "elliptic", "vi": "elliptic",
         "benchmark_assembly.tsv": "elliptic", "para": "parabolic",
         "figures": "figures and tables", "tables": "figures and tables"}


def benchmarks_of_all(results, configfile=None):
    """The benchmark files (relative to results/benchmarks) of the jobs of `all`."""
    cmd = ["snakemake", "-n", "--forceall", "--cores", "2"]
    if configfile:
        cmd += ["--configfile", str(configfile)]
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        raise SystemExit(f"{' '.join(cmd)} failed:\n{out.stdout}{out.stderr}")
    root = Path(results, "benchmarks")
    found = {str(Path(p).relative_to(root)) for p in re.findall(r"^\s+benchmark: (\S+)$",
                                                               out.stdout + out.stderr, re.M)
             if Path(p).is_relative_to(root)}
    if not found:
        raise SystemExit(f"no job of `all` writes its benchmark under {root}: --results must "
                         "be the configuration's results_dir (and --configfile the run's)")
    return found


def gnu_time(path):
    """(wall seconds, maximum resident set size in MB) from `/usr/bin/time -v` output."""
    text = Path(path).read_text()
    wall = rss = None
    for line in text.splitlines():
        key, _, value = line.strip().rpartition(": ")
        if key.startswith("Elapsed (wall clock) time"):
            parts = [float(x) for x in value.split(":")]
            wall = sum(x * 60 ** i for i, x in enumerate(reversed(parts)))
        elif key == "Maximum resident set size (kbytes)":
            rss = float(value) / 1024
    if wall is None or rss is None:
        raise SystemExit(f"--time-log {path}: no 'Elapsed (wall clock) time' or 'Maximum "
                         "resident set size' line: is it the output of /usr/bin/time -v?")
    return wall, rss


ROOT = Path(__file__).resolve().parents[2]      # the project's checkout


def job_threads(configfile=None):
    """The run's job_threads: config.yaml's, or --configfile's over it."""
    import yaml
    threads = yaml.safe_load((ROOT / "config.yaml").read_text()).get("job_threads", 2)
    if configfile:
        threads = (yaml.safe_load(Path(configfile).read_text()) or {}).get("job_threads",
                                                                           threads)
    return int(threads)


def speed_note(assembly_csv, committed=ROOT / "paper-figures" / "benchmark-assembly.csv"):
    """One sentence: the finest level's assembly seconds of the day's benchmark and of the
    committed one."""
    day = pd.read_csv(assembly_csv).sort_values("level").iloc[-1]
    ref = pd.read_csv(committed)
    ref = ref[ref.level == day.level]
    if ref.empty:
        raise SystemExit(f"--assembly {assembly_csv}: level {day.level} is not in {committed}")
    return (f"The same day, `benchmarks/bench_assembly.py` assembled level {int(day.level)} "
            f"({int(day.dofs):,} DOFs, {int(day.threads)} threads) in {day.assembly_s:.2f} s; "
            f"the committed `benchmark-assembly.md` took {ref.assembly_s.iloc[0]:.2f} s: the "
            f"machine ran {day.assembly_s / ref.assembly_s.iloc[0]:.2f}× as long that day.\n\n")


def main(results, out, time_log=None, configfile=None, in_all=None, assembly=None):
    """in_all: the benchmark files of `all`'s jobs (default: benchmarks_of_all of the
    configuration configfile)."""
    wall = gnu_time(time_log) if time_log else None
    in_all = benchmarks_of_all(results, configfile) if in_all is None else set(in_all)
    rows = []
    for f in sorted(Path(results, "benchmarks").rglob("*.tsv")):
        rel = f.relative_to(Path(results, "benchmarks"))
        part = PARTS.get(rel.parts[0], "other") if str(rel) in in_all else "not in `all`"
        d = pd.read_csv(f, sep="\t")
        rows.append({"part": part, "job": str(rel), "seconds": float(d.s.iloc[0]),
                     "cpu_seconds": float(d.cpu_time.iloc[0]),
                     "max_rss_mb": float(d.max_rss.iloc[0])})
    if not rows:
        raise SystemExit(f"no benchmark files under {Path(results, 'benchmarks')}: "
                         "run the pipeline first")
    df = pd.DataFrame(rows)
    summary = df.groupby("part").agg(jobs=("job", "size"), seconds=("seconds", "sum"),
                                     cpu_seconds=("cpu_seconds", "sum"),
                                     peak_rss_mb=("max_rss_mb", "max")).reset_index()
    of_all = df[df.part != "not in `all`"]
    total_s = of_all.seconds.sum()
    summary = pd.concat([summary, pd.DataFrame([{
        "part": "total of `all`", "jobs": len(of_all), "seconds": total_s,
        "cpu_seconds": of_all.cpu_seconds.sum(),
        "peak_rss_mb": of_all.max_rss_mb.max()}])], ignore_index=True)
    heavy = df.sort_values("seconds", ascending=False).head(8)
    head = ""
    threads = job_threads(configfile)
    if wall is not None:
        head = (f"The last run from an empty results directory took {_hms(wall[0])} wall time; "
                f"its largest process peaked at {wall[1] / 1024:.2f} GiB resident "
                "(`/usr/bin/time -v snakemake --cores 2"
                + (f" --configfile {configfile}" if configfile else "")
                + f"`, {threads} thread{'s' if threads > 1 else ''} per job).\n\n")
    if assembly is not None:
        head += speed_note(assembly)
    text = (head + "Per-job benchmarks of the last pipeline run (`results/benchmarks/`), summed by "
            f"part; peak_rss is the largest single job. The jobs of `all` sum to {total_s / 60:.0f} "
            "minutes"
            + (f"; two at a time on two cores, half of that is {total_s / 120:.0f} minutes"
               if threads == 1 else "") + ".\n\n"
            + summary.to_markdown(index=False, floatfmt=".1f")
            + "\n\nThe most expensive jobs:\n\n"
            + heavy.drop(columns="cpu_seconds").to_markdown(index=False, floatfmt=".1f")
            + "\n")
    Path(out, "pipeline-cost.md").write_text(text)
    print(text)


def _hms(seconds):
    """57 min 19 s; 1 h 02 min 33 s (no hours under one hour)."""
    h, rest = divmod(round(seconds), 3600)
    if not h:
        return f"{rest // 60} min {rest % 60:02d} s"
    return f"{h} h {rest // 60:02d} min {rest % 60:02d} s"


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", default="results")
    ap.add_argument("--out", default="paper-figures")
    ap.add_argument("--time-log", default=None,
                    help="stderr of /usr/bin/time -v snakemake --cores 2 (a run from scratch)")
    ap.add_argument("--configfile", default=None,
                    help="the run's --configfile, if any (which jobs `all` has)")
    ap.add_argument("--assembly", default=None,
                    help="CSV of benchmarks/bench_assembly.py run the same day (machine speed)")
    a = ap.parse_args()
    main(a.results, a.out, a.time_log, a.configfile, assembly=a.assembly)
