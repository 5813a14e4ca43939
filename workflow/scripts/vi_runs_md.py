"""Markdown table of the obstacle and friction runs."""
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to
from fracfem_workflow.report import markdown_table

COLUMNS = ["problem", "family", "dofs", "multipliers", "h_max", "iterations_uzawa",
           "iterations_pdas", "contact", "slip_plus", "slip_minus", "stick",
           "max_du_uzawa_pdas", "max_dlambda_uzawa_pdas", "t_assembly", "t_schur",
           "t_uzawa", "t_pdas"]
# counts, shown whole: contact, slip and stick are floats in the joined table where a
# problem has none (no slip in an obstacle problem), and blank there
COUNTS = ["dofs", "multipliers", "iterations_uzawa", "iterations_pdas", "contact",
          "slip_plus", "slip_minus", "stick"]


def main(tables, md):
    df = pd.concat([pd.read_csv(t) for t in tables], ignore_index=True)
    cols = [c for c in COLUMNS if c in df.columns]
    with atomic_path(md) as tmp:
        tmp.write_text(markdown_table(df[cols], COUNTS, digits=".3g") + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.tables), snakemake.output.md)  # noqa: F821
