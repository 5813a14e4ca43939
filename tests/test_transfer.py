"""Point location and interpolation between meshes (fracfem.transfer)."""
import numpy as np
import pytest

from fracfem import disk_graded, disk_uniform, refine_disk
from fracfem.transfer import (interpolate, interpolate_at, interpolation_matrix, locate,
                              transfer)


def test_linear_functions_are_reproduced_inside():
    coarse, fine = disk_uniform(2), disk_graded(0.3)
    u = 1.0 + 2.0 * coarse.p[0] - 3.0 * coarse.p[1]
    v = interpolate(coarse, u, fine)
    elem, _ = locate(coarse, fine.p)
    inside = elem >= 0
    # disk_uniform(2)'s polygon contains the disk of radius cos(π/16) > 0.98
    assert np.all(inside[np.hypot(*fine.p) < 0.98])
    np.testing.assert_allclose(v[inside], 1 + 2 * fine.p[0, inside] - 3 * fine.p[1, inside],
                               atol=1e-12)
    assert np.all(v[~inside] == 0.0)


def test_nested_meshes_carry_p1_functions_exactly():
    # interior nodes of the refinement lie in the coarse polygon: P1 is reproduced
    coarse = disk_uniform(2)
    fine = refine_disk(coarse)
    rng = np.random.default_rng(0)
    u = rng.standard_normal(coarse.p.shape[1])
    u[coarse.boundary_nodes()] = 0.0
    v = interpolate(coarse, u, fine)
    np.testing.assert_allclose(v[: coarse.p.shape[1]], u, atol=1e-12)
    # midpoints of interior coarse edges: the mean of the two ends
    E = interpolation_matrix(coarse, fine.p)
    assert np.allclose(E.sum(axis=1).A1[fine.interior_nodes()], 1.0)


def test_points_outside_get_zero_and_bad_points_raise():
    mesh = disk_uniform(1)
    elem, bary = locate(mesh, np.array([[2.0, 0.0], [0.0, 0.0]]))
    assert elem[0] == -1 and elem[1] >= 0
    assert bary[1].sum() == pytest.approx(1.0)
    with pytest.raises(ValueError, match="points"):
        locate(mesh, np.array([[np.nan], [0.0]]))
    with pytest.raises(ValueError, match="one value per node"):
        interpolate(mesh, np.zeros(3), mesh)


def test_space_time_distance_is_exact_for_piecewise_constant_functions():
    from fracfem import discretise
    from fracfem.transfer import space_time_distance

    mesh = disk_uniform(2)
    disc = discretise(mesh, 0.5)
    rng = np.random.default_rng(1)
    u1, u2, w = (disc.extend(rng.standard_normal(len(disc.free))) for _ in range(3))
    A, fr = disc.A, disc.free
    # pieces: u1 on (0, 0.3], u2 on (0.3, 1]; reference: w on (0, 1], same mesh
    d = space_time_distance([(0, 0.3, mesh, u1), (0.3, 1.0, mesh, u2)],
                            [(0.0, 0.5, mesh, w), (0.5, 1.0, mesh, w)], A, fr)
    e1, e2 = (u1 - w)[fr], (u2 - w)[fr]
    assert d == pytest.approx(np.sqrt(0.3 * e1 @ A @ e1 + 0.7 * e2 @ A @ e2), rel=1e-12)
    assert space_time_distance([(0, 1, mesh, w)], [(0, 1, mesh, w)], A, fr) == 0.0
    with pytest.raises(ValueError, match="time intervals"):
        space_time_distance([(0, 0.5, mesh, w)], [(0, 1, mesh, w)], A, fr)


def _direct_distance(pieces, reference, A, free):
    """The slow reference of SpaceTimeReference: e and A e formed on every interval of
    the union time grid."""
    ref_mesh = reference[0][2]
    ta = np.array([pieces[0][0]] + [pc[1] for pc in pieces])
    tb = np.array([reference[0][0]] + [pc[1] for pc in reference])
    grid = np.union1d(ta, tb)
    total = 0.0
    for a, b in zip(grid[:-1], grid[1:]):
        i = np.searchsorted(ta, 0.5 * (a + b)) - 1
        j = np.searchsorted(tb, 0.5 * (a + b)) - 1
        e = interpolate(pieces[i][2], pieces[i][3], ref_mesh)[free] - reference[j][3][free]
        total += (b - a) * e @ (A @ e)
    return np.sqrt(total)


