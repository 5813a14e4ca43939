"""Tests for fracfem.meshes."""

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from skfem import MeshTri

from fracfem.meshes import (
    disk_graded_aniso,
    disk_graded_rings,
    disk_uniform,
    interior_nodes,
    lshape,
    mesh_from_arrays,
    mesh_size,
    min_angle,
    refine_disk,
    square,
    validate_mesh,
)


def signed_areas(m):
    p, t = m.p, m.t
    e1, e2 = p[:, t[1]] - p[:, t[0]], p[:, t[2]] - p[:, t[0]]
    return 0.5 * (e1[0] * e2[1] - e1[1] * e2[0])


def boundary_radii(m):
    return np.linalg.norm(m.p[:, m.boundary_nodes()], axis=0)


def assert_conforming_disk(m, tol=1e-14):
    """Every interior edge has two triangles; the boundary is one closed polygon on the circle."""
    f2t = m.f2t
    assert np.all(f2t[0] >= 0)
    bfacets = np.flatnonzero(f2t[1] < 0)
    # each triangle has 3 edges: 3 Nt = 2 * interior + boundary
    assert 3 * m.t.shape[1] == 2 * (m.facets.shape[1] - bfacets.size) + bfacets.size
    # Euler characteristic of a disk
    assert m.p.shape[1] - m.facets.shape[1] + m.t.shape[1] == 1
    edges = m.facets[:, bfacets]
    nodes, deg = np.unique(edges, return_counts=True)
    assert np.all(deg == 2)
    on_circle = np.flatnonzero(np.abs(np.linalg.norm(m.p, axis=0) - 1) <= tol)
    np.testing.assert_array_equal(nodes, on_circle)
    # walk the boundary polygon: a single cycle through all boundary edges
    nbrs = {v: [] for v in nodes.tolist()}
    for a, b in edges.T.tolist():
        nbrs[a].append(b)
        nbrs[b].append(a)
    start = prev = int(nodes[0])
    cur, steps = nbrs[start][0], 1
    while cur != start:
        nxt = nbrs[cur][0] if nbrs[cur][0] != prev else nbrs[cur][1]
        prev, cur, steps = cur, nxt, steps + 1
        assert steps <= edges.shape[1]
    assert steps == edges.shape[1]


# ---------------------------------------------------------------- disk_uniform

@pytest.mark.parametrize("level", range(1, 7))
def test_disk_uniform_counts(level):
    m = disk_uniform(level)
    assert m.t.shape[1] == 4 ** (level + 1)
    assert m.p.shape[1] == 2 * 4**level + 2**(level + 1) + 1
    ref = MeshTri.init_circle(level)
    np.testing.assert_array_equal(m.p, ref.p)
    np.testing.assert_array_equal(m.t, ref.t)
    assert np.all(np.abs(boundary_radii(m) - 1) <= 1e-14)
    assert_conforming_disk(m)


def test_disk_uniform_level6():
    m = disk_uniform(6)
    assert m.t.shape[1] == 16384
    idx = interior_nodes(m)
    assert idx.size == 8065 and idx.dtype == np.int64
    assert np.all(np.diff(idx) > 0)


def test_disk_area_converges_from_below():
    areas = [np.abs(signed_areas(disk_uniform(k))).sum() for k in range(1, 7)]
    assert np.all(np.diff(areas) > 0) and areas[-1] < np.pi
    err = np.pi - np.array(areas)
    assert err[-1] < 1e-3
    np.testing.assert_allclose(err[1:] / err[:-1], 0.25, rtol=0.05)
    g = [np.abs(signed_areas(disk_graded_rings(n))).sum() for n in (4, 8, 16, 32)]
    assert np.all(np.diff(g) > 0) and g[-1] < np.pi and np.pi - g[-1] < 1e-3


@pytest.mark.parametrize("bad", [0, 10, -1, 2.0, "3", True, None])
def test_disk_uniform_rejects(bad):
    with pytest.raises(ValueError, match=r"level.*\[1, 9\]"):
        disk_uniform(bad)


# ----------------------------------------------------------------- disk_graded_rings

