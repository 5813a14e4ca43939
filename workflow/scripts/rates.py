"""The rate table: ours next to the paper's (CSV, Markdown, LaTeX)."""
from pathlib import Path

import numpy as np
import pandas as pd

from fracfem_workflow.io import atomic_path, write_table
from fracfem_workflow.logs import log_to
from fracfem_workflow.report import (PARTIAL_RATE_TABLES, fit_mask, join_tiers,
                                     rate_table, whole_numbers, with_variant_key)


# why a rate can differ from the paper's (README, "Differences from the paper")
REF_ELLIPTIC = ("the reference energy is the extrapolation of a large adaptive series; its "
                "uncertainty and cross-checks are in elliptic-errors.md")
EXACT3 = "the reference energy is exact here (pure slip), so the difference is the method's"
REF_PARA = ("the error is the distance to the limit of the reference's family, extrapolated "
            "from the distances to its runs, each with its measured uncertainty (error bars "
            "in Figures 13/15); parabolic-reference-check.md measures the extrapolation on a "
            "problem with known solution")
REASONS = {(1, "graded"): "against its mesh size h the error falls about as the theory's h¹ "
                         "(`rate in h`, second table of `ex1-errors.md`), while over these "
                         "runs the DOFs grow faster than h⁻² (`dofs ~ h^p`; less so as h "
                         "shrinks): the rate against DOFs is their ratio, flatter than −1/2 "
                         "mostly through the DOFs, and its local slopes approach −1/2 from "
                         "above; the paper's rate, steeper than −1/2 (it states the h-rate "
                         "for N ~ h⁻² as twice its size), would need an error falling faster "
                         "than h¹",
           (2, "graded"): "`ex2-graded-rings.md` solves Example 2 on the graded family at "
                          "every ring count n between the series' own (n = ⌈1/h⌉), nothing "
                          "else changed: the error rises and falls from one n to the next "
                          "and lies on no single power law at these sizes, so the rates "
                          "through other windows of ring counts, or through h-halved "
                          "families, spread around the paper's and the series' rates; part "
                          "of it is the dip of u_h below χ that the averaged constraint "
                          "allows, which lowers E(u_h) by a share of the error that changes "
                          "with n (the lift max(u_h, χ) at the fine nodes has steadier "
                          "errors, though not one power law either)",
           (1, "adaptive"): "`ex1-adaptive-rate.md` runs Algorithm B again from finer "
                            "start meshes, nothing else changed: after a few steps each "
                            "series has this one's error at the same DOFs, yet the rate "
                            "fitted through all its steps is steeper the finer its start "
                            "mesh: that rate says where the series starts (the paper does "
                            "not state its start mesh) more than how the meshes it reaches "
                            "converge; the local slopes steepen along the series "
                            "(`ex1-errors.md`; the paper-scale tier continues it)",
           (2, "adaptive"): "`ex2-adaptive-rate.md` runs Algorithm B again with one setting "
                            "changed at a time and measures every step also by its distance "
                            "‖u_h − u_ref‖_a to a later step of the series, the norm the "
                            "paper plots: where u_h no longer dips far below χ, that "
                            "distance with u_ref's own error added back matches the energy "
                            "error, and the marking parameter θ hardly moves the rate, so "
                            "neither the measure nor θ explains the difference; the start "
                            "mesh does (the paper does not state its own): from a finer one "
                            "the rate is steeper, from a coarser one, on which u_h dips far "
                            "below χ for several steps while η falls, the error stalls and "
                            "the rate is much flatter. The reference energy is the limit of "
                            "the large adaptive series whose first steps these are "
                            "(docs/differences.md); the rates against the other families' "
                            "limits are in elliptic-errors.md",
           (3, "adaptive"): EXACT3,
           (2, "uniform"): REF_ELLIPTIC, (3, "uniform"): EXACT3,
           (4, "uniform"): REF_PARA,
           (5, "uniform"): "ex5-uniform-rate.md changes one thing at a time: without "
                           "friction the local slopes stay within a few per cent of "
                           "Example 5's; with u₀ = 1, which does not vanish on ∂Ω, they are "
                           "close to, and somewhat flatter than, the boundary layer's "
                           "−1/(4 + 4s) at every level. Example 5's u₀ vanishes on ∂Ω, and "
                           "its runs solved again on the same meshes with more time steps "
                           "(parabolic.uniform_cause.time_refinements) lose most of their "
                           "squared error at every level: at our sizes its error is mostly "
                           "the time steps', and its local slopes steepen level by level, "
                           "none yet beyond −2s/(2 + 2s), the rate of that error with τ ~ "
                           "h^(2s), instead of flattening toward the layer's (the "
                           "paper-scale tier measures one level more against a finer family, "
                           "with the errors' uncertainties)"}

