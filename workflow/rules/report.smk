# Rate table (paper-figures/rates.csv, .md, .tex) and the assembly benchmark.


rule rates:
    input:
        ex1=rules.ex1_table.output.table,
        vi=[f"{RES}/vi/{p}/errors.csv" for p in ELLIPTIC_VI],
        para=[f"{RES}/para/{p}/errors.csv" for p in PARA_PROBLEMS],
    output:
        csv=f"{OUT}/rates.csv",
        md=f"{OUT}/rates.md",
        tex=f"{OUT}/rates.tex",
    params:
        paper_s={1: EX1["s"]},
    log:
        f"{RES}/logs/rates.log",
    script:
        "../scripts/rates.py"


rule benchmark_assembly:
    output:
        csv=f"{OUT}/benchmark-assembly.csv",
        md=f"{OUT}/benchmark-assembly.md",
    params:
        levels=config["benchmark"]["levels"],
        s=config["benchmark"]["s"],
    log:
        f"{RES}/logs/benchmark_assembly.log",
    benchmark:
        f"{RES}/benchmarks/benchmark_assembly.tsv"
    threads: 2
    shell:
        "NUMBA_NUM_THREADS={threads} python {workflow.basedir}/benchmarks/bench_assembly.py "
        "--levels {params.levels} --s {params.s} --csv {output.csv} --md {output.md} > {log} 2>&1"


rule bad_inputs:
    output:
        md=f"{OUT}/bad-inputs.md",
    log:
        f"{RES}/logs/bad_inputs.log",
    script:
        "../scripts/bad_inputs.py"


# Not in `rule all`: run with `snakemake --cores 2 stability` (issue 6).
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
    script:
        "../scripts/stability.py"


# Not in `rule all`: `snakemake --cores 2 stability_vi` (issue 6, obstacle/friction part).
rule stability_vi:
    output:
        md=f"{OUT}/stability-vi.md",
        csv=f"{RES}/stability/vi.csv",
    log:
        f"{RES}/logs/stability_vi.log",
    benchmark:
        f"{RES}/benchmarks/stability_vi.tsv"
    threads: 2
    script:
        "../scripts/stability_vi.py"
