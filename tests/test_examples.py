"""The paper's example data (fracfem.examples) and the exact pure-slip energy."""
import numpy as np
import pytest

import fracfem as ff
from fracfem import examples, vi


def test_printed_example3_is_pure_slip_and_scaled_example1():
    # f ≡ 1 > F: λ_H = F everywhere and u_h = (1 − F) × Example 1's discrete solution
    coarse = ff.disk_uniform(2)
    prob, f = examples.example3(coarse, s=0.6, a=1.0, b=0.0, F=0.5)
    u, lam, _ = vi.solve(prob, "pdas", tol=1e-12)
    np.testing.assert_allclose(lam, 0.5, rtol=1e-10)
    disc = ff.discretise(prob.fine, 0.6, 1.0)
    u1 = disc.extend(ff.solve_laplace(disc))
    np.testing.assert_allclose(u, 0.5 * u1, atol=1e-12)
    # discrete energy −½(1−F)²(1, u_1h) lies above the exact one and approaches it
    E_h = -0.5 * 0.25 * float(disc.b @ u1[disc.free])
    E = examples.pure_slip_energy(0.6, 0.5)
    assert E < E_h < 0.9 * E
    assert E == pytest.approx(-0.5 * 0.25 * ff.disk_energy(0.6))


@pytest.mark.parametrize("F, a", [(1.0, 1.0), (-0.1, 1.0), (np.nan, 1.0)])
def test_pure_slip_energy_refuses_other_data(F, a):
    with pytest.raises(ValueError, match="pure slip"):
        examples.pure_slip_energy(0.5, F, a)


def test_ring_initial_value_has_the_right_signs():
    u0 = examples.ring_initial(0.6)
    x = np.array([[0.0, 0.3, 0.8, 1.0], [0.0, 0.0, 0.0, 0.0]])
    v = u0(x)
    assert v[0] == pytest.approx(0.6) and v[1] > 0 and v[2] < 0 and v[3] == 0
    with pytest.raises(ValueError, match="r0"):
        examples.ring_initial(1.5)
