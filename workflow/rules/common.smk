# Configuration: normalise command-line overrides, validate against the schema,
# and choose the output root (a run whose science differs from config.yaml
# never writes over the committed paper figures).
import hashlib
import json
import os
import re
from pathlib import Path
from types import SimpleNamespace as Namespace

import yaml
from snakemake.utils import validate

from fracfem.meshes import disk_uniform, graded_ring_count, interior_nodes, refine_disk
from fracfem.problems import series_tag   # the tag format the scripts parse


def _as_list(value, name):
    """--config passes lists as strings ("[0.3, 0.6]" or "0.3,0.6")."""
    if isinstance(value, str):
        text = value.strip()
        if not text.startswith("["):
            text = f"[{text}]"
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
# the config key listing the members of each mesh family's series
SERIES_KEYS = {"uniform": "uniform_levels", "graded": "graded_h", "graded-sr": "graded_sr_h"}
for _key in SERIES_KEYS.values():
    if _key in config["example1"]:
        config["example1"][_key] = _as_list(config["example1"][_key], f"example1.{_key}")
config["benchmark"]["levels"] = _as_list(config["benchmark"]["levels"], "benchmark.levels")

validate(config, "../schemas/config.schema.yaml")

# the reference energy of Examples 2 and 3 is extrapolated through three runs of one family,
# and the same extrapolation is checked against Example 1's exact energy
_REF_KEY = SERIES_KEYS[config["reference"]["family"]]
for _block in ("example1", "example2", "example3"):   # Example 1: the extrapolation check
    if len(config[_block].get(_REF_KEY, [])) < 3:
        raise ValueError(f"config {_block}.{_REF_KEY}={config[_block].get(_REF_KEY, [])!r} must "
                         f"list at least 3 meshes: reference.family="
                         f"{config['reference']['family']!r} extrapolates through its three "
                         "finest energies")
# ex1-adaptive-rate.md cuts the pipeline's adaptive series at the changed series' size, and
# fits a rate through every series from its start mesh: at least two steps each
_A, _C = config["example1"]["adaptive"], config["example1"]["adaptive_changes"]
if _C["max_dofs"] > _A["max_dofs"]:
    raise ValueError(f"config example1.adaptive_changes.max_dofs={_C['max_dofs']} must be at "
                     f"most example1.adaptive.max_dofs={_A['max_dofs']}: the unchanged series "
                     "is cut there")
for _lv in sorted(set(_C["start_level"]) | {_A["start_level"]}):
    _n = len(interior_nodes(disk_uniform(_lv)))
    if _n >= _C["max_dofs"]:
        raise ValueError(f"config example1.adaptive_changes.max_dofs={_C['max_dofs']} must "
                         f"exceed the DOFs of every start mesh: disk_uniform({_lv}) has {_n}")

# ex2-graded-rings.md runs the graded family at every ring count of example2.graded_rings;
# the graded series' meshes (n = ceil(1/h)) must be among them
_first, _last = config["example2"]["graded_rings"]
_series_n = sorted({graded_ring_count(h) for h in config["example2"]["graded_h"]})
if not _first <= _last or _series_n[0] < _first or _series_n[-1] > _last:
    raise ValueError(f"config example2.graded_rings={[_first, _last]} must be [first, last] "
                     f"ring counts, first <= last, holding the graded series' ring counts "
                     f"{_series_n} (graded_h={config['example2']['graded_h']}: n = ceil(1/h))")

# ex2-adaptive-rate.md: the changed series are cut at their max_dofs, the unchanged one too,
# which runs on to reference_dofs for the reference step: at or beyond its cut, and every
# start mesh below max_dofs (a rate needs two steps)
_A, _C = config["vi_adaptive"], config["example2"]["adaptive_changes"]
if _C["reference_dofs"] < _C["max_dofs"]:
    raise ValueError(f"config example2.adaptive_changes.reference_dofs={_C['reference_dofs']} "
                     f"must be at least its max_dofs={_C['max_dofs']}: the reference step "
                     "lies at or beyond the steps it measures")
