"""The workflow's own package (fracfem_workflow): result files, parameter columns,
time to reach an error."""
import json

import numpy as np
import pandas as pd
import pytest

import fracfem as ff
from fracfem_workflow.io import save_arrays, with_provenance, write_table
from fracfem_workflow.report import time_to_reach
from fracfem_workflow.runs import parabolic_pieces, parameter_columns


def test_failed_writes_leave_no_file(tmp_path):
    target = tmp_path / "row.csv"

    class Boom(pd.DataFrame):
        def to_csv(self, *a, **k):
            raise RuntimeError("disk full")

    with pytest.raises(RuntimeError):
        write_table(Boom({"a": [1]}), target)
    assert list(tmp_path.iterdir()) == []
    save_arrays(tmp_path / "x.npz", a=np.arange(3))
    assert [p.name for p in tmp_path.iterdir()] == ["x.npz"]


def test_parameter_columns_survive_a_csv_round_trip(tmp_path):
    quad = ff.QuadratureOptions(coincident=12)
    cols = parameter_columns(quadrature=quad, theta=0.5, tau_factor=0.25, solver="pdas",
                             segment=(-0.5, 0.5))
    write_table(with_provenance(pd.DataFrame([cols])), tmp_path / "r.csv")
    row = pd.read_csv(tmp_path / "r.csv").iloc[0]
    assert row.theta == 0.5 and row.tau_factor == 0.25 and row.solver == "pdas"
    assert json.loads(row.segment) == [-0.5, 0.5]
    # the options can be rebuilt from the row: nothing of them is lost
    back = {k[len("quadrature_"):]: (tuple(json.loads(v)) if isinstance(v, str) else v.item())
            for k, v in row.items() if k.startswith("quadrature_")}
    assert ff.QuadratureOptions(**back) == quad
    assert isinstance(row.git_commit, str)


def test_time_to_reach_interpolates_in_log_log():
    t = np.array([1.0, 10.0, 100.0])
    e = np.array([1e-1, 1e-2, 1e-3])
    assert time_to_reach(t, e, 1e-2) == pytest.approx(10.0)
    assert time_to_reach(t, e, 10 ** -1.5) == pytest.approx(10 ** 0.5)
    assert time_to_reach(t[::-1], e[::-1], 10 ** -2.5) == pytest.approx(10 ** 1.5)
    assert time_to_reach(t, e, 1.0) == 1.0                 # reached by the first run
    assert np.isnan(time_to_reach(t, e, 1e-4))             # never reached


def test_parabolic_pieces_are_the_steps_of_a_run(tmp_path):
    m = ff.disk_uniform(1)
    times = np.array([0.0, 0.25, 1.0])
    U = np.arange(3 * m.p.shape[1], dtype=float).reshape(3, -1)
    save_arrays(tmp_path / "run.npz", p=m.p, t=m.t, times=times, U=U)
    pieces, _ = parabolic_pieces(tmp_path / "run.npz")
    assert [(a, b) for a, b, _, _ in pieces] == [(0.0, 0.25), (0.25, 1.0)]
    np.testing.assert_array_equal(pieces[1][3], U[2])     # u on (t_1, t_2] is U[2]


def test_mismatched_parameters_reads_back_csv_cells(tmp_path):
    """A row written with parameter_columns and read back from CSV matches the same
    parameters (lists as JSON, ints as floats, quadrature fields) and names each change."""
    import json

    import pandas as pd

    import fracfem as ff
    from fracfem_workflow.runs import mismatched_parameters, parameter_columns
    expected = parameter_columns(quadrature=ff.QuadratureOptions(), theta=0.5, start_level=2,
                                 max_dofs=100000, tol=1e-10, operator="auto",
                                 data=json.dumps({"s": 0.5, "slope": 4.0}, sort_keys=True))
    pd.DataFrame([expected]).to_csv(tmp_path / "row.csv", index=False)
    row = pd.read_csv(tmp_path / "row.csv").iloc[0].to_dict()
    assert mismatched_parameters(row, expected) == []
    changed = {**expected, "theta": 0.4, "operator": "dense",
               "quadrature_far_orders": json.dumps([0, 2, 4]),
               "data": json.dumps({"s": 0.4, "slope": 4.0}, sort_keys=True)}
    assert sorted(mismatched_parameters(row, changed)) == sorted(
        ["theta", "operator", "quadrature_far_orders", "data"])
    assert mismatched_parameters({k: v for k, v in row.items() if k != "tol"},
                                 expected) == ["tol"]