@pytest.mark.parametrize("operator", ["dense", "compressed"])
def test_space_time_reference_matches_the_direct_sum_and_applies_A_once_per_piece(operator):
    from fracfem import discretise
    from fracfem.transfer import SpaceTimeReference

    ref_mesh, coarse = disk_uniform(3), disk_uniform(2)
    other = refine_disk(coarse, np.arange(0, coarse.t.shape[1], 2))
    disc = discretise(ref_mesh, 0.5, operator=operator)
    rng = np.random.default_rng(3)
    ref_t = np.linspace(0, 1, 8)                   # 7 reference pieces
    reference = [(a, b, ref_mesh, disc.extend(rng.standard_normal(len(disc.free))))
                 for a, b in zip(ref_t[:-1], ref_t[1:])]

    def run(mesh, edges):
        vals = [rng.standard_normal(mesh.p.shape[1]) for _ in edges[1:]]
        for v in vals:
            v[mesh.boundary_nodes()] = 0.0
        return [(a, b, mesh, v) for a, b, v in zip(edges[:-1], edges[1:], vals)]

    # a coarse run on 3 steps, then one on two meshes (time slabs) with 5 steps
    runs = [run(coarse, np.linspace(0, 1, 4)),
            run(coarse, [0, 0.2, 0.45]) + run(other, [0.45, 0.7, 0.8, 1.0])]
    ref = SpaceTimeReference(reference, disc.A, disc.free)
    for k, pieces in enumerate(runs):
        d = ref.distance(pieces)
        assert d == pytest.approx(_direct_distance(pieces, reference, disc.A, disc.free),
                                  rel=1e-10)
        # A: once per reference piece (kept) and once per run piece
        assert ref.matvecs == 7 + sum(len(r) for r in runs[:k + 1])
    assert ref.distance(reference) < 1e-12 * d   # interpolation at its own nodes


def test_space_time_distance_refuses_gaps_and_mixed_reference_meshes():
    from fracfem import discretise
    from fracfem.transfer import space_time_distance

    mesh, other = disk_uniform(2), disk_uniform(1)
    disc = discretise(mesh, 0.5)
    w = np.zeros(mesh.p.shape[1])
    v = np.zeros(other.p.shape[1])
    with pytest.raises(ValueError, match="contiguous"):
        space_time_distance([(0, 0.4, mesh, w), (0.5, 1.0, mesh, w)], [(0, 1, mesh, w)],
                            disc.A, disc.free)
    with pytest.raises(ValueError, match="one mesh"):
        space_time_distance([(0, 1, mesh, w)], [(0, 0.5, mesh, w), (0.5, 1, other, v)],
                            disc.A, disc.free)


def test_transfer_is_exact_for_p1_on_a_refinement_and_zero_outside():
    coarse = disk_uniform(2)
    fine = refine_disk(coarse, np.arange(0, coarse.t.shape[1], 3))
    lin = lambda x: 0.3 + x[0] - 2 * x[1]  # noqa: E731
    vals = interpolate_at(coarse, lin(coarse.p), fine.p[:, :coarse.p.shape[1]])
    np.testing.assert_allclose(vals, lin(coarse.p), atol=1e-13)
    inside = np.linalg.norm(fine.p, axis=0) < 0.9
    vals = interpolate_at(coarse, lin(coarse.p), fine.p[:, inside])
    np.testing.assert_allclose(vals, lin(fine.p[:, inside]), atol=1e-13)
    el, _ = locate(coarse, np.array([[2.0, 0.0], [0.0, 0.999]]).T)
    assert el[0] == -1                                     # outside the disk
    u = transfer(coarse, lin(coarse.p), fine)
    assert np.all(u[fine.boundary_nodes()] == 0.0)


def _a_orthonormal(vectors, A):
    """Gram–Schmidt in the inner product x·A y."""
    out = []
    for v in vectors:
        for q in out:
            v = v - (q @ A @ v) * q
        out.append(v / np.sqrt(v @ A @ v))
    return out


