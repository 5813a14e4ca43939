"""What every column of the pipeline's and the benchmarks' tables means.

One source for the README's glossary (``workflow/scripts/update_readme.py`` renders
it) and for the test that every column of every committed table is defined.
Groups are (title, in_readme, {column: meaning}); a column defined in an earlier
group is not repeated in a later one.  The README shows the groups of the paper's
tables (in_readme); docs/glossary.md shows all.
"""

GROUPS = [
    ("Every table", True, {
        "s": "fractional order",
        "family": "mesh family: `uniform` (red refinement of the disk), `graded` (2-graded "
                  "towards the boundary), `adaptive` (Algorithm B or C), `reference`",
        "tag": "a series member: `L<level>` uniform, `h<h>` graded",
        "level": "uniform refinement level of the disk mesh",
        "dofs": "unknowns of u_h: the free (interior) nodes of the fine mesh T_h",
        "problem": "example and data variant: `ex2`, `ex3-printed` (the paper's data), "
                   "`ex3-signchange` (f = 1 − 3|x|²), `ex4-u1` (u₀ = 1), `ex4-u2` (ũ₀ = 2), "
                   "`ex5`",
        "example": "the paper's example number",
        "variant": "the data variant of an example (as in `problem`)",
        "error": "energy error: ((f,u) − (f,u_h))^½ with the exact (f,u) (Example 1); "
                 "√(2|E(u_h) − E_ref|), E the discrete energy (Examples 2, 3); the "
                 "L²(0,T; Hˢ) distance to the reference run (Examples 4, 5); in "
                 "`bad-inputs.md` the exception raised",
        "eta": "the a posteriori estimator η of the run (Sections 6, 7 of the paper)",
        "efficiency": "eta / error",
        "steps": "adaptive steps (`elliptic-errors.md`) or time steps (`parabolic-runs.md`)",
        "multipliers": "m: elements of the multiplier mesh T_H (λ_H is P0 on T_H)",
        "h_max": "longest edge of the fine mesh T_h",
        "status": "`ok`, or why the case was refused",
        "case": "the configuration tried",
        "seconds": "wall seconds of the job or case",
        "peak_mem_mb": "peak resident memory of the run's process, MB",
        "peak_rss_mb": "peak resident memory, MB (largest job of a part in "
                       "`pipeline-cost.md`)",
    }),
    ("Timings", True, {
        "t_assembly": "wall seconds of stiffness matrix and load vector",
        "t_solve": "wall seconds of the linear solve",
        "t_total": "wall seconds of the whole run: mesh, assembly, solve, estimator",
        "t_cumulative": "adaptive series: t_total summed over all steps so far",
        "t_schur": "forming the Schur complement S = BᵀA⁻¹B",
        "t_uzawa": "Uzawa (Algorithm A) solve",
        "t_pdas": "primal–dual active set solve",
        "t_wall": "wall seconds of a parabolic run (adaptive: all passes so far, without "
                  "the error measurement)",
        "common error": "the smallest error every family reaches",
        "t_adaptive [s]": "wall seconds the adaptive family needs to reach the common error",
        "t_graded [s]": "the same for the graded family",
        "t_uniform [s]": "the same for the uniform family",
        "fastest": "family with the smallest of those times",
        "speed-up vs slowest": "slowest of the three times / fastest",
    }),
    ("Rates (`rates.md`)", True, {
        "rate": "least-squares slope of log error against log DOFs (space-time DOFs for "
                "Examples 4, 5) over the series",
        "paper_rate": "the paper's rate for the same example and family",
        "difference": "rate − paper_rate",
        "n_points": "runs in the fit",
        "dof_min": "smallest DOFs in the fit",
        "dof_max": "largest DOFs in the fit",
    }),
    ("Quadrature check (`ex1-quadrature-check.md`)", True, {
        "fu_h": "(f, u_h) with the default quadrature",
        "fu_h_raised": "(f, u_h) with every order raised (`QuadratureOptions().raised()`)",
        "change": "fu_h_raised − fu_h",
        "error_squared": "(f,u) − (f,u_h), the squared energy error",
        "change_over_error_squared": "|change| / error_squared: must be far below 1",
        "t_assembly_raised": "assembly seconds with the raised orders",
    }),
    ("Obstacle and friction (`vi-runs.md`, `ex5-free-boundary.md`)", True, {
        "iterations_uzawa": "Uzawa iterations",
        "iterations_pdas": "PDAS active-set steps",
        "contact": "coarse elements in contact (λ_H < 0)",
        "slip_plus": "coarse elements slipping with λ_H = F",
        "slip_minus": "coarse elements slipping with λ_H = −F",
        "stick": "coarse elements sticking (|λ_H| < F)",
        "max_du_uzawa_pdas": "max |u_Uzawa − u_PDAS| at the nodes",
        "max_dlambda_uzawa_pdas": "max |λ_Uzawa − λ_PDAS| over T_H",
        "t": "time",
        "slip+ (λ=F)": "as slip_plus, at time t",
        "slip− (λ=−F)": "as slip_minus, at time t",
        "slip+ outer radius": "largest centroid radius of the slip+ elements",
        "slip− inner radius": "smallest centroid radius of the slip− elements",
    }),
    ("References (`elliptic-errors.md`, `parabolic-runs.md`, "
     "`parabolic-reference-check.md`)", True, {
        "reference": "how E_ref is obtained: exact, or extrapolated from a family",
        "E_ref": "the reference energy",
        "extrapolated": "limit E_∞ of E_∞ + C·N^(−β) through the three finest graded "
                        "energies",
        "reference error": "√(2|extrapolated − E|) where E is exact; else the spread "
                           "√(2|max − min|) of the three families' extrapolations",
        "finest error": "the smallest error of any family",
        "spread of the extrapolations": "max − min of the three families' limits",
        "families": "families extrapolated",
        "adaptive rate range": "fitted adaptive rate with each family's limit as reference",
        "graded rate range": "the same, graded",
        "uniform rate range": "the same, uniform",
        "ratio": "reference error / finest error",
        "efficiency min": "smallest efficiency along the adaptive series",
        "efficiency max": "largest efficiency along the adaptive series",
        "max/min": "efficiency max / efficiency min",
        "efficiency per step": "efficiency of each adaptive step",
        "spacetime_dofs": "Σ over time steps of the free nodes: unknowns in space-time",
        "first_contact": "first time at which λ_H < 0 somewhere (NaN: never)",
        "reference_error_estimate": "the reference run's own error, extrapolated along the "
                                    "graded rate (dashed line in Figures 13, 15)",
        "exact error": "L²(0,T; Hˢ) error against the manufactured solution",
        "error vs reference": "the same run's error measured against a reference run",
        "rate, exact error": "rate fitted from the exact errors",
        "rate, error vs reference": "rate fitted from the errors against the reference",
        "finest exact error": "exact error of the finest run",
        "reference's exact error": "exact error of the reference run itself",
    }),
    ("Stability (`stability.md`, `stability-vi.md`)", False, {
        "h_min": "shortest edge",
        "min_angle": "smallest angle of the mesh, degrees",
        "min angle [°]": "smallest angle of the fine mesh, degrees",
        "galerkin_ok": "(f,u_h) ≤ (f,u): the Galerkin bound holds",
        "spd": "the free block of the stiffness matrix is symmetric positive definite",
        "cond": "its condition number",
        "quad_change_over_err2": "as change_over_error_squared",
        "finite": "every number of the result is finite",
        "energy growth": "largest increase of ½a(u^k,u^k) (+ j_H) between steps, relative "
                         "to its largest value (0: the energy never grows)",
        "min gap": "smallest coarse mean of u_h − χ (≥ 0 up to round-off: feasible)",
        "complementarity": "max |λ_H · gap| (obstacle) or max ||λ_H| − F| where the mean moves "
                           "(friction)",
        "λ in set": "λ_H lies in Λ_H (λ ≤ 0, or |λ| ≤ F)",
        "pdas iterations (max)": "most PDAS steps of any time step",
        "uzawa": "Uzawa iterations, or why it stopped",
        "max |u_pdas − u_uzawa|": "largest nodal difference of the two solvers' u_h",
        "|u − u_free| / |u_free|": "distance to the unconstrained solution, relative",
        "max |λ|": "largest |λ_H|",
        "max |coarse mean of u|": "largest |coarse mean of u_h|",
        "contact fraction": "fraction of coarse elements in contact",
        "max gap at t = τ": "largest coarse gap after the first step",
    }),
    ("Cost (`pipeline-cost.md`, `benchmark-assembly.md`)", False, {
        "part": "elliptic (Examples 1–3), parabolic (Examples 4, 5), figures and tables",
        "jobs": "jobs of the part",
        "job": "a job's benchmark file under `results/benchmarks/`",
        "max_rss_mb": "peak resident memory of the job, MB",
        "triangles": "triangles of the mesh",
        "pairs": "unordered element pairs: the work of a dense assembly",
        "threads": "numba threads",
        "floor_s": "one kernel evaluation per pair, same process: a lower bound",
        "singular_s": "touching pairs (identical, edge, vertex)",
        "far_s": "separated pairs",
        "exterior_s": "κ, the Ωᶜ part",
        "assembly_s": "assembly wall seconds",
        "pairs_per_s": "pairs / assembly_s",
        "ratio_to_floor": "assembly_s / floor_s",
    }),
    ("Compressed operator (`benchmarks/compressed.md`, `benchmarks/vi_compressed.md`)", False, {
        "size": "mesh: uniform level or graded h",
        "matvec_s": "seconds of one product op @ x",
        "iterations": "PCG iterations to the solver tolerance",
        "solve_s": "solve wall seconds",
        "nbytes_mb": "memory of the compressed representation, MB",
        "matvec_rel_diff": "‖(op − A)x‖ / ‖Ax‖ against the dense matrix, random x",
        "energy_rel_diff": "relative difference of (f, u_h), compressed against dense",
        "dense_assembly_s": "dense assembly seconds on the same mesh",
        "seconds_2_processes": "PyNucleus, assembly + solve, 2 MPI processes",
        "seconds_1_process": "PyNucleus, one process",
        "note": "remarks on the row",
        "order": "Chebyshev interpolation order",
        "operator_mb": "as nbytes_mb",
        "preconditioner_s": "setting up the preconditioner",
        "pdas_steps": "PDAS active-set steps",
        "inner_iterations": "projected-PCG iterations over all PDAS steps",
        "inner_per_solve": "inner_iterations / pdas_steps",
        "dense_solve_s": "the dense PDAS solve on the same mesh",
        "du_rel": "max |u_compressed − u_dense| / max |u_dense|",
        "dlam_rel": "the same for λ_H",
    }),
    ("Pointwise (−Δ)ˢu_h (`benchmarks/pointwise.md`)", False, {
        "points": "evaluation points: the quadrature points of every element",
        "edges": "mesh edges (sources of the single layer)",
        "dense_s": "seconds of the dense path, every point against every edge",
        "compressed_s": "seconds of the compressed path",
        "near_field_s": "its point–edge pairs of near blocks, by the dense rules",
        "far_field_s": "its H² passes over the far blocks",
        "trees_s": "its cluster trees, block trees and sources",
        "compressed_growth": "compressed_s over that of the previous level",
        "points_growth": "points over those of the previous level",
        "max_rel_diff": "max |compressed − dense| / max |dense| over the points",
        "dense_rss_mb": "peak resident memory of the dense run's process, MB",
        "compressed_rss_mb": "the same for the compressed run",
        "load": "1-minute load average of the machine before-after each run",
        "rule_order": "degree of the triangle rule whose points are evaluated",
        "point_edge_pairs": "points × edges: the work of the dense path",
        "speedup": "dense_s / compressed_s",
    }),
    ("Bad input (`bad-inputs.md`)", False, {
        "parameter": "the parameter tried",
        "input": "the bad value",
        "message": "the message the user gets",
    }),
]


def definitions():
    """{column: meaning} over all groups (a later group's repeat wins)."""
    out = {}
    for _, _, cols in GROUPS:
        out.update(cols)
    return out


def markdown(readme_only=False):
    """The glossary as compact markdown: one paragraph per group."""
    parts = []
    for title, in_readme, cols in GROUPS:
        if readme_only and not in_readme:
            continue
        items = "; ".join(f"`{c}`: {m}" for c, m in cols.items())
        parts.append(f"**{title}.** {items}.")
    return "\n\n".join(parts)