for _lv in sorted(set(_C["start_level"]) | {_A["start_level"]}):
    # the DOFs are those of T_h, the refinement of the start mesh T_H
    _n = len(interior_nodes(refine_disk(disk_uniform(_lv))))
    if _n >= _C["max_dofs"]:
        raise ValueError(f"config example2.adaptive_changes.max_dofs={_C['max_dofs']} must "
                         f"exceed the DOFs of every start mesh: T_H = disk_uniform({_lv}) "
                         f"gives T_h with {_n}")


def _science(cfg):
    return {k: v for k, v in cfg.items()
            if k not in ("output_root", "results_dir", "tier", "tiers", "job_threads",
                         "operator_cache")}


def _fingerprint(cfg):
    return hashlib.sha1(json.dumps(_science(cfg), sort_keys=True).encode()).hexdigest()[:10]


def _committed_tiers():
    """{committed output root: (its config files, its configuration)}: config.yaml's, and
    config/paper.yaml's over it (merged as --configfile merges)."""
    import copy

    from snakemake.utils import update_config
    base = yaml.safe_load((Path(workflow.basedir) / "config.yaml").read_text())
    paper = copy.deepcopy(base)
    update_config(paper, yaml.safe_load(
        (Path(workflow.basedir) / "config" / "paper.yaml").read_text()))
    return {base["output_root"]: ("config.yaml", base),
            paper["output_root"]: ("config.yaml + config/paper.yaml", paper)}


RES = config["results_dir"]
OUT = config["output_root"]
# a committed output root is written only by its own configuration: a run whose science
# differs (e.g. --config s_values=...) writes beside its results instead
_COMMITTED = _committed_tiers()
if OUT in _COMMITTED:
    _files, _own = _COMMITTED[OUT]
    if _fingerprint(config) != _fingerprint(_own):
        OUT = f"{RES}/custom-{_fingerprint(config)}/figures"
        logger.info(f"config differs from {_files}: figures go to {OUT}")

# Dense operators that several jobs need (one mesh, s and quadrature: Example 3's two
# variants, Example 4's two initial values, a reference family's member and its error) are
# assembled by the first and read back by the others (fracfem.opcache, bit for bit the
# same matrix; a job's time columns keep the assembly's seconds).  The directory lives
# while the run does: removed when it ends.  The adaptive algorithms' jobs, whose meshes
# are their own and whose pages time every step, neither read nor keep any.  A
# FRACFEM_OPERATOR_CACHE set beforehand is used instead and kept; operator_cache: false
# turns it off.
# The Snakefile's onstart sets FRACFEM_OPERATOR_CACHE for the jobs (not here: a program
# that only reads the workflow through Snakemake's API must not inherit it).
OPERATOR_CACHE = None
if config.get("operator_cache", True) and "FRACFEM_OPERATOR_CACHE" not in os.environ:
    OPERATOR_CACHE = os.path.abspath(f"{RES}/operators")


def remove_operator_cache():
    """The end of a run, successful or not: its operators are a means, not a result."""
    if OPERATOR_CACHE:
        import shutil
        shutil.rmtree(OPERATOR_CACHE, ignore_errors=True)

# Which ready job starts first on few cores: the parabolic problems' jobs (their chains run
# reference family → its error → Algorithm C → errors → time split, a quarter of an hour in
# a row), then the other long single jobs, and the many short ones fill the end (in a run
# without this order the last chain ran alone for minutes: pipeline-cost.md)
PRIORITY = {"parabolic": 2, "long": 1}

TIER = config.get("tier", "default")
# threads of every job that computes (numba's parallel loops); 1 packs two jobs onto two
# cores, which the default tier's many minute-long jobs prefer (pipeline-cost.md)
JOB_THREADS = config.get("job_threads", 2)


def tier_table(p):
    """A tier's rate tables: [its rates.csv], or while that tier's parabolic series are
    unfinished, whichever of the partial tables beside it exist (rules rates_elliptic,
    rates_parabolic: Examples 1-3, its problems with kept error tables); [] if none."""
    from fracfem_workflow.report import PARTIAL_RATE_TABLES
    if Path(p).exists():
        return [str(p)]
    return [str(q) for q in (Path(p).with_name(n) for n in PARTIAL_RATE_TABLES) if q.exists()]


def other_tiers(wildcards=None):
    """{name: [rate tables]} of the other tiers with a rate table (not this run's own)."""
    own = Path(OUT).resolve()
    found = {name: tier_table(p) for name, p in config.get("tiers", {}).items()
             if name != TIER and Path(p).resolve().parent != own}
    return {name: ps for name, ps in found.items() if ps}


