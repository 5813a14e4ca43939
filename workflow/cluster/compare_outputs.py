"""Compare two result directories of the pipeline (e.g. a local and a SLURM run).

    python workflow/cluster/compare_outputs.py results-local results-slurm [--rtol 1e-9]

Every file under both directories is compared except benchmarks/ and logs/ (wall
times and log text differ between any two runs):

  .csv          numerically, column by column (relative tolerance --rtol, absolute
                --atol); columns holding wall times, memory peaks or provenance of
                the run (TIMING_COLUMNS: t_*, *_s, created, git_commit, ...) are left out
  .md .tex .json  as text, with every number compared within the tolerance; cells of
                markdown table columns whose header is a timing column or derived
                from wall times (TIMING_HEADERS: seconds, [s], fastest, speed-up) are
                left out
  .npz          array by array, floats within the tolerance, others exactly
  .png          the decoded pixels (matplotlib), so PNG metadata does not matter
  .pdf          the bytes after removing /CreationDate and /ModDate
  other         the bytes

A file whose content is a wall time (EXPECTED_TO_DIFFER: the assembly benchmark and
the error-vs-time figures) is reported but not counted as a difference.  Exit code 1
if anything else differs or exists on one side only.
"""
import argparse
import fnmatch
import json
import math
import re
import sys
from pathlib import Path

import numpy as np

TIMING_COLUMNS = re.compile(
    r"^(t_\w*|\w+_s|\w*_per_s|\w*seconds\w*|s/\w+|time|wall\w*|peak_mem\w*|created|git_commit"
    r"|ratio_to_floor)$", re.I)
# markdown headers of columns holding or derived from wall times
TIMING_HEADERS = re.compile(r"\b(seconds|wall|fastest|speed-?up)\b|\[s\]|\(s\)", re.I)
EXPECTED_TO_DIFFER = ["*benchmark-assembly.*", "*benchmark-compressed.*", "*-vs-time.*",
                      "*error-vs-time*"]
SKIP_DIRS = {"benchmarks", "logs"}
NUMBER = re.compile(r"(?<![\w.])[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?(?![\w.])")


def files_under(root):
    root = Path(root)
    return {p.relative_to(root).as_posix() for p in root.rglob("*")
            if p.is_file() and not (set(p.relative_to(root).parts[:-1]) & SKIP_DIRS)
            and not p.name.startswith(".tmp-")}


def close(a, b, rtol, atol):
    """(equal within tolerance, relative difference)"""
    if a == b or (math.isnan(a) and math.isnan(b)):
        return True, 0.0
    diff = abs(a - b)
    rel = diff / max(abs(a), abs(b))
    return diff <= atol + rtol * max(abs(a), abs(b)), rel


def compare_numbers_in_text(ta, tb, rtol, atol):
    """(equal, max relative difference, first differing token)"""
    pa, pb = NUMBER.split(ta), NUMBER.split(tb)
    na, nb = NUMBER.findall(ta), NUMBER.findall(tb)
    if pa != pb or len(na) != len(nb):
        for x, y in zip(ta.splitlines(), tb.splitlines()):
            if NUMBER.sub("#", x) != NUMBER.sub("#", y):
                return False, math.inf, f"{x!r} vs {y!r}"
        return False, math.inf, "different text"
    worst = 0.0
    for x, y in zip(na, nb):
        ok, rel = close(float(x), float(y), rtol, atol)
        worst = max(worst, rel)
        if not ok:
            return False, rel, f"{x} vs {y}"
    return True, worst, ""


def drop_timing_cells(text):
    """Markdown tables with the cells of timing columns blanked."""
    out, drop = [], set()
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if not line.lstrip().startswith("|"):
            drop = set()
            out.append(line)
            continue
        cells = line.split("|")
        is_header = (k + 1 < len(lines) and re.match(r"^\s*\|[\s:|-]+\|\s*$", lines[k + 1])
                     and not re.match(r"^\s*\|[\s:|-]+\|\s*$", line))
        if is_header:
            drop = {j for j, c in enumerate(cells)
                    if TIMING_COLUMNS.match(re.sub(r"[`*\s]", "", c).strip() or "-")
                    or TIMING_HEADERS.search(c)}
        out.append("|".join("~" if j in drop and not is_header else c
                            for j, c in enumerate(cells)))
    return "\n".join(out)


def compare_csv(fa, fb, rtol, atol):
    import pandas as pd
    a, b = pd.read_csv(fa), pd.read_csv(fb)
    if list(a.columns) != list(b.columns) or len(a) != len(b):
        return "DIFFERENT", f"columns/rows {list(a.columns)} x {len(a)} vs {list(b.columns)} x {len(b)}"
    skipped = [c for c in a.columns if TIMING_COLUMNS.match(str(c))]
    worst = 0.0
    for c in a.columns:
        if c in skipped:
            continue
        x, y = a[c], b[c]
        if pd.api.types.is_numeric_dtype(x) and pd.api.types.is_numeric_dtype(y):
            for u, v in zip(x.astype(float), y.astype(float)):
                ok, rel = close(u, v, rtol, atol)
                worst = max(worst, rel)
                if not ok:
                    return "DIFFERENT", f"column {c}: {u!r} vs {v!r}"
        else:
            for u, v in zip(map(str, x), map(str, y)):     # NaN -> "nan" on both sides
                ok, rel, what = compare_numbers_in_text(u, v, rtol, atol)
                worst = max(worst, rel)
                if not ok:
                    return "DIFFERENT", f"column {c}: {what}"
    note = f"timing/provenance columns left out: {', '.join(skipped)}" if skipped else ""
    return "numerically equal", (f"max rel diff {worst:.1e}; " if worst else "") + note


