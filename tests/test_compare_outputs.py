"""workflow/cluster/compare_outputs.py: two result trees agree up to timings and metadata."""
import importlib.util
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "compare_outputs", ROOT / "workflow" / "cluster" / "compare_outputs.py")
co = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(co)


def tree(root, err="0.125", t_total="1.5", seconds="3.2", pdf_date="20260101", arr=1.0,
         md_err="0.125"):
    (root / "ex1").mkdir(parents=True)
    (root / "logs").mkdir()
    (root / "ex1" / "L2.csv").write_text(
        f"dofs,error,t_total,created,git_commit\n93,{err},{t_total},2026-01-01T00:{seconds},abc\n")
    (root / "runs.md").write_text(
        f"Runs\n\n| dofs | error | seconds |\n|---:|---:|---:|\n| 93 | {md_err} | {seconds} |\n")
    (root / "logs" / "x.log").write_text(f"took {seconds} s\n")
    (root / "f.pdf").write_bytes(b"%PDF-1.4 /CreationDate (D:" + pdf_date.encode() + b") body")
    np.savez(root / "u.npz", u=np.array([arr, 2.0]), n=np.array([1, 2]))
    return root


def statuses(rows):
    return {rel: status for rel, status, _ in rows}


def test_timings_dates_and_logs_do_not_count(tmp_path):
    a = tree(tmp_path / "a")
    b = tree(tmp_path / "b", t_total="9.9", seconds="7.7", pdf_date="20270202")
    rows = co.compare_dirs(a, b)
    st = statuses(rows)
    assert "logs/x.log" not in st
    assert st["ex1/L2.csv"] == "numerically equal"
    assert st["runs.md"] == "numerically equal"
    assert st["f.pdf"] == "same after dates"
    assert st["u.npz"] == "identical"
    assert not any(s.isupper() for s in st.values())


@pytest.mark.parametrize("kwargs, path", [
    ({"err": "0.126"}, "ex1/L2.csv"),
    ({"md_err": "0.1250001"}, "runs.md"),
    ({"arr": 1.0 + 1e-6}, "u.npz"),
])
def test_a_changed_number_is_a_difference(tmp_path, kwargs, path):
    a, b = tree(tmp_path / "a"), tree(tmp_path / "b", **kwargs)
    st = statuses(co.compare_dirs(a, b))
    assert st[path] == "DIFFERENT"
    assert co.main([str(a), str(b), "--quiet"]) == 1


def test_tolerance_and_missing_files(tmp_path):
    a, b = tree(tmp_path / "a"), tree(tmp_path / "b", err="0.12500000000001")
    assert statuses(co.compare_dirs(a, b))["ex1/L2.csv"] == "numerically equal"
    assert statuses(co.compare_dirs(a, b, rtol=1e-15, atol=0))["ex1/L2.csv"] == "DIFFERENT"
    (b / "extra.md").write_text("x\n")
    assert statuses(co.compare_dirs(a, b))["extra.md"] == "ONLY IN B"
