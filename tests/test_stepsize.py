"""The time step rule τ = factor · h^{2s} (fracfem.stepsize)."""
import numpy as np
import pytest

from fracfem import parabolic
from fracfem.stepsize import time_step


def test_tau_halves_with_h_for_s_one_half():
    assert time_step(0.1, 0.5) == pytest.approx(0.5 * time_step(0.2, 0.5), rel=1e-14)
    assert time_step(0.2, 0.5) == pytest.approx(0.2, rel=1e-14)


@pytest.mark.parametrize("s", [0.1, 0.5, 0.6, 0.9])
def test_tau_scales_like_h_to_the_2s(s):
    # halving h divides τ by 2^{2s}; the factor enters linearly
    assert time_step(0.3, s) / time_step(0.15, s) == pytest.approx(2 ** (2 * s), rel=1e-13)
    assert time_step(0.3, s, 0.5) == pytest.approx(0.5 * time_step(0.3, s), rel=1e-15)


def test_tau_of_a_graded_mesh_gives_a_grid_no_coarser():
    tau = time_step(0.37, 0.6, 0.5)
    times = parabolic.time_grid(T=1.0, tau=tau)
    assert np.diff(times).max() <= tau * (1 + 1e-12)
    assert len(times) - 1 == int(np.ceil(1.0 / tau))


@pytest.mark.parametrize("kwargs, name", [
    ({"h_max": 0.0, "s": 0.5}, "h_max"), ({"h_max": np.nan, "s": 0.5}, "h_max"),
    ({"h_max": 0.1, "s": 1.2}, "s"), ({"h_max": 0.1, "s": 0.5, "factor": -1.0}, "factor"),
    ({"h_max": 0.1, "s": 0.5, "factor": np.inf}, "factor"),
])
def test_bad_arguments_are_named(kwargs, name):
    with pytest.raises(ValueError, match=name):
        time_step(**kwargs)
