# fracfem reproduction workflow: every figure and table of the paper is its own
# target; `snakemake --cores 2` builds them all (rule all).
from snakemake.utils import min_version

min_version("8.0")

configfile: "config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/example1.smk"
include: "workflow/rules/vi.smk"
include: "workflow/rules/parabolic.smk"
include: "workflow/rules/report.smk"


rule all:
    input:
        rules.fig01.output,
        rules.fig02.output,
        rules.ex1_extra_figures.output,
        rules.rates.output,
        rules.ex1_quadrature_table.output,
        rules.benchmark_assembly.output,
        rules.bad_inputs.output,
        rules.fig03.output,
        rules.fig04.output,
        rules.fig08.output,
        rules.vi_runs_md.output,
        rules.fig05.output,
        rules.fig06.output,
        f"{OUT}/fig07-ex2-error.png",
        f"{OUT}/fig09-ex3-error.png",
        rules.reference_table.output,
        rules.elliptic_error_vs_time.output,
        rules.fig10.output,
        rules.fig14.output,
        f"{OUT}/fig13-ex4-error.png",
        f"{OUT}/fig15-ex5-error.png",
        rules.fig11.output,
        rules.fig12.output,
        rules.parabolic_summary.output,
        rules.para_reference_check.output,
        expand(rules.thin_demo.output, kind=["obstacle", "friction"]),
    default_target: True
