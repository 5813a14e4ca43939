"""The operator of a parabolic problem's reference run, assembled once for the jobs that
measure runs against it (para_adaptive, para_errors, para_time_split), which read it
instead of each assembling it again."""
import fracfem as ff
from fracfem_workflow.logs import script_logger
from fracfem_workflow.runs import save_reference_operator, start

logger = script_logger("para_reference_operator")


def main(ref, quadrature, out, log=None, threads=None):
    start(log, threads)
    save_reference_operator(ref, ff.QuadratureOptions(**quadrature), out)
    logger.info("wrote %s", out)


if __name__ == "__main__":
    main(snakemake.input.ref, snakemake.params.quadrature,  # noqa: F821
         snakemake.output.pkl, snakemake.log[0], snakemake.threads)  # noqa: F821