# the parabolic adaptive rows, where the problem's time-split table is made
# (parabolic.time_split.problems); otherwise REF_PARA alone
TIME_SPLIT = {4: "{table} solves each pass again with more time steps, the space meshes "
                 "kept: the time steps carry a small and shrinking share of the squared "
                 "error (`1 − (e(τ/16)/e)²`), so the error is the space meshes'; its local "
                 "slopes steepen after the first pass, and the fit over every pass from the "
                 "coarsest mesh is pre-asymptotic at our sizes; η falls at the error's rate "
                 "({algorithm}); and " + REF_PARA,
              5: "{table} solves each pass again with more time steps, the space meshes "
                 "kept: most of the first passes' error is the time discretisation's, and "
                 "what the refined runs leave changes little from the second pass on; the "
                 "fitted rate is mostly that of the time error falling, before space and "
                 "time balance; and " + REF_PARA}

# the parabolic graded rows, where the problem's time-split table is made
GRADED_SPLIT = ("{table} solves each graded run again on its mesh with more time steps "
                "(τ/m), nothing else changed: the time steps' share of the squared error "
                "(`1 − (e(τ/16)/e)²`) grows along the series, and the rates with more steps "
                "are steeper; at our sizes the time steps of the graded series, not its "
                "meshes, hold its rate back")


def reason(r, time_split=()):
    """Why row r's rate can differ from the paper's; time_split: the parabolic problems
    whose time-split tables the configuration makes."""
    if r.family in ("adaptive", "graded") and r.example in TIME_SPLIT:
        variant = r.variant if isinstance(r.variant, str) else ""
        problem = f"ex{r.example}" + (f"-{variant}" if variant else "")
        table = f"`{problem}-time-split.md`"
        if r.family == "adaptive":
            return (TIME_SPLIT[r.example].format(table=table,
                                                 algorithm=f"`{problem}-algorithm-c.md`")
                    if problem in time_split else REF_PARA)
        if problem in time_split:
            return GRADED_SPLIT.format(table=table)
    return REASONS.get((r.example, r.family), "not explained yet")


def within(r):
    """Whether the paper's rate lies among the rates row r's runs give with each error
    anywhere within its bound (rate_min … rate_max); nothing for an exact reference or
    unknown bounds."""
    if r.reference_error == 0 or not (pd.notna(r.rate_min) and pd.notna(r.rate_max)):
        return ""
    span = (f" Moving each fitted error independently within its bound gives rates from "
            f"{r.rate_min:.3f} to {r.rate_max:.3f}; the paper's rate lies")
    if r.rate_min <= r.paper_rate <= r.rate_max:
        return (span + " inside that range: the reference is too inaccurate to tell "
                "whether this difference is real.")
    return span + " outside it: the reference's inaccuracy alone does not explain it."


def unmeasured_exclusions(df):
    """{(example, variant, family, s): how many of the group's runs rate_table leaves out
    with a bound that is not their own measured uncertainty}: runs with a finite error
    whose uncertainty is not measured (NaN) where the other runs of their problem have
    one. With a family of four or more members that is a run sharing its space mesh with
    a member, which its error leaves out (fracfem.transfer.ReferenceFamily.error): the
    three left measure no uncertainty, and the run is held to the finest run's error
    instead (report.with_fit_bound). A family of three measures none for any run: then
    nothing is counted."""
    if "error_uncertainty" not in df or "reference_run_error" not in df:
        return {}
    d = with_variant_key(df)
    measured = d.groupby(["example", "variant"]).error_uncertainty.transform(
        lambda u: u.notna().any())
    out = d[~fit_mask(d.error, d.reference_error) & np.isfinite(d.error)
            & d.error_uncertainty.isna() & d.reference_run_error.notna() & measured]
    return {k: len(g) for k, g in out.groupby(["example", "variant", "family", "s"])}


