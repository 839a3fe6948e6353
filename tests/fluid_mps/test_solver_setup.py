"""Solver set-up: the first time step obeys the Courant and viscous limits like every other; a
domain whose neighbour grid would dwarf the particles is refused before anything is allocated."""

import pytest

from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario_text

SCENE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.01
[fluid.time_step]
courant = 0.2
dt_max = 1e-3
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.1, 0.05]
velocity = [{u}, 0.0]
[[fluid.walls]]
shape = "tank"
lower = [0.0, 0.0]
upper = [1.0, 0.2]
"""


def solver(u: float, *overrides: str) -> FluidSolver:
    return FluidSolver(load_scenario_text(SCENE.format(u=u), list(overrides)).scenario.fluid)


def test_first_step_obeys_the_courant_limit():
    """A block thrown at 10 m/s: C l0 / u = 0.2 * 0.01 / 10 = 2e-4 s, not dt_max = 1e-3 s
    (Courant number 1 on the first step, before the limit was applied to it)."""
    assert solver(10.0).dt_next == pytest.approx(2e-4, rel=1e-12)
    assert solver(10.0, "fluid.time_step.dt_initial=1e-4").dt_next == 1e-4  # below: kept
    assert solver(0.0).dt_next == 1e-3  # at rest: dt_max


def test_first_step_obeys_the_viscous_limit():
    """nu = 0.1 m^2/s: viscous number 0.2 gives 0.2 l0^2 / nu = 2e-4 s."""
    s = solver(0.0, "fluid.viscosity=0.1", "fluid.time_step.viscous_number=0.2")
    assert s.dt_next == pytest.approx(2e-4, rel=1e-12)


def test_a_domain_far_larger_than_the_scene_is_refused():
    """100 m x 100 m at l0 = 1 cm for 50 particles: 6.2e6 cells of 4.01 cm against a limit of
    64 per particle + 2^20; refused naming the keys (the grid's cell index alone: 50 MB)."""
    with pytest.raises(ValueError, match=r"fluid.domain_lower \.\. fluid.domain_upper") as err:
        solver(0.0, "fluid.domain_lower=[-50.0, -50.0]", "fluid.domain_upper=[50.0, 50.0]")
    assert "would hold 6.2" in str(err.value) and "allowed at most 64 per particle" in str(
        err.value
    )
    s = solver(0.0, "fluid.domain_lower=[-1.0, -1.0]", "fluid.domain_upper=[2.0, 2.0]")
    assert s.n > 0  # 3 m x 3 m: 2e4 cells, allowed