def other_tier_tables(wildcards=None):
    """Every rate table of other_tiers, the inputs of the rate tables: read, never made
    here, and marked ancient, since each tier's table reads the other's (a table rewritten
    by its own tier does not make the other out of date)."""
    return [ancient(p) for ps in other_tiers().values() for p in ps]


def absent_tiers():
    """The other tiers of the config whose rate table does not exist (yet)."""
    found = other_tiers()
    return [n for n in config.get("tiers", {}) if n != TIER and n not in found]


ENV = "../envs/fracfem.yaml"
EX1 = config["example1"]
EX2 = config["example2"]
EX3 = config["example3"]
THIN = config["thin"]
PARA = config["parabolic"]
QUADRATURE = config["quadrature"]
SOLVER = config["solver"]
GRADING = EX1["grading"]      # the grading exponent of every graded mesh
S_EX1 = sorted({float(EX1["s"])} | {float(s) for s in config["s_values"]})
VI_PROBLEMS = ["ex2"] + [f"ex3-{v}" for v in EX3["variants"]]
PARA_PROBLEMS = list(PARA["examples"])
# the parabolic jobs' rules: the top-level quadrature with parabolic.quadrature on top
PARA_QUADRATURE = {**QUADRATURE, **PARA.get("quadrature", {})}


def para_reference_h(problem):
    """(graded_h, coarser_h) of the reference of a parabolic problem:
    parabolic.reference, or its entry in parabolic.reference.problems."""
    R = {**PARA["reference"], **PARA["reference"].get("problems", {}).get(problem, {})}
    return R["graded_h"], R["coarser_h"]


def para_reference_tag(problem):
    """The series tag (h<h>) of the reference run of a parabolic problem."""
    return series_tag("graded", para_reference_h(problem)[0])


def fmt(x):
    """Canonical text of a number in file names (0.5, 0.14, 3)."""
    return f"{float(x):g}"


def path(pattern, **wildcards):
    """One file of a rule's output pattern, wildcards not given kept as wildcards."""
    (out,) = expand(pattern, **wildcards, allow_missing=True)
    return out


def series(block):
    """(family, tag) of every run of the uniform, graded (anisotropic, the paper's) and
    graded-sr (shape-regular) series of a config block."""
    return [(family, series_tag(family, value))
            for family, key in SERIES_KEYS.items() for value in block.get(key, [])]


def families(block):
    """The mesh families a config block runs, in the order of series()."""
    return list(dict.fromkeys(fam for fam, _ in series(block)))


def quadrature_check_tag(block, family):
    """The tag of the run a family's quadrature check repeats: the rank-th finest of its
    series, rank = the block's ``quadrature_check[family]`` (1, the finest, if not given)."""
    rank = block.get("quadrature_check", {}).get(family, 1)
    members = [t for fam, t in series(block) if fam == family]
    if not 1 <= rank <= len(members):
        raise ValueError(f"config example1.quadrature_check.{family}={rank!r} must be a rank "
                         f"from 1 (the finest) to {len(members)} (the coarsest of "
                         f"example1.{SERIES_KEYS[family]}={block.get(SERIES_KEYS[family])!r})")
    return members[-rank]


def ex1_runs(s_list, key="row"):
    """Example 1's uniform and graded runs for every s of s_list."""
    return [path(getattr(rules.ex1_solve.output, key), family=fam, s=fmt(s), tag=tag)
            for s in s_list for fam, tag in series(EX1)]


# ------------------------------------------------- the examples behind the problem names
def vi_example(wildcards):
    """fracfem.example name of an elliptic problem (ex2, ex3-<variant>, thin-<kind>)."""
    problem = wildcards.problem
    return problem if problem.startswith("thin-") else problem.split("-")[0]


def vi_data(wildcards):
    """The parameters of fracfem.example(vi_example(wildcards), ...)."""
    problem = wildcards.problem
    if problem == "ex2":
        return {"s": EX2["s"], **EX2["obstacle"]}
    if problem.startswith("ex3-"):
        return {"s": EX3["s"], **EX3["variants"][problem[4:]]}
    kind = problem[len("thin-"):]
    return {"s": THIN["s"], "segment": THIN["segment"], **THIN[kind]}


