"""Collect the quadrature checks into a Markdown table."""
import pandas as pd

from fracfem.io import atomic_path


def main(inputs, md):
    df = pd.concat([pd.read_csv(f) for f in inputs], ignore_index=True)
    with atomic_path(md) as tmp:
        tmp.write_text(df.to_markdown(index=False, floatfmt=".6g") + "\n")


if __name__ == "__main__":
    main(list(snakemake.input), snakemake.output.md)  # noqa: F821
