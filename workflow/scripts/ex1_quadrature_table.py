"""Collect the quadrature checks into a Markdown table."""
import pandas as pd

from fracfem_workflow.io import atomic_path
from fracfem_workflow.logs import log_to

COLUMNS = ["family", "s", "tag", "dofs", "fu_h", "fu_h_raised", "change", "error_squared",
           "change_over_error_squared", "t_assembly_raised", "operator"]


def main(rows, md):
    df = pd.concat([pd.read_csv(f) for f in rows], ignore_index=True)
    if "operator" not in df:      # rows made before the run recorded its operator: dense
        df["operator"] = "dense"
    df["operator"] = df["operator"].fillna("dense")
    with atomic_path(md) as tmp:
        tmp.write_text(df[COLUMNS].to_markdown(index=False, floatfmt=".6g") + "\n")


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    main(list(snakemake.input.rows), snakemake.output.md)  # noqa: F821
