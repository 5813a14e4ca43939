"""The examples built from their parameters and the meshes of series tags
(fracfem.problems)."""
import numpy as np
import pytest

import fracfem as ff
from fracfem import examples, problems, vi


@pytest.mark.parametrize("family, value, tag", [
    ("uniform", 3, "L3"), ("uniform", 3.0, "L3"), ("graded", 0.35, "h0.35"),
    ("graded", 0.20, "h0.2"), ("graded", 1e-5, "h1e-05"), ("graded-sr", 0.35, "r0.35"),
])
def test_tags_round_trip(family, value, tag):
    assert problems.series_tag(family, value) == tag
    assert problems.parse_series_tag(tag) == (family, value)


@pytest.mark.parametrize("tag", ["L", "L3.5", "h", "hx", "3", "Lh3", "h0.3 ", "r", "s0.3", None])
def test_bad_tags_are_refused(tag):
    with pytest.raises(ValueError, match="tag"):
        problems.parse_series_tag(tag)


@pytest.mark.parametrize("family, value", [("uniform", 2.5), ("uniform", -1),
                                           ("graded", 0.0), ("graded", np.nan),
                                           ("graded-sr", -0.1),
                                           ("adaptive", 1)])
def test_bad_series_members_are_refused(family, value):
    with pytest.raises(ValueError):
        problems.series_tag(family, value)


def same_mesh(a, b):
    return a.p.shape == b.p.shape and np.allclose(a.p, b.p) and np.array_equal(a.t, b.t)


def test_series_meshes_of_tags():
    assert same_mesh(problems.series_mesh("L3"), ff.disk_uniform(3))
    assert same_mesh(problems.series_mesh("h0.1", 2.0), ff.disk_graded_aniso(0.1, 2.0))
    assert same_mesh(problems.series_mesh("r0.35", 2.0), ff.disk_graded(0.35, 2.0))
    # mixed problems: the fine mesh of L3 is disk_uniform(3), T_H one level coarser
    coarse = problems.multiplier_mesh("L3")
    assert same_mesh(coarse, ff.disk_uniform(2))
    assert vi.fine_mesh(coarse).p.shape == ff.disk_uniform(3).p.shape
    assert same_mesh(problems.multiplier_mesh("r0.56", 3.0), ff.disk_graded(0.56, 3.0))
    assert same_mesh(problems.multiplier_mesh("h0.2", 3.0), ff.disk_graded_aniso(0.2, 3.0))
    with pytest.raises(ValueError, match="level >= 1"):
        problems.multiplier_mesh("L0")


def test_example_from_name_and_parameters():
    ex = problems.example("ex3", s=0.6, a=1.0, b=3.0, F=0.5)
    assert ex == problems.Example3(0.6, 1.0, 3.0, 0.5)
    with pytest.raises(ValueError, match="ex9"):
        problems.example("ex9")
    with pytest.raises(ValueError, match="'G'"):
        problems.example("ex5", s=0.6, G=0.1)


@pytest.mark.parametrize("name, params, word", [
    ("ex1", {"s": 1.5}, "s"), ("ex2", {"height": 1.0, "slope": 0.5}, "slope"),
    ("ex3", {"F": -1.0}, "F"), ("ex3", {"a": np.nan}, "a"), ("ex4", {"u0": np.inf}, "u0"),
    ("ex5", {"r0": 1.2}, "r0"), ("thin-obstacle", {"s": 0.5}, "s"),
    ("thin-friction", {"segment": (0.5, -0.5)}, "segment"),
])
def test_bad_example_data_fails_before_assembly(name, params, word):
    with pytest.raises(ValueError, match=word):
        problems.example(name, **params)


def test_exact_energies_where_known():
    assert problems.Example1(0.5).exact_energy == pytest.approx(-0.5 * ff.disk_energy(0.5))
    printed = problems.Example3(s=0.6, a=1.0, b=0.0, F=0.5)
    assert printed.exact_energy == pytest.approx(examples.pure_slip_energy(0.6, 0.5))
    assert problems.Example3(s=0.6, a=1.0, b=3.0, F=0.5).exact_energy is None
    assert problems.Example3(s=0.6, a=0.4, b=0.0, F=0.5).exact_energy is None  # sticks
    assert problems.Example2().exact_energy is None


def test_parabolic_examples_share_the_elliptic_obstacle():
    coarse = ff.disk_uniform(1)
    p2 = problems.Example2(s=0.5, height=1.0, slope=4.0).problem(coarse)
    p4 = problems.Example4(s=0.5, u0=2.0, height=1.0, slope=4.0).problem(coarse)
    assert p4.kind == "obstacle"
    np.testing.assert_allclose(p4.cset.g, p2.cset.g, rtol=1e-14)
    np.testing.assert_allclose(p4.disc.A, p2.disc.A, rtol=1e-14)
    assert np.all(p4.disc.b == 0) and np.all(p2.disc.b > 0)       # f = 0 against f = 1
    assert problems.Example4(u0=2.0).initial_value == 2.0


