"""One browsable page of every figure and table the pipeline made (RESULTS.md).

The page sits beside the figures, so its image links are file names.  Every number
on it is copied from a table of the same run; the texts only say what is shown.
"""
from pathlib import Path

from fracfem_workflow.io import atomic_path

# (heading, intro, figures, tables): figures and tables by file name in the figure root (a
# name with "{problem}" stands for one file per problem of parabolic.time_split, one with
# "{para}" for one file per parabolic problem, one with "{self}" for one file per problem of
# parabolic.self_reference).
SECTIONS = [
    ("Example 1: the exact solution (s = 0.5 and the configured orders)",
     "Energy error ‖u − u_h‖ = ((f,u) − (f,u_h))^½ against the exact energy, on uniform, "
     "2-graded and adaptive (Algorithm B) meshes. `eta` is the a posteriori estimator, "
     "`efficiency` = eta / error, times are wall seconds per phase.",
     ["fig01-ex1-solution-graded.png", "fig02-ex1-error.png",
      "extra-ex1-error-vs-time.png", "extra-ex1-orders.png", "extra-ex1-adaptive-rate.png"],
     ["ex1-errors.md", "ex1-adaptive-rate.md"]),
    ("Rates against the paper",
     "Least-squares slopes of log error against log DOFs (space-time DOFs for Examples 4 "
     "and 5), ours beside the paper's; `difference` = ours − paper.",
     [], ["rates.md"]),
    ("Quadrature check",
     "Every quadrature order raised (`QuadratureOptions().raised()`): the change of (f, u_h) "
     "relative to the squared energy error, which must stay far below one.",
     [], ["ex1-quadrature-check.md"]),
    ("Example 2 (obstacle) and Example 3 (friction)",
     "Mixed form: u_h on T_h, λ_H on T_H; PDAS is stored, Uzawa (Algorithm A) solves the "
     "same problem and the columns `max_du_uzawa_pdas`, `max_dlambda_uzawa_pdas` give how "
     "far apart the two are. The error is √(2|E(u_h) − E_ref|) with E the discrete energy.",
     ["fig03-obstacle.png", "fig04-ex2-solution-uniform.png",
      "fig05-ex2-solution-adaptive.png", "fig06-ex2-adaptive-meshes.png",
      "fig07-ex2-error.png", "fig08-ex3-solution-multiplier.png", "fig09-ex3-error.png",
      "extra-ex2-graded-rings.png", "extra-ex2-adaptive-rate.png"],
     ["vi-runs.md", "elliptic-errors.md", "ex2-graded-rings.md", "ex2-adaptive-rate.md"]),
    ("Error against wall time, Examples 1–3",
     "Wall time of a run: mesh, assembly, factorisation, Schur complement and solver "
     "(uniform, graded); all Algorithm B steps so far (adaptive).",
     ["extra-elliptic-error-vs-time.png"], ["elliptic-error-vs-time.md"]),
    ("Thin obstacle and thin friction (Problems B and D, not in the paper)",
     "Constraints on the segment Γ̃ = [−½, ½] × {0}.",
     ["extra-thin-obstacle.png", "extra-thin-friction.png"], []),
    ("Examples 4 and 5 (parabolic)",
     "DG(0) in time on uniform, 2-graded and space-time adaptive (Algorithm C) meshes; the "
     "error is the L²(0,T; Hˢ) distance to a fine reference run.",
     ["fig10-ex4-solution.png", "fig11-ex4-indicators-in-time.png",
      "fig12-ex4-spacetime-meshes.png", "fig13-ex4-error.png", "fig14-ex5-solution.png",
      "fig15-ex5-error.png", "extra-parabolic-error-vs-time.png",
      "extra-{para}-algorithm-c.png"],
     ["parabolic-runs.md", "{para}-algorithm-c.md", "ex5-free-boundary.md",
      "ex5-uniform-rate.md", "{problem}-time-split.md", "{self}-self-reference.md",
      "parabolic-reference-check.md"]),
    ("Assembly benchmark",
     "Example 1, s = 0.5, uniform disks, warm numba cache; `floor_s` is one kernel "
     "evaluation per unordered element pair in the same process.",
     [], ["benchmark-assembly.md"]),
    ("Bad input, tried",
     "Each invalid parameter or file and the error a user gets; nothing is written.",
     [], ["bad-inputs.md"]),
]

TITLE = ("# Results\n\nEvery figure and table of the last `snakemake` run in this folder, "
         "grouped by example. Built by the rule `results_page`; every column is defined in "
         "`docs/glossary.md` (those of the paper's tables also in the README's glossary). "
         "Targets outside `rule all` write their own "
         "pages here: `stability.md` and `stability-vi.md` (`snakemake --cores 2 stability "
         "stability_vi`) and `benchmark-compressed.md` (`snakemake --cores 2 "
         "benchmark_compressed`).\n")


def expand(entry, problems, para, self_reference=()):
    """The file names an entry of SECTIONS stands for: "{problem}" once per problem of
    ``problems``, "{para}" once per problem of ``para``, "{self}" once per problem of
    ``self_reference``."""
    if "{problem}" in entry:
        return [entry.format(problem=p) for p in problems]
    if "{para}" in entry:
        return [entry.format(para=p) for p in para]
    if "{self}" in entry:
        return [entry.format(self=p) for p in self_reference]
    return [entry]


def render(root, problems=(), para=(), self_reference=()):
    """The page's text from the files in `root`; a missing file is an error.
    problems: those of the names with "{problem}" (parabolic.time_split), para: those of
    the names with "{para}" (every parabolic problem), self_reference: those of the names
    with "{self}" (parabolic.self_reference), in order."""
    root = Path(root)
    parts = [TITLE]
    for heading, intro, figures, tables in SECTIONS:
        parts.append(f"\n## {heading}\n\n{intro}\n")
        for name in (n for entry in figures
                     for n in expand(entry, problems, para, self_reference)):
            if not (root / name).exists():
                raise FileNotFoundError(f"{root / name} is missing: run its rule first")
            parts.append(f"\n![{name}]({name})\n")
        for entry in tables:
            for name in expand(entry, problems, para, self_reference):
                text = (root / name).read_text().strip()
                parts.append(f"\n### `{name}`\n\n{text}\n")
    return "".join(parts)


def main(root, out, problems=(), para=(), self_reference=()):
    text = render(root, problems, para, self_reference)
    with atomic_path(out) as tmp:
        tmp.write_text(text)


if __name__ == "__main__":
    main(Path(snakemake.output.md).parent, snakemake.output.md,  # noqa: F821
         snakemake.params.time_split, snakemake.params.para,  # noqa: F821
         snakemake.params.self_reference)  # noqa: F821
