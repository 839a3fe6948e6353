"""Particle generation: lattice alignment of fluid and walls, layers, normals, hydrostatic start."""

import numpy as np
import pytest
from scipy.spatial import cKDTree

from mpsfem.fluid_mps.geometry import (
    build_particles,
    compress_still_water,
    default_dummy_layers,
    hydrostatic_pressure,
    lattice_notes,
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


def test_compressed_start_compresses_each_layer_by_its_equilibrium_pressure():
    """Still water 0.5 m deep compressed with k = 2e-5 1/Pa: each column keeps its bottom and
    its particles; its top drops by D - D', D' = (sqrt(1 + 2 a D) - 1) / a (a = k rho g), a D^2
    / 2 (1 - a D) to O((a D)^2); the starting pressure stays linear in height, rho g (H' - h)
    (MPS's momentum equation carries the reference density), and every pair of neighbouring
    layers is compressed by 1 + k p at its mid-height; the floor carries the compressed
    column. The top is read as the highest particle plus l0/2, an O(a l0^2) error in p."""
    k, rho, g, H, l0 = 2e-5, 1000.0, 9.81, 0.5, 0.1
    fluid = load_scenario_text(SCENE).scenario.fluid
    ps = build_particles(fluid)
    f = ps.kind == FLUID
    old = ps.pos.copy()
    gravity = np.array([0.0, -g])
    drop = compress_still_water(ps.pos, ps.kind, gravity, rho, l0, k)
    a = k * rho * g
    assert drop == pytest.approx(H - (np.sqrt(1 + 2 * a * H) - 1) / a, rel=1e-12)
    assert drop == pytest.approx(a * H**2 / 2 * (1 - a * H), rel=2 * (a * H) ** 2)
    np.testing.assert_array_equal(ps.pos[~f], old[~f])  # walls stay
    np.testing.assert_array_equal(ps.pos[f, 0], old[f, 0])  # only heights change
    assert ps.pos[f, 1].min() < old[f, 1].min()  # the bottom layer too, towards the floor
    top = H - drop
    p = hydrostatic_pressure(ps.pos, ps.kind, gravity, rho, l0)
    np.testing.assert_allclose(
        p[f], rho * g * (top - ps.pos[f, 1]), rtol=0, atol=rho * g * a * l0**2
    )
    col = f & np.isclose(old[:, 0], 0.05)
    y = np.sort(ps.pos[col, 1])
    p_mid = rho * g * (top - 0.5 * (y[1:] + y[:-1]))
    np.testing.assert_allclose(np.diff(y), l0 / (1 + k * p_mid), rtol=1e-12)
    floor = (ps.kind == WALL) & np.isclose(ps.pos[:, 1], -0.05) & (ps.pos[:, 0] < 1.0)
    np.testing.assert_allclose(p[floor], rho * g * (top + 0.05), rtol=0, atol=rho * g * a * l0**2)
    # k = 0: nothing moves
    ps0 = build_particles(fluid)
    assert compress_still_water(ps0.pos, ps0.kind, gravity, rho, l0, 0.0) == 0.0
    np.testing.assert_array_equal(ps0.pos, old)


# spacing 0.1: the tank's left wall at -0.263 l0 off the fluid's lattice, a paddle 1.7368 l0
# thick whose face x = 0 touches the water, a deck 0.38 l0 off the lattice above the water, and
# a second block off the lattice by 0.3 l0
OFF_LATTICE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.1
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [1.0, 0.5]
[[fluid.blocks]]
lower = [0.53, 0.0]
upper = [1.53, 0.3]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [-0.17368, 0.0]
upper = [2.0, 1.0]
[[fluid.walls]]
name = "paddle"
shape = "box"
lower = [-0.17368, 0.0]
upper = [0.0, 0.8]
[[fluid.walls]]
name = "deck"
shape = "box"
lower = [1.138, 0.638]
upper = [1.75, 0.85]
"""


def test_walls_line_up_with_the_fluid_lattice_at_their_wetted_face():
    """A paddle whose fluid-side face is on the lattice has its pressure layer half a spacing
    behind that face, a whole spacing from the first fluid particle, whatever its thickness
    (before: the box's lattice started at its lower corner, 0.737 l0 from the water)."""
    fluid = load_scenario_text(OFF_LATTICE).scenario.fluid
    ps = build_particles(fluid)
    l0 = 0.1
    fluid_pos = ps.pos[ps.kind == FLUID]
    # every fluid particle, of both blocks, on the first block's lattice; the second block's
    # corners moved to it (0.53 -> 0.5) and overlapping sites kept once
    frac = (fluid_pos / l0 - 0.5) % 1.0
    assert np.allclose(np.minimum(frac, 1 - frac), 0.0, atol=1e-9)
    assert ps.n_fluid == 10 * 5 + 5 * 3
    paddle = ps.patches[1]
    ppos, pkind = ps.pos[paddle.start : paddle.stop], ps.kind[paddle.start : paddle.stop]
    face = ppos[pkind == WALL]
    assert np.isclose(face[:, 0].max(), -0.5 * l0, atol=1e-12)  # half a spacing behind x = 0
    assert np.isclose(ppos[:, 0].min(), -1.5 * l0, atol=1e-12)  # 2 cells: lower face -> -0.2
    d, _ = cKDTree(ps.pos[ps.kind == WALL]).query(fluid_pos)
    assert d.min() >= l0 * (1.0 - 1e-9)
    # a face off the lattice on both sides keeps the nearer one as given: the deck's bottom
    deck = ps.patches[2]
    dpos = ps.pos[deck.start : deck.stop]
    assert np.isclose(dpos[:, 1].min(), 0.638 + 0.5 * l0, atol=1e-12)
    assert np.isclose(dpos[:, 0].min(), 1.138 + 0.5 * l0, atol=1e-12)
    # the tank keeps its floor and the face nearer the lattice (right wall at x = 2.0)
    tank = ps.patches[0]
    tpos, tkind = ps.pos[tank.start : tank.stop], ps.kind[tank.start : tank.stop]
    layer0 = tpos[tkind == WALL]
    assert np.isclose(layer0[:, 0].max(), 2.0 + 0.5 * l0, atol=1e-12)
    assert np.isclose(layer0[:, 1].min(), -0.5 * l0, atol=1e-12)
    notes = lattice_notes(fluid)
    assert [n.split(":")[0] for n in notes] == [
        "fluid.blocks[1]",
        "fluid.walls[0] (tank)",
        "fluid.walls[1] (paddle)",
        "fluid.walls[2] (deck)",
    ]
    assert "filled as [-0.2, 0.0] .. [0.0, 0.8]" in notes[2]
    assert lattice_notes(load_scenario_text(SCENE).scenario.fluid) == []


def test_overlapping_walls_are_refused():
    """A box pushed into the tank's floor put wall particles on the floor's dummy sites (distance
    0: a singular kernel for the original weight); refused naming both walls."""
    box = """
[[fluid.walls]]
name = "step"
shape = "box"
lower = [1.2, -0.2]
upper = [1.6, 0.3]
"""
    fluid = load_scenario_text(SCENE + box).scenario.fluid
    with pytest.raises(
        ValueError, match=r"fluid.walls\[0\] \(tank\) and fluid.walls\[1\] \(step\)"
    ):
        build_particles(fluid)
    resting = box.replace("-0.2", "0.0")  # on the floor's face: allowed
    ps = build_particles(load_scenario_text(SCENE + resting).scenario.fluid)
    site = np.rint(ps.pos / 0.1 * 1e3).astype(np.int64)
    assert len(np.unique(site, axis=0)) == len(ps.pos)
