# Examples 4 and 5 (paper Section 8.2): parabolic obstacle and friction, DG(0) in time.


rule para_solve:
    output:
        row=f"{RES}/para/{{problem}}/{{family}}/{{tag}}.csv",
        npz=f"{RES}/para/{{problem}}/{{family}}/{{tag}}.npz",
    log:
        f"{RES}/logs/para/{{problem}}_{{family}}_{{tag}}.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_{{family}}_{{tag}}.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
        family="uniform|graded|graded-sr",
    params:
        example=para_example,
        data=para_data,
        grading=GRADING,
        T=PARA["T"],
        tau_factor=para_tau_factor,
        tol=SOLVER["tol"],
        quadrature=PARA_QUADRATURE,
        operator=lambda w: PARA["reference"]["operator"] if w.family == "reference" else "dense",
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_solve.py"


# The runs of the reference's family (the reference and its coarser runs): para_solve's job
# under a name of its own, so that a cluster profile gives the reference the hour it needs
# at the paper-scale tier while the series' runs keep their minutes
use rule para_solve as para_reference_solve with:
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
        family="reference",


# The reference's operator, assembled once (minutes at the default tier's size) for the
# jobs below that measure runs against it, of every problem with the same s and reference
# mesh (para_operator_owner). Kept, not temporary: made again for a later target, it would
# be newer than Algorithm C's outputs and Snakemake would run Algorithm C again (hours at
# the paper-scale tier); ancient() does not help, as it needs the file to exist
rule para_reference_operator:
    input:
        ref=para_reference,
    output:
        pkl=f"{RES}/para/{{problem}}/reference-operator.pkl",
    log:
        f"{RES}/logs/para/{{problem}}_reference_operator.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_reference_operator.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        quadrature=PARA_QUADRATURE,
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_reference_operator.py"


# The reference's family (para_reference_coarser and the reference) with the operator's
# products of every run, built once (a minute at the default tier's size) for the jobs
# below that measure runs against its limit; kept, as the operator
rule para_reference_family:
    input:
        ref=para_reference,
        operator=para_reference_operator,
        coarser=para_reference_coarser,
    output:
        pkl=f"{RES}/para/{{problem}}/reference-family.pkl",
    log:
        f"{RES}/logs/para/{{problem}}_reference_family.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_reference_family.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        quadrature=PARA_QUADRATURE,
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_reference_family.py"


rule para_adaptive:
    input:
        ref=para_reference,
        operator=para_reference_operator,
        coarser=para_reference_coarser,
        family=rules.para_reference_family.output.pkl,
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
        example=para_example,
        data=para_data,
        T=PARA["T"],
        theta=PARA["adaptive"]["theta"],
        start_level=PARA["adaptive"]["start_level"],
        c_tau=PARA["adaptive"]["c_tau"],
        max_spacetime_dofs=PARA["adaptive"]["max_spacetime_dofs"],
        max_iterations=PARA["adaptive"]["max_iterations"],
        figure_iterations=PARA["adaptive"]["figure_iterations"],
        operator=PARA["adaptive"]["operator"],
        output_times=PARA["output_times"],
        tol=SOLVER["tol"],
        quadrature=PARA_QUADRATURE,
        # each pass that does not end the run; the job continues from it when started
        # again (a time limit, a lost machine), and removes it when done
        checkpoint=lambda wc: f"{RES}/para/{wc.problem}/adaptive/checkpoint.npz",
        # a checkpoint kept in the repository: the job starts from a copy of it when it is
        # further on than the job's own (a run longer than one allocation; docs/cluster.md)
        committed=lambda wc: (None if PARA["adaptive"]["committed_checkpoints"] is None else
                              str(Path(workflow.basedir) / PARA["adaptive"]["committed_checkpoints"]
                                  / f"{wc.problem}-adaptive.npz")),
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_adaptive.py"


# The reference's own error, from the two coarser runs of its family (its own target: the
# paper-scale tier measures it without Algorithm C's passes)
rule para_reference_error:
    input:
        ref=para_reference,
        operator=para_reference_operator,
        ref_row=para_reference_row,
        coarser=lambda w: para_reference_coarser(w)[-2:],   # the last two measure its error
    output:
        csv=f"{RES}/para/{{problem}}/reference-error.csv",
    log:
        f"{RES}/logs/para/{{problem}}_reference_error.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_reference_error.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        quadrature=PARA_QUADRATURE,
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_reference_error.py"


rule para_errors:
    input:
        adaptive=rules.para_adaptive.output.table,
        rows=para_series_rows,
        npz=para_series_npz,
        ref=para_reference,
        operator=para_reference_operator,
        coarser=para_reference_coarser,
        family=rules.para_reference_family.output.pkl,
        ref_error=rules.para_reference_error.output.csv,
    output:
        csv=f"{RES}/para/{{problem}}/errors.csv",
    log:
        f"{RES}/logs/para/{{problem}}_errors.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_errors.tsv"
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        quadrature=PARA_QUADRATURE,
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_errors.py"


