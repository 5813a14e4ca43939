"""The README and docs/: runnable snippets, generated numbers in sync, every column defined."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))
BLOCKS = [(doc.name, block) for doc in DOCS
          for block in re.findall(r"^```python\n(.*?)^```", doc.read_text(), flags=re.S | re.M)]

sys.path.insert(0, str(ROOT / "workflow" / "scripts"))
import update_readme  # noqa: E402
from fracfem_workflow import glossary  # noqa: E402


def test_the_readme_has_the_library_examples():
    readme = [b for name, b in BLOCKS if name == "README.md"]
    # Laplacian (dense and compressed) and the obstacle problem
    assert len(readme) >= 3
    assert all("import fracfem" in block for block in readme)


def test_the_readme_is_short():
    assert len((ROOT / "README.md").read_text()) <= 15_000


@pytest.mark.parametrize("index", range(len(BLOCKS)))
def test_python_block_runs_alone(index, tmp_path):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(
        [str(ROOT)] + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p]))
    name, block = BLOCKS[index]
    run = subprocess.run([sys.executable, "-c", block], env=env, cwd=tmp_path,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, f"python block {index + 1} ({name}) failed:\n{run.stderr}"


def test_generated_blocks_match_the_committed_outputs():
    """Every <!-- BEGIN name --> block equals paper-figures/name.md (or the glossary), and
    the glossary block of the report's front page is the current glossary."""
    docs = update_readme.documents(ROOT)
    assert ROOT / "report" / "workflow.rst" in docs
    for doc in docs:
        text = doc.read_text()
        assert update_readme.fill(text, ROOT / "paper-figures") == text, (
            f"{doc.name} is out of date: run python workflow/scripts/update_readme.py")


def test_fill_replaces_a_stale_block(tmp_path):
    (tmp_path / "t.md").write_text("| a |\n|---|\n| 2 |\n")
    stale = "x\n<!-- BEGIN t -->\n| a |\n|---|\n| 1 |\n<!-- END t -->\ny"
    assert "| 2 |" in update_readme.fill(stale, tmp_path)
    assert "| 1 |" not in update_readme.fill(stale, tmp_path)


def _columns(path):
    lines = path.read_text().splitlines()
    for head, rule in zip(lines, lines[1:]):
        if head.startswith("|") and re.fullmatch(r"\|[-:| ]+\|", rule.strip()):
            cells = re.split(r"(?<!\\)\|", head.strip()[1:-1])
            yield from (c.strip().replace("\\|", "|") for c in cells)


TABLES = [*sorted((ROOT / "paper-figures").glob("*.md")),
          *sorted((ROOT / "paper-figures").glob("*.csv")),
          *sorted((ROOT / "benchmarks").glob("*.md"))]


@pytest.mark.parametrize("table", TABLES, ids=lambda p: p.name)
def test_every_column_is_in_the_glossary(table):
    columns = (table.read_text().splitlines()[0].split(",") if table.suffix == ".csv"
               else _columns(table))
    missing = sorted(set(columns) - set(glossary.definitions()))
    assert not missing, f"{table.name}: columns without a glossary entry: {missing}"


def test_the_column_parser_sees_escaped_pipes():
    import tempfile
    with tempfile.TemporaryDirectory() as d:
        p = Path(d, "t.md")
        p.write_text("| case | max \\|λ\\| |\n|:--|--:|\n| a | 1 |\n")
        assert list(_columns(p)) == ["case", "max |λ|"]
