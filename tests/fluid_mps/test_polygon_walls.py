"""Polygon walls (2D): particle layout along the faces, normals, fluid carving, and still water
against an inclined face (hydrostatic pressure rho g h)."""

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from mpsfem.fluid_mps.geometry import (
    build_particles,
    outline_distance,
    polygon_outline,
    polygon_wall,
    solid_box,
)
from mpsfem.fluid_mps.particle_kinds import FLUID, WALL
from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario_text

BETA = math.radians(30.0)
WEDGE = [
    [0.0, 0.0],
    [0.5, 0.5 * math.tan(BETA)],
    [0.5, 0.6],
    [-0.5, 0.6],
    [-0.5, 0.5 * math.tan(BETA)],
]
#: an L shape: one reflex corner at (0.5, 0.5)
ELL = [[0.0, 0.0], [1.0, 0.0], [1.0, 0.5], [0.5, 0.5], [0.5, 1.0], [0.0, 1.0]]


def _sorted(pts):
    return np.lexsort((np.round(pts[:, 1], 9), np.round(pts[:, 0], 9)))


@pytest.mark.parametrize("lo, hi", [((0.0, 0.0), (1.0, 0.6)), ((0.2, 0.3), (0.5, 1.0))])
def test_lattice_rectangle_is_a_box(lo, hi):
    """An axis-aligned rectangle with corners on the lattice lays exactly a box's particles,
    layers and pressure-layer normals (the thin one fills its core as the box does)."""
    verts = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]]
    p, layer, n = polygon_wall(verts, 0.1, 4)
    q, lq, nq = solid_box(lo, hi, 0.1, 4)
    a, b = _sorted(p), _sorted(q)
    assert len(p) == len(q)
    np.testing.assert_allclose(p[a], q[b], atol=1e-12)
    np.testing.assert_array_equal(layer[a], lq[b])
    wall = layer[a] == 0
    np.testing.assert_allclose(n[a][wall], nq[b][wall], atol=1e-12)


@pytest.mark.parametrize("verts", [WEDGE, WEDGE[::-1], ELL], ids=["wedge", "clockwise", "ell"])
def test_layers_spacing_and_no_duplicates(verts):
    """Layer m lies (m + 1/2) l0 inside the outline (pressure layer exactly, deeper layers within
    l0 / 4); no two particles closer than l0 / 2, none without a neighbour within 1.1 l0 (no
    gaps); along a face the pitch is within l0 (1 +- 1/(2 n)) of a face n spacings long."""
    l0, layers = 0.02, 5
    p, layer, _ = polygon_wall(verts, l0, layers)
    v = polygon_outline(verts)
    dist = outline_distance(p, v)
    assert set(np.unique(layer)) == set(range(layers))
    np.testing.assert_allclose(dist[layer == 0], 0.5 * l0, atol=1e-12)
    assert np.all(np.abs(dist - (layer + 0.5) * l0) <= 0.25 * l0 + 1e-12)
    d, _ = cKDTree(p).query(p, k=2)
    assert d[:, 1].min() >= 0.5 * l0
    assert d[:, 1].max() <= 1.1 * l0
    # pitch of the pressure layer along the first face (apex to knuckle for the wedge)
    a, b = v[0], v[1]
    t = (b - a) / np.linalg.norm(b - a)
    on = (layer == 0) & (np.abs((p - a) @ np.array([t[1], -t[0]]) + 0.5 * l0) < 1e-9)
    s = np.sort((p[on] - a) @ t)
    count = len(s) - 1
    assert np.all(np.abs(np.diff(s) / l0 - 1.0) <= 1.0 / (2 * count) + 1e-12)


def test_pressure_layer_normals_point_to_the_fluid():
    """Unit normals; on a face away from corners exactly the face's outward normal (the wedge's
    right face rises at beta, so its outward normal is (sin beta, -cos beta)); at the apex the
    bisector, straight down; a step of 0.6 l0 along any normal leaves the polygon."""
    l0 = 0.02
    p, layer, n = polygon_wall(WEDGE, l0, 5)
    w = layer == 0
    np.testing.assert_allclose(np.linalg.norm(n[w], axis=1), 1.0, atol=1e-12)
    right = w & (p[:, 0] > 2 * l0) & (p[:, 0] < 0.5 - 2 * l0) & (p[:, 1] < 0.25)
    assert right.sum() > 10
    np.testing.assert_allclose(n[right], [[math.sin(BETA), -math.cos(BETA)]] * right.sum())
    apex = w & (np.abs(p[:, 0]) < 1e-12)
    assert apex.sum() == 1
    np.testing.assert_allclose(n[apex], [[0.0, -1.0]], atol=1e-12)
    # every pressure particle's normal points out of the polygon: a step along it leaves
    out = p[w] + n[w] * 0.6 * l0
    assert np.all(outline_distance(out, polygon_outline(WEDGE)) < 0.5 * l0)


