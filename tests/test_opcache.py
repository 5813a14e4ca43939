"""The operator cache (fracfem.opcache): a dense operator read back is the one assembly
gives, bit for bit; anything the matrix depends on changes the entry; a broken entry is
assembled again; without a directory nothing is written."""
import json

import numpy as np
import pytest

import fracfem as ff
from fracfem.opcache import ENV, cache_directory, free_block_in_place


@pytest.fixture
def mesh():
    return ff.disk_uniform(2)


def test_a_second_discretisation_reads_back_the_same_matrix(tmp_path, mesh, monkeypatch):
    monkeypatch.delenv(ENV, raising=False)
    fresh = ff.discretise(mesh, 0.5, 1.0)
    assert "cache" not in fresh.info
    with ff.operator_cache(tmp_path):
        first = ff.discretise(mesh, 0.5, 1.0)
        second = ff.discretise(mesh, 0.5, 0.0)          # other data, same operator
    assert (first.info["cache"], second.info["cache"]) == ("miss", "hit")
    np.testing.assert_array_equal(first.A, fresh.A)
    np.testing.assert_array_equal(second.A, fresh.A)
    np.testing.assert_array_equal(second.b, 0.0)
    # a hit reports what the assembly cost, and how long the read took
    assert second.timings["assembly"] == first.timings["assembly"] > 0
    assert "operator_load" in second.timings and "operator_load" not in first.timings
    assert len(list(tmp_path.glob("*.npy"))) == 1
    assert not list(tmp_path.glob(".tmp-*"))


def test_what_the_matrix_depends_on_changes_the_entry(tmp_path, mesh):
    moved = ff.disk_uniform(2)
    moved.p[:, mesh.interior_nodes()[0]] += 1e-3
    with ff.operator_cache(tmp_path):
        ff.discretise(mesh, 0.5)
        other = [ff.discretise(mesh, 0.6), ff.discretise(moved, 0.5),
                 ff.discretise(mesh, 0.5, quadrature=ff.QuadratureOptions(coincident=12))]
    assert [d.info["cache"] for d in other] == ["miss"] * 3
    assert len(list(tmp_path.glob("*.npy"))) == 4
    expected = ff.discretise(moved, 0.5)                 # outside the block: no cache
    np.testing.assert_array_equal(other[1].A, expected.A)


def test_a_broken_entry_is_assembled_again(tmp_path, mesh):
    with ff.operator_cache(tmp_path):
        good = ff.discretise(mesh, 0.5)
        entry = next(tmp_path.glob("*.npy"))
        entry.write_bytes(entry.read_bytes()[:100])      # truncated
        again = ff.discretise(mesh, 0.5)
        assert again.info["cache"] == "miss"
        np.testing.assert_array_equal(again.A, good.A)
        json_file = entry.with_suffix(".json")
        json_file.write_text(json.dumps({"shape": [3, 3]}))   # no seconds
        assert ff.discretise(mesh, 0.5).info["cache"] == "miss"
        assert ff.discretise(mesh, 0.5).info["cache"] == "hit"   # written whole again


def test_the_environment_turns_it_on_and_a_block_turns_it_off(tmp_path, mesh, monkeypatch):
    monkeypatch.setenv(ENV, str(tmp_path / "ops"))
    assert cache_directory() == tmp_path / "ops"
    ff.discretise(mesh, 0.5)
    assert len(list((tmp_path / "ops").glob("*.npy"))) == 1
    with ff.operator_cache(None):
        assert cache_directory() is None
        assert "cache" not in ff.discretise(mesh, 0.5).info
    monkeypatch.setenv(ENV, str(tmp_path / "ops" / next((tmp_path / "ops").glob("*.npy")).name))
    with pytest.raises(ValueError, match=f"{ENV}=.*must be a directory"):
        ff.discretise(mesh, 0.5)