def test_a_saved_reference_operator_measures_as_the_assembled_one(tmp_path):
    """The reference's operator assembled once and read back (para_reference_operator) gives
    the same distances as assembling it in the job; one made for another quadrature, or
    whose product has changed, is refused."""
    import pickle

    from fracfem_workflow.runs import (load_reference_operator, save_reference_operator,
                                       stored_reference)
    m = ff.disk_uniform(2)
    rng = np.random.default_rng(0)
    times = np.array([0.0, 0.5, 1.0])
    U = rng.standard_normal((3, m.p.shape[1]))
    save_arrays(tmp_path / "ref.npz", p=m.p, t=m.t, times=times, U=U, s=0.5)
    quad = ff.QuadratureOptions()
    save_reference_operator(tmp_path / "ref.npz", quad, tmp_path / "A.pkl")
    run = [(0.0, 1.0, ff.disk_uniform(1), np.ones(ff.disk_uniform(1).p.shape[1]))]
    fresh, _ = stored_reference(tmp_path / "ref.npz", quad)
    read, s = stored_reference(tmp_path / "ref.npz", quad, tmp_path / "A.pkl")
    assert s == 0.5 and read.distance(run) == pytest.approx(fresh.distance(run), rel=1e-13)
    pieces, _ = parabolic_pieces(tmp_path / "ref.npz")
    with pytest.raises(ValueError, match="another reference run or quadrature"):
        load_reference_operator(tmp_path / "A.pkl", pieces, 0.5, quad.raised())
    with pytest.raises(ValueError, match="another reference run or quadrature"):
        load_reference_operator(tmp_path / "A.pkl", pieces, 0.6, quad)
    data = pickle.loads((tmp_path / "A.pkl").read_bytes())
    data["check"] = (data["check"][0], 1.001 * data["check"][1])
    (tmp_path / "A.pkl").write_bytes(pickle.dumps(data))
    with pytest.raises(ValueError, match="product differs"):
        load_reference_operator(tmp_path / "A.pkl", pieces, 0.5, quad)


def test_a_saved_reference_family_measures_as_the_one_built_in_the_job(tmp_path):
    """save_reference_family's file, read by stored_family, gives the distances and
    extrapolated error of the family built in the job; one made from other runs, or whose
    distances have changed, is refused."""
    import pickle

    from fracfem_workflow.runs import family_error, save_reference_family, stored_family
    rng = np.random.default_rng(3)
    files = []
    for k, (level, n) in enumerate(((1, 2), (2, 3), (3, 4), (3, 6))):
        m = ff.disk_uniform(level)           # a converging family: u + 0.2^k (noise)
        times = np.linspace(0.0, 1.0, n + 1)
        U = (1.0 - (m.p ** 2).sum(0))[None, :] * (1.0 + times[:, None]) \
            + 0.2 ** k * rng.standard_normal((n + 1, m.p.shape[1]))
        U[:, m.boundary_nodes()] = 0.0
        files.append(tmp_path / f"run{len(files)}.npz")
        save_arrays(files[-1], p=m.p, t=m.t, times=times, U=U, s=0.5)
    ref, coarser, quad = files[-1], files[:-1], ff.QuadratureOptions()
    save_reference_family(ref, coarser, quad, None, tmp_path / "family.pkl")
    fresh, _ = stored_family(ref, coarser, quad)
    read, s = stored_family(ref, coarser, quad, saved=tmp_path / "family.pkl")
    run = [(0.0, 0.4, ff.disk_uniform(2), rng.standard_normal(ff.disk_uniform(2).p.shape[1])),
           (0.4, 1.0, ff.disk_uniform(2), np.zeros(ff.disk_uniform(2).p.shape[1]))]
    assert s == 0.5
    np.testing.assert_allclose(read.steps, fresh.steps, rtol=1e-13)
    np.testing.assert_allclose(read.distances(run), fresh.distances(run), rtol=1e-13)
    assert family_error(read, run) == pytest.approx(family_error(fresh, run), rel=1e-12,
                                                    nan_ok=True)
    with pytest.raises(ValueError, match="other runs or another quadrature"):
        stored_family(ref, coarser[1:], quad, saved=tmp_path / "family.pkl")
    with pytest.raises(ValueError, match="other runs or another quadrature"):
        stored_family(ref, coarser, quad.raised(), saved=tmp_path / "family.pkl")
    data = pickle.loads((tmp_path / "family.pkl").read_bytes())
    data["check"] = 1.001 * data["check"]
    (tmp_path / "family.pkl").write_bytes(pickle.dumps(data))
    with pytest.raises(ValueError, match="distances differ"):
        stored_family(ref, coarser, quad, saved=tmp_path / "family.pkl")