# Algorithm B with the compressed operator to reference.large.max_dofs DOFs: the reference
# energy of Examples 2 and 3 where none is exact, and on the printed Example 3 (exact) the
# check of that reference's uncertainty
LARGE_REFERENCE_PROBLEMS = [p for p in VI_PROBLEMS if p.startswith(("ex2", "ex3-"))]


def committed_reference(problem, kind="table"):
    """The committed copy of the large run of ``problem`` (written by reference_large):
    its steps (kind 'table') or the meshes kept for Figure 6 (kind 'meshes')."""
    name = f"{problem}.csv" if kind == "table" else f"{problem}-meshes.npz"
    return Path(workflow.basedir) / config["reference"]["large"]["committed"] / name


def large_parameters(wildcards):
    """What a large run of this problem records and must match for its copy to be used:
    the data, Algorithm B's settings, the solver tolerance and the quadrature."""
    from fracfem import QuadratureOptions
    from fracfem_workflow.runs import parameter_columns
    L = config["reference"]["large"]
    return parameter_columns(quadrature=QuadratureOptions(**QUADRATURE), theta=L["theta"],
                             marking="maximum", start_level=L["start_level"],
                             max_dofs=L["max_dofs"], tol=SOLVER["tol"], operator="auto",
                             data=json.dumps(vi_data(wildcards), sort_keys=True))


def large_reference(wildcards, kind="table"):
    """The large run a problem's errors are measured against (kind 'table'; 'meshes': its
    meshes for Figure 6): the committed copy when it was computed with the same data and
    settings (large_parameters; for the meshes, with every reference.large.figure_steps)
    and reference.large.recompute is false, else the run itself (rule vi_adaptive_large,
    tens of minutes and GBs on two cores)."""
    problem = wildcards.problem
    table, path = committed_reference(problem), committed_reference(problem, kind)
    fresh = f"{RES}/vi/{problem}/adaptive-large/" + ("steps.csv" if kind == "table"
                                                     else "meshes.npz")
    if config["reference"]["large"]["recompute"] or not (table.exists() and path.exists()):
        return fresh
    import numpy as np
    import pandas as pd
    from fracfem_workflow.runs import mismatched_parameters
    try:
        row = pd.read_csv(table).iloc[0].to_dict()
        differ = mismatched_parameters(row, large_parameters(wildcards))
        if kind == "meshes":
            kept = set(np.load(path)["steps"].tolist())
            differ += [] if set(config["reference"]["large"]["figure_steps"]) <= kept else [
                "figure_steps"]
    except (OSError, ValueError, KeyError, IndexError) as err:
        differ = [f"unreadable ({err})"]
    if not differ:
        return str(path)
    logger.warning(f"{path} differs from this configuration in {', '.join(differ)}: the "
                   f"reference of {problem} is recomputed (rule vi_adaptive_large)")
    return fresh


def para_example(wildcards):
    """fracfem.example name of a parabolic problem (ex4-<u0>, ex5)."""
    return wildcards.problem.split("-")[0]


def para_data(wildcards):
    """The parameters of fracfem.example(para_example(wildcards), ...); Example 4 has
    the obstacle of Example 2."""
    data = dict(PARA["examples"][wildcards.problem])
    if wildcards.problem.startswith("ex4"):
        data.update(EX2["obstacle"])
    return data


def para_tau_factor(wildcards):
    """τ = factor · h_max^{2s}: the factor of a family (the reference has its own)."""
    if wildcards.family == "reference":
        return PARA["reference"]["tau_factor"]
    return PARA["tau_factor"][wildcards.family]


def committed_para_reference(problem, kind="npz", root=None):
    """The committed copy of the reference run of a parabolic problem (written by
    para_reference_commit): its time steps (kind 'npz', U in single precision), its row
    ('csv') or its measured own error (para_reference_error's row, 'error'); root: the
    directory of the copies (default parabolic.reference.committed)."""
    name = {"error": f"{problem}-reference-error.csv",
            "runs": f"{problem}-coarser-tier-errors.csv"}.get(kind, f"{problem}-parabolic.{kind}")
    return Path(workflow.basedir) / (root or PARA["reference"]["committed"]) / name