# Algorithm C's passes of one problem from its own run and its reference's measured
# error alone (seconds): neither the uniform and graded series nor their error measurement
rule para_passes:
    input:
        table=rules.para_adaptive.output.table,
        ref_error=rules.para_reference_error.output.csv,
    output:
        md=report(
            f"{OUT}/{{problem}}-algorithm-c.md",
            caption="../../report/captions/algorithm-c.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
        png=report(
            f"{OUT}/extra-{{problem}}-algorithm-c.png",
            caption="../../report/captions/algorithm-c.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    log:
        f"{RES}/logs/para/{{problem}}_passes.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_passes.tsv"
    conda:
        ENV
    script:
        "../scripts/para_passes.py"


rule fig_para_error:
    input:
        csv=para_error_tables,
    output:
        png=report(
            f"{OUT}/fig{{num}}-{{slug}}.png",
            caption="../../report/captions/fig13-fig15.rst",
            category=lambda w: {"13": "Example 4 (parabolic obstacle)",
                                "15": "Example 5 (parabolic friction)"}[w.num],
            subcategory="Paper figures",
            labels=lambda w: {"figure": f"Figure {int(w.num)}",
                              "shows": "space-time error against space-time DOFs"},
        ),
        pdf=f"{OUT}/fig{{num}}-{{slug}}.pdf",
    wildcard_constraints:
        num="13|15",
        slug="ex4-error|ex5-error",
    log:
        f"{RES}/logs/fig{{num}}-{{slug}}.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig{{num}}-{{slug}}.tsv"
    conda:
        ENV
    script:
        "../scripts/fig_para_error.py"


rule fig10:
    input:
        npz=path(rules.para_adaptive.output.npz, problem="ex4-u1"),
    output:
        png=report(
            f"{OUT}/fig10-ex4-solution.png",
            caption="../../report/captions/fig10.rst",
            category="Example 4 (parabolic obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 10", "shows": "u_hτ and λ_H at the final time"},
        ),
        pdf=f"{OUT}/fig10-ex4-solution.pdf",
    params:
        figure="fig10",
    log:
        f"{RES}/logs/fig10.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig10.tsv"
    conda:
        ENV
    script:
        "../scripts/fig04.py"


rule fig14:
    input:
        npz=path(rules.para_adaptive.output.npz, problem="ex5"),
        reference=lambda w: para_reference(Namespace(problem="ex5")),
    output:
        png=report(
            f"{OUT}/fig14-ex5-solution.png",
            caption="../../report/captions/fig14.rst",
            category="Example 5 (parabolic friction)",
            subcategory="Paper figures",
            labels={"figure": "Figure 14", "shows": "u_hτ and λ_H at several times"},
        ),
        pdf=f"{OUT}/fig14-ex5-solution.pdf",
        md=report(
            f"{OUT}/ex5-free-boundary.md",
            caption="../../report/captions/ex5-free-boundary.rst",
            category="Example 5 (parabolic friction)",
            subcategory="Tables",
        ),
    params:
        times=[t for t in PARA["output_times"] if t < PARA["T"]],   # the paper: 0, 0.2, 0.4, 0.8
        F=PARA["examples"]["ex5"]["F"],
        tol=SOLVER["tol"],
    log:
        f"{RES}/logs/fig14.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig14.tsv"
    conda:
        ENV
    script:
        "../scripts/fig14.py"


rule fig11:
    input:
        npz=path(rules.para_adaptive.output.npz, problem="ex4-u2"),
        table=path(rules.para_adaptive.output.table, problem="ex4-u2"),
    output:
        png=report(
            f"{OUT}/fig11-ex4-indicators-in-time.png",
            caption="../../report/captions/fig11.rst",
            category="Example 4 (parabolic obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 11", "shows": "indicators over time"},
        ),
        pdf=f"{OUT}/fig11-ex4-indicators-in-time.pdf",
    log:
        f"{RES}/logs/fig11.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig11.tsv"
    conda:
        ENV
    script:
        "../scripts/fig11.py"


rule fig12:
    input:
        npz=path(rules.para_adaptive.output.npz, problem="ex4-u1"),
    output:
        png=report(
            f"{OUT}/fig12-ex4-spacetime-meshes.png",
            caption="../../report/captions/fig12.rst",
            category="Example 4 (parabolic obstacle)",
            subcategory="Paper figures",
            labels={"figure": "Figure 12", "shows": "space-time adaptive meshes"},
        ),
        pdf=f"{OUT}/fig12-ex4-spacetime-meshes.pdf",
    log:
        f"{RES}/logs/fig12.log",
    benchmark:
        f"{RES}/benchmarks/figures/fig12.tsv"
    conda:
        ENV
    script:
        "../scripts/fig12.py"


