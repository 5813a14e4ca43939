# fracfem reproduction workflow: every figure and table of the paper is its own
# target; `snakemake --cores 2` builds them all (rule all).
from snakemake.utils import min_version

min_version("8.0")

configfile: "config.yaml"

# `snakemake --report report.html` (or report.zip) after a run: every figure and table
# with its caption (report/captions/), this page first.
report: "report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/example1.smk"
include: "workflow/rules/vi.smk"
include: "workflow/rules/parabolic.smk"
include: "workflow/rules/report.smk"
include: "workflow/rules/docs.smk"

# Jobs that only read finished results and draw a figure or write a table (seconds
# each): on a cluster they run beside Snakemake instead of waiting in the queue.
localrules:
    all,
    ex1_table,
    ex1_quadrature_table,
    ex1_extra_figures,
    ex1_adaptive_rate,
    ex2_graded_rings,
    ex2_adaptive_rate,
    fig01,
    fig02,
    vi_table,
    vi_runs_md,
    fig03,
    fig04,
    fig05,
    fig06,
    fig08,
    thin_demo,
    fig_vi_error,
    reference_table,
    reference_large,
    elliptic_error_vs_time,
    fig_para_error,
    para_passes,
    fig10,
    fig11,
    fig12,
    fig14,
    parabolic_summary,
    rates,
    rates_elliptic,
    rates_parabolic,
    results_page,


rule all:
    input:
        rules.fig01.output,
        rules.fig02.output,
        rules.ex1_extra_figures.output,
        rules.ex1_adaptive_rate.output,
        rules.rates.output,
        rules.ex1_quadrature_table.output,
        rules.benchmark_assembly.output,
        rules.bad_inputs.output,
        rules.fig03.output,
        rules.fig04.output,
        rules.fig08.output,
        rules.vi_runs_md.output,
        rules.fig05.output,
        rules.ex2_graded_rings.output,
        rules.ex2_adaptive_rate.output,
        rules.fig06.output,
        expand(rules.fig_vi_error.output, zip, num=["07", "09"], slug=["ex2-error", "ex3-error"]),
        rules.reference_table.output,
        rules.elliptic_error_vs_time.output,
        rules.fig10.output,
        rules.fig14.output,
        expand(rules.fig_para_error.output, zip, num=["13", "15"],
               slug=["ex4-error", "ex5-error"]),
        rules.fig11.output,
        rules.fig12.output,
        rules.parabolic_summary.output,
        expand(rules.para_passes.output, problem=PARA_PROBLEMS),
        rules.para_reference_check.output,
        rules.ex5_uniform_cause.output,
        expand(rules.para_time_split.output, problem=PARA["time_split"]["problems"]),
        expand(rules.para_self_reference.output,
               problem=PARA["self_reference"]["problems"]),
        expand(rules.thin_demo.output, kind=["obstacle", "friction"]),
        rules.results_page.output,
    default_target: True


# the dense operators kept while the run lasts (common.smk): a means, not a result
onstart:
    if OPERATOR_CACHE:
        os.environ["FRACFEM_OPERATOR_CACHE"] = OPERATOR_CACHE
    # numba's kernels compiled (or loaded from its cache) before the first job, so that
    # no job times their compilation (fracfem.warmup: minutes on a fresh installation)
    from fracfem.warmup import is_warm
    if not is_warm():
        import sys
        Path(f"{RES}/logs").mkdir(parents=True, exist_ok=True)
        shell(f"{sys.executable} -m fracfem.warmup > {RES}/logs/warmup.log 2>&1")

onsuccess:
    remove_operator_cache()

onerror:
    remove_operator_cache()
