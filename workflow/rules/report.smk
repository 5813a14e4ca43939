# Rate table (paper-figures/rates.csv, .md, .tex) and the assembly benchmark.


def rate_table_outputs(stem):
    """The outputs of a rate table (rates, rates_elliptic, rates_parabolic): OUT/<stem>.csv
    and .md, both shown in the report, and .tex beside them."""
    def shown(ext):
        return report(f"{OUT}/{stem}.{ext}", caption="../../report/captions/rates.rst",
                      category="Across examples", subcategory="Rate table")

    return {"csv": shown("csv"), "md": shown("md"), "tex": f"{OUT}/{stem}.tex"}


def rate_table_tiers():
    """The params every rate table shares: this tier's name, the other tiers' tables
    (other_tiers) and the tiers of the config with none yet."""
    return {"tier": TIER, "tiers": other_tiers(), "absent": absent_tiers()}


rule rates:
    input:
        ex1=rules.ex1_table.output.table,
        vi=[vi_errors_table(p) for p in VI_PROBLEMS],
        para=[para_errors_table(p) for p in PARA_PROBLEMS],
        tiers=other_tier_tables,
    output:
        **rate_table_outputs("rates"),
    params:
        **rate_table_tiers(),
        time_split=PARA["time_split"]["problems"],   # the tables the explanations may cite
    log:
        f"{RES}/logs/rates.log",
    benchmark:
        f"{RES}/benchmarks/tables/rates.tsv"
    conda:
        ENV
    script:
        "../scripts/rates.py"


rule rates_elliptic:
    # the rate table of Examples 1-3 alone: a tier whose parabolic series are not finished
    # (the paper-scale tier's Algorithm C runs take hours per pass) shows its elliptic
    # rates beside the other tiers' in the meantime
    input:
        ex1=rules.ex1_table.output.table,
        vi=[vi_errors_table(p) for p in VI_PROBLEMS],
        tiers=other_tier_tables,
    output:
        **rate_table_outputs("rates-elliptic"),
    params:
        **rate_table_tiers(),
        time_split=[],
    log:
        f"{RES}/logs/rates_elliptic.log",
    benchmark:
        f"{RES}/benchmarks/tables/rates_elliptic.tsv"
    conda:
        ENV
    script:
        "../scripts/rates.py"


rule rates_parabolic:
    # the rate table of the parabolic problems whose error tables are kept
    # (parabolic.kept_errors): the paper-scale tier's Algorithm C runs take more than one
    # run of this machine each, so its finished problems' rates are shown, beside the other
    # tiers', before the last one is done; reads the kept tables and fits them, nothing else
    input:
        para=kept_para_tables,
        tiers=other_tier_tables,
    output:
        **rate_table_outputs("rates-parabolic"),
    params:
        **rate_table_tiers(),
        # the time-split pages its explanations may cite: those this tier has made
        time_split=[p for p in PARA["time_split"]["problems"]
                    if Path(f"{OUT}/{p}-time-split.md").exists()],
    log:
        f"{RES}/logs/rates_parabolic.log",
    benchmark:
        f"{RES}/benchmarks/tables/rates_parabolic.tsv"
    conda:
        ENV
    script:
        "../scripts/rates.py"


rule benchmark_assembly:
    output:
        csv=report(
            f"{OUT}/benchmark-assembly.csv",
            caption="../../report/captions/benchmark-assembly.rst",
            category="Benchmarks and checks",
            subcategory="Benchmarks",
        ),
        md=report(
            f"{OUT}/benchmark-assembly.md",
            caption="../../report/captions/benchmark-assembly.rst",
            category="Benchmarks and checks",
            subcategory="Benchmarks",
        ),
    params:
        script=str(Path(workflow.basedir) / "benchmarks" / "bench_assembly.py"),
        levels=config["benchmark"]["levels"],
        s=config["benchmark"]["s"],
    log:
        f"{RES}/logs/benchmark_assembly.log",
    benchmark:
        f"{RES}/benchmarks/benchmark_assembly.tsv"
    threads: 2   # the benchmarks measure the two-core machine, whatever job_threads says
    conda:
        ENV
    shell:
        "NUMBA_NUM_THREADS={threads} python {params.script} "
        "--levels {params.levels} --s {params.s} --csv {output.csv} --md {output.md} > {log} 2>&1"


# Not in `rule all` (about an hour at the default sizes):
# `snakemake --cores 2 benchmark_compressed`.
rule benchmark_compressed:
    output:
        csv=report(
            f"{OUT}/benchmark-compressed.csv",
            caption="../../report/captions/benchmark-compressed.rst",
            category="Benchmarks and checks",
            subcategory="Benchmarks",
        ),
        md=report(
            f"{OUT}/benchmark-compressed.md",
            caption="../../report/captions/benchmark-compressed.rst",
            category="Benchmarks and checks",
            subcategory="Benchmarks",
        ),
    params:
        script=str(Path(workflow.basedir) / "benchmarks" / "bench_compressed.py"),
        uniform=config["benchmark_compressed"]["uniform"],
        graded=config["benchmark_compressed"]["graded"],
        s=config["benchmark_compressed"]["s"],
    log:
        f"{RES}/logs/benchmark_compressed.log",
    benchmark:
        f"{RES}/benchmarks/benchmark_compressed.tsv"
    threads: 2   # the benchmarks measure the two-core machine, whatever job_threads says
    conda:
        ENV
    shell:
        "NUMBA_NUM_THREADS={threads} python {params.script} --uniform {params.uniform} "
        "--graded {params.graded} --s {params.s} --csv {output.csv} --md {output.md} "
        "> {log} 2>&1"


rule bad_inputs:
    output:
        md=report(
            f"{OUT}/bad-inputs.md",
            caption="../../report/captions/bad-inputs.rst",
            category="Benchmarks and checks",
            subcategory="Checks",
        ),
    log:
        f"{RES}/logs/bad_inputs.log",
    benchmark:
        f"{RES}/benchmarks/tables/bad_inputs.tsv"
    conda:
        ENV
    script:
        "../scripts/bad_inputs.py"


# Not in `rule all`: run with `snakemake --cores 2 stability`.
rule stability:
    output:
        md=report(
            f"{OUT}/stability.md",
            caption="../../report/captions/stability.rst",
            category="Benchmarks and checks",
            subcategory="Stability",
        ),
        png=report(
            f"{OUT}/extra-stability.png",
            caption="../../report/captions/stability.rst",
            category="Benchmarks and checks",
            subcategory="Stability",
        ),
        csv=f"{RES}/stability/table.csv",
    log:
        f"{RES}/logs/stability.log",
    benchmark:
        f"{RES}/benchmarks/stability.tsv"
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/stability.py"


# Not in `rule all`: `snakemake --cores 2 stability_vi` (obstacle/friction part).
rule stability_vi:
    output:
        md=report(
            f"{OUT}/stability-vi.md",
            caption="../../report/captions/stability-vi.rst",
            category="Benchmarks and checks",
            subcategory="Stability",
        ),
        csv=f"{RES}/stability/vi.csv",
    log:
        f"{RES}/logs/stability_vi.log",
    benchmark:
        f"{RES}/benchmarks/stability_vi.tsv"
    threads: JOB_THREADS
    conda:
        ENV
    script:
        "../scripts/stability_vi.py"