def larger_committed(kind):
    """Input function: what a larger tier committed beside its finer references of the same
    families (parabolic.reference.larger; nothing when null), for the problems that have it:
    their measured errors (kind 'error') or the errors of a coarser tier's runs measured
    against them (kind 'runs', para_errors_commit); shown in parabolic-runs.md."""
    def files(wildcards=None):
        root = PARA["reference"].get("larger")
        if not root:
            return []
        found = [committed_para_reference(p, kind, root) for p in PARA_PROBLEMS]
        return [str(f) for f in found if f.exists()]
    return files


def para_reference_parameters(wildcards):
    """What the reference run of this problem records and must match for its copy to be
    used: data, mesh, τ factor, operator, solver tolerance and quadrature."""
    from fracfem import QuadratureOptions
    from fracfem_workflow.runs import parameter_columns
    R = PARA["reference"]
    return {"tag": para_reference_tag(wildcards.problem), **parameter_columns(
        quadrature=QuadratureOptions(**PARA_QUADRATURE), grading=GRADING, T=PARA["T"],
        tau_factor=R["tau_factor"], solver="pdas", tol=SOLVER["tol"], operator=R["operator"],
        data=para_data(wildcards))}


def para_reference(wildcards):
    """The reference run of a parabolic problem: the committed copy when it was computed
    with the same data and settings (para_reference_parameters) and
    parabolic.reference.recompute is false, else the run itself (rule para_solve, family
    reference: tens of minutes on two cores, parabolic-runs.md)."""
    problem = wildcards.problem
    npz, row = committed_para_reference(problem), committed_para_reference(problem, "csv")
    fresh = path(rules.para_solve.output.npz, problem=problem, family="reference",
                 tag=para_reference_tag(problem))
    if PARA["reference"]["recompute"] or not (npz.exists() and row.exists()):
        return fresh
    import pandas as pd
    from fracfem_workflow.runs import mismatched_parameters
    try:
        differ = mismatched_parameters(pd.read_csv(row).iloc[0].to_dict(),
                                       para_reference_parameters(wildcards))
    except (OSError, ValueError, KeyError, IndexError) as err:
        differ = [f"unreadable ({err})"]
    if not differ:
        return str(npz)
    logger.warning(f"{npz} differs from this configuration in {', '.join(differ)}: the "
                   f"reference of {problem} is recomputed (rule para_solve)")
    return fresh


def para_operator_owner(problem):
    """The problem whose reference operator `problem`'s jobs read: the first parabolic
    problem with the same order s and reference mesh (Example 4's two initial values share
    one, assembled once; runs.load_reference_operator checks mesh, s and quadrature)."""
    def key(p):
        return PARA["examples"][p].get("s"), para_reference_tag(p)
    return next(p for p in PARA_PROBLEMS if key(p) == key(problem))


def para_reference_operator(wildcards):
    """The operator file of a parabolic problem's reference run (para_operator_owner)."""
    return path(rules.para_reference_operator.output.pkl,
                problem=para_operator_owner(wildcards.problem))


def para_reference_row(wildcards):
    """The row (time, memory, size) of the reference run para_reference uses."""
    ref = para_reference(wildcards)
    return ref[:-len("npz")] + "csv"


def para_reference_coarser(wildcards):
    """The coarser runs of the reference's family (coarsest first)."""
    return [path(rules.para_solve.output.npz, problem=wildcards.problem, family="reference",
                 tag=series_tag("graded", h))
            for h in para_reference_h(wildcards.problem)[1]]


def para_graded_run(problem, h):
    """The file of a graded run of a problem's reference family made with the reference's
    settings: the reference itself (para_reference: its committed copy when it matches)
    where h is the reference's, else that run (rule para_solve, family reference)."""
    tag = series_tag("graded", h)
    if tag == para_reference_tag(problem):
        return para_reference(Namespace(problem=problem))
    return path(rules.para_solve.output.npz, problem=problem, family="reference", tag=tag)


def vi_series_rows(wildcards):
    """The uniform and graded runs of an elliptic obstacle/friction problem."""
    block = EX2 if wildcards.problem == "ex2" else EX3
    return [path(rules.vi_solve.output.row, problem=wildcards.problem, family=fam, tag=tag)
            for fam, tag in series(block)]


