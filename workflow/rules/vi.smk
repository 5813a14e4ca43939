# Examples 2 and 3 (paper Section 8.1) and the thin demonstrations: mixed form,
# PDAS solution cross-checked by Uzawa (Algorithm A) on every mesh.


rule vi_solve:
    output:
        row=f"{RES}/vi/{{problem}}/{{family}}/{{tag}}.csv",
        npz=f"{RES}/vi/{{problem}}/{{family}}/{{tag}}.npz",
    log:
        f"{RES}/logs/vi/{{problem}}_{{family}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_{{family}}_{{tag}}.tsv"
    wildcard_constraints:
        problem=r"ex2|ex3-\w+|thin-obstacle|thin-friction",
        family="uniform|graded|graded-sr|demo",
    params:
        example=vi_example,
        data=vi_data,
        grading=GRADING,
        tol=SOLVER["tol"],
        maxiter=SOLVER["maxiter"],
        quadrature=QUADRATURE,
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_solve.py"


rule vi_table:
    input:
        rows=vi_series_rows,
    output:
        table=f"{RES}/vi/{{problem}}/table.csv",
    log:
        f"{RES}/logs/vi/{{problem}}_table.log",
    benchmark:
        f"{RES}/benchmarks/tables/vi_{{problem}}_table.tsv"
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    conda:
        ENV
    script:
        "../scripts/collect_rows.py"


rule vi_runs_md:
    input:
        tables=expand(rules.vi_table.output.table, problem=VI_PROBLEMS),
    output:
        md=report(
            f"{OUT}/vi-runs.md",
            caption="../../report/captions/vi-runs.rst",
            category="Across examples",
            subcategory="Examples 1–3",
        ),
    log:
        f"{RES}/logs/vi_runs_md.log",
    benchmark:
        f"{RES}/benchmarks/tables/vi_runs_md.tsv"
    conda:
        ENV
    script:
        "../scripts/vi_runs_md.py"


rule fig03:
    output:
        png=report(
            f"{OUT}/fig03-obstacle.png",
            caption="../../report/captions/fig03.rst",
            category="Example 2 (obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 3", "shows": "the obstacle"},
        ),
        pdf=f"{OUT}/fig03-obstacle.pdf",
    params:
        height=EX2["obstacle"]["height"],
        slope=EX2["obstacle"]["slope"],
    log:
        f"{RES}/logs/fig03.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig03.tsv"
    conda:
        ENV
    script:
        "../scripts/fig03.py"


rule fig04:
    input:
        npz=path(rules.vi_solve.output.npz, problem="ex2", family="uniform",
                 tag=series_tag("uniform", EX2["figure4_level"])),
    output:
        png=report(
            f"{OUT}/fig04-ex2-solution-uniform.png",
            caption="../../report/captions/fig04.rst",
            category="Example 2 (obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 4", "shows": "u_h and λ_H on a uniform mesh"},
        ),
        pdf=f"{OUT}/fig04-ex2-solution-uniform.pdf",
    params:
        figure="fig04",
    log:
        f"{RES}/logs/fig04.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig04.tsv"
    conda:
        ENV
    script:
        "../scripts/fig04.py"


rule fig08:
    input:
        npz=path(rules.vi_solve.output.npz, problem=f"ex3-{EX3['figure8_variant']}",
                 family="uniform", tag=series_tag("uniform", EX3["figure8_level"])),
    output:
        png=report(
            f"{OUT}/fig08-ex3-solution-multiplier.png",
            caption="../../report/captions/fig08.rst",
            category="Example 3 (friction)",
            subcategory="Paper figures",
            labels={"figure": "Figure 8", "shows": "u_h and λ_H on a uniform mesh"},
        ),
        pdf=f"{OUT}/fig08-ex3-solution-multiplier.pdf",
    params:
        problem=f"ex3-{EX3['figure8_variant']}",
        F=EX3["variants"][EX3["figure8_variant"]]["F"],
    log:
        f"{RES}/logs/fig08.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig08.tsv"
    conda:
        ENV
    script:
        "../scripts/fig08.py"


