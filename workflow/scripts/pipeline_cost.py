"""Sum Snakemake's per-job benchmark files into a cost table (run after the pipeline).

    python workflow/scripts/pipeline_cost.py [--results results] [--out paper-figures]

Every job wrote seconds and peak RSS to results/benchmarks/ (its `benchmark:`
file).  The elliptic part is Examples 1–3 and the assembly benchmark, the parabolic
part Examples 4–5; figures and tables are the jobs that only read results.  With `--cores 2` and two threads per job the jobs run one after
another, so the sum of job seconds is close to the pipeline's wall time.
"""
import argparse
from pathlib import Path

import pandas as pd

PARTS = {"ex1": "elliptic", "ex1-quadrature": "elliptic", "vi": "elliptic",
         "benchmark_assembly.tsv": "elliptic", "para": "parabolic",
         "figures": "figures and tables", "tables": "figures and tables",
         "stability.tsv": "stability (not in `all`)",
         "stability_vi.tsv": "stability (not in `all`)"}


def main(results, out):
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
    heavy = df.sort_values("seconds", ascending=False).head(8)
    text = ("Per-job benchmarks of the last pipeline run (`results/benchmarks/`), summed by "
            "part; peak_rss is the largest single job.\n\n"
            + summary.to_markdown(index=False, floatfmt=".1f")
            + "\n\nThe most expensive jobs:\n\n"
            + heavy.to_markdown(index=False, floatfmt=".1f") + "\n")
    Path(out, "pipeline-cost.md").write_text(text)
    print(text)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--results", default="results")
    ap.add_argument("--out", default="paper-figures")
    a = ap.parse_args()
    main(a.results, a.out)