def differences(rates, limit=0.05, time_split=(), unmeasured=None):
    """One sentence per row whose rate differs from the paper's by more than limit;
    unmeasured: :func:`unmeasured_exclusions` of the runs the rows were fitted from."""
    unmeasured = unmeasured or {}
    lines = []
    for r in rates.itertuples(index=False):
        name = f"Example {r.example}{' (' + r.variant + ')' if r.variant else ''}"
        if pd.notna(r.paper_rate) and pd.isna(r.rate):
            lines.append(f"- {name}, {r.family}: no rate against {r.paper_rate:.3f} — only "
                         f"{r.n_points} of its runs lie above 3× their reference's error "
                         "(Examples 4, 5: the uncertainty of their error) or above the "
                         "reference energy; a finer reference is needed.")
        if pd.notna(r.paper_rate) and abs(r.rate - r.paper_rate) > limit:
            why = reason(r, time_split)
            own = (unmeasured.get((r.example, r.variant or "", r.family, r.s), 0)
                   if unmeasured else 0)
            if r.n_excluded and own:
                one, more = own == 1, r.n_excluded - own
                why = (f"{own} of its {r.n_points + r.n_excluded} runs "
                       f"{'shares its' if one else 'share their'} space mesh with a member "
                       "of the reference's family, which the measurement leaves out; the "
                       "three members left measure no uncertainty of "
                       f"{'its error' if one else 'their errors'}, so "
                       f"{'its bound is' if one else 'their bound is'} the reference run's "
                       f"own error, within 3× of which {'it lies' if one else 'they lie'}; "
                       f"{'it is' if one else 'they are'} left out"
                       + ("" if not more else
                          f", as {'is' if more == 1 else 'are'} {more} more within 3× "
                          f"{'its' if more == 1 else 'their'} measured uncertainty (a finer "
                          "reference is needed)")
                       + f", and the rate rests on {r.n_points}. A coarser member added to "
                       "the family would measure that uncertainty"
                       + ("" if why == "not explained yet" else f". Also: {why}"))
            elif r.n_excluded:
                why = (f"{r.n_excluded} of its {r.n_points + r.n_excluded} runs lie within 3× "
                       "their reference's error (Examples 4, 5: the uncertainty of their "
                       "error) and are left out, so the rate rests on "
                       f"{r.n_points}; a finer reference is needed"
                       + ("" if why == "not explained yet" else f". Also: {why}"))
            lines.append(f"- {name}, {r.family}: {r.rate:.3f} against {r.paper_rate:.3f} — "
                         f"{why}.{within(r)}")
    return lines


def tier_paths(paths):
    """A tier's rate tables as a list (one path, or its partial tables)."""
    return [str(paths)] if isinstance(paths, (str, Path)) else [str(p) for p in paths]


def tier_source(name, paths):
    """Where tier ``name``'s columns come from, for the note under the table."""
    paths = tier_paths(paths)
    parts = [PARTIAL_RATE_TABLES[Path(p).name] for p in paths
             if Path(p).name in PARTIAL_RATE_TABLES]
    text = " and ".join(f"`{p}`" for p in paths)
    if parts:
        held = " and ".join(parts)
        others = "other " if "rates-parabolic.csv" in {Path(p).name for p in paths} else ""
        text += (f" (the {name} tier's {held}; its {others}parabolic series are not "
                 "finished)")
    return text


def read_tier(paths) -> pd.DataFrame:
    """A tier's rate table: its partial tables (disjoint rows) read as one."""
    return pd.concat([pd.read_csv(p) for p in tier_paths(paths)], ignore_index=True)


