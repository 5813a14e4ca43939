# Configuration: normalise command-line overrides, validate against the schema,
# and choose the output root (a run whose science differs from config.yaml
# never writes over the committed paper figures).
import hashlib
import json

import yaml
from snakemake.utils import validate


def _as_list(value, name):
    """--config passes lists as strings ("[0.3, 0.6]" or "0.3,0.6")."""
    if isinstance(value, str):
        text = value.strip()
        if not text.startswith("["):
            text = "[" + text + "]"
        try:
            value = yaml.safe_load(text)
        except yaml.YAMLError as err:
            raise ValueError(f"config {name}={value!r} is not a list of numbers") from err
    if not isinstance(value, (list, tuple)):
        value = [value]
    # some Snakemake versions split "[0.3, 0.6]" into strings: parse each item
    items = []
    for item in value:
        if isinstance(item, str):
            item = yaml.safe_load(item.strip().strip("[]").strip()) if item.strip("[] ") else None
        if item is not None:
            items.append(item)
    return items


for _key in ("s_values",):
    config[_key] = _as_list(config[_key], _key)
for _key in ("uniform_levels", "graded_h"):
    config["example1"][_key] = _as_list(config["example1"][_key], f"example1.{_key}")
config["benchmark"]["levels"] = _as_list(config["benchmark"]["levels"], "benchmark.levels")

validate(config, "../schemas/config.schema.yaml")


def _science(cfg):
    return {k: v for k, v in cfg.items() if k not in ("output_root", "results_dir")}


def _fingerprint(cfg):
    return hashlib.sha1(json.dumps(_science(cfg), sort_keys=True).encode()).hexdigest()[:10]


with open(workflow.basedir + "/config.yaml") as _fh:
    _default = yaml.safe_load(_fh)

RES = config["results_dir"]
OUT = config["output_root"]
if OUT == _default["output_root"] and _fingerprint(config) != _fingerprint(_default):
    OUT = f"{RES}/custom-{_fingerprint(config)}/figures"
    logger.info(f"config differs from config.yaml: figures go to {OUT}")

EX1 = config["example1"]
S_EX1 = sorted({float(EX1["s"])} | {float(s) for s in config["s_values"]})


def fmt(x):
    """Canonical text of a number in file names (0.5, 0.14, 3)."""
    return f"{float(x):g}"


def ex1_level_tags(family):
    if family == "uniform":
        return [f"L{int(l)}" for l in EX1["uniform_levels"]]
    return [f"h{fmt(h)}" for h in EX1["graded_h"]]


def ex1_rows(s_list):
    return [f"{RES}/ex1/{fam}/s{fmt(s)}/{tag}.csv"
            for s in s_list for fam in ("uniform", "graded") for tag in ex1_level_tags(fam)]


wildcard_constraints:
    family="uniform|graded",
    s=r"[0-9.]+",
    tag=r"L[0-9]+|h[0-9.]+",
