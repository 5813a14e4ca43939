"""Reading the Markdown pages the workflow writes, for the tests that check them."""
import re


def row_cells(line, rule):
    """The cells of one table line, stripped, escaped bars read as bars. A line with bars
    where the table's separator line has them (an aligned table) is cut there, since a
    cell may hold a bar itself (max |λ|); any other line at its unescaped bars."""
    bars = [i for i, ch in enumerate(rule) if ch == "|"]
    if len(line) == len(rule) and all(line[i] == "|" for i in bars):
        cells = [line[a + 1:b] for a, b in zip(bars, bars[1:])]
    else:
        cells = re.split(r"(?<!\\)\|", line.strip()[1:-1])
    return [c.strip().replace("\\|", "|") for c in cells]


def _blocks(text):
    """Each table of a page as its lines: header, separator, rows."""
    block = []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            block.append(line.rstrip())
        elif block:
            if len(block) >= 2 and re.fullmatch(r"\|[\s:|-]+\|", block[1]):
                yield block
            block = []


def page_headers(text):
    """The column names of every table of a Markdown page, in order."""
    return [row_cells(head, rule) for head, rule, *_ in _blocks(text)]


def page_tables(text):
    """Every table of a Markdown page, in order: its rows (the separator left out), each a
    dict of its header's names to the row's cells."""
    tables = []
    for head, rule, *rows in _blocks(text):
        names = row_cells(head, rule)
        table = []
        for line in rows:        # a bar inside a cell would shift every cell after it
            cells = row_cells(line, rule)
            if len(cells) != len(names):
                raise ValueError(f"a row of {len(cells)} cells under a header of "
                                 f"{len(names)}: {cells}")
            table.append(dict(zip(names, cells)))
        tables.append(table)
    return tables