def para_series(wildcards, key):
    return [path(getattr(rules.para_solve.output, key), problem=wildcards.problem, family=fam,
                 tag=tag)
            for fam, tag in series(PARA)]


def para_series_rows(wildcards):
    """The rows of the uniform and graded runs of a parabolic problem."""
    return para_series(wildcards, "row")


def para_series_npz(wildcards):
    """The time steps of the uniform and graded runs of a parabolic problem (same order)."""
    return para_series(wildcards, "npz")


def vi_error_tables(wildcards):
    """The error tables shown in Figure 7 (Example 2) or 9 (Example 3)."""
    problems = ["ex2"] if wildcards.num == "07" else VI_PROBLEMS[1:]
    return [vi_errors_table(p) for p in problems]


def kept_vi_errors(problem, kind="csv"):
    """The copy of an elliptic obstacle/friction problem's error table (kind 'csv') or of
    its reference's record ('json') kept in the repository (reference.kept_errors, rule
    vi_errors_keep; the settings it was made with beside the table, <problem>-vi-errors.json);
    None when that is null."""
    root = config["reference"].get("kept_errors")
    if root is None:
        return None
    name = f"{problem}-vi-errors.csv" if kind == "csv" else f"{problem}-vi-reference.json"
    return Path(workflow.basedir) / root / name


def _no_kept_vi_errors():
    raise ValueError("config reference.kept_errors=None: vi_errors_keep needs the folder to "
                     "keep the error tables in (config/paper.yaml sets one)")


def kept_vi_settings(problem):
    """What a kept error table of an elliptic obstacle/friction problem must have been made
    with (JSON; written beside it by vi_errors_keep): the problem's data, its series and
    their grading, the quadrature and the solver's settings, Algorithm B's settings, the
    reference's family and the large run's parameters."""
    w = Namespace(problem=problem)
    return json.dumps({
        "data": vi_data(w), "series": series(EX2 if problem == "ex2" else EX3),
        "grading": GRADING, "quadrature": QUADRATURE, "solver": SOLVER,
        "adaptive": config["vi_adaptive"], "reference_family": config["reference"]["family"],
        "large": large_parameters(w)}, sort_keys=True, default=str)


_KEPT_VI_CHOICE = {}


def vi_errors_table(problem, kind="csv"):
    """An elliptic obstacle/friction problem's error table (kind 'csv') or its reference's
    record ('json') as the pages read them: the kept copies where reference.kept_errors
    has them made with this configuration's settings (kept_vi_settings; a tier whose runs
    take more than one run of its machine assembles its pages across Examples 1-3 from
    there), else vi_errors's outputs (computed when missing)."""
    if problem not in _KEPT_VI_CHOICE:
        csv, ref = kept_vi_errors(problem), kept_vi_errors(problem, "json")
        choice = (path(rules.vi_errors.output.csv, problem=problem),
                  path(rules.vi_errors.output.json, problem=problem))
        if csv is not None and (csv.exists() or ref.exists()):
            import pandas as pd
            from fracfem_workflow.runs import key_differences
            try:
                differ = key_differences(csv.with_suffix(".json").read_text(),
                                         kept_vi_settings(problem))
                if not ref.exists():
                    differ.append("no reference record")
                if "family" not in pd.read_csv(csv, nrows=1).columns:
                    differ.append("no family column")
            except (OSError, ValueError) as err:
                differ = [f"unreadable ({type(err).__name__}: {err})"]
            if not differ:
                choice = (str(csv), str(ref))
            else:
                logger.warning(f"{csv} differs from this configuration in "
                               f"{', '.join(differ)}: the errors of {problem} are computed "
                               "(rule vi_errors)")
        _KEPT_VI_CHOICE[problem] = choice
    return _KEPT_VI_CHOICE[problem][0 if kind == "csv" else 1]


def kept_para_errors(problem):
    """The copy of a parabolic problem's error table kept in the repository
    (parabolic.kept_errors, rule para_errors_keep); None when that is null."""
    root = PARA.get("kept_errors")
    return None if root is None else Path(workflow.basedir) / root / f"{problem}-errors.csv"


def _no_kept_errors():
    raise ValueError("config parabolic.kept_errors=None: para_errors_keep needs the folder to "
                     "keep the error tables in (config/paper.yaml sets one)")


