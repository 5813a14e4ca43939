"""Copy the pipeline's measured numbers into README.md and docs/*.md between markers, and
the column glossary into them and into the report's front page.

    python workflow/scripts/update_readme.py [--root paper-figures] [--check]

Each Markdown block <!-- BEGIN name --> ... <!-- END name --> is replaced by the file
<root>/<name>.md written by the pipeline (or by the column glossary of
``fracfem_workflow.glossary`` for the blocks ``glossary`` and ``glossary-full``), so
every number in the README and the docs comes from a pipeline output, never from
typing.  In report/workflow.rst the block between the comments ``.. BEGIN glossary-rst``
and ``.. END glossary-rst`` is the same glossary as reStructuredText.  ``--check``
changes nothing and exits 1 if a block is out of date.
"""
import argparse
import re
import sys
from pathlib import Path

from fracfem_workflow import glossary

ROOT = Path(__file__).resolve().parents[2]
BLOCK = re.compile(r"<!-- BEGIN ([\w.-]+) -->.*?<!-- END \1 -->", flags=re.S)
RST_BLOCK = re.compile(r"^\.\. BEGIN ([\w.-]+)\n.*?^\.\. END \1$", flags=re.S | re.M)
GENERATED = {"glossary": lambda: glossary.markdown(readme_only=True),
             "glossary-full": lambda: glossary.markdown()}
GENERATED_RST = {"glossary-rst": lambda: glossary.rst()}


def documents(root=ROOT):
    """The files whose blocks are generated."""
    return ([root / "README.md"] + sorted((root / "docs").glob("*.md"))
            + [root / "report" / "workflow.rst"])


def block_text(name, figures):
    if name in GENERATED:
        return GENERATED[name]()
    src = figures / f"{name}.md"
    if not src.exists():
        raise FileNotFoundError(f"{src} is missing: run the pipeline first")
    return src.read_text().strip()


def rst_block_text(name):
    if name not in GENERATED_RST:
        raise KeyError(f"unknown reStructuredText block {name!r}")
    return GENERATED_RST[name]()


def fill(text, figures):
    """`text` with every block replaced by its current content."""
    text = BLOCK.sub(lambda m: f"<!-- BEGIN {m.group(1)} -->\n"
                               f"{block_text(m.group(1), figures)}\n"
                               f"<!-- END {m.group(1)} -->", text)
    # RST comments end at the first blank line, so the content stands apart from them
    return RST_BLOCK.sub(lambda m: f".. BEGIN {m.group(1)}\n\n"
                                   f"{rst_block_text(m.group(1))}\n\n"
                                   f".. END {m.group(1)}", text)


def main(root="paper-figures", check=False):
    stale = []
    for doc in documents():
        text = doc.read_text()
        new = fill(text, ROOT / root)
        if new != text:
            stale.append(doc.relative_to(ROOT))
            if not check:
                doc.write_text(new)
    if check and stale:
        print("out of date: " + ", ".join(map(str, stale)), file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", default="paper-figures")
    ap.add_argument("--check", action="store_true")
    args = ap.parse_args()
    sys.exit(main(args.root, args.check))
