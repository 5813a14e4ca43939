"""What every column of the pipeline's and the benchmarks' tables means.

The one source of the column definitions: ``workflow/scripts/update_readme.py``
renders it into the README (the groups with in_readme), into docs/glossary.md (all
groups) and into the front page of ``snakemake --report`` (report/workflow.rst, all
groups, as reStructuredText); a test checks that every column of every committed
table is defined.

Groups are (title, in_readme, {columns: meaning}); columns is one name or a tuple of
names sharing a meaning.  A column defined in an earlier group is not repeated in a
later one.  Titles and meanings are Markdown with `code` spans only: they are turned
into reStructuredText by :func:`rst`.
"""
import re
import textwrap

GROUPS = [
    ("Shared columns", True, {
        "s": "order of the fractional Laplacian",
        "problem": "`ex2`, `ex3-<key of example3.variants>`: `ex3-printed` (the paper's "
                   "data), `ex3-signchange` (f = 1 − 3|x|²), and the keys of "
                   "`parabolic.examples`: `ex4-u1`, `ex4-u2` (u₀ = 1, 2), `ex5`",
        ("example", "variant"): "the paper's example number, and the data set within it "
                                "(`printed`, `signchange`, `u1`, `u2`; else empty)",
        "family": "mesh family: `uniform`, `graded` (the paper's: anisotropic, 2-graded towards "
                  "the boundary circle, N ~ h⁻²), `graded-sr` (2-graded but shape-regular, "
                  "N ~ h⁻²|log h|), `adaptive` (Algorithm B for Examples 1–3, C for "
                  "Examples 4, 5)",
        "tag": "the run within its family: `L<level>`, `h<h>` (graded), `r<h>` (graded-sr), "
               "`step<k>` (Algorithm B after k refinements), `it<k>` (pass k of Algorithm C)",
        "dofs": "free (interior) nodes of the P1 mesh (the fine mesh T_h for the mixed "
                "problems), for Algorithm C the most over its time slabs "
                "(`elliptic-errors.md`: range of the adaptive series)",
        "steps": "time steps, for Algorithm C summed over its slabs (`elliptic-errors.md`: "
                 "runs of the adaptive series)",
        "spacetime_dofs": "`dofs` × `steps`, for Algorithm C Σ_j steps × free nodes of slab j",
        "multipliers": "number of values of λ_H, the elements of T_H (coarse edges for the "
                       "thin problems)",
        "h_max": "largest triangle diameter (longest edge) of the fine mesh",
        "error": "Example 1 ‖u − u_h‖_a = √((f,u) − (f,u_h)), Examples 2, 3 "
                 "√(2|E(u_h) − E_ref|) (E the discrete energy), Examples 4, 5 the L²(0,T; a) "
                 "distance to the reference run (`bad-inputs.md`: the exception class)",
        "eta": "global a posteriori estimator η of Section 7 (parabolic: of Theorem 6.18, "
               "space, time, contact and initial parts), adaptive runs only",
        "efficiency": "`eta` / `error`",
        "peak_mem_mb": "peak resident memory of the job's process so far, MiB",
    }),
    ("Wall seconds (`t_*`, measured: they change on every run)", True, {
        "t_assembly": "stiffness matrix and load vector (adaptive: the step's discrete "
                      "problem)",
        "t_solve": "the linear solve",
        "t_total": "mesh + assembly + solve (adaptive: assemble, solve, estimate, mark and "
                   "refine of the step)",
        "t_cumulative": "adaptive: from the start of Algorithm B to the end of the step",
        "t_schur": "the Schur complement S = BᵀA⁻¹B, after the Cholesky factor of A",
        ("t_uzawa", "t_pdas"): "the Uzawa (Algorithm A) and primal–dual active set "
                               "iterations",
        "t_wall": "the whole parabolic run (adaptive: all passes so far, without the error "
                  "measurement)",
    }),
    ("Rates (`rates.md`, `rates.csv`)", True, {
        "rate": "least-squares slope of log `error` against log `dofs` (Examples 4, 5: "
                "`spacetime_dofs`) over the runs whose error exceeds 3× `reference_error` "
                "(all runs when the reference is exact); NaN when fewer than two do",
        ("rate_min", "rate_max"): "steepest and flattest `rate` of the same runs, each "
                                  "error anywhere in its bound (Examples 2, 3: E_ref ± its "
                                  "uncertainty; 4, 5: ± `error_uncertainty`)",
        "paper_rate": "the paper's rate (paper's s and data only)",
        "difference": "`rate` − `paper_rate` (> 0: our error falls more slowly)",
        "n_points": "runs in the fit",
        "n_excluded": "runs left out: error ≤ 3× `reference_error`",
        "reference_error": "the reference's own error: 0 if exact; Examples 2, 3 the "
                           "`large uncertainty` of `elliptic-errors.md`; Examples 4, 5 "
                           "the largest `error_uncertainty` of the series",
        "smallest_error": "smallest error of the series",
        ("dof_min", "dof_max"): "smallest and largest DOFs of the fit",
    }),
    ("Rates of the other tiers (`rates.md`, `rates.csv`)", False, {
        tuple(f"{c}_{t}" for t in ("default", "paper-scale")
              for c in ("rate", "n_points", "dof_max", "smallest_error")):
            "the same row's `rate`, `n_points`, `dof_max` and `smallest_error` in the tier "
            "named after the underscore (`config.yaml`: `tiers`), shown where that tier's "
            "`rates.csv` exists, or, its parabolic series unfinished, from whichever of its "
            "partial tables exist: `rates-elliptic.csv` (Examples 1–3), `rates-parabolic.csv` "
            "(its parabolic problems whose error tables are kept)",
    }),
    ("Error against wall time (`elliptic-error-vs-time.md`, `parabolic-runs.md`)", True, {
        "common error": "the largest of the families' smallest errors",
        ("t_adaptive [s]", "t_graded [s]", "t_graded-sr [s]", "t_uniform [s]"):
            "wall time of the run (Examples 2, 3: with factorisation, Schur complement, "
            "PDAS; adaptive: all steps so far) at which the family first reaches it, "
            "log–log interpolated",
        "fastest": "the family with the smallest such time",
        "speed-up vs slowest": "largest of those times / smallest",
    }),
    ("Obstacle and friction (`vi-runs.md`, `ex5-free-boundary.md`)", False, {
        ("iterations_uzawa", "iterations_pdas"): "Uzawa and PDAS iterations on the same "
                                                 "discrete problem",
        "contact": "elements of T_H with λ_H < 0 (beyond round-off)",
        ("slip_plus", "slip_minus", "stick"): "elements of T_H with λ_H = F, λ_H = −F "
                                              "(relative tolerance), the rest",
        ("max_du_uzawa_pdas", "max_dlambda_uzawa_pdas"): "largest nodal difference of the "
                                                         "Uzawa and PDAS u_h, and of their "
                                                         "λ_H",
        "t": "end of the time step",
        ("slip+ (λ=F)", "slip− (λ=−F)"): "as `slip_plus`, `slip_minus` at time `t`",
        ("slip+ outer radius", "slip− inner radius"): "largest centroid radius of the slip+ "
                                                      "elements, smallest of the slip− ones "
                                                      "(NaN: none)",
    }),
    ("Quadrature check (`ex1-quadrature-check.md`)", False, {
        ("fu_h", "fu_h_raised"): "(f,u_h) with the default quadrature and with every order "
                                 "raised (`QuadratureOptions().raised()`)",
        "change": "`fu_h_raised` − `fu_h`",
        "error_squared": "(f,u) − (f,u_h), the squared energy error",
        "change_over_error_squared": "|`change`| / `error_squared`: must be far below 1",
        "t_assembly_raised": "assembly seconds with the raised orders",
        "operator": "the stiffness of the run and of its raised repeat: `dense` (the matrix) or "
                    "`compressed` (`example1.operator`; the raised repeat keeps the compression's "
                    "tolerance, so that the change is the quadrature's)",
    }),
    ("Reference energies (`elliptic-errors.md`)", False, {
        "reference": "where E_ref comes from: `exact`, `exact (pure slip)`, "
                     "`extrapolated (Algorithm B to <N> DOFs)`",
        "E_ref": "the reference energy of the errors (Example 1: −½(f,u))",
        "extrapolated": "limit E_∞ of E_∞ + C·N^(−β) through the three finest energies of "
                        "the `reference.family` series",
        "reference error": "E exact: √(2|`extrapolated` − E|); else `large uncertainty`",
        "large DOFs": "fine DOFs of the last step of the large Algorithm B series "
                      "(compressed operator; rule `vi_adaptive_large`)",
        "large extrapolated": "limit E_∞ through the large series' three finest energies: "
                              "E_ref where no energy is exact",
        "large uncertainty": "√(2 max(|E_∞ − E_∞'|, |E_∞' − E_∞''|)), E_∞', E_∞'' the same "
                             "limit without the finest run, without the two finest",
        "large check": "E exact: √(2|`large extrapolated` − E|), the true error of that limit",
        ("large time [s]", "large peak MB"): "wall time and peak memory of the whole large "
                                              "series (measured when it was computed)",
        "finest error": "smallest error of any family",
        "spread of the extrapolations": "√(2|max − min|) of the families' limits",
        "families": "families whose extrapolation exists",
        ("adaptive rate range", "graded rate range", "graded-sr rate range",
         "uniform rate range"):
            "smallest … largest fitted rate of the family, each family's limit and the large "
            "series' limit in turn the reference",
        "ratio": "`reference error` / `finest error`",
        ("efficiency min", "efficiency max", "max/min"): "extremes of `efficiency` along "
                                                         "the adaptive series, their ratio",
        "efficiency per step": "`efficiency` of every adaptive step, in order",
    }),
    ("Parabolic runs (`parabolic-runs.md`)", False, {
        "error_vs_reference": "Examples 4, 5: the run's distance to the reference run "
                              "alone (the finest of its family)",
        "error_uncertainty": "Examples 4, 5: the change of the extrapolated `error` from "
                             "the extrapolation through the family's coarser runs, and no "
                             "less than its correction to `error_vs_reference` "
                             "(fracfem.transfer.extrapolated_distance); NaN where fewer than "
                             "four runs of the family are left to extrapolate through (then "
                             "`reference_run_error` bounds the fits)",
        "reference_run_error": "Examples 4, 5: the reference run's own measured error, "
                               "d23·r/(1 − r) (`parabolic-runs.md`)",
        "first_contact": "Example 4: time of the first step with some λ_H < 0 (NaN: none)",
        ("d12", "d23"): "L²(0,T; a) distances between the reference's family at the two "
                        "coarser h (`parabolic.reference.coarser_h`), and between the finer "
                        "of them and the reference",
        "ratio r": "d23/d12",
        "operator used": "the stiffness representation of the reference run: `dense` or "
                         "`compressed`",
        "reference / finest spacetime_dofs": "how much larger the reference is than the "
                                             "largest run it judges",
        "finest adaptive error": "error of the last Algorithm C pass",
        ("error (larger reference)", "local slope (larger reference)"):
            "`error` and `local slope` of the same pass measured against the paper-scale "
            "tier's finer reference of the same family (`parabolic.reference.larger`)",
        "finest error / reference_error": "smallest error of any run over the reference's "
                                          "own: the margin of the 3× rule",
        "passes": "Algorithm C passes run",
        "error rate (fitted runs)": "rate of the error over the passes whose error exceeds "
                                    "3× `reference_error`",
        "η rate (same runs)": "rate of the estimator η over the same passes",
        "η rate (all)": "rate of η over every pass",
        ("η_space rate (same runs)", "η_time rate (same runs)", "η_contact rate (same runs)",
         "η_initial rate (same runs)"): "rate of one part of η over the same passes: the "
                                        "square root of the space, time, contact or initial "
                                        "term of η² (Theorem 6.18), summed over the run; "
                                        "empty where the part is at round-off level",
        "time share of η² (finest)": "the time term's share of η² in the finest pass",
        "η_time,a rate (same runs)": "rate of √(Σ_k τ_k a(u^k − u^{k−1}, u^k − u^{k−1})), "
                                     "the time term in the energy norm, over the same passes",
        "η_a rate (same runs)": "rate of η_a, η with that time term in place of its "
                                "h^{−2s}‖·‖²_{L²} form, over the same passes",
        "η_a efficiency per pass": "η_a / error of every pass",
        "fitted": "passes in those fits",
        "efficiency per pass": "η/error of every pass, in order",
    }),
    ("Parabolic reference check (`parabolic-reference-check.md`)", False, {
        "exact error": "L²(0,T; a) error against the manufactured solution, exact in time",
        "error vs reference": "the same run's distance to the reference run alone",
        "extrapolated error": "the same run's error measured like Examples 4, 5: the "
                              "distance to the limit of the reference's family, extrapolated "
                              "from the distances to its three finest runs",
        "uncertainty": "the change of `extrapolated error` from the extrapolation through "
                       "the three runs before, and no less than its correction to `error vs "
                       "reference` (NaN: fewer than four runs to extrapolate through)",
        "left out": "runs of the reference's family left out of the extrapolation: those "
                    "on the run's own space mesh",
        ("extrapolated / exact − 1", "vs reference / exact − 1"):
            "relative deviation of `extrapolated error` and of `error vs reference` from "
            "the exact error",
        ("rate, exact error", "rate, error vs reference", "rate, extrapolated error"):
            "rates of these errors against `spacetime_dofs`",
        "largest deviation / bound": "the largest |`extrapolated error` − `exact error`| "
            "of the family, in units of the bound the rate fits use: its `uncertainty`, or "
            "`reference error estimate` where it has none (≤ 1: the bound holds)",
        "finest exact error": "smallest exact error of the family",
        "reference's exact error": "exact error of the reference run",
        "exact errors": "exact errors of the reference's family, coarsest first",
        "reference error estimate": "d23·r/(1 − r) from those runs, as for Examples 4, 5",
        "estimate / exact": "the estimate over the reference's exact error (> 1: on the "
                            "safe side)",
    }),
    ("Example 1's adaptive rate (`ex1-adaptive-rate.md`)", False, {
        "case": "Algorithm B as configured (`example1.adaptive`; Example 2: `vi_adaptive`), "
                "or with one setting changed (`example1.adaptive_changes`, "
                "`example2.adaptive_changes`)",
        ("theta", "start_level"): "the series' marking parameter θ (η(Δ) > θ η_max) and "
                                  "start mesh `disk_uniform(start_level)`",
        "step": "refinements of the start mesh so far (0: the start mesh)",
        "start dofs": "`dofs` of the start mesh",
        "Algorithm B steps": "steps of the series up to its first with at least "
                             "`example1.adaptive_changes.max_dofs` DOFs (Example 2: "
                             "`example2.adaptive_changes.max_dofs`), where every series "
                             "is cut",
        "last dofs": "`dofs` of the series' last step",
        "marked": "triangles the step marks for refinement (the last step's too, which the "
                  "series does not refine; −1: a step stopped by `max_steps` marks none)",
        "innermost marked radius": "distance from the disk's centre of the marked "
                                   "triangle nearest to it (its centroid's): how far "
                                   "inward the step refines (nan: none marked)",
        "error / unchanged at the same DOFs": "`error` over the unchanged series' error at "
                                              "the same `dofs`, log–log interpolated "
                                              "between all its steps, not only those up "
                                              "to the cut (nan beyond its last step)",
    }),
    ("Example 1's graded families against h (second table of `ex1-errors.md`)", False, {
        "runs": "runs of the series",
        "h": "the series' mesh sizes h (their tags), largest … smallest",
        "rate in h": "least-squares slope of log `error` against log h",
        "dofs ~ h^p": "p: least-squares slope of log `dofs` against log h (−2 when the DOFs "
                      "quadruple as h halves)",
    }),
    ("Example 2's graded family at every ring count (`ex2-graded-rings.md`)", False, {
        "n": "ring count of T_H = `disk_graded_rings(n)`; the graded series' "
             "`disk_graded_aniso(h)` is n = ceil(1/h)",
        "fitted through": "the ring counts a rate is fitted through: the graded series', "
                          "every one, every one from n on, or n, 2n, 4n, … (h halved)",
        "ring counts": "the ring counts of that fit (fitted ones only)",
        "points": "how many ring counts the fit of `rate` has",
        "lifted rate": "the same fit of `lifted error`",
        "lifted energy": "E(ũ_h) for ũ_h = max(u_h, χ) at the fine nodes (0 on ∂Ω), which "
                         "meets the constraint at every node",
        "lifted error": "√(2|E(ũ_h) − E_ref|): the error measure of u_h with its dip "
                        "below χ removed at the fine nodes (not a bound: between the nodes "
                        "ũ_h can lie below χ)",
        "fitted": "energy not below E_ref and error above 3× the reference's own: the "
                  "ring count enters the fits of `rate`",
        "lifted fitted": "the same for `lifted energy` and `lifted error`; `lifted rate` "
                         "goes through the ring counts where both this and `fitted` hold",
        "lifted points": "how many ring counts the fit of `lifted rate` has",
        "lifted local slope": "`local slope` of `lifted error`",
        "largest dip": "max(χ − u_h) over the free fine nodes: how far the averaged "
                       "constraint lets u_h dip below χ (≤ 0: nowhere; "
                       "`ex2-adaptive-rate.md`: 0 when nowhere, and in its first table the "
                       "largest over the series' steps)",
        "dip's share": "(E(ũ_h) − E(u_h)) / (E(ũ_h) − E_ref): the part of the lifted energy "
                       "error that the dip below χ takes off E(u_h) (nan where an energy "
                       "lies below E_ref)",
        "contact elements": "elements of T_H where λ_H < 0 (contact)",
        "contact radius / reference": "√(area/π) of those elements over the same of the "
                                      "large reference run's last mesh",
        "in graded series": "whether the graded series (`example2.graded_h`) has this n",
    }),
    ("Example 2's adaptive rate (`ex2-adaptive-rate.md`)", False, {
        "energy error": "√(2|E(u_h) − E_ref|), the rate table's measure of Example 2",
        "below E_ref": "E(u_h) < E_ref: the energy error is no error there and is not fitted",
        "distance to u_ref": "‖u_h − u_ref‖_a, the energy-norm distance to the unchanged "
                             "series' first step with at least `example2.adaptive_changes."
                             "reference_dofs` DOFs (u_h interpolated onto its mesh): the "
                             "norm the paper plots against its benchmark",
        ("fitted (energy error)", "fitted (distance to u_ref)"):
            "steps a rate is fitted through: energy error above 3× E_ref's uncertainty "
            "and E(u_h) ≥ E_ref; distance above 3× an estimate of u_ref's own error (its "
            "energy error plus E_ref's uncertainty; not a bound)",
        ("rate (energy error)", "rate (distance to u_ref)"):
            "least-squares slope of the measure against `dofs` through the fitted steps "
            "of the series (nan: fewer than two)",
        "both fitted": "steps of the series where both measures are fitted",
        ("rate (energy error, both fitted)", "rate (distance, both fitted)"):
            "each measure's rate through the `both fitted` steps: the same steps, only the "
            "measure changed",
        "steps below E_ref": "steps of the series whose energy lies below E_ref",
        "distance to u_ref / energy error": "how far the two measures differ (1: not at all); "
                                            "near u_ref the distance falls below the "
                                            "error by u_ref's own",
        "√(distance² + e(u_ref)²) / energy error": "the distance with u_ref's energy error "
                                                   "e(u_ref) added in quadrature, over the "
                                                   "energy error: 1 where the energy error "
                                                   "equals the distance to the exact "
                                                   "solution, if u_h − u_ref and u − u_ref "
                                                   "are orthogonal (nested Galerkin "
                                                   "solutions of a linear problem are)",
        "local slope (distance)": "`local slope` of `distance to u_ref`",
        "η / distance": "`eta` over `distance to u_ref`: the efficiency index in the "
                        "paper's measure (too large near u_ref, where the distance "
                        "misses u_ref's own error)",
        "smallest η / distance": "the smallest `η / distance` of the series' steps",
    }),
    ("Example 5's uniform rate (`ex5-uniform-rate.md`)", False, {
        "case": "Example 5 as configured, or one change of it (`Example 5, τ/m`: its "
                "uniform runs on the same meshes with m× the time steps, against its family)",
        "error (τ/m)": "`error` of a uniform run of Example 5 solved again on its meshes "
                       "with m× its time steps",
        "1 − (e(τ/m)/e)²": "the part of the run's squared error that m× the time steps "
                           "remove: the time discretisation's share, as far as they remove it",
        "least share": "its least value with `error` and `error (τ/m)` each anywhere within "
                       "its `error_uncertainty`: 1 − ((e(τ/m) + u(τ/m))/(e − u))² (−inf: "
                       "no bound, where e − u ≤ 0 or an uncertainty is infinite; nan where "
                       "an uncertainty is not measured)",
        "reference run": "the finest graded run of the family the case's series is "
                         "measured against",
        "consecutive distances": "distances between consecutive runs of that family, "
                                 "coarsest first",
        "rate_vs_reference": "rate of the distances to the family's finest run alone "
                             "(`error_vs_reference`), all runs",
        "largest uncertainty / error": "the largest `error_uncertainty` / `error` of the "
                                       "series",
        "local slope": "slope of log `error` against log `dofs` (Examples 4, 5: "
                       "`spacetime_dofs`) from the previous run of the series",
        "last local slope": "`local slope` of the finest run",
    }),
    ("Algorithm C pass by pass (`<problem>-algorithm-c.md`)", False, {
        "slabs": "time slabs of the pass, each with one space mesh for all its time steps",
        "error / reference_error": "the pass's error over its `reference_error`: the "
                                   "margin of the 3× rule",
        "in fit": "whether the pass's error exceeds 3× `reference_error`, so that rates are "
                  "fitted through it",
        "local slope η": "`local slope` of the estimator η",
        "t_error_pass": "seconds to measure the pass's error against the reference run "
                        "(in neither `t_total` nor `t_wall`)",
    }),
    ("Time split of Algorithm C's and the graded series' errors (`<problem>-time-split.md`)",
     False, {
        "time steps": "each pass (graded run) with its own time steps, or with m times as "
                      "many on every slab (τ/m), the space meshes unchanged",
        "fitted passes": "the passes in the fit (error above 3× `reference_error`)",
        "fitted tag": "the graded runs in the fit (error above 3× its uncertainty)",
        "pass": "pass of Algorithm C; `spacetime_dofs`, `steps`, `dofs` are its own (m = 1)",
        ("error (τ/4)", "error (τ/16)"): "`error` of the pass's (graded run's) space meshes "
                                         "with m = 4, 16 times the time steps",
        ("local slope (τ/4)", "local slope (τ/16)"): "`local slope` of that error against "
                                                     "the pass's (run's) `spacetime_dofs`",
        "1 − (e(τ/16)/e)²": "the part of the pass's (run's) squared error that refining its "
                            "time steps 16-fold removes",
        "m": "`time-split.csv`: the factor of the time steps (1: the pass itself)",
        "pass_spacetime_dofs": "`time-split.csv`: the pass's own `spacetime_dofs`",
        "series": "`time-split.csv`: `adaptive` (a pass of Algorithm C) or `graded` (a run "
                  "of the graded series)",
        "t_resolve": "`time-split.csv`: seconds to solve and estimate the pass again with m "
                     "times the steps, its operators read back from the operator cache "
                     "(m = 1: the pass's own time, with its assembly); a graded run: "
                     "seconds to solve it again with m times its steps and measure it (m = 1 "
                     "too: checked against the errors table's error and uncertainty)",
    }),
    ("Algorithm C's passes against its last pass (`<problem>-self-reference.md`)", False, {
        "measured against": "the reference the passes before the last are measured "
                            "against, and which of them the rate is fitted through",
        "passes in the fit": "the passes the rate is fitted through",
        "error_vs_last": "distance of the pass to Algorithm C's last pass in L²(0,T; Hˢ), "
                         "each slab of the last pass in its own mesh's a-norm",
        "error_vs_last_on_reference": "distance of the pass to Algorithm C's last pass, "
                                      "both interpolated onto the reference run's mesh and "
                                      "measured in its a-norm (as `error_vs_reference`)",
        "local slope (last)": "`local slope` of `error_vs_last`",
    }),
    ("Stability (`stability.md`, `stability-vi.md`)", False, {
        "case": "what was run",
        "status": "`ok`, or `refused:` and the error the library raised",
        "seconds": "wall seconds of the case; `pipeline-cost.md`: of the job, summed over "
                   "the part's jobs",
        "cpu_seconds": "`stability.md`: CPU seconds of the case, all threads (process time): "
                       "unlike `seconds`, hardly changed by other processes on the cores",
        "h_min": "shortest edge",
        ("min_angle", "min angle [°]"): "smallest angle of the (fine) mesh, degrees",
        "galerkin_ok": "(f,u_h) < (f,u), the Galerkin bound",
        "spd": "the free block of the stiffness matrix has a positive smallest eigenvalue",
        "cond": "its condition number λ_max / λ_min",
        "cond_scaled": "condition number of D^(−1/2) A D^(−1/2), D the diagonal of that block",
        "quad_change_over_err2": "as `change_over_error_squared`",
        "thinnest_layer": "distance of the interior nodes nearest to the circle from it: the "
                          "thickness of the thinnest layer of a ring mesh",
        "max_aspect": "largest aspect ratio of a triangle, longest edge / smallest height",
        "roundoff_over_err2": "|(f,u_h) by LU of A − (f,u_h) by the Cholesky factor of "
                              "D^(−1/2) A D^(−1/2)| / err²: round-off of the solve",
        "residual": "‖b − A u‖ / ‖b‖ of the LU solve",
        "finite": "every computed value is finite",
        "energy growth": "largest increase of the discrete energy between time steps, "
                         "relative to its largest value",
        "min gap": "smallest coarse mean of u_h − χ (≥ 0: feasible)",
        "complementarity": "obstacle: max |λ_H · gap|; friction: max ||λ_H| − F| where the "
                           "coarse mean of u_h moves",
        "λ in set": "λ_H ≤ 0, or |λ_H| ≤ F, at every step",
        "pdas iterations (max)": "most PDAS iterations of any step",
        "uzawa": "most Uzawa iterations, or why Uzawa stopped",
        "max |u_pdas − u_uzawa|": "largest nodal difference of the two solvers' u_h",
        "|u − u_free| / |u_free|": "max-norm distance to the unconstrained solution, relative",
        "max |λ|": "largest |λ_H|",
        "max |coarse mean of u|": "largest |mean of u_h over an element of T_H|",
        "contact fraction": "fraction of the elements of T_H with λ_H < 0",
        "max gap at t = τ": "u₀ = χ: the largest coarse gap after the first step",
    }),
    ("Cost (`pipeline-cost.md`, `benchmark-assembly.md`, `benchmark-assembly.csv`)", False, {
        "part": "elliptic (Examples 1–3), parabolic (Examples 4, 5), figures and tables",
        "jobs": "jobs of the part",
        "job": "a job's benchmark file under `results/benchmarks/`",
        "max_rss_mb": "peak resident memory of the job, MiB",
        "cpu_seconds": "CPU seconds of the part's jobs, summed (Snakemake samples a job's "
                       "CPU time every 30 s: a job of a few seconds counts little or nothing)",
        "peak_rss_mb": "peak resident memory, MiB: the largest job of the part; benchmarks: "
                       "the case's process",
        "level": "the mesh `disk_uniform(level)` (`vi_compressed.md`: T_H)",
        ("triangles", "pairs"): "triangles N_T and unordered element pairs N_T(N_T − 1)/2",
        "threads": "numba threads",
        "floor_s": "one kernel evaluation per pair of centroids, parallel: a lower bound",
        ("singular_s", "far_s", "exterior_s"): "seconds for the touching pairs, the "
                                               "separated pairs, the exterior term κ",
        "assembly_s": "assembly seconds",
        "pairs_per_s": "`pairs` / `assembly_s`",
        "ratio_to_floor": "`assembly_s` / `floor_s`",
    }),
    ("Compressed operator (`benchmarks/compressed.md`, `benchmarks/compressed-graded.md`, "
     "`benchmarks/vi_compressed.md`, `benchmarks/adaptive-ex2.md`)",
     False, {
        "size": "mesh: uniform level or graded h",
        "matvec_s": "seconds of one product, mean of three",
        "iterations": "preconditioned CG iterations",
        "solve_s": "solve seconds",
        ("nbytes_mb", "operator_mb"): "memory of the compressed operator, MiB",
        ("matvec_rel_diff", "energy_rel_diff"): "relative difference to the dense matrix of "
                                                "a product with a random vector, and of "
                                                "(f,u_h)",
        "dense_assembly_s": "dense assembly seconds on the same mesh",
        ("seconds_2_processes", "seconds_1_process", "note"): "published PyNucleus "
                                                              "timings (2 MPI processes, 1), "
                                                              "remarks",
        "order": "Chebyshev interpolation order",
        ("t_trees", "t_near", "t_singular", "t_coupling", "t_far_diagonal", "t_exterior"):
            "assembly phases, seconds: cluster and block trees; separated near pairs; "
            "touching pairs and close thin pairs; far-block coupling matrices; the far-field diagonal terms; "
            "the exterior term κ",
        "preconditioner_s": "setting up the preconditioner",
        ("dofs_from", "dofs_to"): "the two sizes compared (free nodes)",
        ("time_exponent", "rss_exponent"): "k in N^k between them: of assembly + solve "
                                           "seconds, of peak RSS",
        "start": "how PDAS starts: cold (λ_H = 0), or nested (from the solution on the "
                 "previous level, itself solved by nested iteration from level 2)",
        "coarse_s": "seconds of the levels below, nested: their assembly and solves",
        "pdas_steps": "PDAS active-set steps",
        "inner_iterations": "PCG iterations over all PDAS steps",
        "inner_per_solve": "PCG iterations of each PDAS step, in order",
        "dense_solve_s": "the dense PDAS solve on the same mesh",
        ("du_rel", "dlam_rel"): "max |u − u_dense| / max |u_dense|, the same for λ_H",
        "energy": "the discrete energy E(u_h) = ½a(u_h,u_h) − (f,u_h)",
        "estimate_s": "seconds of the step's estimator η (its pointwise (−Δ)ˢu_h included)",
        "cumulative_s": "seconds from the start of Algorithm B to the end of the step",
    }),
    ("Assembly memory by phase (`benchmarks/assembly-memory.md`, "
     "`benchmarks/assembly-memory-threads.md`, `benchmarks/assembly-memory-large.md`)", False, {
        "code": "the commit whose fracfem is measured ('+': with changes to fracfem/)",
        "threads": "numba's threads in the assembly (more than the machine's cores: to see "
                   "how memory grows with them)",
        "near_nnz": "entries of the near field's sparse matrix on the free nodes",
        "held_mb": "memory of the finished compressed operator, MiB",
        "phase": "phase of the assembly (as `t_trees` … `t_exterior`, then the restriction "
                 "to free nodes and the leaf matrix); `whole`: the assembly",
        "phase_s": "its seconds",
        "phase_mb": "the largest resident set seen in it (sampled every 10 ms), MiB above the "
                    "one before the assembly",
    }),
    ("Dense or compressed for `operator=\"auto\"` (`benchmarks/auto-operator.md`)", False, {
        "mesh_kind": "the mesh: a family member, or the (fine) mesh of an Algorithm B step",
        "dense_total_s": "seconds to assemble the dense matrix and solve by Cholesky",
        "compressed_total_s": "seconds to assemble the compressed operator and solve by "
                              "preconditioned CG",
        "dense_over_compressed": "`dense_total_s` / `compressed_total_s`",
        "u_rel_diff": "max |u_dense − u_compressed| / max |u_dense|",
    }),
    ("Dense Cholesky at large n (`benchmarks/cholesky.md`)", False, {
        "rows": "rows (and columns) of the symmetric positive definite matrix",
        "factorisation": "`scipy`: `scipy.linalg.cho_factor` (LAPACK dpotrf); `blocked`: "
                         "`fracfem.solvers.cho_factor` by blocks, as fracfem factorises above "
                         "`BLOCKED_CHOLESKY_N` rows",
        "exit": "how the child process that factorised ended: `ok`, or the signal that "
                "ended it (`SIGSEGV`: a crash inside OpenBLAS)",
        "factor_s": "wall seconds of the factorisation alone",
        "solve_s": "wall seconds of one solve with the factor (`scipy.linalg.cho_solve`)",
        "relative_residual": "‖Ax − b‖ / ‖b‖ of the solve with the factor",
        "matrix_mb": "one n × n matrix of float64, MB",
        "factor_extra_mb": "resident memory the factorisation adds to the matrix it "
                           "factorises in place, MB",
        "solve_extra_mb": "resident memory the solve adds beyond the factorisation's peak, "
                          "MB (a copy of the factor would show here)",
        "child_peak_mb": "peak resident memory of the child process, MB",
    }),
    ("PCG with the multilevel preconditioner (`benchmarks/pcg.md`)", False, {
        "mesh": "the mesh, as the fracfem call that makes it",
        "condition": "condition estimate of the preconditioned operator: the ratio of "
                     "the extreme Ritz values from the CG coefficients",
        ("jacobi_iterations", "jacobi_condition"): "the same with the diagonal alone "
                                                    "(Jacobi)",
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
    ("Pointwise (−Δ)ˢu_h of K functions (`benchmarks/pointwise-batch.md`)", False, {
        "K": "functions evaluated on one mesh (columns of u)",
        "singles_s": "seconds of K calls with one function each",
        "batch_s": "seconds of one call with all K functions",
        "batch_per_function_s": "batch_s / K",
        "batch_speedup": "singles_s / batch_s",
        "batch_rel_diff": "max over the K functions of max |batched − single| / "
                          "max |single| over the points",
    }),
    ("One product of the compressed operator (`benchmarks/matvec.md`)", False, {
        "far_blocks": "admissible blocks of the H² matrix",
        "before_s": "seconds of one product as before the leaf matrix and the BLAS "
                    "limit: element sources and leaf kernels, scipy's one-thread near-field "
                    "product, BLAS threading each call inside the numba threads",
        "reference_product_s": "the same with BLAS on one thread in the coupling",
        "product_s": "seconds of one product of the operator as built (leaf matrix, sparse "
                     "products on all threads)",
        "near_field_s": "its sparse near-field part",
        "far_field_s": "its admissible-block part",
        "couple_s": "the coupling of the admissible blocks within far_field_s, BLAS on "
                    "one thread",
        "couple_blas_threads_s": "the same coupling with BLAS threading each call inside "
                                 "the numba threads",
        "product_rel_diff": "|product − reference product| / |reference product|",
        "leaf_matrix_mb": "memory of the leaf matrix within nbytes_mb, MiB",
        "column_in_block_1_s": "seconds per column of the products of a block of columns "
                               "taken one at a time",
        "column_in_block_8_s": "the same, 8 columns at a time (CompressedOperator._matmat: "
                               "the near field and the leaf matrix read once for them)",
        "column_in_block_32_s": "the same, 32 at a time",
        "block_used_1": "the block the operator used when asked for 1 column at a time",
        "block_used_8": "the block it used when asked for 8 (at most 8: its far-field "
                        "work arrays are held within compressed.MATMAT_BYTES)",
        "block_used_32": "the block it used when asked for 32",
        "block_rel_diff": "largest |block product − products column by column| / "
                          "|products column by column|",
        "product_speedup": "before_s / product_s",
    }),
    ("The exterior term κ: leaves of its trees (`benchmarks/kappa.md`)", False, {
        "boundary_edges": "edges of the mesh on ∂Ω (κ's sources: two Gauss points each)",
        "source_leaf": "Gauss points per leaf of κ's source tree "
                       "(CompressedKappa's source_leaf)",
        "target_leaf": "points per leaf of κ's target tree (CompressedKappa's target_leaf)",
        "exterior_min_s": "least seconds, over the benchmark's runs, of the exterior part "
                          "of the assembly (∫_T φ_a φ_b κ of every element) with κ from "
                          "those trees",
        "exterior_max_s": "the most seconds of those runs",
        "max_rel_err": "largest |κ − direct sum| / direct sum over a random sample of its "
                       "points (fracfem.assembly.exterior_kernel)",
    }),
    ("Where the Taylor rule starts (`benchmarks/taylor-threshold.md`)", False, {
        "diam_min": "smallest triangle diameter of the mesh",
        "near_nnz_R8": "node pairs of the compressed operator's near field with the Taylor "
                       "rule from separation ratio 8 (config.yaml)",
        "near_nnz_R4": "the same from separation ratio 4 (config/paper.yaml)",
        "near_ratio": "near_nnz_R8 / near_nnz_R4",
        "near_share_R8": "near_nnz_R8 over the entries of a dense matrix on all nodes",
        "energy_error": "E − E_h: exact energy minus (f, u_h) with the rules of config.yaml",
        "change_R4": "|E_h(R = 4) − E_h(R = 8)|",
        "change_raised": "|E_h(raised rules) − E_h(R = 8)|: every singular and near rule "
                         "raised, the Taylor rule kept for the farthest class, which starts "
                         "at ratio 16 (`QuadratureOptions.raised(keep_taylor=True)`)",
        "error_over_change_R4": "|energy_error| / change_R4",
    }),
    ("Bad input (`bad-inputs.md`)", False, {
        "parameter": "the argument at fault",
        "input": "what was passed",
        "message": "the message the user gets (first line, shortened)",
    }),
]


def _names(columns):
    return (columns,) if isinstance(columns, str) else tuple(columns)


def definitions():
    """{column: meaning} over all groups (a later group's repeat wins)."""
    return {name: meaning for _, _, cols in GROUPS for columns, meaning in cols.items()
            for name in _names(columns)}


def markdown(readme_only=False):
    """The glossary as compact Markdown: one paragraph per group."""
    parts = []
    for title, in_readme, cols in GROUPS:
        if readme_only and not in_readme:
            continue
        items = "; ".join(", ".join(f"`{c}`" for c in _names(columns)) + f": {meaning}"
                          for columns, meaning in cols.items())
        parts.append(f"**{title}.** {items}.")
    return "\n\n".join(parts)


def _rst_inline(text):
    """Markdown inline text as reStructuredText: `code` spans become literals; | and *
    (substitutions and emphasis in RST) and backslashes are escaped elsewhere."""
    out = []
    for k, piece in enumerate(re.split(r"`([^`]+)`", text)):
        if k % 2:
            out.append(f"``{piece}``")
        else:
            out.append(re.sub(r"([\\|*])", r"\\\1", piece))
    return "".join(out)


def _wrap(text, width, indent):
    """``text`` wrapped at spaces outside ``literals`` (a column name stays on one line)."""
    keep = re.sub(r"``.*?``", lambda m: m.group(0).replace(" ", "\0"), text)
    lines = textwrap.wrap(keep, width, initial_indent=indent, subsequent_indent=indent,
                          break_long_words=False, break_on_hyphens=False)
    return "\n".join(lines).replace("\0", " ")


def rst(underline="~", width=92):
    """The glossary as reStructuredText: one subsection per group (titles underlined
    with ``underline``), a definition list of its columns.  The report's front page is
    also a Jinja template, so Jinja delimiters are refused."""
    parts = []
    for title, _, cols in GROUPS:
        head = _rst_inline(title)
        items = [", ".join(f"``{c}``" for c in _names(columns)) + "\n"
                 + _wrap(_rst_inline(meaning), width, "    ")
                 for columns, meaning in cols.items()]
        parts.append(f"{head}\n{underline * len(head)}\n\n" + "\n".join(items))
    text = "\n\n".join(parts)
    for delim in ("{{", "{%", "{#"):
        if delim in text:
            raise ValueError(f"the glossary contains the Jinja delimiter {delim!r}")
    return text
