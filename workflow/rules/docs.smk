# RESULTS.md: every figure and table of `rule all` on one page, beside the figures.


rule results_page:
    input:
        rules.fig01.output.png,
        rules.fig02.output.png,
        rules.ex1_extra_figures.output,
        rules.ex1_adaptive_rate.output,
        rules.ex1_table.output,
        rules.rates.output.md,
        rules.ex1_quadrature_table.output.md,
        rules.fig03.output.png,
        rules.fig04.output.png,
        rules.fig05.output.png,
        rules.fig06.output.png,
        rules.ex2_graded_rings.output,
        rules.ex2_adaptive_rate.output,
        expand(rules.fig_vi_error.output.png, zip, num=["07", "09"],
               slug=["ex2-error", "ex3-error"]),
        rules.fig08.output.png,
        rules.vi_runs_md.output.md,
        rules.reference_table.output.md,
        rules.elliptic_error_vs_time.output,
        expand(rules.thin_demo.output.png, kind=["obstacle", "friction"]),
        rules.fig10.output.png,
        rules.fig11.output.png,
        rules.fig12.output.png,
        expand(rules.fig_para_error.output.png, zip, num=["13", "15"],
               slug=["ex4-error", "ex5-error"]),
        rules.fig14.output,
        rules.parabolic_summary.output,
        rules.para_reference_check.output.md,
        rules.ex5_uniform_cause.output.md,
        expand(rules.para_time_split.output.md, problem=PARA["time_split"]["problems"]),
        expand(rules.para_self_reference.output.md,
               problem=PARA["self_reference"]["problems"]),
        expand(rules.para_passes.output, problem=PARA_PROBLEMS),
        rules.benchmark_assembly.output.md,
        rules.bad_inputs.output.md,
    params:
        time_split=PARA["time_split"]["problems"],
        para=PARA_PROBLEMS,
        self_reference=PARA["self_reference"]["problems"],
    output:
        md=report(
            f"{OUT}/RESULTS.md",
            caption="../../report/captions/results-page.rst",
            category="Across examples",
            subcategory="Tables",
        ),
    log:
        f"{RES}/logs/results_page.log",
    benchmark:
        f"{RES}/benchmarks/tables/results_page.tsv"
    conda:
        ENV
    script:
        "../scripts/results_page.py"