def kept_errors_settings(problem):
    """What a kept error table of ``problem`` must have been made with (JSON; written
    beside it by para_errors_keep): everything that decides its rows and their errors,
    the problem's data, the series and their time steps, Algorithm C's settings and
    limits, the reference's family, the quadrature and the solver tolerance."""
    w = Namespace(problem=problem)
    graded_h, coarser_h = para_reference_h(problem)
    A, R = PARA["adaptive"], PARA["reference"]
    return json.dumps({
        "data": para_data(w), "T": PARA["T"], "tau_factor": PARA["tau_factor"],
        "series": series(PARA), "grading": GRADING, "quadrature": PARA_QUADRATURE,
        "tol": SOLVER["tol"],
        "adaptive": {k: A[k] for k in ("theta", "start_level", "c_tau", "max_spacetime_dofs",
                                       "max_iterations", "operator")},
        "reference": {"graded_h": graded_h, "coarser_h": coarser_h,
                      "tau_factor": R["tau_factor"], "operator": R["operator"]}},
        sort_keys=True, default=str)


def kept_errors_differ(table, problem):
    """How a kept error table of ``problem`` differs from what this configuration would
    compute (an empty list: it is this configuration's): the settings recorded beside it
    (kept_errors_settings), and a readable table holding this configuration's series."""
    try:
        import pandas as pd
        from fracfem_workflow.runs import key_differences
        differ = key_differences(Path(table).with_suffix(".json").read_text(),
                                 kept_errors_settings(problem))
        d = pd.read_csv(table)
        runs = d[d.family != "adaptive"]
        if not (d.family == "adaptive").any():
            differ.append("no Algorithm C rows")
        if sorted(zip(runs.family, runs.tag)) != sorted(series(PARA)):
            differ.append("series runs")
    except Exception as err:      # a missing record or a damaged table: computed instead
        differ = [f"unreadable ({type(err).__name__}: {err})"]
    return differ


_KEPT_CHOICE = {}


def para_errors_table(problem):
    """A parabolic problem's error table as the tables and figures read it: its kept copy
    where parabolic.kept_errors has one made with this configuration's settings
    (kept_errors_differ; a tier whose runs take more than one allocation assembles them
    from there), else para_errors's output (computed when missing)."""
    if problem in _KEPT_CHOICE:
        return _KEPT_CHOICE[problem]
    kept = kept_para_errors(problem)
    choice = path(rules.para_errors.output.csv, problem=problem)
    if kept is not None and kept.exists():
        differ = kept_errors_differ(kept, problem)
        if not differ:
            choice = str(kept)
        else:
            logger.warning(f"{kept} differs from this configuration in {', '.join(differ)}: "
                           f"the errors of {problem} are computed (rule para_errors)")
    _KEPT_CHOICE[problem] = choice
    return choice


def kept_para_tables(wildcards=None):
    """The kept error tables this configuration reads (para_errors_table), the inputs of
    rule rates_parabolic: a tier's finished parabolic problems; raises when there is none."""
    if PARA.get("kept_errors") is None:
        raise ValueError("rates_parabolic: config parabolic.kept_errors is null: set it to the "
                         "folder of the kept error tables (config/paper.yaml does)")
    kept = [t for p in PARA_PROBLEMS if (t := para_errors_table(p)) == str(kept_para_errors(p))]
    if kept:
        return kept
    there = [p for p in PARA_PROBLEMS if kept_para_errors(p).exists()]
    raise ValueError(
        "rates_parabolic: no parabolic problem has a kept error table made with this "
        "configuration: " + (f"those of {', '.join(there)} differ from it (the warnings "
                             "above say how)" if there else
                             f"parabolic.kept_errors={PARA['kept_errors']!r} holds no "
                             "<problem>-errors.csv of " + ", ".join(PARA_PROBLEMS)))


def para_error_tables(wildcards):
    """The error tables shown in Figure 13 (Example 4) or 15 (Example 5)."""
    example = "ex4" if wildcards.num == "13" else "ex5"
    return [para_errors_table(p) for p in PARA_PROBLEMS if p.split("-")[0] == example]


wildcard_constraints:
    family="uniform|graded|graded-sr",
    s=r"[0-9.]+",
    tag=r"L[0-9]+|[hr][0-9.e-]+",
