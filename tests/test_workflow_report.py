"""The Snakemake report: every figure and table of the figures root is registered with
report(...), its caption exists and renders (Jinja with the run's config, then
reStructuredText without warnings), and the front page defines every table column.

The workflow is parsed by Snakemake's API in a subprocess (no job runs, no DAG is built);
the registrations are read from the output files' flags, as `snakemake --report` reads
them."""
import json
import re
import shutil
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import pytest

from pages import page_headers

ROOT = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.skipif(shutil.which("snakemake") is None,
                                reason="snakemake is not installed")

# the registrations of a parsed workflow, as JSON on stdout
EXTRACT = r"""
import json, sys
from pathlib import Path
from snakemake.api import SnakemakeApi
from snakemake.io import get_flag_value, is_flagged
from snakemake.settings.types import ConfigSettings, OutputSettings, Quietness, ResourceSettings

root = Path(sys.argv[1]).resolve()
configfiles = [root / p for p in sys.argv[2:]]
with SnakemakeApi(OutputSettings(quiet={Quietness.ALL})) as api:
    wf = api.workflow(resource_settings=ResourceSettings(cores=1),
                      config_settings=ConfigSettings(configfiles=configfiles),
                      snakefile=root / "Snakefile", workdir=root)._workflow
    targets = [str(f) for f in wf.get_rule("all").input]
    outputs = []
    for rule in wf.rules:
        params = {k: v for k, v in rule.params.items() if not callable(v)}
        for f in rule.output:
            rep = get_flag_value(f, "report") if is_flagged(f, "report") else None
            outputs.append({
                "rule": rule.name, "pattern": str(f), "regex": f.regex().pattern,
                "params": params,
                "report": None if rep is None else {
                    "caption": None if rep.caption is None
                    else rep.caption.get_path_or_uri(secret_free=True),
                    "category": rep.category, "subcategory": rep.subcategory,
                    "labels": rep.labels}})
    for o in outputs:          # functions of the wildcards: evaluated per target below
        rep = o["report"]
        if rep is not None:
            rep.update({k: None for k in ("category", "labels") if callable(rep[k])})
    # category and labels of every concrete target of rule all
    evaluated = {}
    for rule in wf.rules:
        for f in rule.output:
            if not is_flagged(f, "report"):
                continue
            rep = get_flag_value(f, "report")
            for t in targets:
                m = f.match(t)
                if m is None:
                    continue
                w = type("W", (), m.groupdict())
                evaluated[t] = {k: (getattr(rep, k)(w) if callable(getattr(rep, k))
                                    else getattr(rep, k)) for k in ("category", "labels")}
    print(json.dumps({"config": wf.config, "targets": targets, "outputs": outputs,
                      "evaluated": evaluated,
                      "front": None if wf.report_text is None
                      else wf.report_text.get_path_or_uri(secret_free=True),
                      "output_root": str(Path(wf.globals["OUT"]))}, default=str))
"""

CONFIGS = {"default": [], "ci": ["config/ci.yaml"]}
CATEGORIES = {"Example 1", "Example 2 (obstacle)", "Example 3 (friction)",
              "Example 4 (parabolic obstacle)", "Example 5 (parabolic friction)",
              "Across examples", "Thin obstacle and friction (not in the paper)",
              "Benchmarks and checks"}
REGISTERED_SUFFIXES = (".png", ".md", ".csv")   # PDFs and rates.tex duplicate these


