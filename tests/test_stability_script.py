"""workflow/scripts/stability.py: the measurements of one stability case."""
import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import fracfem as ff
from pages import page_tables

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location(
    "stability", ROOT / "workflow" / "scripts" / "stability.py")
st = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(st)


def test_lanczos_eigenvalues_match_the_dense_ones(monkeypatch):
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((200, 200)))
    ev = np.geomspace(1e-6, 1.0, 200)
    A = (q * ev) @ q.T
    dense = st.extreme_eigenvalues(A)
    monkeypatch.setattr(st, "DENSE_EIG", 100)
    lanczos = st.extreme_eigenvalues(A)
    np.testing.assert_allclose(dense, (1e-6, 1.0), rtol=1e-8)
    np.testing.assert_allclose(lanczos, dense, rtol=1e-5)


@pytest.mark.parametrize("layer", [1e-6, 1e-10])
def test_mesh_columns_see_the_thin_outer_layer(layer):
    n = 6
    cols = st.mesh_columns(ff.disk_graded_rings(n, 4.0, layer=layer))
    np.testing.assert_allclose(cols["thinnest_layer"], layer, rtol=1e-5)
    # the layer's triangles: a chord of the boundary ring over a height ~ layer
    chord = 2 * np.sin(np.pi / np.ceil(2 * np.pi * n))
    assert 0.9 * chord / layer < cols["max_aspect"] < 1.5 * chord / layer


def test_a_case_row_has_every_check():
    row = st.case("uniform", ff.disk_uniform(1), 0.5, family="test")
    assert row["status"] == "ok" and row["family"] == "test"
    assert row["galerkin_ok"] and row["spd"] and row["finite"]
    assert row["dofs"] == len(ff.disk_uniform(1).interior_nodes())
    assert 1 <= row["cond_scaled"] and 1 <= row["cond"]
    # the two solves agree to round-off, the raised quadrature to far below 1 % of err²
    assert row["roundoff_over_err2"] < 1e-10 and row["residual"] < 1e-13
    assert row["quad_change_over_err2"] < 1e-2
    np.testing.assert_allclose(row["error"] ** 2, ff.disk_energy(0.5) - row["fu_h"])


def _rows(errors, quad=1e-4):
    """An n-series at μ = 2 with the given errors and one outer-layer case."""
    base = dict(family="n-series", grading=2.0, status="ok", cond=5.0, cond_scaled=3.0,
                roundoff_over_err2=1e-14, residual=1e-16, max_aspect=10.0, galerkin_ok=True,
                spd=True)
    rows = [dict(base, case=f"n{n}", n=n, dofs=4 * n * n, error=e, thinnest_layer=n ** -2.0,
                 quad_change_over_err2=quad) for n, e in zip((4, 8, 16), errors)]
    rows.append(dict(base, case="layer", family="outer layer", n=8, dofs=300, error=0.1,
                     thinnest_layer=1e-6, quad_change_over_err2=quad))
    return pd.DataFrame(rows)


def test_reading_states_what_limits_the_error():
    text = st.reading(_rows([0.2, 0.1, 0.05]))
    assert "falls at every step" in text and "last slope against DOFs -0.50" in text
    assert "the approximation alone" in text
    stuck = st.reading(_rows([0.2, 0.1, 0.11], quad=0.05))
    assert "stops falling" in stuck and "At least one case is limited" in stuck
    assert "0.05 of err²" in stuck


def test_reading_sums_both_clocks_over_every_anisotropic_case():
    """Wall against CPU seconds over the anisotropic cases, a refused one included; a table
    from before the CPU clock (no such columns) is read without them."""
    rows = _rows([0.2, 0.1, 0.05]).assign(seconds=[10.0, 30.0, 100.0, 20.0],
                                           cpu_seconds=[19.0, 58.0, 60.0, 3.0])
    refused = rows.iloc[[0]].assign(status="refused: x", seconds=1000.0, cpu_seconds=1.0)
    text = st.reading(pd.concat([rows, refused], ignore_index=True))
    assert "took 1160 s wall time and 141 s CPU time (all threads; 0.12 CPU seconds" in text
    assert "wall time" not in st.reading(_rows([0.2, 0.1, 0.05]))


def test_page_prints_the_clocks_in_full_and_the_rest_to_three_digits():
    """A case of 1640.24 s wall (1234.56 s CPU) prints as 1640.2 and 1234.6, not 1.64e+03 and
    1.23e+03; the errors keep three significant digits; each table has its own columns."""
    sweep = pd.DataFrame([dict(case="s sweep, disk_uniform(3)", s=0.01, dofs=113, h_min=0.125,
                               min_angle=34.1, error=0.51312, galerkin_ok=True, spd=True,
                               cond=6.46, quad_change_over_err2=2.9e-6, status="ok")])
    aniso = _rows([0.2, 0.1, 0.05]).assign(seconds=[12.4, 33.2, 1640.24, 81.8],
                                           cpu_seconds=[20.0, 60.0, 1234.56, 150.0])
    text = st.page(pd.concat([sweep, aniso], ignore_index=True))
    first, second = page_tables(text)
    assert list(first[0]) == st.COLUMNS and list(second[0]) == st.ANISO_COLUMNS
    (cells,) = [r for r in second if r["case"] == "n16"]
    assert (cells["seconds"], cells["cpu_seconds"]) == ("1640.2", "1234.6")
    assert first[0]["error"] == "0.513" and first[0]["dofs"] == "113"
    assert "e+03" not in text and "**Reading" in text


def test_committed_page_has_the_scripts_columns():
    """paper-figures/stability.md (its rule is outside `rule all`) was written by this
    script as it stands: its two tables have the columns page() writes."""
    first, second = page_tables((ROOT / "paper-figures" / "stability.md").read_text())
    assert list(first[0]) == st.COLUMNS and list(second[0]) == st.ANISO_COLUMNS
