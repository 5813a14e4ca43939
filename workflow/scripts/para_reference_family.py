"""The reference family of a parabolic problem (its reference run and the coarser runs of
its family, with the operator's products of each), built once for the jobs that measure
runs against its limit (para_adaptive, para_errors, para_time_split), which read it
instead of each building it again."""
import fracfem as ff
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import save_reference_family, start

logger = script_logger("para_reference_family")


def main(ref, coarser, operator, quadrature, out, log=None, threads=None):
    start(log, threads)
    save_reference_family(ref, list(coarser), ff.QuadratureOptions(**quadrature), operator,
                          out)
    logger.info("wrote %s", out)


if __name__ == "__main__":
    main(snakemake.input.ref, list(snakemake.input.coarser),  # noqa: F821
         snakemake.input.operator, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.pkl, snakemake.log[0], snakemake.threads)  # noqa: F821