@pytest.fixture(scope="module", params=sorted(CONFIGS))
def workflow(request):
    out = subprocess.run([sys.executable, "-c", EXTRACT, str(ROOT), *CONFIGS[request.param]],
                         cwd=ROOT, capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stdout + out.stderr
    return json.loads(out.stdout.strip().splitlines()[-1])


def producer(wf, target):
    """The output item of the rule that makes ``target``, and its wildcards."""
    for o in wf["outputs"]:
        m = re.match(o["regex"], target)
        if m:
            return o, m.groupdict()
    raise AssertionError(f"no rule makes {target}")


def render(caption, config, wildcards=None, params=None):
    """A caption as `snakemake --report` renders it, but strict: an unknown config key or
    wildcard raises, and so does any reStructuredText warning."""
    import docutils.core
    import jinja2

    env = jinja2.Environment(trim_blocks=True, lstrip_blocks=True,
                             undefined=jinja2.StrictUndefined)
    snakemake = SimpleNamespace(config=config, wildcards=SimpleNamespace(**(wildcards or {})),
                                params=SimpleNamespace(**(params or {})))
    text = env.from_string(caption.read_text()).render(snakemake=snakemake)
    html = docutils.core.publish_parts(
        text, writer="html",
        settings_overrides={"halt_level": 2, "report_level": 2})["body"]
    return text, html


def figures_and_tables(wf):
    """The targets of rule all in the figures root that the report shows."""
    return [t for t in wf["targets"]
            if t.startswith(wf["output_root"] + "/") and t.endswith(REGISTERED_SUFFIXES)]


def paper_figures(wf):
    return [t for t in wf["targets"] if re.search(r"/fig\d\d-[\w-]+\.png$", t)]


def test_every_paper_figure_is_registered_with_its_caption(workflow):
    figures = paper_figures(workflow)
    assert sorted(int(re.search(r"/fig(\d\d)-", f).group(1)) for f in figures) == \
        list(range(1, 16))
    for fig in figures:
        num = int(re.search(r"/fig(\d\d)-", fig).group(1))
        item, wildcards = producer(workflow, fig)
        rep = item["report"]
        assert rep is not None, f"{fig} is not registered with report()"
        caption = Path(rep["caption"])
        assert caption.is_file(), f"{fig}: caption {caption} is missing"
        text, html = render(caption, workflow["config"], wildcards, item["params"])
        # the caption names the paper figure it reproduces (wildcard rules branch on num)
        assert f"Figure {num}**" in text, (fig, text)
        assert rep["subcategory"] == "Paper figures"
        meta = workflow["evaluated"][fig]
        assert meta["category"] in CATEGORIES and meta["category"].startswith("Example"), fig
        assert meta["labels"]["figure"] == f"Figure {num}", fig


def test_every_figure_and_table_of_the_output_root_is_registered(workflow):
    root = workflow["output_root"]
    outputs = [o for o in workflow["outputs"]
               if o["pattern"].startswith(root + "/") and o["pattern"].endswith(
                   REGISTERED_SUFFIXES)]
    # names without the wildcard constraints: extra-thin-{kind}.png
    names = {re.sub(r"\{(\w+),[^{}]*\}", r"{\1}", Path(o["pattern"]).name) for o in outputs}
    # the paper's figures, the rate table, and the tables and extras of rule all
    for name in ("rates.csv", "rates.md", "ex1-errors.md", "vi-runs.md", "elliptic-errors.md",
                 "parabolic-runs.md", "extra-ex1-orders.png", "extra-thin-{kind}.png"):
        assert name in names
    for o in outputs:
        rep = o["report"]
        assert rep is not None, f"{o['pattern']} (rule {o['rule']}) is not registered"
        assert Path(rep["caption"]).is_file(), o["pattern"]
        assert rep["subcategory"], o["pattern"]
        if rep["category"] is not None:        # None: a function of the wildcards
            assert rep["category"] in CATEGORIES, o["pattern"]
    for target in figures_and_tables(workflow):
        assert workflow["evaluated"][target]["category"] in CATEGORIES, target


def test_every_caption_renders_for_every_target(workflow):
    rendered = 0
    for target in figures_and_tables(workflow):
        item, wildcards = producer(workflow, target)
        text, html = render(Path(item["report"]["caption"]), workflow["config"], wildcards,
                            item["params"])
        assert "{{" not in html and "{%" not in html
        rendered += 1
    assert rendered >= 30


def test_the_front_page_defines_every_column_of_the_committed_tables(workflow):
    front = Path(workflow["front"])
    assert front == ROOT / "report" / "workflow.rst"
    source = front.read_text()
    render(front, workflow["config"])
    families = "uniform|graded|adaptive"
    columns = {}
    for table in sorted((ROOT / "paper-figures").glob("*.md")):
        for names in page_headers(table.read_text()):
            columns.setdefault(table.name, []).extend(names)
    for table in sorted((ROOT / "paper-figures").glob("*.csv")):
        columns[table.name] = table.read_text().splitlines()[0].split(",")
    assert len(columns) >= 15 and "efficiency" in columns["ex1-errors.md"]
    missing = {}
    for name, cols in columns.items():
        for col in cols:
            generic = re.sub(rf"^({families})\b|(?<=t_)({families})", "<family>", col)
            if f"``{col}``" not in source and f"``{generic}``" not in source:
                missing.setdefault(name, []).append(col)
    assert not missing, missing