rule thin_demo:
    input:
        npz=path(rules.vi_solve.output.npz, problem="thin-{kind}", family="demo",
                 tag=series_tag("uniform", THIN["level"])),
    output:
        png=report(
            f"{OUT}/extra-thin-{{kind}}.png",
            caption="../../report/captions/extra-thin.rst",
            category="Thin obstacle and friction (not in the paper)",
            subcategory="Further figures",
        ),
    wildcard_constraints:
        kind="obstacle|friction",
    log:
        f"{RES}/logs/thin_demo_{{kind}}.log",
    benchmark:
        f"{RES}/benchmarks/figures/thin_demo_{{kind}}.tsv"
    conda:
        ENV
    script:
        "../scripts/fig_thin.py"


# ---------------------------------------------------------------- adaptive series and errors
rule vi_adaptive:
    output:
        table=f"{RES}/vi/{{problem}}/adaptive/steps.csv",
        npz=f"{RES}/vi/{{problem}}/adaptive/meshes.npz",
    log:
        f"{RES}/logs/vi/{{problem}}_adaptive.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_adaptive.tsv"
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    params:
        example=vi_example,
        data=vi_data,
        theta=config["vi_adaptive"]["theta"],
        start_level=config["vi_adaptive"]["start_level"],
        max_dofs=config["vi_adaptive"]["max_dofs"],
        max_steps=config["vi_adaptive"]["max_steps"],
        figure_steps=[],   # Figure 6 is drawn from the large series (reference.large)
        tol=SOLVER["tol"],
        quadrature=QUADRATURE,
        operator=config["vi_adaptive"]["operator"],
        family="adaptive",
        # the u_h of every step too where it is ex2-adaptive-rate.md's unchanged series
        every_step=lambda w: w.problem == "ex2" and EX2_UNCHANGED_IS_ADAPTIVE,
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_adaptive.py"


# The reference energy of Examples 2 and 3 where no exact one is known: the same Algorithm B
# with the compressed operator, to reference.large.max_dofs fine DOFs (tens of minutes and
# GBs per problem on two cores: elliptic-errors.md).  Not part of `all`: its committed copy under
# reference.large.committed is used when it was computed for the same data (large_reference
# in common.smk); `snakemake --cores 2 reference_large` recomputes it.
rule vi_adaptive_large:
    output:
        table=f"{RES}/vi/{{problem}}/adaptive-large/steps.csv",
        npz=f"{RES}/vi/{{problem}}/adaptive-large/meshes.npz",
    log:
        f"{RES}/logs/vi/{{problem}}_adaptive_large.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_adaptive_large.tsv"
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    params:
        example=vi_example,
        data=vi_data,
        theta=config["reference"]["large"]["theta"],
        start_level=config["reference"]["large"]["start_level"],
        max_dofs=config["reference"]["large"]["max_dofs"],
        max_steps=config["reference"]["large"]["max_steps"],
        figure_steps=config["reference"]["large"]["figure_steps"],
        tol=SOLVER["tol"],
        quadrature=QUADRATURE,
        operator="auto",
        family="adaptive-large",
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_adaptive.py"


# `snakemake --cores 2 reference_large`: recompute the large runs and replace their committed
# copies (the input files, not outputs of this rule: a fresh clone uses the copies as they are)
rule reference_large:
    input:
        tables=expand(rules.vi_adaptive_large.output.table, problem=LARGE_REFERENCE_PROBLEMS),
        meshes=expand(rules.vi_adaptive_large.output.npz, problem=LARGE_REFERENCE_PROBLEMS),
    params:
        problems=LARGE_REFERENCE_PROBLEMS,
        committed={p: (str(committed_reference(p)), str(committed_reference(p, "meshes")))
                   for p in LARGE_REFERENCE_PROBLEMS},
        meshes_problem="ex2",   # Figure 6
    log:
        f"{RES}/logs/reference_large.log",
    benchmark:
        f"{RES}/benchmarks/tables/reference_large.tsv"
    conda:
        ENV
    script:
        "../scripts/reference_copy.py"


