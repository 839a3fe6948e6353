"""Front probe: clusters linked within link_distance, whatever the step's neighbour radius."""

import pytest

from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario_text

# two blocks whose nearest particles are 3 l0 apart (x = 0.115 and 0.145 m), every kernel radius
# 2.1 l0 and no viscosity: the step's neighbour list holds pairs within 2.1 l0 only
SCENE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.01
viscosity = 0.0
[fluid.kernel]
re_density = 2.1
re_gradient = 2.1
re_laplacian = 2.1
re_pressure = 2.1
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.12, 0.05]
[[fluid.blocks]]
lower = [0.14, 0.0]
upper = [0.2, 0.05]
[[fluid.walls]]
shape = "tank"
lower = [0.0, 0.0]
upper = [0.5, 0.2]
[[probes]]
name = "front"
kind = "front"
link_distance = {link}
min_cluster_fraction = 0.6
"""


@pytest.mark.parametrize("link, front", [(2.0, 0.12), (3.5, 0.2)])
def test_front_links_clusters_beyond_the_step_neighbour_radius(link, front):
    """The second block (30 particles, half the first's 60) counts only when linked to the
    first, 3 l0 away: at link_distance 3.5 l0, beyond the step's list radius 2.1 l0 (before: the
    probe read the step's list, missed the pairs and returned the first block's edge, 0.12 m)."""
    sc = load_scenario_text(SCENE.format(link=link)).scenario
    s = FluidSolver(sc.fluid)
    assert s.search_radius == pytest.approx(0.021)
    assert s.probe_value(sc.probes[0]) == pytest.approx(front, abs=1e-12)