def test_atomic_write_removes_its_targets_stale_temporary_files(tmp_path):
    """A writer killed by SIGKILL leaves its temporary file; the next write of the same
    target removes it, and leaves those of other targets alone."""
    import pandas as pd

    from fracfem_workflow.io import write_table

    stale = tmp_path / ".tmp-x.csv-k1ll3d.csv"
    other = tmp_path / ".tmp-y.csv-run1ng.csv"
    stale.write_text("half a row")
    other.write_text("being written")
    write_table(pd.DataFrame({"a": [1]}), tmp_path / "x.csv")
    assert not stale.exists() and other.exists()
    assert pd.read_csv(tmp_path / "x.csv").a.tolist() == [1]
    assert sorted(p.name for p in tmp_path.iterdir()) == [".tmp-y.csv-run1ng.csv", "x.csv"]


def test_solved_pieces_reproduce_a_run_stored_by_para_solve(tmp_path):
    """A run solved again in a script (solved_pieces, as para_time_split and
    ex5_uniform_cause do) gives the pieces that para_solve stores for the same run: the
    same time intervals, the same mesh and the same u_k."""
    import importlib.util
    from pathlib import Path

    from fracfem.meshes import mesh_size
    from fracfem_workflow.runs import solved_pieces
    path = Path(__file__).parents[1] / "workflow" / "scripts" / "para_solve.py"
    spec = importlib.util.spec_from_file_location("para_solve", path)
    para_solve = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(para_solve)
    quad, data = {}, {"s": 0.5, "u0": 2.0}
    npz = tmp_path / "run.npz"
    para_solve.main("ex4-u2", "uniform", "L2", "ex4", data, 2.0, 0.3, 0.5, 1e-10, quad,
                    tmp_path / "row.csv", npz)
    stored, _ = parabolic_pieces(npz)
    prob = ff.example("ex4", **data).problem(ff.multiplier_mesh("L2", 2.0),
                                             ff.QuadratureOptions(**quad), operator="dense")
    times = ff.time_grid(T=0.3, tau=ff.time_step(mesh_size(prob.fine), 0.5, 0.5))
    again = solved_pieces(prob, ff.example("ex4", **data).initial_value, times, 1e-10)
    assert len(again) == len(stored) == len(times) - 1 >= 2
    for (a0, a1, am, au), (b0, b1, bm, bu) in zip(again, stored):
        assert (a0, a1) == pytest.approx((b0, b1), abs=1e-15)
        np.testing.assert_array_equal(am.p, bm.p)
        np.testing.assert_allclose(au, bu, rtol=0, atol=1e-13 * np.abs(bu).max())