def test_reference_family_recovers_the_distance_to_the_limit_of_an_asymptotic_family():
    """u_k = r^k (w + z_k), limit 0: the members' errors are not aligned with one another
    (z_k mutually a-orthogonal), but ‖u_k‖ ∝ r^k and v's angle with them stays fixed; the
    extrapolated distance is ‖v‖ to round-off, while the finest member is off by more."""
    from fracfem import discretise
    from fracfem.transfer import ReferenceFamily

    mesh = disk_uniform(2)
    disc = discretise(mesh, 0.5)
    A = disc.A
    rng = np.random.default_rng(7)
    w, z1, z2, z3, z4, y = _a_orthonormal(
        [rng.standard_normal(len(disc.free)) for _ in range(6)], A)
    v = 0.3 * w + 0.8 * y                        # a-orthogonal to every z_k
    r = 0.6
    members = [[(0.0, 1.0, mesh, disc.extend(r ** k * (0.7 * w + 0.5 * z)))]
               for k, z in enumerate((z1, z2, z3, z4), start=1)]
    fam = ReferenceFamily(members, A, disc.free)
    exact = np.sqrt(v @ A @ v)
    out = fam.error([(0.0, 1.0, mesh, disc.extend(v))], leave_out_shared=False)
    assert fam.steps[1] / fam.steps[0] == pytest.approx(r, rel=1e-12)
    assert out["error"] == pytest.approx(exact, rel=1e-10)
    # the two extrapolations agree: the uncertainty is the correction to the finest distance
    assert abs(out["distances"][-1] - exact) > 1e-3 * exact
    assert out["uncertainty"] == pytest.approx(abs(out["distances"][-1] - exact), rel=1e-8)
    # three members: the same estimate, no uncertainty
    three = ReferenceFamily(members[1:], A, disc.free).error(
        [(0.0, 1.0, mesh, disc.extend(v))], leave_out_shared=False)
    assert three["error"] == pytest.approx(exact, rel=1e-10) and np.isnan(three["uncertainty"])
    # v on the members' own mesh: by default every member is left out, nothing measured
    shared = fam.error([(0.0, 1.0, mesh, disc.extend(v))])
    assert shared["left_out"] == [0, 1, 2, 3] and np.isnan(shared["error"])


def test_reference_family_distances_match_one_reference_per_member():
    """The one-pass distances to every member equal SpaceTimeReference's, one member at a
    time, measured on the finest member's mesh (coarser members interpolated onto it)."""
    from fracfem import discretise
    from fracfem.transfer import ReferenceFamily, SpaceTimeReference

    fine, mid, coarse = disk_uniform(3), disk_uniform(2), disk_uniform(1)
    disc = discretise(fine, 0.5)
    rng = np.random.default_rng(5)

    def run(mesh, edges):
        vals = [rng.standard_normal(mesh.p.shape[1]) for _ in edges[1:]]
        for x in vals:
            x[mesh.boundary_nodes()] = 0.0
        return [(a, b, mesh, x) for a, b, x in zip(edges[:-1], edges[1:], vals)]

    members = [run(coarse, [0, 0.5, 1]), run(mid, [0, 0.3, 0.6, 1]),
               run(fine, np.linspace(0, 1, 6))]
    fam = ReferenceFamily(members, disc.A, disc.free)
    pieces = run(mid, [0, 0.25, 0.7, 1])
    # the run on the middle member's mesh (a copy of it): that member is left out
    assert fam.shared_members(pieces) == [1]
    copy = type(mid)(mid.p.copy(), mid.t.copy())
    assert fam.shared_members([(a, b, copy, x) for a, b, _, x in pieces]) == [1]
    # the same triangles in another order, their vertices too (a mesh made by refinement
    # keeps its own order; one read back through MeshTri has each triangle's sorted)
    shuffled = type(mid)(mid.p.copy(), mid.t[[1, 2, 0]][:, ::-1].copy(), sort_t=False)
    assert not np.array_equal(shuffled.t, mid.t)
    assert fam.shared_members([(a, b, shuffled, x) for a, b, _, x in pieces]) == [1]
    other = type(mid)(mid.p.copy(), mid.t.copy(), sort_t=False)
    other.t[:, 0] = [other.t[0, 0], other.t[1, 0], other.t[1, 1]]   # one triangle changed
    assert fam.shared_members([(a, b, other, x) for a, b, _, x in pieces]) == []
    assert fam.shared_members(run(coarse, [0, 1])) == [0]
    assert fam.shared_members(run(refine_disk(mid, [0]), [0, 1])) == []
    assert fam.distances(members[-1])[-1] == 0.0      # the finest member to itself
    for k, m in enumerate(members):
        on_fine = [(a, b, fine, interpolate(mm, x, fine)) for a, b, mm, x in m]
        one = SpaceTimeReference(on_fine, disc.A, disc.free)
        assert fam.distances(pieces)[k] == pytest.approx(one.distance(pieces), rel=1e-10)
        if k:
            assert fam.steps[k - 1] == pytest.approx(
                one.distance([(a, b, fine, interpolate(mm, x, fine))
                              for a, b, mm, x in members[k - 1]]), rel=1e-10)


