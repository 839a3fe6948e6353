"""Particle generation: lattice alignment of fluid and walls, layers, normals, hydrostatic start."""

import numpy as np

from mpsfem.fluid_mps.geometry import (
    build_particles,
    default_dummy_layers,
    hydrostatic_pressure,
    solid_box,
    tank_walls,
)
from mpsfem.fluid_mps.particle_kinds import DUMMY, FLUID, WALL
from mpsfem.scenario.loader import load_scenario_text

SCENE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.1
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [1.0, 0.5]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [2.0, 1.0]
"""


def test_tank_layers_and_normals():
    pts, layer, normal = tank_walls([0.0, 0.0], [1.0, 0.5], 0.1, 3)
    # floor spans x in (-0.3, 1.3) at y = -0.05 (pressure layer), side walls up to y = 0.5
    floor0 = pts[(layer == 0) & (pts[:, 1] < 0)]
    assert np.isclose(floor0[:, 1], -0.05).all()
    assert np.isclose(floor0[:, 0].min(), -0.05) and np.isclose(floor0[:, 0].max(), 1.05)
    assert len(pts) == 16 * 3 + 2 * 3 * 5  # floor rows (incl. corners) + two side walls
    assert layer.max() == 2
    # normals of the pressure layer point into the fluid
    mid = np.isclose(pts[:, 0], 0.55) & np.isclose(pts[:, 1], -0.05)
    np.testing.assert_allclose(normal[mid], [[0.0, 1.0]])
    left = np.isclose(pts[:, 0], -0.05) & np.isclose(pts[:, 1], 0.25)
    np.testing.assert_allclose(normal[left], [[1.0, 0.0]])
    corner = np.isclose(pts[:, 0], -0.05) & np.isclose(pts[:, 1], -0.05)
    np.testing.assert_allclose(normal[corner], [[np.sqrt(0.5), np.sqrt(0.5)]])


def test_solid_box_layers():
    pts, layer, normal = solid_box([0.0, 0.0], [1.0, 1.0], 0.1, 2)
    assert len(pts) == 100 - 36  # two layers of a 10 x 10 box
    assert (layer < 2).all()
    top = np.isclose(pts[:, 1], 0.95) & np.isclose(pts[:, 0], 0.45)
    np.testing.assert_allclose(normal[top], [[0.0, 1.0]])


def test_build_particles_counts_and_alignment():
    fluid = load_scenario_text(SCENE).scenario.fluid
    ps = build_particles(fluid)
    assert ps.n_fluid == 10 * 5
    assert (ps.kind[: ps.n_fluid] == FLUID).all()
    walls = ps.kind[ps.n_fluid :]
    assert set(np.unique(walls)) == {WALL, DUMMY}
    # every coordinate sits on the same half-offset lattice
    frac = (ps.pos / 0.1 - 0.5) % 1.0
    assert np.allclose(np.minimum(frac, 1 - frac), 0.0, atol=1e-9)
    assert default_dummy_layers(4.01) == 5
    assert ps.patches[0].name == "tank" and ps.patches[0].stop == len(ps.pos)


def test_hydrostatic_start():
    fluid = load_scenario_text(SCENE).scenario.fluid
    ps = build_particles(fluid)
    p = hydrostatic_pressure(ps.pos, ps.kind, np.array([0.0, -9.81]), 1000.0, 0.1)
    f = ps.kind == FLUID
    np.testing.assert_allclose(p[f], 1000 * 9.81 * (0.5 - ps.pos[f, 1]))
    assert (p[ps.kind == DUMMY] == 0).all()
    floor = (ps.kind == WALL) & np.isclose(ps.pos[:, 1], -0.05) & (ps.pos[:, 0] < 1.0)
    np.testing.assert_allclose(p[floor], 1000 * 9.81 * 0.55)