@pytest.mark.parametrize("n", [2, 3, 5, 8, 17])
@pytest.mark.parametrize("grading", [1.0, 1.5, 2.0, 3.0])
def test_disk_graded_valid(n, grading):
    m = disk_graded_rings(n, grading)
    validate_mesh(m.p, m.t)
    assert np.all(signed_areas(m) > 0)
    assert np.all(np.abs(boundary_radii(m) - 1) <= 1e-14)
    assert_conforming_disk(m)
    # boundary layer: innermost ring off the circle is at distance n**(-grading)
    r = np.linalg.norm(m.p[:, interior_nodes(m)], axis=0)
    np.testing.assert_allclose(1 - r.max(), (1 / n) ** grading, rtol=1e-6)
    # ring radii are 1 - (1 - k/n)**grading
    radii = np.unique(np.round(np.linalg.norm(m.p, axis=0), 12))
    expected = 1 - (1 - np.arange(n + 1) / n) ** grading
    np.testing.assert_allclose(radii, expected, atol=1e-11)


def test_disk_graded_angles():
    for n in (4, 8, 16, 32):
        assert min_angle(disk_graded_rings(n, 1.0)) > 15
    assert min_angle(disk_graded_rings(16, 2.0)) < 5
    assert min_angle(disk_graded_rings(32, 2.0)) < min_angle(disk_graded_rings(16, 2.0))


def test_disk_graded_max_angle_in_layer():
    """The boundary layer is tensor-like: no flat (near 180 degree) triangles."""
    m = disk_graded_rings(32, 2.0)
    p, t = m.p, m.t
    cosines = []
    for i in range(3):
        u, v = p[:, t[(i + 1) % 3]] - p[:, t[i]], p[:, t[(i + 2) % 3]] - p[:, t[i]]
        cosines.append((u * v).sum(0) / np.linalg.norm(u, axis=0) / np.linalg.norm(v, axis=0))
    assert np.degrees(np.arccos(np.min(cosines))) < 120


@pytest.mark.parametrize("grading", [1.0, 2.0, 3.0])
def test_disk_graded_dofs_grow_like_n2(grading):
    nv = [disk_graded_rings(n, grading).p.shape[1] for n in (8, 16, 32, 64)]
    ratios = np.array(nv[1:]) / np.array(nv[:-1])
    assert np.all(np.abs(ratios - 4) < 0.35)
    assert abs(ratios[-1] - 4) < 0.1


def test_disk_graded_h_and_grading_one_is_quasi_uniform():
    for n in (8, 16, 32):
        m = disk_graded_rings(n, 1.0)
        assert 1 / n < mesh_size(m) < 2 / n
        assert min_angle(m) > 25


@pytest.mark.parametrize("kwargs, match", [
    ({"n": 1}, r"n .*\[2, 2000\]"),
    ({"n": 2001}, r"n .*\[2, 2000\]"),
    ({"n": 4.0}, r"n .*\[2, 2000\]"),
    ({"n": 4, "grading": 0.5}, r"grading.*\[1.0, 10.0\]"),
    ({"n": 4, "grading": 11.0}, r"grading.*\[1.0, 10.0\]"),
    ({"n": 4, "grading": float("nan")}, r"grading.*nan"),
    ({"n": 4, "grading": float("inf")}, r"grading"),
    ({"n": 4, "grading": "2"}, r"grading"),
    ({"n": 100, "grading": 10.0}, r"n=100 with grading=10"),
])
def test_disk_graded_rejects(kwargs, match):
    with pytest.raises(ValueError, match=match):
        disk_graded_rings(**kwargs)


@pytest.mark.parametrize("n, grading, layer", [(2, 1.0, 0.25), (8, 2.0, 1e-6), (8, 4.0, 1e-10),
                                               (12, 3.0, 1e-4)])