def test_bad_input_is_refused_before_the_cache_is_read(tmp_path, mesh):
    with ff.operator_cache(tmp_path):
        ff.discretise(mesh, 0.5)
        with pytest.raises(ValueError, match="s="):
            ff.discretise(mesh, "0.5")
        with pytest.raises(ValueError, match="quadrature=.*QuadratureOptions"):
            ff.discretise(mesh, 0.5, quadrature={"coincident": 12})


def test_equal_quadrature_written_otherwise_is_one_entry(tmp_path, mesh):
    """8 and 8.0, a tuple and a list, a numpy integer: the same options, the same entry."""
    default = ff.QuadratureOptions()
    same = ff.QuadratureOptions(coincident=np.int64(default.coincident),
                                far_thresholds=[int(x) for x in default.far_thresholds])
    with ff.operator_cache(tmp_path):
        ff.discretise(mesh, 0.5, quadrature=default)
        assert ff.discretise(mesh, 0.5, quadrature=same).info["cache"] == "hit"


def test_a_cache_that_cannot_be_written_costs_the_reuse_only(tmp_path, mesh):
    blocked = tmp_path / "file"
    blocked.write_text("")
    with ff.operator_cache(blocked / "ops"):           # its parent is a file: mkdir fails
        d = ff.discretise(mesh, 0.5)
    assert d.info["cache"] == "miss"
    np.testing.assert_array_equal(d.A, ff.discretise(mesh, 0.5).A)


def test_the_number_of_chunks_is_part_of_the_entry(tmp_path, mesh):
    import numba
    if numba.config.NUMBA_NUM_THREADS < 2:
        pytest.skip("one numba thread only")
    before = numba.get_num_threads()
    try:
        with ff.operator_cache(tmp_path):
            numba.set_num_threads(1)
            ff.discretise(mesh, 0.5)
            numba.set_num_threads(2)
            assert ff.discretise(mesh, 0.5).info["cache"] == "miss"
    finally:
        numba.set_num_threads(before)


def test_a_matrix_too_large_is_refused_also_when_the_cache_holds_it(tmp_path, mesh,
                                                                    monkeypatch):
    with ff.operator_cache(tmp_path):
        ff.discretise(mesh, 0.5)
        monkeypatch.setenv("FRACFEM_MEMORY_LIMIT", "16K")
        with pytest.raises(ff.DenseMemoryError, match="FRACFEM_MEMORY_LIMIT"):
            ff.discretise(mesh, 0.5)


@pytest.mark.parametrize("free", [[0, 1, 2, 3, 4, 5, 6], [0, 1, 2, 5, 6], [1, 3, 4, 6], [6], [0],
                                  []])
def test_the_free_block_is_taken_in_place(free):
    rng = np.random.default_rng(len(free))
    A = rng.standard_normal((7, 7))
    want = A[np.ix_(free, free)].copy()
    Af = free_block_in_place(A, free)
    assert np.array_equal(Af, want)
    assert Af is A and Af.flags.c_contiguous and Af.flags.owndata    # no second matrix
    assert Af.nbytes == 8 * len(free) ** 2                               # and no more


@pytest.mark.parametrize("free,what", [([2, 1], "ascending"), ([1, 1], "ascending"),
                                       ([0, 7], r"\[0, 7\)"), ([-1, 2], r"\[0, 7\)")])
def test_the_free_block_refuses_bad_indices(free, what):
    with pytest.raises(ValueError, match=what):
        free_block_in_place(np.zeros((7, 7)), free)
    with pytest.raises(ValueError, match="integer indices, not bool"):
        free_block_in_place(np.zeros((7, 7)), [False, True])
    for A in (np.zeros((7, 6)), np.zeros(7), np.asfortranarray(np.ones((7, 7))[:, ::-1]),
              np.zeros((8, 8))[:7, :7], np.zeros((7, 7)).T):
        with pytest.raises(ValueError, match="square C-contiguous array that owns its data"):
            free_block_in_place(A, [0])
