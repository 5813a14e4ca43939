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
        grading=EX1["grading"],
        quadrature=config["quadrature"],
        config={k: config[k] for k in ("example1", "quadrature")},
    threads: 2
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
        adaptive=EX1["adaptive"],
        quadrature=config["quadrature"],
    threads: 2
    script:
        "../scripts/ex1_adaptive.py"


rule ex1_table:
    input:
        ex1_rows(S_EX1),
        f"{RES}/ex1/adaptive/s{fmt(EX1['s'])}/steps.csv",
    output:
        table=f"{RES}/ex1/table.csv",
    log:
        f"{RES}/logs/ex1/table.log",
    script:
        "../scripts/collect_rows.py"


rule fig01:
    input:
        npz=f"{RES}/ex1/graded/s{fmt(EX1['s'])}/h{fmt(EX1['figure1_h'])}.npz",
    output:
        png=f"{OUT}/fig01-ex1-solution-graded.png",
        pdf=f"{OUT}/fig01-ex1-solution-graded.pdf",
    log:
        f"{RES}/logs/fig01.log",
    script:
        "../scripts/fig01.py"


rule fig02:
    input:
        rows=ex1_rows([EX1["s"]]) + [f"{RES}/ex1/adaptive/s{fmt(EX1['s'])}/steps.csv"],
    output:
        png=f"{OUT}/fig02-ex1-error.png",
        pdf=f"{OUT}/fig02-ex1-error.pdf",
    params:
        s=EX1["s"],
    log:
        f"{RES}/logs/fig02.log",
    script:
        "../scripts/fig02.py"


rule ex1_extra_figures:
    input:
        table=rules.ex1_table.output.table,
    output:
        time=f"{OUT}/extra-ex1-error-vs-time.png",
        orders=f"{OUT}/extra-ex1-orders.png",
        errors=f"{OUT}/ex1-errors.md",
    log:
        f"{RES}/logs/ex1_extra.log",
    script:
        "../scripts/ex1_extra.py"


rule ex1_quadrature_check:
    input:
        row=f"{RES}/ex1/{{family}}/s{{s}}/{{tag}}.csv",
    output:
        row=f"{RES}/ex1-quadrature/{{family}}/s{{s}}/{{tag}}.csv",
    log:
        f"{RES}/logs/ex1-quadrature/{{family}}_s{{s}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/ex1-quadrature/{{family}}_s{{s}}_{{tag}}.tsv"
    params:
        grading=EX1["grading"],
        quadrature=config["quadrature"],
    threads: 2
    script:
        "../scripts/ex1_quadrature.py"


rule ex1_quadrature_table:
    input:
        [f"{RES}/ex1-quadrature/{fam}/s{fmt(EX1['s'])}/{ex1_level_tags(fam)[-1]}.csv"
         for fam in ("uniform", "graded")],
    output:
        md=f"{OUT}/ex1-quadrature-check.md",
    log:
        f"{RES}/logs/ex1_quadrature_table.log",
    script:
        "../scripts/ex1_quadrature_table.py"
