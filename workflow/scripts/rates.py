"""The rate table: ours next to the paper's (CSV, Markdown, LaTeX)."""
import pandas as pd

from fracfem.io import atomic_path, write_table
from fracfem.report import rate_table


def main(tables, csv, md, tex):
    frames = []
    for t in tables:
        d = pd.read_csv(t)
        if "spacetime_dofs" in d:      # parabolic: rates against space-time DOFs
            d = d.assign(dofs=d.spacetime_dofs)
        frames.append(d)
    df = pd.concat(frames, ignore_index=True)
    rates = rate_table(df)
    rates["difference"] = (rates.rate - rates.paper_rate).round(3)
    write_table(rates, csv)
    with atomic_path(md) as tmp:
        tmp.write_text(rates.to_markdown(index=False, floatfmt="g") + "\n")
    with atomic_path(tex) as tmp:
        tmp.write_text(to_latex(rates))


def to_latex(df):
    """A plain tabular environment (no jinja2 needed)."""
    def cell(v):
        if isinstance(v, float):
            return "--" if pd.isna(v) else f"{v:.3f}"
        return str(v).replace("_", r"\_")
    lines = [r"\begin{tabular}{" + "l" * len(df.columns) + "}", r"\hline",
             " & ".join(cell(c) for c in df.columns) + r" \\", r"\hline"]
    lines += [" & ".join(cell(v) for v in row) + r" \\" for row in df.itertuples(index=False)]
    lines += [r"\hline", r"\end{tabular}", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    main([snakemake.input.ex1] + list(snakemake.input.vi)  # noqa: F821
         + list(snakemake.input.para),  # noqa: F821
         snakemake.output.csv, snakemake.output.md, snakemake.output.tex)  # noqa: F821