def test_example5_is_friction_everywhere_with_a_ring_initial_value():
    ex = problems.Example5(s=0.6, F=0.1, r0=0.6)
    prob = ex.problem(ff.disk_uniform(1))
    assert prob.kind == "friction" and np.all(prob.disc.b == 0)
    np.testing.assert_array_equal(prob.cset.upper, 0.1)
    u0 = ex.initial_value(np.array([[0.0, 0.8], [0.0, 0.0]]))
    assert u0[0] > 0 > u0[1]


def test_other_parabolic_data_reuse_the_operator_of_the_same_mesh():
    """problem(coarse, stiffness=disc) is the problem assembled afresh for the new data
    (the same operator, its own load and constraints); a disc of another mesh or s is
    refused, naming it."""
    coarse = problems.multiplier_mesh("L3")
    first = problems.Example5(s=0.6, F=0.1).problem(coarse)
    fresh = problems.Example5(s=0.6, F=0.0).problem(coarse)
    reused = problems.Example5(s=0.6, F=0.0).problem(coarse, stiffness=first.disc)
    assert reused.disc.A is first.disc.A
    np.testing.assert_allclose(reused.disc.A, fresh.disc.A, rtol=1e-13, atol=0)
    np.testing.assert_array_equal(reused.cset.upper, 0.0)
    obstacle = problems.Example4(s=0.6, u0=2.0).problem(coarse, stiffness=first.disc)
    assert obstacle.kind == "obstacle" and obstacle.disc.A is first.disc.A
    l1 = ff.disk_uniform(1)
    d1 = ff.discretise(l1, 0.6, 1.0)
    d2 = ff.discretise(l1, 0.6, 2.0, stiffness=d1)
    np.testing.assert_allclose(d2.b, 2 * d1.b, rtol=1e-14)
    with pytest.raises(ValueError, match="another mesh"):
        problems.Example5(s=0.6).problem(problems.multiplier_mesh("L2"), stiffness=first.disc)
    with pytest.raises(ValueError, match="s=0.6, not s=0.5"):
        problems.Example5(s=0.5).problem(coarse, stiffness=first.disc)
    with pytest.raises(ValueError, match="stiffness"):
        ff.discretise(l1, 0.6, stiffness=d1.A)


def test_example3_load_is_the_radial_load():
    ex = problems.Example3(a=1.0, b=3.0)
    x = np.array([[0.0, 1.0], [0.0, 0.0]])
    np.testing.assert_allclose(ex.f(x), [1.0, -2.0])
    prob = ex.problem(ff.disk_uniform(1))
    np.testing.assert_allclose(prob.disc.b, ff.load_vector(prob.fine, ex.f)[prob.disc.free])


@pytest.mark.parametrize("cls, kind", [(problems.ThinObstacleDemo, "thin_obstacle"),
                                       (problems.ThinFrictionDemo, "thin_friction")])
def test_thin_demos_put_multipliers_on_the_segment(cls, kind):
    prob = cls().problem(problems.multiplier_mesh("L3"))
    assert prob.kind == kind
    # Γ̃ = [−0.5, 0.5] × {0} of disk_uniform(2): its edges have length 0.25
    assert prob.edges.shape[1] == 4 == prob.cset.n_multipliers


@pytest.mark.parametrize("name, params", [("ex1", {}), ("ex2", {}), ("ex3", {"b": 3.0}),
                                          ("ex4", {"u0": 2.0}), ("ex5", {}),
                                          ("thin-obstacle", {}), ("thin-friction", {})])
def test_every_example_assembles_compressed_as_dense(name, params):
    """problem(mesh, operator='compressed') is the same problem with the
    stiffness matrix compressed: equal loads, and A x equal to the compression
    tolerance; a bad operator name is refused naming the parameter."""
    ex = ff.example(name, **params)
    mesh = ff.disk_uniform(3) if name == "ex1" else problems.multiplier_mesh("L4")
    dense = ex.problem(mesh)
    comp = ex.problem(mesh, operator="compressed")
    dd, dc = (dense, comp) if name == "ex1" else (dense.disc, comp.disc)
    assert dd.dense and not dc.dense
    np.testing.assert_array_equal(dc.b, dd.b)
    x = np.random.default_rng(1).standard_normal(dd.A.shape[0])
    assert np.linalg.norm(dc.A @ x - dd.A @ x) <= 1e-6 * np.linalg.norm(dd.A @ x)
    with pytest.raises(ValueError, match="operator"):
        ex.problem(mesh, operator="sparse")