rule vi_errors:
    input:
        series=rules.vi_table.output.table,
        adaptive=rules.vi_adaptive.output.table,
        large=large_reference,
    output:
        csv=f"{RES}/vi/{{problem}}/errors.csv",
        json=f"{RES}/vi/{{problem}}/reference.json",
    log:
        f"{RES}/logs/vi/{{problem}}_errors.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_errors.tsv"
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    params:
        example=vi_example,
        data=vi_data,
        reference_family=config["reference"]["family"],
    conda:
        ENV
    script:
        "../scripts/vi_errors.py"


# `snakemake --cores 2 <RES>/vi/<problem>/errors-kept.txt --configfile config/paper.yaml`:
# the problem's error table and its reference's record copied to reference.kept_errors
# with the settings they were made with; the pages across Examples 1-3 then read them
# instead of computing them (vi_errors_table), so that a tier whose runs take more than one
# run of its machine makes Examples 2-3's runs in one and Example 1's in another
rule vi_errors_keep:
    input:
        csv=rules.vi_errors.output.csv,
        json=rules.vi_errors.output.json,
    output:
        note=f"{RES}/vi/{{problem}}/errors-kept.txt",
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    params:
        committed=lambda w: [str(kept_vi_errors(w.problem) or _no_kept_vi_errors()),
                             str(kept_vi_errors(w.problem, "json"))],
        settings=lambda w: kept_vi_settings(w.problem),   # written beside the table (.json)
    log:
        f"{RES}/logs/vi/{{problem}}_errors_keep.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_errors_keep.tsv"
    conda:
        ENV
    script:
        "../scripts/para_errors_copy.py"


rule reference_table:
    input:
        refs=[vi_errors_table(p, "json") for p in VI_PROBLEMS],
        errors=[vi_errors_table(p) for p in VI_PROBLEMS],
        ex1=rules.ex1_table.output.table,
    output:
        md=report(
            f"{OUT}/elliptic-errors.md",
            caption="../../report/captions/elliptic-errors.rst",
            category="Across examples",
            subcategory="Examples 1–3",
        ),
    params:
        family=config["reference"]["family"],
    log:
        f"{RES}/logs/reference_table.log",
    benchmark:
        f"{RES}/benchmarks/tables/reference_table.tsv"
    conda:
        ENV
    script:
        "../scripts/reference_table.py"


rule fig05:
    input:
        npz=path(rules.vi_adaptive.output.npz, problem="ex2"),
    output:
        png=report(
            f"{OUT}/fig05-ex2-solution-adaptive.png",
            caption="../../report/captions/fig05.rst",
            category="Example 2 (obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 5", "shows": "u_h and λ_H on the last adaptive mesh"},
        ),
        pdf=f"{OUT}/fig05-ex2-solution-adaptive.pdf",
    params:
        figure="fig05",
    log:
        f"{RES}/logs/fig05.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig05.tsv"
    conda:
        ENV
    script:
        "../scripts/fig04.py"


rule fig06:
    input:
        npz=lambda wildcards: large_reference(Namespace(problem="ex2"), kind="meshes"),
    output:
        png=report(
            f"{OUT}/fig06-ex2-adaptive-meshes.png",
            caption="../../report/captions/fig06.rst",
            category="Example 2 (obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 6", "shows": "adaptive meshes"},
        ),
        pdf=f"{OUT}/fig06-ex2-adaptive-meshes.pdf",
    log:
        f"{RES}/logs/fig06.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig06.tsv"
    conda:
        ENV
    script:
        "../scripts/fig06.py"


rule fig_vi_error:
    input:
        csv=vi_error_tables,
    output:
        png=report(
            f"{OUT}/fig{{num}}-{{slug}}.png",
            caption="../../report/captions/fig07-fig09.rst",
            category=lambda w: {"07": "Example 2 (obstacle)", "09": "Example 3 (friction)"}[w.num],
            subcategory="Paper figures",
            labels=lambda w: {"figure": f"Figure {int(w.num)}",
                              "shows": "energy error against DOFs"},
        ),
        pdf=f"{OUT}/fig{{num}}-{{slug}}.pdf",
    wildcard_constraints:
        num="07|09",
        slug="ex2-error|ex3-error",
    log:
        f"{RES}/logs/fig{{num}}-{{slug}}.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig{{num}}-{{slug}}.tsv"
    conda:
        ENV
    script:
        "../scripts/fig_vi_error.py"