def test_extrapolated_distance_refuses_families_that_do_not_converge():
    from fracfem.transfer import extrapolated_distance

    with pytest.raises(RuntimeError, match="does not converge"):
        extrapolated_distance([0.3, 0.2, 0.1], [0.1, 0.12])
    with pytest.raises(ValueError, match="K >= 3"):
        extrapolated_distance([0.3, 0.2], [0.1])
    # a distance that the family's limit cannot have (e² < 0 at x = 0): no estimate
    assert np.isnan(extrapolated_distance([0.9, 0.5, 0.1], [0.5, 0.25])["error"])
    # a member left out: the three that remain, without uncertainty; two left: nothing
    e, d = [0.5, 0.4, 0.35, 0.33], [0.2, 0.1, 0.05]
    kept = extrapolated_distance(e, d, exclude=[2])
    x = np.array([0.2, 0.1, 0.05 ** 2 / 0.1])       # members 0, 1, 3: x_k = d_k, d_3²/d_2
    expected = np.sqrt(np.polyfit(x, np.array([0.5, 0.4, 0.33]) ** 2, 2)[-1])
    assert kept["error"] == pytest.approx(expected, rel=1e-12)
    assert np.isnan(kept["uncertainty"])
    assert np.isnan(extrapolated_distance(e, d, exclude=[0, 1])["error"])


def test_extrapolated_distance_uses_the_members_it_keeps():
    """Five members, not on a model: the estimate is the parabola in x_k through the three
    finest kept members and the uncertainty its change from the three kept before (no less
    than its correction), computed here with numpy.polyfit; a failing estimate before makes
    the uncertainty infinite."""
    from fracfem.transfer import extrapolated_distance

    e = np.array([0.61, 0.52, 0.47, 0.455, 0.449])
    d = np.array([0.3, 0.16, 0.09, 0.05])
    x = np.append(d, d[-1] ** 2 / d[-2])

    def at0(idx):
        return np.sqrt(np.polyfit(x[idx], e[idx] ** 2, 2)[-1])

    for exclude, last, before in (((), [2, 3, 4], [1, 2, 3]), ((3,), [1, 2, 4], [0, 1, 2]),
                                  ((4,), [1, 2, 3], [0, 1, 2])):
        out = extrapolated_distance(e, d, exclude=exclude)
        assert out["error"] == pytest.approx(at0(last), rel=1e-12)
        assert out["uncertainty"] == pytest.approx(
            max(abs(at0(last) - at0(before)), abs(at0(last) - e[last[-1]])), rel=1e-10)
    # the estimate through the three before has e² < 0: nothing confirms this one
    out = extrapolated_distance([0.9, 0.5, 0.1, 0.1], [0.5, 0.25, 0.125])
    assert np.isfinite(out["error"]) and out["uncertainty"] == np.inf


