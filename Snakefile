# fracfem reproduction workflow: every figure and table of the paper is its own
# target; `snakemake --cores 2` builds them all (rule all).
from snakemake.utils import min_version

min_version("8.0")

configfile: "config.yaml"


include: "workflow/rules/common.smk"
include: "workflow/rules/example1.smk"
include: "workflow/rules/vi.smk"
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
        expand(rules.thin_demo.output, kind=["obstacle", "friction"]),
    default_target: True
