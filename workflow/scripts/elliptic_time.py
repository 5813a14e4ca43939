"""Error against wall time for Examples 1–3 and the time each family needs for a
common error level (the smallest error every family reaches)."""
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).parent))
from plotstyle import MARKERS, plt, save  # noqa: E402

from fracfem.io import atomic_path  # noqa: E402


def time_to_reach(g, level):
    """Wall time at which the series first reaches `level` (log-log interpolation)."""
    g = g.sort_values("t_wall")
    e, t = np.log(g.error.values), np.log(g.t_wall.values)
    for k in range(len(e)):
        if e[k] <= np.log(level):
            if k == 0:
                return float(np.exp(t[0]))
            w = (e[k - 1] - np.log(level)) / (e[k - 1] - e[k])
            return float(np.exp(t[k - 1] + w * (t[k] - t[k - 1])))
    return np.nan


def time_panel(ax, d, name, xlabel="wall time [s]"):
    """Error against wall time of every family of d on ax; the time each family needs
    for the smallest error all of them reach, as one row of the summary table."""
    level = d.groupby("family").error.min().max()
    times = {}
    for fam, g in d.groupby("family"):
        g = g.sort_values("t_wall")
        ax.loglog(g.t_wall, g.error, marker=MARKERS[fam], label=fam)
        times[fam] = time_to_reach(g, level)
    ax.axhline(level, color="grey", lw=0.6, ls="--")
    ax.set_title(name, fontsize=9)
    ax.set_xlabel(xlabel)
    ax.legend(fontsize=7)
    best = min(times, key=times.get)
    return {"common error": level, **{f"t_{k} [s]": v for k, v in sorted(times.items())},
            "fastest": best, "speed-up vs slowest": max(times.values()) / times[best]}


def main(ex1_csv, vi_csvs, s, png, md):
    ex1 = pd.read_csv(ex1_csv)
    ex1 = ex1[np.isclose(ex1.s, s)].copy()
    ex1["t_wall"] = np.where(ex1.family == "adaptive", ex1.t_cumulative, ex1.t_total)
    ex1["name"] = "Example 1"
    frames = [ex1[["name", "family", "dofs", "error", "t_wall"]]]
    for csv in vi_csvs:
        d = pd.read_csv(csv)
        var = d.variant.fillna("").iloc[0]
        d["name"] = f"Example {d.example.iloc[0]}" + (f" ({var})" if var else "")
        frames.append(d[["name", "family", "dofs", "error", "t_wall"]])
    df = pd.concat(frames, ignore_index=True)
    names = list(dict.fromkeys(df.name))
    fig, axes = plt.subplots(1, len(names), figsize=(4.2 * len(names), 3.8), squeeze=False)
    rows = []
    for ax, name in zip(axes[0], names):
        rows.append({"example": name, **time_panel(ax, df[df.name == name], name)})
    axes[0][0].set_ylabel("energy error")
    fig.suptitle("Error against wall time (adaptive: all steps so far; VI: PDAS solve)")
    save(fig, png)
    with atomic_path(md) as tmp:
        tmp.write_text(pd.DataFrame(rows).to_markdown(index=False, floatfmt=".4g") + "\n")


if __name__ == "__main__":
    main(snakemake.input.ex1, list(snakemake.input.vi), snakemake.params.s,  # noqa: F821
         snakemake.output.png, snakemake.output.md)  # noqa: F821
