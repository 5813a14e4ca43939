# Rate table (paper-figures/rates.csv, .md, .tex) and the assembly benchmark.


rule rates:
    input:
        ex1=rules.ex1_table.output.table,
        vi=expand(rules.vi_errors.output.csv, problem=VI_PROBLEMS),
        para=expand(rules.para_errors.output.csv, problem=PARA_PROBLEMS),
    output:
        csv=f"{OUT}/rates.csv",
        md=f"{OUT}/rates.md",
        tex=f"{OUT}/rates.tex",
    log:
        f"{RES}/logs/rates.log",
    benchmark:
        f"{RES}/benchmarks/tables/rates.tsv"
    conda:
        ENV
    script:
        "../scripts/rates.py"


rule benchmark_assembly:
    output:
        csv=f"{OUT}/benchmark-assembly.csv",
        md=f"{OUT}/benchmark-assembly.md",
    params:
        script=str(Path(workflow.basedir) / "benchmarks" / "bench_assembly.py"),
        levels=config["benchmark"]["levels"],
        s=config["benchmark"]["s"],
    log:
        f"{RES}/logs/benchmark_assembly.log",
    benchmark:
        f"{RES}/benchmarks/benchmark_assembly.tsv"
    threads: 2
    conda:
        ENV
    shell:
        "NUMBA_NUM_THREADS={threads} python {params.script} "
        "--levels {params.levels} --s {params.s} --csv {output.csv} --md {output.md} > {log} 2>&1"


# Not in `rule all` (about an hour at the default sizes):
# `snakemake --cores 2 benchmark_compressed`.
rule benchmark_compressed:
    output:
        csv=f"{OUT}/benchmark-compressed.csv",
        md=f"{OUT}/benchmark-compressed.md",
    params:
        script=str(Path(workflow.basedir) / "benchmarks" / "bench_compressed.py"),
        uniform=config["benchmark_compressed"]["uniform"],
        graded=config["benchmark_compressed"]["graded"],
        s=config["benchmark_compressed"]["s"],
    log:
        f"{RES}/logs/benchmark_compressed.log",
    benchmark:
        f"{RES}/benchmarks/benchmark_compressed.tsv"
    threads: 2
    conda:
        ENV
    shell:
        "NUMBA_NUM_THREADS={threads} python {params.script} --uniform {params.uniform} "
        "--graded {params.graded} --s {params.s} --csv {output.csv} --md {output.md} "
        "> {log} 2>&1"


rule bad_inputs:
    output:
        md=f"{OUT}/bad-inputs.md",
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
        md=f"{OUT}/stability.md",
        png=f"{OUT}/extra-stability.png",
        csv=f"{RES}/stability/table.csv",
    log:
        f"{RES}/logs/stability.log",
    benchmark:
        f"{RES}/benchmarks/stability.tsv"
    threads: 2
    conda:
        ENV
    script:
        "../scripts/stability.py"


# Not in `rule all`: `snakemake --cores 2 stability_vi` (obstacle/friction part).
rule stability_vi:
    output:
        md=f"{OUT}/stability-vi.md",
        csv=f"{RES}/stability/vi.csv",
    log:
        f"{RES}/logs/stability_vi.log",
    benchmark:
        f"{RES}/benchmarks/stability_vi.tsv"
    threads: 2
    conda:
        ENV
    script:
        "../scripts/stability_vi.py"
