# Examples 2 and 3 (paper Section 8.1) and the thin demonstrations: mixed form,
# PDAS solution cross-checked by Uzawa (Algorithm A) on every mesh.
EX2 = config["example2"]
EX3 = config["example3"]
THIN = config["thin"]
VI_PROBLEMS = ["ex2"] + [f"ex3-{v}" for v in EX3["variants"]]


def vi_tags(problem, family):
    c = EX2 if problem == "ex2" else EX3
    if family == "uniform":
        return [f"L{int(l)}" for l in c["uniform_levels"]]
    return [f"h{fmt(h)}" for h in c["graded_h"]]


def vi_rows(problem):
    return [f"{RES}/vi/{problem}/{fam}/{tag}.csv"
            for fam in ("uniform", "graded") for tag in vi_tags(problem, fam)]


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
        family="uniform|graded|demo",
    params:
        config={k: config[k] for k in ("example1", "example2", "example3", "thin", "solver",
                                       "quadrature")},
    threads: 2
    script:
        "../scripts/vi_solve.py"


rule vi_table:
    input:
        lambda w: vi_rows(w.problem),
    output:
        table=f"{RES}/vi/{{problem}}/table.csv",
    log:
        f"{RES}/logs/vi/{{problem}}_table.log",
    script:
        "../scripts/collect_rows.py"


rule vi_runs_md:
    input:
        [f"{RES}/vi/{p}/table.csv" for p in VI_PROBLEMS],
    output:
        md=f"{OUT}/vi-runs.md",
    log:
        f"{RES}/logs/vi_runs_md.log",
    script:
        "../scripts/vi_runs_md.py"


rule fig03:
    output:
        png=f"{OUT}/fig03-obstacle.png",
        pdf=f"{OUT}/fig03-obstacle.pdf",
    params:
        obstacle=EX2["obstacle"],
    log:
        f"{RES}/logs/fig03.log",
    script:
        "../scripts/fig03.py"


rule fig04:
    input:
        npz=f"{RES}/vi/ex2/uniform/L{EX2['figure4_level']}.npz",
    output:
        png=f"{OUT}/fig04-ex2-solution-uniform.png",
        pdf=f"{OUT}/fig04-ex2-solution-uniform.pdf",
    params:
        obstacle=EX2["obstacle"],
    log:
        f"{RES}/logs/fig04.log",
    script:
        "../scripts/fig04.py"


rule fig08:
    input:
        npz=f"{RES}/vi/ex3-{EX3['figure8_variant']}/uniform/L{EX3['figure8_level']}.npz",
    output:
        png=f"{OUT}/fig08-ex3-solution-multiplier.png",
        pdf=f"{OUT}/fig08-ex3-solution-multiplier.pdf",
    params:
        title=f"Example 3 ({EX3['figure8_variant']} data)",
    log:
        f"{RES}/logs/fig08.log",
    script:
        "../scripts/fig08.py"


rule thin_demo:
    input:
        npz=f"{RES}/vi/thin-{{kind}}/demo/L{THIN['level']}.npz",
    output:
        png=f"{OUT}/extra-thin-{{kind}}.png",
    wildcard_constraints:
        kind="obstacle|friction",
    log:
        f"{RES}/logs/thin_demo_{{kind}}.log",
    script:
        "../scripts/fig_thin.py"


# ---------------------------------------------------------------- adaptive series and errors
ELLIPTIC_VI = ["ex2"] + [f"ex3-{v}" for v in EX3["variants"]]


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
        config={k: config[k] for k in ("example1", "example2", "example3", "vi_adaptive",
                                       "solver", "quadrature")},
    threads: 2
    script:
        "../scripts/vi_adaptive.py"


rule vi_errors:
    input:
        series=f"{RES}/vi/{{problem}}/table.csv",
        adaptive=f"{RES}/vi/{{problem}}/adaptive/steps.csv",
    output:
        csv=f"{RES}/vi/{{problem}}/errors.csv",
        json=f"{RES}/vi/{{problem}}/reference.json",
    log:
        f"{RES}/logs/vi/{{problem}}_errors.log",
    wildcard_constraints:
        problem=r"ex2|ex3-\w+",
    params:
        config={k: config[k] for k in ("example3", "reference")},
    script:
        "../scripts/vi_errors.py"


rule reference_table:
    input:
        refs=[f"{RES}/vi/{p}/reference.json" for p in ELLIPTIC_VI],
        errors=[f"{RES}/vi/{p}/errors.csv" for p in ELLIPTIC_VI],
        ex1=f"{RES}/ex1/table.csv",
    output:
        md=f"{OUT}/elliptic-errors.md",
    params:
        family=config["reference"]["family"],
    log:
        f"{RES}/logs/reference_table.log",
    script:
        "../scripts/reference_table.py"


rule fig05:
    input:
        npz=f"{RES}/vi/ex2/adaptive/meshes.npz",
    output:
        png=f"{OUT}/fig05-ex2-solution-adaptive.png",
        pdf=f"{OUT}/fig05-ex2-solution-adaptive.pdf",
    params:
        title=lambda w: "Example 2, adaptive: $u_h$ ({triangles} triangles)",
    log:
        f"{RES}/logs/fig05.log",
    script:
        "../scripts/fig04.py"


rule fig06:
    input:
        npz=f"{RES}/vi/ex2/adaptive/meshes.npz",
    output:
        png=f"{OUT}/fig06-ex2-adaptive-meshes.png",
        pdf=f"{OUT}/fig06-ex2-adaptive-meshes.pdf",
    log:
        f"{RES}/logs/fig06.log",
    script:
        "../scripts/fig06.py"


rule fig_vi_error:
    input:
        csv=lambda w: [f"{RES}/vi/{p}/errors.csv"
                       for p in (["ex2"] if w.num == "07" else
                                 [f"ex3-{v}" for v in EX3["variants"]])],
    output:
        png=f"{OUT}/fig{{num}}-{{slug}}.png",
        pdf=f"{OUT}/fig{{num}}-{{slug}}.pdf",
    wildcard_constraints:
        num="07|09",
        slug="ex2-error|ex3-error",
    log:
        f"{RES}/logs/fig{{num}}-{{slug}}.log",
    script:
        "../scripts/fig_vi_error.py"


rule elliptic_error_vs_time:
    input:
        ex1=f"{RES}/ex1/table.csv",
        vi=[f"{RES}/vi/{p}/errors.csv" for p in ELLIPTIC_VI],
    output:
        png=f"{OUT}/extra-elliptic-error-vs-time.png",
        md=f"{OUT}/elliptic-error-vs-time.md",
    params:
        s=EX1["s"],
    log:
        f"{RES}/logs/elliptic_error_vs_time.log",
    script:
        "../scripts/elliptic_time.py"
