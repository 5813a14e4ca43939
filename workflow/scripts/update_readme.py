"""Copy the pipeline's measured tables into README.md between markers.

    python workflow/scripts/update_readme.py [--root paper-figures]

Each block <!-- BEGIN name --> ... <!-- END name --> is replaced by the file
<root>/<name>.md written by the pipeline, so every number in the README comes
from a pipeline output, never from typing.
"""
import argparse
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def main(root):
    readme = ROOT / "README.md"
    text = readme.read_text()

    def repl(m):
        src = ROOT / root / f"{m.group(1)}.md"
        if not src.exists():
            raise SystemExit(f"{src} is missing: run the pipeline first")
        return f"<!-- BEGIN {m.group(1)} -->\n{src.read_text().strip()}\n<!-- END {m.group(1)} -->"

    new = re.sub(r"<!-- BEGIN ([\w.-]+) -->.*?<!-- END \1 -->", repl, text, flags=re.S)
    readme.write_text(new)


if __name__ == "__main__":
    ap = argparse.ArgumentParser()
    ap.add_argument("--root", default="paper-figures")
    main(ap.parse_args().root)