def test_disk_graded_layer_splits_only_the_outer_layer(n, grading, layer):
    """One more ring at radius 1 - layer with the boundary ring's nodes; all else unchanged."""
    plain = disk_graded_rings(n, grading)
    m = disk_graded_rings(n, grading, layer=layer)
    validate_mesh(m.p, m.t)
    assert np.all(signed_areas(m) > 0)
    assert_conforming_disk(m)
    nb = len(plain.boundary_nodes())
    assert m.p.shape[1] == plain.p.shape[1] + nb
    assert m.t.shape[1] == plain.t.shape[1] + 2 * nb
    # the plain mesh's nodes come first, in the same places
    np.testing.assert_array_equal(m.p[:, :plain.p.shape[1] - nb], plain.p[:, :-nb])
    r = np.linalg.norm(m.p[:, interior_nodes(m)], axis=0)
    np.testing.assert_allclose(1 - r.max(), layer, rtol=1e-5)
    new = np.abs(np.linalg.norm(m.p, axis=0) - (1 - layer)) < 0.1 * layer
    assert new.sum() == nb
    np.testing.assert_allclose(np.sort(np.arctan2(m.p[1, new], m.p[0, new]) % (2 * np.pi)),
                               2 * np.pi * np.arange(nb) / nb, atol=1e-12)


@pytest.mark.parametrize("layer, match", [
    (1e-11, r"layer .*\[1e-10, 0.0078125\]"),
    (0.01, r"layer .*\[1e-10, 0.0078125\]"),
    (float("nan"), r"layer .*nan"),
    ("1e-6", r"layer"),
    (True, r"layer"),
])
def test_disk_graded_layer_rejects(layer, match):
    with pytest.raises(ValueError, match=match):
        disk_graded_rings(8, 2.0, layer=layer)


# ------------------------------------------------------------ disk_graded_aniso


@pytest.mark.parametrize("grading", [1.0, 2.0, 3.0])
def test_disk_graded_aniso_dofs_quadruple_as_h_halves(grading):
    """N ~ h^-2 without a logarithmic factor: each halving of h multiplies the
    number of interior nodes by 4 within 10 % (measured 4.05–4.22)."""
    nint = [len(disk_graded_aniso(h, grading).interior_nodes()) for h in (1 / 8, 1 / 16, 1 / 32)]
    ratios = np.array(nint[1:]) / np.array(nint[:-1])
    assert np.all(np.abs(ratios / 4.0 - 1.0) < 0.1), ratios


@pytest.mark.parametrize("h, grading", [(1 / 8, 2.0), (1 / 16, 2.0), (1 / 10, 3.0), (0.3, 4.0)])
def test_disk_graded_aniso_is_valid_and_anisotropically_graded(h, grading):
    m = disk_graded_aniso(h, grading)
    validate_mesh(m.p, m.t)
    n = int(np.ceil(1 / h - 1e-9))
    r = np.unique(np.round(np.linalg.norm(m.p, axis=0), 12))
    width = np.diff(r)
    # thinnest layer at the circle: n^-grading, and layers thin out toward it
    assert width.min() == pytest.approx(float(n) ** -grading, rel=1e-9)
    assert width[-1] == width.min()
    # tangential size ~ h on the circle
    b = m.boundary_nodes()
    assert 2 * np.pi / len(b) == pytest.approx(h, rel=0.2)
    # so the elements at the circle have aspect ratio ~ h^(1 - grading)
    if grading > 1:
        assert min_angle(m) < 90 * float(n) ** (1 - grading)


@pytest.mark.parametrize("kwargs, match", [
    ({"h": 0.6}, r"h .*\[0.0005, 0.5\].*0.6"),
    ({"h": 0.0}, r"h .*\[0.0005, 0.5\]"),
    ({"h": 0.1, "grading": 0.5}, r"grading .*\[1.0, 4.0\].*0.5"),
    ({"h": 0.1, "grading": 4.5}, r"grading .*\[1.0, 4.0\].*4.5"),
    ({"h": 0.001, "grading": 4.0}, r"h=0.001 with grading=4"),
])
def test_disk_graded_aniso_rejects(kwargs, match):
    with pytest.raises(ValueError, match=match):
        disk_graded_aniso(**kwargs)


@pytest.mark.parametrize("h, n", [(0.4, 3), (0.25, 4), (0.14, 8), (0.1, 10), (0.07, 15),
                                  (0.05, 20), (1 / 3, 3)])