def test_slabwise_reference_takes_time_edges_rounded_near_a_slab_end():
    """A run whose time edges miss the reference's slab ends by round-off (5e-13 of T = 1,
    at a slab ending at 1e-4) is measured as the run with exact edges, not refused; a piece
    shorter than that which straddles a slab end counts for its length."""
    from skfem import MeshTri

    from fracfem import laplace
    from fracfem.transfer import SlabwiseReference

    m = disk_uniform(1)
    d = laplace.discretise(m, 0.5, 0.0)
    twin = MeshTri(m.p.copy(), m.t.copy())              # another slab's mesh object
    U = list(np.random.default_rng(0).standard_normal((4, m.p.shape[1])))
    ref = SlabwiseReference([(0.0, 1e-4, m, U[0]), (1e-4, 2e-4, twin, U[1]),
                             (2e-4, 1.0, m, U[0])], lambda mesh: (d.A, np.asarray(d.free)))

    def run(e1, e2=None):
        edges = [0.0, e1] + ([] if e2 is None else [e2]) + [2e-4, 1.0]
        return [(a, b, m, U[2 + k % 2]) for k, (a, b) in enumerate(zip(edges, edges[1:]))]

    exact = ref.distance(run(1e-4))
    assert ref.distance(run(1e-4 + 5e-13)) == pytest.approx(exact, rel=1e-7)
    # a 9e-13 piece across the slab end 1e-4, its neighbours as exact's pieces
    sliver = [(0.0, 1e-4 - 4e-13, m, U[2]), (1e-4 - 4e-13, 1e-4 + 5e-13, m, U[1]),
              (1e-4 + 5e-13, 2e-4, m, U[3]), (2e-4, 1.0, m, U[2])]
    assert ref.distance(sliver) == pytest.approx(exact, rel=1e-7)


@pytest.mark.parametrize("operator", ["dense", "compressed"])
def test_energy_distance_of_nested_galerkin_solutions_is_their_load_difference(operator):
    # V_c ⊂ V_f and Galerkin orthogonality: ‖u_f − u_c‖_a² = (f, u_f) − (f, u_c), up to the
    # quadrature's difference between the coarse and the fine matrix
    from skfem import MeshTri

    from fracfem import discretise, solve_laplace
    from fracfem.transfer import energy_distance

    coarse = MeshTri.init_sqsymmetric().refined(2)
    fine = coarse.refined(1)
    for s in (0.25, 0.75):
        dc, df = discretise(coarse, s), discretise(fine, s, operator=operator)
        uc, uf = dc.extend(solve_laplace(dc)), df.extend(solve_laplace(df))
        d = energy_distance(coarse, uc, (df, uf))
        assert d ** 2 == pytest.approx(df.b @ uf[df.free] - dc.b @ uc[dc.free], rel=1e-4)
        assert energy_distance(fine, uf, (df, uf)) < 1e-12 * d
    with pytest.raises(ValueError, match="u_ref must have one value per node"):
        energy_distance(coarse, uc, (df, uc))


def test_reference_refuses_an_operator_that_cannot_take_a_block_of_columns():
    """The reference's matrix is applied to a block of columns at once: an operator whose
    ``@`` flattens a block is refused by name, not summed into a wrong distance."""
    from fracfem import discretise
    from fracfem.transfer import SpaceTimeReference
    mesh = disk_uniform(2)
    disc = discretise(mesh, 0.5)
    u = np.zeros(mesh.p.shape[1])
    u[disc.free] = np.linspace(1.0, 2.0, len(disc.free))

    class Flat:
        def __matmul__(self, x):
            return (disc.A @ x).ravel()

    ref = SpaceTimeReference([(0.0, 0.5, mesh, u), (0.5, 1.0, mesh, 2 * u)], Flat(),
                             disc.free)
    with pytest.raises(ValueError, match="A_ref must map"):
        ref.distance([(0.0, 1.0, mesh, u)])
    good = SpaceTimeReference([(0.0, 0.5, mesh, u), (0.5, 1.0, mesh, 2 * u)], disc.A,
                              disc.free)
    # ‖u − u_ref‖ = ‖u‖_a on (0.5, 1) only
    a = np.sqrt(0.5 * u[disc.free] @ disc.A @ u[disc.free])
    assert good.distance([(0.0, 1.0, mesh, u)]) == pytest.approx(a, rel=1e-12)