def compare_text(fa, fb, rtol, atol, markdown):
    ta, tb = Path(fa).read_text(), Path(fb).read_text()
    if ta == tb:
        return "identical", ""
    if markdown:
        ta, tb = drop_timing_cells(ta), drop_timing_cells(tb)
    ok, worst, what = compare_numbers_in_text(ta, tb, rtol, atol)
    if not ok:
        return "DIFFERENT", what
    notes = ([f"max rel diff {worst:.1e}"] if worst else []) + (
        ["timing columns left out"] if markdown else [])
    return "numerically equal", "; ".join(notes)


def compare_npz(fa, fb, rtol, atol):
    with np.load(fa, allow_pickle=False) as a, np.load(fb, allow_pickle=False) as b:
        if sorted(a.files) != sorted(b.files):
            return "DIFFERENT", f"arrays {sorted(a.files)} vs {sorted(b.files)}"
        worst = 0.0
        for k in a.files:
            x, y = a[k], b[k]
            if x.shape != y.shape or x.dtype != y.dtype:
                return "DIFFERENT", f"{k}: {x.dtype}{x.shape} vs {y.dtype}{y.shape}"
            if np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.complexfloating):
                if not np.allclose(x, y, rtol=rtol, atol=atol, equal_nan=True):
                    return "DIFFERENT", f"{k}: max abs diff {np.nanmax(np.abs(x - y)):.3e}"
                scale = np.maximum(np.abs(x), np.abs(y))
                with np.errstate(invalid="ignore", divide="ignore"):
                    rel = np.where(scale > 0, np.abs(x - y) / scale, 0.0)
                worst = max(worst, float(np.nanmax(rel)) if rel.size else 0.0)
            elif not np.array_equal(x, y):
                return "DIFFERENT", f"{k} differs"
    return ("identical" if worst == 0 else "numerically equal"), (
        f"max rel diff {worst:.1e}" if worst else "")


def compare_png(fa, fb):
    import matplotlib.image as mpimg
    x, y = mpimg.imread(fa), mpimg.imread(fb)
    if x.shape != y.shape:
        return "DIFFERENT", f"size {x.shape} vs {y.shape}"
    if not np.array_equal(x, y):
        return "DIFFERENT", f"{np.count_nonzero(np.any(x != y, axis=-1))} pixels differ"
    return "same pixels", ""


def compare_pdf(fa, fb):
    strip = re.compile(rb"/(CreationDate|ModDate) \(D:[^)]*\)")
    a, b = strip.sub(b"", Path(fa).read_bytes()), strip.sub(b"", Path(fb).read_bytes())
    return ("same after dates", "") if a == b else ("DIFFERENT", "bytes differ")


def compare_file(fa, fb, rtol, atol):
    if Path(fa).read_bytes() == Path(fb).read_bytes():
        return "identical", ""
    suffix = Path(fa).suffix.lower()
    if suffix == ".csv":
        return compare_csv(fa, fb, rtol, atol)
    if suffix in (".md", ".tex", ".json", ".txt"):
        return compare_text(fa, fb, rtol, atol, markdown=suffix == ".md")
    if suffix == ".npz":
        return compare_npz(fa, fb, rtol, atol)
    if suffix == ".png":
        return compare_png(fa, fb)
    if suffix == ".pdf":
        return compare_pdf(fa, fb)
    return "DIFFERENT", "bytes differ"


def compare_dirs(a, b, rtol=1e-9, atol=1e-12, expected=EXPECTED_TO_DIFFER):
    """[(relative path, status, detail)] for the union of both trees; a status in
    capitals is a failure."""
    fa, fb = files_under(a), files_under(b)
    rows = []
    for rel in sorted(fa | fb):
        if rel not in fb:
            rows.append((rel, "ONLY IN A", str(a)))
            continue
        if rel not in fa:
            rows.append((rel, "ONLY IN B", str(b)))
            continue
        try:
            status, detail = compare_file(Path(a, rel), Path(b, rel), rtol, atol)
        except Exception as err:                    # unreadable file: report, do not stop
            status, detail = "DIFFERENT", f"{type(err).__name__}: {err}"
        if status == "DIFFERENT" and any(fnmatch.fnmatch(rel, p) for p in expected):
            status = "timing output"
        rows.append((rel, status, detail))
    return rows


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rtol", type=float, default=1e-9)
    ap.add_argument("--atol", type=float, default=1e-12)
    ap.add_argument("--json", help="also write the rows to this file")
    ap.add_argument("--quiet", action="store_true", help="print only the summary and failures")
    args = ap.parse_args(argv)
    rows = compare_dirs(args.a, args.b, args.rtol, args.atol)
    counts = {}
    for rel, status, detail in rows:
        counts[status] = counts.get(status, 0) + 1
        if not args.quiet or status.isupper() or status == "timing output":
            print(f"{status:18} {rel}" + (f"  ({detail})" if detail else ""))
    print("summary: " + ", ".join(f"{n} {s}" for s, n in sorted(counts.items())))
    if args.json:
        Path(args.json).write_text(json.dumps(
            {"a": args.a, "b": args.b, "rtol": args.rtol, "atol": args.atol,
             "counts": counts, "files": rows}, indent=1))
    return 1 if any(s.isupper() for _, s, _ in rows) else 0


if __name__ == "__main__":
    sys.exit(main())
