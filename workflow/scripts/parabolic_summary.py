"""Table of every parabolic run and error against wall time (Examples 4, 5)."""
import sys
from pathlib import Path

import pandas as pd

sys.path.insert(0, str(Path(__file__).parent))
from elliptic_time import time_to_reach  # noqa: E402
from plotstyle import MARKERS, plt, save  # noqa: E402

from fracfem.io import atomic_path  # noqa: E402


def main(csvs, md, png):
    df = pd.concat([pd.read_csv(c) for c in csvs], ignore_index=True)
    cols = ["problem", "family", "tag", "dofs", "steps", "spacetime_dofs", "error", "eta",
            "first_contact", "t_wall", "peak_mem_mb", "reference_error_estimate"]
    table = df[[c for c in cols if c in df]].sort_values(["problem", "family",
                                                          "spacetime_dofs"])
    fig, axes = plt.subplots(1, len(csvs), figsize=(4.2 * len(csvs), 3.8), squeeze=False)
    fastest = []
    for ax, (prob, d) in zip(axes[0], df.groupby("problem")):
        level = d.groupby("family").error.min().max()
        times = {}
        for fam, g in d.groupby("family"):
            g = g.sort_values("t_wall")
            ax.loglog(g.t_wall, g.error, marker=MARKERS[fam], label=fam)
            times[fam] = time_to_reach(g, level)
        best = min(times, key=times.get)
        fastest.append({"problem": prob, "common error": level,
                        **{f"t_{k} [s]": v for k, v in sorted(times.items())},
                        "fastest": best,
                        "speed-up vs slowest": max(times.values()) / times[best]})
        ax.axhline(level, color="grey", lw=0.6, ls="--")
        ax.set_title(prob, fontsize=9)
        ax.set_xlabel("wall time [s] (adaptive: all passes so far)")
        ax.legend(fontsize=7)
    axes[0][0].set_ylabel(r"$L^2(0,T;H^s)$ error vs reference")
    save(fig, png)
    with atomic_path(md) as tmp:
        tmp.write_text("Time each family needs to reach the smallest error all of them reach "
                       "(wall time of the run; adaptive: all passes so far, without the error "
                       "measurement):\n\n"
                       + pd.DataFrame(fastest).to_markdown(index=False, floatfmt=".4g")
                       + "\n\nEvery run:\n\n"
                       + table.to_markdown(index=False, floatfmt=".4g") + "\n")


if __name__ == "__main__":
    main(list(snakemake.input.csv), snakemake.output.md, snakemake.output.png)  # noqa: F821