def test_graded_ring_count_names_the_rings_mesh_of_h(h, n):
    """disk_graded_aniso(h) is disk_graded_rings(ceil(1/h)); h = 1/n exactly keeps n."""
    from fracfem.meshes import disk_graded_rings, graded_ring_count
    assert graded_ring_count(h) == n
    a, b = disk_graded_aniso(h), disk_graded_rings(n)
    assert np.array_equal(a.p, b.p) and np.array_equal(a.t, b.t)


def test_graded_ring_count_rejects_h_outside_its_range():
    from fracfem.meshes import graded_ring_count
    with pytest.raises(ValueError, match=r"h .*\[0.0005, 0.5\].*0.7"):
        graded_ring_count(0.7)


def test_triangle_areas_of_either_orientation_sum_to_the_domain():
    from fracfem.meshes import triangle_areas
    m = square(3)
    assert triangle_areas(m.p, m.t).sum() == pytest.approx(4.0)
    flipped = m.t[[0, 2, 1]]
    assert np.array_equal(triangle_areas(m.p, flipped), triangle_areas(m.p, m.t))
    assert triangle_areas(m.p, m.t) == pytest.approx(np.abs(signed_areas(m)))


# ------------------------------------------------------------ square / lshape

@pytest.mark.parametrize("n", [1, 2, 7])
def test_square(n):
    m = square(n)
    assert m.t.shape[1] == 2 * n * n and m.p.shape[1] == (n + 1) ** 2
    assert np.all(signed_areas(m) > 0)
    assert np.isclose(signed_areas(m).sum(), 4.0)
    np.testing.assert_allclose(m.p.min(axis=1), -1)
    np.testing.assert_allclose(m.p.max(axis=1), 1)
    assert np.isclose(mesh_size(m), 2 * np.sqrt(2) / n)
    assert np.isclose(min_angle(m), 45)


@pytest.mark.parametrize("level", [0, 1, 3])
def test_lshape(level):
    m = lshape(level)
    assert m.t.shape[1] == 6 * 4**level
    a = signed_areas(m)
    assert np.all(a > 0) and np.isclose(a.sum(), 3.0)
    c = m.p[:, m.t].mean(axis=1)
    assert not np.any((c[0] > 0) & (c[1] < 0)), "lower right quadrant must be cut out"
    assert np.any((c[0] > 0) & (c[1] > 0)) and np.any((c[0] < 0) & (c[1] < 0))
    validate_mesh(m.p, m.t)


@pytest.mark.parametrize("func, bad", [(square, 0), (square, 2.5), (lshape, -1), (lshape, 10)])
def test_square_lshape_reject(func, bad):
    name = "n" if func is square else "level"
    with pytest.raises(ValueError, match=rf"{name} must be an integer"):
        func(bad)


# ---------------------------------------------------------------- refine_disk

