"""Sum Snakemake's per-job benchmark files into a cost table (run after the pipeline).

    python workflow/scripts/pipeline_cost.py [--results results] [--out paper-figures]
                                             [--time-log FILE]

--time-log: the stderr of `/usr/bin/time -v snakemake --cores 2` (a run from an empty
results directory): its wall time and peak memory are stated above the table.

Every job wrote seconds and peak RSS to results/benchmarks/ (its `benchmark:`
file).  The elliptic part is Examples 1–3 and the assembly benchmark, the parabolic
part Examples 4–5; figures and tables are the jobs that only read results.  With `--cores 2`
the two-thread jobs run one after another, but the one-thread runs of the mesh series
(profiles/default) run two at a time, so the sum of job seconds exceeds the pipeline's wall
time; that is measured by `/usr/bin/time` (--time-log).
"""
import argparse
from pathlib import Path

import pandas as pd

PARTS = {"ex1": "elliptic", "ex1-quadrature": "elliptic", "vi": "elliptic",
         "benchmark_assembly.tsv": "elliptic", "para": "parabolic",
         "figures": "figures and tables", "tables": "figures and tables",
         "stability.tsv": "stability (not in `all`)",
         "stability_vi.tsv": "stability (not in `all`)"}


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


def main(results, out, time_log=None):
    wall = gnu_time(time_log) if time_log else None
    rows = []
    for f in sorted(Path(results, "benchmarks").rglob("*.tsv")):
        rel = f.relative_to(Path(results, "benchmarks"))
        part = PARTS.get(rel.parts[0], "other")
        d = pd.read_csv(f, sep="\t")
        rows.append({"part": part, "job": str(rel), "seconds": float(d.s.iloc[0]),
                     "max_rss_mb": float(d.max_rss.iloc[0])})
    if not rows:
        raise SystemExit(f"no benchmark files under {Path(results, 'benchmarks')}: "
                         "run the pipeline first")
    df = pd.DataFrame(rows)
    summary = df.groupby("part").agg(jobs=("job", "size"), seconds=("seconds", "sum"),
                                     peak_rss_mb=("max_rss_mb", "max")).reset_index()
    in_all = df[~df.part.str.contains("not in `all`")]
    summary = pd.concat([summary, pd.DataFrame([{
        "part": "total of `all`", "jobs": len(in_all), "seconds": in_all.seconds.sum(),
        "peak_rss_mb": in_all.max_rss_mb.max()}])], ignore_index=True)
    minutes = in_all.seconds.sum() / 60
    heavy = df.sort_values("seconds", ascending=False).head(8)
    head = ""
    if wall is not None:
        head = (f"The last run from an empty results directory took {_hms(wall[0])} wall time "
                f"with a peak resident memory of {wall[1] / 1024:.2f} GB "
                "(`/usr/bin/time -v snakemake --cores 2`).\n\n")
    text = (head + "Per-job benchmarks of the last pipeline run (`results/benchmarks/`), summed by "
            f"part; peak_rss is the largest single job. The jobs of `all` sum to {minutes:.0f} "
            "minutes.\n\n"
            + summary.to_markdown(index=False, floatfmt=".1f")
            + "\n\nThe most expensive jobs:\n\n"
            + heavy.to_markdown(index=False, floatfmt=".1f") + "\n")
    Path(out, "pipeline-cost.md").write_text(text)
    print(text)


def _hms(seconds):
    h, rest = divmod(round(seconds), 3600)
    return f"{h} h {rest // 60:02d} min {rest % 60:02d} s"


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", default="results")
    ap.add_argument("--out", default="paper-figures")
    ap.add_argument("--time-log", default=None,
                    help="stderr of /usr/bin/time -v snakemake --cores 2 (a run from scratch)")
    a = ap.parse_args()
    main(a.results, a.out, a.time_log)