SCENE = """
[run]
end_time = {end}
[fluid]
spacing = 0.01
[fluid.time_step]
dt_max = 2e-3
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.4, 0.25]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [0.4, 0.4]
[[fluid.walls]]
name = "ramp"
shape = "polygon"
vertices = [[0.1, 0.05], [0.3, 0.05], [0.1, 0.15]]
"""


def test_fluid_carved_from_the_polygon():
    """No fluid particle inside the triangle or closer than l0 / 2 to its outline; the fluid
    next to the inclined face is kept (a particle within l0 of it)."""
    fluid = load_scenario_text(SCENE.format(end=0.1)).scenario.fluid
    ps = build_particles(fluid)
    f = ps.pos[ps.kind == FLUID]
    d = outline_distance(f, polygon_outline(fluid.walls[1].vertices))
    assert d.min() >= 0.5 * fluid.spacing * (1 - 1e-9)
    from mpsfem.fluid_mps.geometry import inside_polygon

    assert not inside_polygon(f, np.asarray(fluid.walls[1].vertices)).any()
    assert d.min() < fluid.spacing


def test_overlapping_polygon_is_refused():
    text = SCENE.format(end=0.1).replace("[0.1, 0.05], [0.3, 0.05]", "[0.1, -0.01], [0.3, 0.05]")
    fluid = load_scenario_text(text).scenario.fluid
    with pytest.raises(ValueError, match=r"fluid.walls\[1\] \(ramp\) and fluid.walls\[0\]"):
        build_particles(fluid)


def test_hydrostatic_pressure_on_an_inclined_face():
    """Still water 0.25 m deep over a submerged triangle whose upper face rises at 26.6 deg: over
    0.1-0.3 s the time-mean pressure of each pressure-layer particle of that face (2 l0 from its
    corners) is rho g (H - y) within 2 % of rho g H, the tolerance of the box tank's gauge test
    (tests/scenarios/test_hydrostatic.py; the rebuilt wall pressure adds the exact hydrostatic
    jump to its fluid neighbours, so only their pressure noise remains)."""
    sc = load_scenario_text(SCENE.format(end=0.3)).scenario
    solver = FluidSolver(sc.fluid)
    pt = solver.patch("ramp")
    idx = np.arange(pt.start, pt.stop)
    l0 = sc.fluid.spacing
    a, b = np.array([0.3, 0.05]), np.array([0.1, 0.15])
    t = (b - a) / np.linalg.norm(b - a)
    rel = solver.pos[idx] - a
    along, off = rel @ t, rel @ np.array([t[1], -t[0]])
    face = idx[
        (solver.kind[idx] == WALL)
        & (np.abs(off + 0.5 * l0) < 1e-9)
        & (along > 2 * l0)
        & (along < np.linalg.norm(b - a) - 2 * l0)
    ]
    assert len(face) >= 15
    acc = np.zeros(len(face))
    samples = 0
    while solver.t < sc.run.end_time - 1e-12:
        solver.step(solver.dt_towards(sc.run.end_time))
        if solver.t > 0.1:
            acc += solver.p[face]
            samples += 1
    rho_g = 1000.0 * 9.81
    expected = rho_g * (0.25 - solver.pos[face, 1])
    err = np.abs(acc / samples - expected) / (rho_g * 0.25)
    print(f"inclined face: {len(face)} particles, largest error {err.max() * 100:.2f} % rho g H")
    assert samples > 50
    assert err.max() < 0.02


def _wedge_study():
    import importlib.util
    import sys
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "validation" / "wedge_entry.py"
    spec = importlib.util.spec_from_file_location("wedge_entry", path)
    module = importlib.util.module_from_spec(spec)
    sys.modules["wedge_entry"] = module
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_wedge_force_against_wagner(tmp_path):
    """The 30 deg wedge of scenarios/wedge_entry_2d.toml at l0 = B / 20 (about 15 s): the force
    coefficient F / (rho V^3 t) from the impulse over c = 0.3-0.6 B lies between 0.7 and 1.0 of
    Wagner's pi^3 / (4 tan^2 beta) = 23.25. Wagner's linearised theory bounds the force from
    above (the nonlinear similarity solution's force is lower); the lower bound allows the 15-25 %
    that our three spacings read below it (docs/validation_water_entry.md). The face pressure's
    similarity peak lies at the spray root, 0.8 <= |x| / c <= 1.2."""
    study = _wedge_study()
    study.run_case(30, 20, out_dir=tmp_path)
    row = study.analyse(30, 20, out_dir=tmp_path)
    print({k: row[k] for k in ("cf_impulse", "cf_wagner", "cp_max", "xi_peak")})
    assert 0.7 <= row["cf_impulse"] / row["cf_wagner"] <= 1.0
    assert 0.8 <= row["xi_peak"] <= 1.2