def point_triangle_distance(x, tri):
    """Distance from points x (2, N) to triangles tri (2, 3, N); 0 inside."""
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    l1 = ((x[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (x[1] - a[1])) / det
    l2 = ((b[0] - a[0]) * (x[1] - a[1]) - (x[0] - a[0]) * (b[1] - a[1])) / det
    inside = (l1 >= -1e-12) & (l2 >= -1e-12) & (1 - l1 - l2 >= -1e-12)
    dist = np.full(x.shape[1], np.inf)
    for u, v in ((a, b), (b, c), (c, a)):
        s = np.clip(((x - u) * (v - u)).sum(0) / ((v - u) ** 2).sum(0), 0, 1)
        dist = np.minimum(dist, np.linalg.norm(x - (u + s * (v - u)), axis=0))
    return np.where(inside, 0.0, dist)


@pytest.mark.parametrize("coarse", [disk_uniform(2), disk_graded_rings(6, 2.0)],
                         ids=["uniform", "graded"])
def test_refine_disk_uniform(coarse):
    p0, t0 = coarse.p.copy(), coarse.t.copy()
    fine = refine_disk(coarse)
    np.testing.assert_array_equal(coarse.p, p0)
    np.testing.assert_array_equal(coarse.t, t0)
    nc = t0.shape[1]
    assert fine.t.shape[1] == 4 * nc
    np.testing.assert_array_equal(fine.p[:, :p0.shape[1]], p0)
    assert np.all(np.abs(boundary_radii(fine) - 1) <= 1e-14)
    assert_conforming_disk(fine)
    validate_mesh(fine.p, fine.t)
    centroids = fine.p[:, fine.t].mean(axis=1)
    parent = np.arange(fine.t.shape[1]) % nc
    d = point_triangle_distance(centroids, p0[:, t0[:, parent]])
    assert d.max() < 1e-2
    bnd_elems = np.isin(fine.t, fine.boundary_nodes()).any(axis=0)
    assert np.all(d[~bnd_elems] == 0)
    assert np.abs(signed_areas(fine)).sum() > np.abs(signed_areas(coarse)).sum()  # bulged out


def test_refine_disk_matches_init_circle():
    m = refine_disk(refine_disk(disk_uniform(1)))
    ref = disk_uniform(3)
    np.testing.assert_allclose(m.p, ref.p, atol=1e-15)
    np.testing.assert_array_equal(m.t, ref.t)


@pytest.mark.parametrize("mask", [False, True])
def test_refine_disk_local(mask):
    coarse = disk_uniform(3)
    r = np.linalg.norm(coarse.p[:, coarse.t].mean(axis=1), axis=0)
    marked = r > 0.7  # a subset touching the boundary
    fine = refine_disk(coarse, marked if mask else np.flatnonzero(marked))
    assert coarse.t.shape[1] < fine.t.shape[1] < 4 * coarse.t.shape[1]
    b = boundary_radii(fine)
    assert np.all(np.abs(b - 1) <= 1e-14) and b.size > coarse.boundary_nodes().size
    assert_conforming_disk(fine)
    validate_mesh(fine.p, fine.t)
    area = np.abs(signed_areas(fine)).sum()
    assert np.abs(signed_areas(coarse)).sum() < area < np.pi


@pytest.mark.parametrize("marked", [[-1], [10**6], [[0, 1]], np.zeros(3, bool), [0.5]])
def test_refine_disk_rejects_bad_marked(marked):
    with pytest.raises(ValueError, match="marked"):
        refine_disk(disk_uniform(1), marked)


# -------------------------------------------------------------- validate_mesh

def good():
    m = disk_graded_rings(4, 2.0)
    return m.p.copy(), m.t.copy()


def test_validate_accepts_good_meshes():
    for m in (disk_uniform(3), disk_graded_rings(5), square(3), lshape(1)):
        validate_mesh(m.p, m.t)
    p = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    validate_mesh(p, np.array([[0], [1], [2]]))
    validate_mesh(p * 1e-8, np.array([[0], [2], [1]], dtype=np.int32))  # small scale, CW


def test_validate_rejects_p_shape():
    p, t = good()
    with pytest.raises(ValueError, match=r"p must be .*shape \(2, Nv\)"):
        validate_mesh(p.T, t)
    with pytest.raises(ValueError, match=r"p must be a float array"):
        validate_mesh(p.astype(int), t)


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_validate_rejects_nonfinite(value):
    p, t = good()
    p[1, 7] = value
    with pytest.raises(ValueError, match=r"p has NaN/inf coordinates at nodes \[7\]"):
        validate_mesh(p, t)


def test_validate_rejects_t_dtype_and_shape():
    p, t = good()
    with pytest.raises(ValueError, match=r"t must be an integer array"):
        validate_mesh(p, t.astype(float))
    with pytest.raises(ValueError, match=r"t must be .*shape \(3, Nt\)"):
        validate_mesh(p, t.T)
    with pytest.raises(ValueError, match=r"t must be"):
        validate_mesh(p, t[:, :0])


def test_validate_rejects_out_of_range():
    p, t = good()
    t[2, 5] = p.shape[1]
    with pytest.raises(ValueError, match=r"t has node indices outside .* triangles \[5\]"):
        validate_mesh(p, t)
    t[2, 5] = -1
    with pytest.raises(ValueError, match=r"t has node indices outside"):
        validate_mesh(p, t)


def test_validate_rejects_duplicate_nodes():
    p, t = good()
    # node 3 duplicated; one triangle uses the copy, so the copy is not unused
    p = np.hstack([p, p[:, [3]] * (1 + 1e-16)])
    k = np.flatnonzero((t == 3).any(axis=0))[0]
    t[t[:, k] == 3, k] = p.shape[1] - 1
    with pytest.raises(ValueError, match=rf"p has duplicate nodes: \[3, {p.shape[1] - 1}\]"):
        validate_mesh(p, t)


def test_validate_rejects_unused_nodes():
    p, t = good()
    p = np.hstack([p, [[5.0], [5.0]]])
    with pytest.raises(ValueError, match=rf"p has unused nodes .*\[{p.shape[1] - 1}\]"):
        validate_mesh(p, t)


def test_validate_rejects_repeated_vertices():
    p, t = good()
    t[1, 4] = t[0, 4]
    with pytest.raises(ValueError, match=r"t has triangles with repeated vertices: \[4\]"):
        validate_mesh(p, t)


@pytest.mark.parametrize("eps", [0.0, 1e-16])
def test_validate_rejects_zero_area(eps):
    p = np.array([[0.0, 1.0, 0.0, 2.0], [0.0, 0.0, 1.0, eps]])
    t = np.array([[0, 0], [1, 1], [2, 3]])
    match = r"t has \(near-\)zero-area triangles \[1\].*triangle 1 has area"
    with pytest.raises(ValueError, match=match):
        validate_mesh(p, t)


def test_mesh_from_arrays_orients_ccw():
    m = disk_uniform(2)  # scikit-fem mixes orientations
    assert np.any(signed_areas(m) < 0)
    m2 = mesh_from_arrays(m.p, m.t)
    assert np.all(signed_areas(m2) > 0)
    np.testing.assert_array_equal(np.sort(m2.t, axis=0), np.sort(m.t, axis=0))
    with pytest.raises(ValueError, match="p has NaN"):
        mesh_from_arrays(np.full_like(m.p, np.nan), m.t)


def test_min_angle_and_mesh_size():
    m = mesh_from_arrays(np.array([[0.0, 2.0, 0.0], [0.0, 0.0, 2.0]]), np.array([[0], [1], [2]]))
    assert np.isclose(min_angle(m), 45.0) and np.isclose(mesh_size(m), 2 * np.sqrt(2))


# ------------------------------------------------------------ property tests

@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 12), grading=st.floats(1.0, 4.0))
def test_random_graded_meshes_are_valid(n, grading):
    m = disk_graded_rings(n, grading)
    validate_mesh(m.p, m.t)
    a = signed_areas(m)
    assert np.all(a > 0) and a.sum() < np.pi
    if n >= 8:
        assert abs(a.sum() - np.pi) < 0.02 * np.pi
    assert np.all(np.abs(boundary_radii(m) - 1) <= 1e-14)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(2, 8), grading=st.floats(1.0, 3.0),
       kind=st.sampled_from(["nan", "index", "dup"]), data=st.data())
def test_random_corruptions_rejected(n, grading, kind, data):
    m = disk_graded_rings(n, grading)
    p, t = m.p.copy(), m.t.copy()
    if kind == "nan":
        p[data.draw(st.integers(0, 1)), data.draw(st.integers(0, p.shape[1] - 1))] = np.nan
        match = "NaN"
    elif kind == "index":
        j = data.draw(st.integers(0, t.shape[1] - 1))
        i = data.draw(st.integers(0, 2))
        t[i, j] = data.draw(st.one_of(st.integers(p.shape[1], 10**6), st.integers(-10**6, -1)))
        match = "outside"
    else:
        k = data.draw(st.integers(0, p.shape[1] - 1))
        p = np.hstack([p, p[:, [k]]])
        match = "duplicate"
    with pytest.raises(ValueError, match=match):
        validate_mesh(p, t)
