"""Concatenate one-row CSV files into a tidy table."""
import pandas as pd

from fracfem.io import write_table


def main(inputs, output):
    df = pd.concat([pd.read_csv(f) for f in inputs], ignore_index=True)
    write_table(df.sort_values(["s", "family", "dofs"]), output)


if __name__ == "__main__":
    main(list(snakemake.input), snakemake.output.table)  # noqa: F821
