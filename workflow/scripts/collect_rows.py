"""Concatenate one-row CSV files into a tidy table."""
import pandas as pd

from fracfem_workflow.io import write_table
from fracfem_workflow.logs import log_to


def main(rows, table):
    df = pd.concat([pd.read_csv(f) for f in rows], ignore_index=True)
    write_table(df.sort_values(["s", "family", "dofs"]), table)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.rows), snakemake.output.table)  # noqa: F821
