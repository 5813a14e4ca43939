# Example 1 (paper Section 8.1): (−Δ)^s u = 1 on the unit disk, exact solution.


rule ex1_solve:
    output:
        row=f"{RES}/ex1/{{family}}/s{{s}}/{{tag}}.csv",
        npz=f"{RES}/ex1/{{family}}/s{{s}}/{{tag}}.npz",
    log:
        f"{RES}/logs/ex1/{{family}}_s{{s}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/ex1/{{family}}_s{{s}}_{{tag}}.tsv"
    params:
        grading=GRADING,
        quadrature=QUADRATURE,
        operator=EX1["operator"],
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/ex1_solve.py"


rule ex1_adaptive:
    output:
        table=f"{RES}/ex1/adaptive/s{{s}}/steps.csv",
        npz=f"{RES}/ex1/adaptive/s{{s}}/last.npz",
    log:
        f"{RES}/logs/ex1/adaptive_s{{s}}.log",
    benchmark:
        f"{RES}/benchmarks/ex1/adaptive_s{{s}}.tsv"
    params:
        theta=EX1["adaptive"]["theta"],
        start_level=EX1["adaptive"]["start_level"],
        max_dofs=EX1["adaptive"]["max_dofs"],
        max_steps=EX1["adaptive"]["max_steps"],
        quadrature=QUADRATURE,
        operator=EX1["adaptive"]["operator"],
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/ex1_adaptive.py"


# Algorithm B for Example 1 again with one setting of example1.adaptive changed at a time
# (ex1-adaptive-rate.md): {change: {setting: value}}
EX1_CHANGES = {
    **{f"start{lv}": {"start_level": lv} for lv in EX1["adaptive_changes"]["start_level"]},
    **{f"theta{fmt(th)}": {"theta": th} for th in EX1["adaptive_changes"]["theta"]},
}


def ex1_change(wildcards, key):
    """A setting of the series of change wildcards.change: the change's or adaptive's."""
    return {**EX1["adaptive"], **EX1_CHANGES[wildcards.change]}[key]


rule ex1_adaptive_change:
    output:
        table=f"{RES}/ex1/adaptive-changes/s{{s}}/{{change}}.csv",
    wildcard_constraints:
        change="|".join(re.escape(c) for c in EX1_CHANGES) or "(?!)",
    log:
        f"{RES}/logs/ex1/adaptive-changes_s{{s}}_{{change}}.log",
    benchmark:
        f"{RES}/benchmarks/ex1/adaptive-changes_s{{s}}_{{change}}.tsv"
    params:
        theta=lambda w: ex1_change(w, "theta"),
        start_level=lambda w: ex1_change(w, "start_level"),
        max_dofs=EX1["adaptive_changes"]["max_dofs"],
        max_steps=EX1["adaptive"]["max_steps"],
        quadrature=QUADRATURE,
        operator=EX1["adaptive"]["operator"],
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/ex1_adaptive.py"


rule ex1_adaptive_rate:
    input:
        series=path(rules.ex1_adaptive.output.table, s=fmt(EX1["s"])),
        changes=[path(rules.ex1_adaptive_change.output.table, s=fmt(EX1["s"]), change=c)
                 for c in EX1_CHANGES],
    output:
        md=report(
            f"{OUT}/ex1-adaptive-rate.md",
            caption="../../report/captions/ex1-adaptive-rate.rst",
            category="Example 1",
            subcategory="Tables",
        ),
        png=report(
            f"{OUT}/extra-ex1-adaptive-rate.png",
            caption="../../report/captions/ex1-adaptive-rate.rst",
            category="Example 1",
            subcategory="Further figures",
        ),
    params:
        changes={f"{k} = {v}": change for change in EX1_CHANGES.values()
                 for k, v in change.items()},
        max_dofs=EX1["adaptive_changes"]["max_dofs"],
    log:
        f"{RES}/logs/ex1_adaptive_rate.log",
    benchmark:
        f"{RES}/benchmarks/tables/ex1_adaptive_rate.tsv"
    conda:
        ENV
    script:
        "../scripts/ex1_adaptive_rate.py"


