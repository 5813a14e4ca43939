"""Output of the benchmark scripts: one Markdown table and the CSV of the same rows."""
from __future__ import annotations

import csv
from pathlib import Path
from typing import Callable


def markdown(rows: list[dict], columns: list[str], cell: Callable[[object, str], str]) -> str:
    """A Markdown table of ``rows`` with these columns, each value as cell(value, column)."""
    lines = ["| " + " | ".join(columns) + " |", "|" + "---|" * len(columns)]
    for r in rows:
        lines.append("| " + " | ".join(cell(r.get(c), c) for c in columns) + " |")
    return "\n".join(lines) + "\n"


def write(rows: list[dict], columns: list[str], table: str, csv_path: Path | None,
          md_path: Path | None) -> None:
    """The rows to ``csv_path`` and the table to ``md_path`` (each when given)."""
    if csv_path:
        with open(csv_path, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=columns)
            w.writeheader()
            w.writerows(rows)
    if md_path:
        md_path.write_text(table)
