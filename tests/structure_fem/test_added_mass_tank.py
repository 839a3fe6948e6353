"""The potential-flow added-mass operator of a plate forming a tank's bottom
(structure_fem.added_mass_tank; issue 21, task H1) against the closed form of the rectangular
tank (Faltinsen & Timokha 2009, Sloshing, ch. 5): m_0 = rho H for the lifted column, m_n =
rho tanh(k_n H) / k_n for the cosine mode k_n = n pi / W.

Tolerances from the discretisation's order: rigid heave is exact (every n >= 1 mode integrates
to zero over the bottom), a cosine mode interpolated at the nodes carries m_n (1 - (k_n h)^2 /
6 + O(h^4)) (piecewise-linear interpolation and hat-function projection, measured -1.63e-2 at
k h = pi / 10)."""

import numpy as np
import pytest
from scipy.integrate import trapezoid

from mpsfem.structure_fem.added_mass_tank import tank_bottom_added_mass, tank_mode_projections

RHO, W, H = 1000.0, 1.0, 2.0


def mode_error(elements: int, n: int, depth: float = H) -> float:
    """Relative error of cos(k_n x)'s added mass per unit area (Rayleigh quotient of the
    nodal interpolant over int cos^2 = W / 2) against rho tanh(k_n H) / k_n."""
    x = np.linspace(0.0, W, elements + 1)
    k = n * np.pi / W
    w = np.cos(k * x)
    got = w @ tank_bottom_added_mass(x, RHO, depth) @ w / (0.5 * W)
    return got / (RHO * np.tanh(k * depth) / k) - 1.0


@pytest.mark.parametrize("elements", [1, 7, 20])
def test_rigid_heave_lifts_the_whole_column(elements):
    """Sum of M_a = rho H W (kg per m of depth), to round-off, on uniform and graded meshes."""
    x = np.linspace(0.0, W, elements + 1) ** 1.3
    M = tank_bottom_added_mass(x, RHO, H)
    assert M.sum() == pytest.approx(RHO * H * x[-1], rel=1e-12)


@pytest.mark.parametrize(("n", "depth"), [(1, H), (2, H), (3, 0.1), (4, 0.3)])
def test_cosine_mode_carries_its_closed_form_added_mass_at_second_order(n, depth):
    """Error within 5 % of -(k h)^2 / 6 on 20 elements, and four times smaller on 40 (the
    shallow depths make tanh(k H) < 1 matter)."""
    h = W / 20
    expected = -((n * np.pi / W * h) ** 2) / 6.0
    e20, e40 = mode_error(20, n, depth), mode_error(40, n, depth)
    assert e20 == pytest.approx(expected, rel=5e-2)
    assert np.log2(e20 / e40) == pytest.approx(2.0, abs=0.05)


def test_clamped_first_mode_matches_the_rayleigh_estimate():
    """sin^2(pi x / W) = 1/2 - cos(2 pi x / W) / 2: m_a = rho (2H/3 + W tanh(2 pi H / W) /
    (6 pi)) = 1386 kg/m^2 (benchmarks/bench_coupling_stress.plate_added_mass); on the plate's
    20 elements within the interpolation error of the cosine part (1e-3 here)."""
    x = np.linspace(0.0, W, 21)
    w = np.sin(np.pi * x / W) ** 2
    got = w @ tank_bottom_added_mass(x, RHO, H) @ w / (3.0 * W / 8.0)
    exact = RHO * (2.0 * H / 3.0 + W * np.tanh(2.0 * np.pi * H / W) / (6.0 * np.pi))
    assert got == pytest.approx(exact, rel=1e-3)


def test_symmetric_positive_definite_and_truncation_converged():
    x = np.linspace(0.0, W, 21)
    M = tank_bottom_added_mass(x, RHO, H)
    assert np.allclose(M, M.T, rtol=0, atol=1e-12 * np.abs(M).max())
    assert np.linalg.eigvalsh(M).min() > 0.0
    more = tank_bottom_added_mass(x, RHO, H, modes=4 * 200 * 20)
    assert np.abs(M - more).max() < 1e-9 * M.diagonal().max()


def test_projections_are_exact():
    """g_ni against a fine trapezoidal quadrature of the hat functions times cos(k_n x)."""
    x = np.array([0.0, 0.1, 0.35, 0.5, 1.0])
    k = np.array([0.0, 3.0, 17.0])
    xs = np.linspace(0.0, 1.0, 200001)
    hats = np.array([np.interp(xs, x, np.eye(x.size)[i]) for i in range(x.size)])
    ref = trapezoid(hats[None] * np.cos(k[:, None, None] * xs), xs, axis=2)
    assert np.allclose(tank_mode_projections(x, k), ref, rtol=0, atol=1e-9)


def test_bad_input_names_the_value():
    x = np.linspace(0.0, W, 5)
    with pytest.raises(ValueError, match="depth"):
        tank_bottom_added_mass(x, RHO, 0.0)
    with pytest.raises(ValueError, match="density"):
        tank_bottom_added_mass(x, -1.0, H)
    with pytest.raises(ValueError, match="increasing"):
        tank_bottom_added_mass(x[::-1], RHO, H)