rule ex1_table:
    input:
        rows=ex1_runs(S_EX1) + [path(rules.ex1_adaptive.output.table, s=fmt(EX1["s"]))],
    output:
        table=f"{RES}/ex1/table.csv",
    log:
        f"{RES}/logs/ex1/table.log",
    benchmark:
        f"{RES}/benchmarks/tables/ex1_table.tsv"
    conda:
        ENV
    script:
        "../scripts/collect_rows.py"


rule fig01:
    input:
        npz=path(rules.ex1_solve.output.npz, family="graded", s=fmt(EX1["s"]),
                 tag=series_tag("graded", EX1["figure1_h"])),
    output:
        png=report(
            f"{OUT}/fig01-ex1-solution-graded.png",
            caption="../../report/captions/fig01.rst",
            category="Example 1",
            subcategory="Paper figures",
            labels={"figure": "Figure 1", "shows": "u_h on a graded mesh"},
        ),
        pdf=f"{OUT}/fig01-ex1-solution-graded.pdf",
    log:
        f"{RES}/logs/fig01.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig01.tsv"
    conda:
        ENV
    script:
        "../scripts/fig01.py"


rule fig02:
    input:
        rows=ex1_runs([EX1["s"]]) + [path(rules.ex1_adaptive.output.table, s=fmt(EX1["s"]))],
    output:
        png=report(
            f"{OUT}/fig02-ex1-error.png",
            caption="../../report/captions/fig02.rst",
            category="Example 1",
            subcategory="Paper figures",
            labels={"figure": "Figure 2", "shows": "energy error against DOFs"},
        ),
        pdf=f"{OUT}/fig02-ex1-error.pdf",
    params:
        s=EX1["s"],
    log:
        f"{RES}/logs/fig02.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig02.tsv"
    conda:
        ENV
    script:
        "../scripts/fig02.py"


rule ex1_extra_figures:
    input:
        table=rules.ex1_table.output.table,
    output:
        time=report(
            f"{OUT}/extra-ex1-error-vs-time.png",
            caption="../../report/captions/extra-ex1-error-vs-time.rst",
            category="Example 1",
            subcategory="Further figures",
        ),
        orders=report(
            f"{OUT}/extra-ex1-orders.png",
            caption="../../report/captions/extra-ex1-orders.rst",
            category="Example 1",
            subcategory="Further figures",
        ),
        errors=report(
            f"{OUT}/ex1-errors.md",
            caption="../../report/captions/ex1-errors.rst",
            category="Example 1",
            subcategory="Tables",
        ),
    log:
        f"{RES}/logs/ex1_extra.log",
    benchmark:
        f"{RES}/benchmarks/figures/ex1_extra.tsv"
    conda:
        ENV
    script:
        "../scripts/ex1_extra.py"


rule ex1_quadrature_check:
    input:
        row=rules.ex1_solve.output.row,
    output:
        row=f"{RES}/ex1-quadrature/{{family}}/s{{s}}/{{tag}}.csv",
    log:
        f"{RES}/logs/ex1-quadrature/{{family}}_s{{s}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/ex1-quadrature/{{family}}_s{{s}}_{{tag}}.tsv"
    params:
        grading=GRADING,
        quadrature=QUADRATURE,
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/ex1_quadrature.py"


rule ex1_quadrature_table:
    input:
        rows=[path(rules.ex1_quadrature_check.output.row, family=fam, s=fmt(EX1["s"]),
                   tag=quadrature_check_tag(EX1, fam))
              for fam in families(EX1)],
    output:
        md=report(
            f"{OUT}/ex1-quadrature-check.md",
            caption="../../report/captions/ex1-quadrature-check.rst",
            category="Benchmarks and checks",
            subcategory="Checks",
        ),
    log:
        f"{RES}/logs/ex1_quadrature_table.log",
    benchmark:
        f"{RES}/benchmarks/tables/ex1_quadrature_table.tsv"
    conda:
        ENV
    script:
        "../scripts/ex1_quadrature_table.py"