def tiers_note(tier, tiers, absent, configured):
    """What the table holds besides this tier's own rates."""
    lines = []
    if tiers:
        lines.append("Beside this tier's (" + tier + ") rates: " + "; ".join(
            f"`rate_{n}`, `n_points_{n}`, `dof_max_{n}`, `smallest_error_{n}` from "
            + tier_source(n, p) for n, p in tiers.items()) + ", the same rows fitted by the "
            "same rule.")
    for n in absent:
        lines.append(f"The tier {n} has not been run here (no `{configured[n]}`, nor either "
                     "partial table (`" + "` or `".join(PARTIAL_RATE_TABLES) + "`) beside it).")
    return lines


def shown_counts(rates: pd.DataFrame) -> pd.DataFrame:
    """The rate table as the page shows it: its counts and DOFs (another tier's too) whole,
    blank where missing."""
    return whole_numbers(rates, [c for c in rates.columns if c in (
        "n_points", "n_excluded", "dof_min", "dof_max") or c.startswith(("n_points_",
                                                                          "dof_max_"))])


def main(tables, csv, md, tex, tier="default", tiers=None, absent=(), configured=None,
         time_split=()):
    frames, dropped = [], 0
    for t in tables:
        d = pd.read_csv(t)
        if "below_reference" in d:
            # an energy below the reference energy gives no valid error: not fitted
            dropped += int(d.below_reference.sum())
            d = d[~d.below_reference.astype(bool)]
        if "reference_error" not in d:  # Example 1: exact solution, no reference error
            if not (d.example == 1).all():
                raise ValueError(f"{t}: no reference_error column")
            d = d.assign(reference_error=0.0)
        if "spacetime_dofs" in d:      # parabolic: rates against space-time DOFs
            d = d.assign(dofs=d.spacetime_dofs)
        frames.append(d)
    df = pd.concat(frames, ignore_index=True)
    rates = rate_table(df)
    rates["difference"] = (rates.rate - rates.paper_rate).round(3)
    diff = differences(rates, time_split=time_split, unmeasured=unmeasured_exclusions(df))
    tiers = tiers or {}
    rates = join_tiers(rates, {n: read_tier(p) for n, p in tiers.items()})
    write_table(rates, csv)
    notes = tiers_note(tier, tiers, absent, configured or {})
    if dropped:
        diff.append(f"- {dropped} runs with an energy below the reference energy are left "
                    "out of the fits.")
    with atomic_path(md) as tmp:
        tmp.write_text(shown_counts(rates).to_markdown(index=False, floatfmt="g") + "\n"
                       + ("\n" + "\n\n".join(notes) + "\n" if notes else "")
                       + ("\nWhere ours differ from the paper's by more than 0.05:\n\n"
                          + "\n".join(diff) + "\n" if diff else ""))
    with atomic_path(tex) as tmp:
        tmp.write_text(to_latex(rates))


def to_latex(df):
    """A plain tabular environment (no jinja2 needed)."""
    def cell(v):
        if isinstance(v, float):
            return "--" if pd.isna(v) else f"{v:.3f}"
        return str(v).replace("_", r"\_")
    lines = [r"\begin{tabular}{" + "l" * len(df.columns) + "}", r"\hline",
             " & ".join(cell(c) for c in df.columns) + r" \\", r"\hline"]
    lines += [" & ".join(cell(v) for v in row) + r" \\" for row in df.itertuples(index=False)]
    lines += [r"\hline", r"\end{tabular}", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    log_to(snakemake.log[0])  # noqa: F821
    # rates: every table; rates_elliptic: Examples 1-3; rates_parabolic: the kept ones
    main(([snakemake.input.ex1] if "ex1" in snakemake.input.keys() else [])  # noqa: F821
         + list(snakemake.input.get("vi", []))  # noqa: F821
         + list(snakemake.input.get("para", [])),  # noqa: F821
         snakemake.output.csv, snakemake.output.md, snakemake.output.tex,  # noqa: F821
         tier=snakemake.params.tier, tiers=dict(snakemake.params.tiers),  # noqa: F821
         absent=list(snakemake.params.absent),  # noqa: F821
         configured=dict(snakemake.config.get("tiers", {})),  # noqa: F821
         time_split=list(snakemake.params.time_split))  # noqa: F821
