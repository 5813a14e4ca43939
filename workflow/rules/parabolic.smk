# Examples 4 and 5 (paper Section 8.2): parabolic obstacle and friction, DG(0) in time.
PARA = config["parabolic"]
PARA_PROBLEMS = list(PARA["examples"])
PARA_REF_TAG = f"h{fmt(PARA['reference']['graded_h'])}"


def para_tags(family):
    if family == "uniform":
        return [f"L{int(l)}" for l in PARA["uniform_levels"]]
    return [f"h{fmt(h)}" for h in PARA["graded_h"]]


def para_runs(problem, ext="csv"):
    return [f"{RES}/para/{problem}/{fam}/{tag}.{ext}"
            for fam in ("uniform", "graded") for tag in para_tags(fam)]


rule para_solve:
    output:
        row=f"{RES}/para/{{problem}}/{{pfamily}}/{{tag}}.csv",
        npz=f"{RES}/para/{{problem}}/{{pfamily}}/{{tag}}.npz",
    log:
        f"{RES}/logs/para/{{problem}}_{{pfamily}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_{{pfamily}}_{{tag}}.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
        pfamily="uniform|graded|reference",
    params:
        config={k: config[k] for k in ("example1", "example2", "parabolic", "solver",
                                       "quadrature")},
    threads: 2
    script:
        "../scripts/para_solve.py"


rule para_adaptive:
    input:
        ref=f"{RES}/para/{{problem}}/reference/{PARA_REF_TAG}.npz",
    output:
        table=f"{RES}/para/{{problem}}/adaptive/iterations.csv",
        npz=f"{RES}/para/{{problem}}/adaptive/meshes.npz",
    log:
        f"{RES}/logs/para/{{problem}}_adaptive.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_adaptive.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        config={k: config[k] for k in ("example1", "example2", "parabolic", "solver",
                                       "quadrature")},
    threads: 2
    script:
        "../scripts/para_adaptive.py"


rule para_errors:
    input:
        adaptive=f"{RES}/para/{{problem}}/adaptive/iterations.csv",
        rows=lambda w: para_runs(w.problem),
        npz=lambda w: para_runs(w.problem, "npz"),
        ref=f"{RES}/para/{{problem}}/reference/{PARA_REF_TAG}.npz",
    output:
        csv=f"{RES}/para/{{problem}}/errors.csv",
    log:
        f"{RES}/logs/para/{{problem}}_errors.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_errors.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        quadrature=config["quadrature"],
    threads: 2
    script:
        "../scripts/para_errors.py"


rule fig_para_error:
    input:
        csv=lambda w: [f"{RES}/para/{p}/errors.csv" for p in PARA_PROBLEMS
                       if p.startswith("ex4" if w.num == "13" else "ex5")],
    output:
        png=f"{OUT}/fig{{num}}-{{slug}}.png",
        pdf=f"{OUT}/fig{{num}}-{{slug}}.pdf",
    wildcard_constraints:
        num="13|15",
        slug="ex4-error|ex5-error",
    log:
        f"{RES}/logs/fig{{num}}-{{slug}}.log",
    script:
        "../scripts/fig_para_error.py"


rule fig10:
    input:
        npz=f"{RES}/para/ex4-u1/adaptive/meshes.npz",
    output:
        png=f"{OUT}/fig10-ex4-solution.png",
        pdf=f"{OUT}/fig10-ex4-solution.pdf",
    params:
        title=lambda w: ("Example 4, $u_0=1$: $u_{{h\\tau}}$ at T = " + f"{PARA['T']:g}"
                         + ", adaptive ({triangles} triangles)"),
    log:
        f"{RES}/logs/fig10.log",
    script:
        "../scripts/fig04.py"


rule fig14:
    input:
        npz=f"{RES}/para/ex5/reference/{PARA_REF_TAG}.npz",
    output:
        png=f"{OUT}/fig14-ex5-solution.png",
        pdf=f"{OUT}/fig14-ex5-solution.pdf",
        md=f"{OUT}/ex5-free-boundary.md",
    params:
        times=[0.0, 0.2, 0.4, 0.8],
        F=PARA["examples"]["ex5"]["F"],
    log:
        f"{RES}/logs/fig14.log",
    script:
        "../scripts/fig14.py"


rule fig11:
    input:
        npz=f"{RES}/para/ex4-u2/adaptive/meshes.npz",
        table=f"{RES}/para/ex4-u2/adaptive/iterations.csv",
    output:
        png=f"{OUT}/fig11-ex4-indicators-in-time.png",
        pdf=f"{OUT}/fig11-ex4-indicators-in-time.pdf",
    log:
        f"{RES}/logs/fig11.log",
    script:
        "../scripts/fig11.py"


rule fig12:
    input:
        npz=f"{RES}/para/ex4-u1/adaptive/meshes.npz",
    output:
        png=f"{OUT}/fig12-ex4-spacetime-meshes.png",
        pdf=f"{OUT}/fig12-ex4-spacetime-meshes.pdf",
    log:
        f"{RES}/logs/fig12.log",
    script:
        "../scripts/fig12.py"


rule parabolic_summary:
    input:
        csv=[f"{RES}/para/{p}/errors.csv" for p in PARA_PROBLEMS],
    output:
        md=f"{OUT}/parabolic-runs.md",
        png=f"{OUT}/extra-parabolic-error-vs-time.png",
    log:
        f"{RES}/logs/parabolic_summary.log",
    script:
        "../scripts/parabolic_summary.py"


rule para_reference_check:
    output:
        md=f"{OUT}/parabolic-reference-check.md",
        csv=f"{RES}/para/reference-check.csv",
    params:
        config={k: config[k] for k in ("example1", "parabolic", "quadrature")},
        s_list=sorted({float(e["s"]) for e in PARA["examples"].values()}),
    log:
        f"{RES}/logs/para/reference_check.log",
    benchmark:
        f"{RES}/benchmarks/para/reference_check.tsv"
    threads: 2
    script:
        "../scripts/para_reference_check.py"