rule elliptic_error_vs_time:
    input:
        ex1=rules.ex1_table.output.table,
        vi=[vi_errors_table(p) for p in VI_PROBLEMS],
    output:
        png=report(
            f"{OUT}/extra-elliptic-error-vs-time.png",
            caption="../../report/captions/elliptic-error-vs-time.rst",
            category="Across examples",
            subcategory="Examples 1–3",
        ),
        md=report(
            f"{OUT}/elliptic-error-vs-time.md",
            caption="../../report/captions/elliptic-error-vs-time.rst",
            category="Across examples",
            subcategory="Examples 1–3",
        ),
    params:
        s=EX1["s"],
    log:
        f"{RES}/logs/elliptic_error_vs_time.log",
    benchmark:
        f"{RES}/benchmarks/figures/elliptic_error_vs_time.tsv"
    conda:
        ENV
    script:
        "../scripts/elliptic_time.py"


rule vi_graded_rings:
    output:
        table=f"{RES}/vi/{{problem}}/graded-rings.csv",
    log:
        f"{RES}/logs/vi/{{problem}}_graded_rings.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_graded_rings.tsv"
    wildcard_constraints:
        problem="ex2",
    params:
        example=vi_example,
        data=vi_data,
        rings=EX2["graded_rings"],
        grading=GRADING,
        tol=SOLVER["tol"],
        quadrature=QUADRATURE,
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_graded_rings.py"


rule ex2_graded_rings:
    input:
        rings=path(rules.vi_graded_rings.output.table, problem="ex2"),
        reference=vi_errors_table("ex2", "json"),
        errors=vi_errors_table("ex2"),
        meshes=lambda wildcards: large_reference(Namespace(problem="ex2"), kind="meshes"),
    output:
        md=report(
            f"{OUT}/ex2-graded-rings.md",
            caption="../../report/captions/ex2-graded-rings.rst",
            category="Example 2 (obstacle)",
            subcategory="Tables",
        ),
        png=report(
            f"{OUT}/extra-ex2-graded-rings.png",
            caption="../../report/captions/ex2-graded-rings.rst",
            category="Example 2 (obstacle)",
            subcategory="Further figures",
        ),
    log:
        f"{RES}/logs/ex2_graded_rings.log",
    benchmark:
        f"{RES}/benchmarks/tables/ex2_graded_rings.tsv"
    conda:
        ENV
    script:
        "../scripts/vi_graded_rings_page.py"


# Algorithm B for Example 2 again with one setting of vi_adaptive changed at a time
# (ex2-adaptive-rate.md): {change: (case, {setting: value})}; the unchanged series runs on
# to reference_dofs, its last step the reference of the distances (vi_adaptive's own series
# where reference_dofs is vi_adaptive's max_dofs: EX2_UNCHANGED_IS_ADAPTIVE)
EX2_CHANGES = {
    "unchanged": ("as configured", {"max_dofs": EX2["adaptive_changes"]["reference_dofs"]}),
    **{f"start{lv}": (f"start_level = {lv}",
                      {"start_level": lv, "max_dofs": EX2["adaptive_changes"]["max_dofs"]})
       for lv in EX2["adaptive_changes"]["start_level"]},
    **{f"theta{fmt(th)}": (f"theta = {th:g}",
                           {"theta": th, "max_dofs": EX2["adaptive_changes"]["max_dofs"]})
       for th in EX2["adaptive_changes"]["theta"]},
}


def ex2_change(wildcards, key):
    """A setting of the series of change wildcards.change: the change's or vi_adaptive's."""
    return {**config["vi_adaptive"], **EX2_CHANGES[wildcards.change][1]}[key]


