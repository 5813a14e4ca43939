"""Reading the Markdown pages the workflow writes, for the tests that check them."""


def page_tables(text):
    """Every table of a Markdown page, in order: its rows (the separator left out), each a
    dict of its header's names to the row's cells, stripped."""
    tables, block = [], []
    for line in text.splitlines() + [""]:
        if line.startswith("|"):
            block.append([c.strip() for c in line.strip().strip("|").split("|")])
        elif block:
            head, _, *rows = block
            for r in rows:       # a bar inside a cell would shift every cell after it
                if len(r) != len(head):
                    raise ValueError(f"a row of {len(r)} cells under a header of {len(head)}: "
                                     f"{r}")
            tables.append([dict(zip(head, r)) for r in rows])
            block = []
    return tables
