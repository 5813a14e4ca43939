"""The reproduction workflow's own code: result files and provenance (io), the
paper's rates and the rate fits (report), figure style (plotstyle), the job's log
file (logs), and what every run script shares (runs).  The scripts in
workflow/scripts import it; fracfem never does."""