rule parabolic_summary:
    input:
        csv=[para_errors_table(p) for p in PARA_PROBLEMS],
        larger=larger_committed("error"),
        larger_runs=larger_committed("runs"),
    output:
        md=report(
            f"{OUT}/parabolic-runs.md",
            caption="../../report/captions/parabolic-runs.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
        png=report(
            f"{OUT}/extra-parabolic-error-vs-time.png",
            caption="../../report/captions/parabolic-runs.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
    log:
        f"{RES}/logs/parabolic_summary.log",
    benchmark:
        f"{RES}/benchmarks/tables/parabolic_summary.tsv"
    conda:
        ENV
    script:
        "../scripts/parabolic_summary.py"


rule para_reference_check:
    output:
        md=report(
            f"{OUT}/parabolic-reference-check.md",
            caption="../../report/captions/parabolic-reference-check.rst",
            category="Benchmarks and checks",
            subcategory="Checks",
        ),
        csv=f"{RES}/para/reference-check.csv",
    params:
        s_list=sorted({float(e["s"]) for e in PARA["examples"].values()}),
        T=PARA["T"],
        grading=GRADING,
        uniform_levels=PARA["uniform_levels"],
        graded_h=PARA["graded_h"],
        tau_factor=PARA["tau_factor"],
        family_h=PARA["reference"]["check_h"],
        reference_tau_factor=PARA["reference"]["tau_factor"],
        quadrature=PARA_QUADRATURE,
    log:
        f"{RES}/logs/para/reference_check.log",
    benchmark:
        f"{RES}/benchmarks/para/reference_check.tsv"
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_reference_check.py"


# Example 5's uniform rate: the series against references made alike, for Example 5 and for
# one change of it at a time (no friction; an initial value that does not vanish on ∂Ω);
# Example 5's own runs are para_solve's, the changed cases share their operators
rule ex5_uniform_cause:
    input:
        family=lambda w: [para_graded_run("ex5", h) for h in PARA["reference"]["check_h"]],
        uniform=lambda w: [path(rules.para_solve.output.npz, problem="ex5", family="uniform",
                                tag=series_tag("uniform", lv))
                           for lv in PARA["uniform_cause"]["uniform_levels"]],
    output:
        md=report(
            f"{OUT}/ex5-uniform-rate.md",
            caption="../../report/captions/ex5-uniform-rate.rst",
            category="Example 5 (parabolic friction)",
            subcategory="Tables",
        ),
        csv=f"{RES}/para/ex5-uniform-cause.csv",
    params:
        data=lambda w: PARA["examples"]["ex5"],
        changes={"F = 0 (no friction)": {"F": 0.0}, "u₀ = 1": {"u0": 1.0}},
        T=PARA["T"],
        grading=GRADING,
        uniform_levels=PARA["uniform_cause"]["uniform_levels"],
        time_refinements=PARA["uniform_cause"]["time_refinements"],
        uniform_tau_factor=PARA["tau_factor"]["uniform"],
        family_h=PARA["reference"]["check_h"],
        reference_tau_factor=PARA["reference"]["tau_factor"],
        tol=SOLVER["tol"],
        quadrature=PARA_QUADRATURE,
    log:
        f"{RES}/logs/para/ex5_uniform_cause.log",
    benchmark:
        f"{RES}/benchmarks/para/ex5_uniform_cause.tsv"
    priority: PRIORITY["long"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/ex5_uniform_cause.py"


# How much of Algorithm C's error, and of the graded series', is the time discretisation's:
# its passes solved again on their own space-time meshes with m times the time steps
# (fracfem.solve_slabs), the graded runs on their meshes with m times theirs
rule para_time_split:
    input:
        ref=para_reference,
        operator=para_reference_operator,
        coarser=para_reference_coarser,
        family=rules.para_reference_family.output.pkl,
        # its reference error and graded runs: a kept table where there is one (it reruns
        # Algorithm C's first passes itself, so a tier's kept problems need no pass of theirs)
        errors=lambda w: para_errors_table(w.problem),
    output:
        md=report(
            f"{OUT}/{{problem}}-time-split.md",
            caption="../../report/captions/time-split.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
        csv=f"{RES}/para/{{problem}}/adaptive/time-split.csv",
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        example=para_example,
        data=para_data,
        T=PARA["T"],
        theta=PARA["adaptive"]["theta"],
        start_level=PARA["adaptive"]["start_level"],
        c_tau=PARA["adaptive"]["c_tau"],
        max_spacetime_dofs=PARA["time_split"]["max_spacetime_dofs"],
        max_iterations=PARA["adaptive"]["max_iterations"],
        refinements=PARA["time_split"]["refinements"],
        graded_h=PARA["graded_h"],
        grading=GRADING,
        graded_tau_factor=PARA["tau_factor"]["graded"],
        operator=PARA["adaptive"]["operator"],
        tol=SOLVER["tol"],
        quadrature=PARA_QUADRATURE,
    log:
        f"{RES}/logs/para/{{problem}}_time_split.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_time_split.tsv"
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_time_split.py"


# Algorithm C's passes measured against its own last pass (as the paper measures against its
# finest adaptive mesh) beside the family's limit: the same passes, only the reference changes
rule para_self_reference:
    input:
        ref=para_reference,
        operator=para_reference_operator,
        coarser=para_reference_coarser,
        family=rules.para_reference_family.output.pkl,
        ref_error=rules.para_reference_error.output.csv,
    output:
        md=report(
            f"{OUT}/{{problem}}-self-reference.md",
            caption="../../report/captions/self-reference.rst",
            category="Across examples",
            subcategory="Examples 4 and 5",
        ),
        csv=f"{RES}/para/{{problem}}/adaptive/self-reference.csv",
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        example=para_example,
        data=para_data,
        T=PARA["T"],
        theta=PARA["adaptive"]["theta"],
        start_level=PARA["adaptive"]["start_level"],
        c_tau=PARA["adaptive"]["c_tau"],
        max_spacetime_dofs=PARA["self_reference"]["max_spacetime_dofs"],
        max_iterations=PARA["adaptive"]["max_iterations"],
        operator=PARA["adaptive"]["operator"],
        tol=SOLVER["tol"],
        quadrature=PARA_QUADRATURE,
    log:
        f"{RES}/logs/para/{{problem}}_self_reference.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_self_reference.tsv"
    priority: PRIORITY["parabolic"]
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/para_self_reference.py"


# `snakemake --cores 2 results/para/<problem>/reference-committed.txt`: compute the reference
# run of one problem and replace its committed copy (parabolic.reference.committed; the input
# files, not outputs of this rule: a fresh clone uses the copies as they are); add
# `--forcerun para_solve` to recompute a reference that has a matching copy already
rule para_reference_commit:
    input:
        npz=lambda w: path(rules.para_solve.output.npz, problem=w.problem, family="reference",
                           tag=para_reference_tag(w.problem)),
        row=lambda w: path(rules.para_solve.output.row, problem=w.problem, family="reference",
                           tag=para_reference_tag(w.problem)),
        error=rules.para_reference_error.output.csv,
    output:
        note=f"{RES}/para/{{problem}}/reference-committed.txt",
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        committed=lambda w: tuple(str(committed_para_reference(w.problem, kind))
                                  for kind in ("npz", "csv", "error")),
        multipliers=["ex5"],    # λ_H kept for ex5-free-boundary.md
    log:
        f"{RES}/logs/para/{{problem}}_reference_commit.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_reference_commit.tsv"
    conda:
        ENV
    script:
        "../scripts/para_reference_copy.py"


# The errors of this configuration's runs, committed beside its references: with
# config/ex4-paper-reference.yaml, the default tier's runs against the paper-scale references
rule para_errors_commit:
    input:
        csv=rules.para_errors.output.csv,
    output:
        note=f"{RES}/para/{{problem}}/errors-committed.txt",
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        committed=lambda w: str(committed_para_reference(w.problem, "runs")),
    log:
        f"{RES}/logs/para/{{problem}}_errors_commit.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_errors_commit.tsv"
    conda:
        ENV
    script:
        "../scripts/para_errors_copy.py"


# `snakemake --cores 2 results-paper/para/<problem>/errors-kept.txt --configfile
# config/paper.yaml`: keep a problem's error table in the repository (parabolic.kept_errors;
# written as a param, not an output: a fresh clone reads the copy as it is), so that the
# figures and tables of a tier whose problems take an allocation each are made from them
# (then `snakemake --cores 2 rates_parabolic --configfile config/paper.yaml`: their rates)
rule para_errors_keep:
    input:
        csv=rules.para_errors.output.csv,
    output:
        note=f"{RES}/para/{{problem}}/errors-kept.txt",
    wildcard_constraints:
        problem="|".join(PARA_PROBLEMS),
    params:
        committed=lambda w: str(kept_para_errors(w.problem) or _no_kept_errors()),
        settings=lambda w: kept_errors_settings(w.problem),   # written beside it (.json)
    log:
        f"{RES}/logs/para/{{problem}}_errors_keep.log",
    benchmark:
        f"{RES}/benchmarks/para/{{problem}}_errors_keep.tsv"
    conda:
        ENV
    script:
        "../scripts/para_errors_copy.py"


# `snakemake --cores 2 para_reference_large --forcerun para_solve`: the same for every problem
rule para_reference_large:
    input:
        [path(rules.para_reference_commit.output.note, problem=p) for p in PARA_PROBLEMS],