# Where the unchanged series stops where vi_adaptive does (the default tier), it is
# vi_adaptive's own series: vi_adaptive keeps every step of Example 2 and no second job
# solves the same steps again
EX2_UNCHANGED_IS_ADAPTIVE = (EX2_CHANGES["unchanged"][1]["max_dofs"]
                             == config["vi_adaptive"]["max_dofs"])
# the series that vi_adaptive_change runs: all but the unchanged one where it is vi_adaptive's
EX2_CHANGE_JOBS = [c for c in EX2_CHANGES
                   if not (c == "unchanged" and EX2_UNCHANGED_IS_ADAPTIVE)]


def ex2_change_files(kind):
    """The files of every series of ex2-adaptive-rate.md ('table' or 'npz'), the unchanged
    one first: vi_adaptive_change's, or vi_adaptive's for a series not in EX2_CHANGE_JOBS."""
    return [path(getattr(rules.vi_adaptive_change.output, kind), problem="ex2", change=c)
            if c in EX2_CHANGE_JOBS
            else path(getattr(rules.vi_adaptive.output, kind), problem="ex2")
            for c in EX2_CHANGES]


rule vi_adaptive_change:
    output:
        table=f"{RES}/vi/{{problem}}/adaptive-changes/{{change}}.csv",
        npz=f"{RES}/vi/{{problem}}/adaptive-changes/{{change}}.npz",
    log:
        f"{RES}/logs/vi/{{problem}}_adaptive_change_{{change}}.log",
    benchmark:
        f"{RES}/benchmarks/vi/{{problem}}_adaptive_change_{{change}}.tsv"
    wildcard_constraints:
        problem="ex2",
        change="|".join(re.escape(c) for c in EX2_CHANGE_JOBS),
    params:
        example=vi_example,
        data=vi_data,
        theta=lambda w: ex2_change(w, "theta"),
        start_level=lambda w: ex2_change(w, "start_level"),
        max_dofs=lambda w: ex2_change(w, "max_dofs"),
        max_steps=config["vi_adaptive"]["max_steps"],
        figure_steps=[],
        tol=SOLVER["tol"],
        quadrature=QUADRATURE,
        operator=config["vi_adaptive"]["operator"],
        family="adaptive-change",
        every_step=True,
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_adaptive.py"


rule vi_adaptive_distances:
    input:
        tables=ex2_change_files("table"),
        npz=ex2_change_files("npz"),
    output:
        csv=f"{RES}/vi/ex2/adaptive-changes/distances.csv",
    log:
        f"{RES}/logs/vi/ex2_adaptive_distances.log",
    benchmark:
        f"{RES}/benchmarks/vi/ex2_adaptive_distances.tsv"
    params:
        example="ex2",
        data=vi_data(Namespace(problem="ex2")),
        quadrature=QUADRATURE,
        operator=config["vi_adaptive"]["operator"],
        cases=[case for case, _ in EX2_CHANGES.values()],
        changes={case: {k: v for k, v in change.items() if k != "max_dofs"}
                 for case, change in EX2_CHANGES.values()},
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/vi_adaptive_distances.py"


rule ex2_adaptive_rate:
    input:
        distances=rules.vi_adaptive_distances.output.csv,
        errors=vi_errors_table("ex2"),
    output:
        md=report(
            f"{OUT}/ex2-adaptive-rate.md",
            caption="../../report/captions/ex2-adaptive-rate.rst",
            category="Example 2 (obstacle)",
            subcategory="Tables",
        ),
        png=report(
            f"{OUT}/extra-ex2-adaptive-rate.png",
            caption="../../report/captions/ex2-adaptive-rate.rst",
            category="Example 2 (obstacle)",
            subcategory="Further figures",
        ),
    params:
        max_dofs=EX2["adaptive_changes"]["max_dofs"],
        series_max_dofs=config["vi_adaptive"]["max_dofs"],
    log:
        f"{RES}/logs/ex2_adaptive_rate.log",
    benchmark:
        f"{RES}/benchmarks/tables/ex2_adaptive_rate.tsv"
    conda:
        ENV
    script:
        "../scripts/ex2_adaptive_rate.py"
