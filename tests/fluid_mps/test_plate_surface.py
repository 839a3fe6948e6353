"""3D plates as boundary particles of the MPS fluid, and nothing interacting through them.

References: the rectangle's geometry (frame, areas: each face h1 h2 per particle, the faces
summing to L1 L2), the linearised rigid rotation u = omega x r that the rigid link of a
Kirchhoff plate must reproduce exactly, a brute-force segment-through-rectangle test for the
neighbour filter, and the hydrostatic pressure rho g (H_side - z) on both sides of a plate one
spacing thick (the density radius 2.1 l0 and the pressure radius 4.01 l0 both reach across it),
with the partition's load rho g (H1^2 - H2^2) W / 2.
"""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.fluid_mps.neighbours import NeighbourSearch
from mpsfem.fluid_mps.participant import FluidParticipant
from mpsfem.fluid_mps.particle_kinds import FLUID
from mpsfem.fluid_mps.plate_surface import PlateSurface, plates_from_interface
from mpsfem.fluid_mps.solver import FluidRunError
from mpsfem.scenario.fluid import FluidSection

L0 = 0.01
RHO, G = 1000.0, 9.81
STEPS, DT = 20, 1e-3
#: pressure tolerance near the plate: the hydrostatic increment across half a spacing
P_TOL = 0.5 * RHO * G * L0


def plate_mesh(origin, axis_u, axis_v, size, divisions, thickness, triangles=False):
    """Interface mesh of a flat rectangular plate (structure_fem's conventions: nodes row by row
    along u, quads anticlockwise about n = u x v; or each quad split into two triangles)."""
    o, eu, ev = (np.asarray(a, float) for a in (origin, axis_u, axis_v))
    eu, ev = eu / np.linalg.norm(eu), ev / np.linalg.norm(ev)
    nu, nv = divisions
    uu, vv = np.meshgrid(np.linspace(0, size[0], nu + 1), np.linspace(0, size[1], nv + 1))
    pts = o + uu.ravel()[:, None] * eu + vv.ravel()[:, None] * ev
    idx = np.arange((nu + 1) * (nv + 1)).reshape(nv + 1, nu + 1)
    quads = np.c_[
        idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    ]
    nrm = np.tile(np.cross(eu, ev), (len(pts), 1))
    cells = (
        {"triangle": np.r_[quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]]}
        if triangles
        else {"quad": quads}
    )
    return InterfaceMesh(pts, nrm, cells, thickness)


def fluid_section(blocks, upper, **extra) -> FluidSection:
    return FluidSection.model_validate(
        {
            "dim": 3,
            "spacing": L0,
            "gravity": [0.0, 0.0, -G],
            "blocks": [{"lower": lo, "upper": hi} for lo, hi in blocks],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0, 0], "upper": upper}],
            **extra,
        }
    )


# ---------------------------------------------------------------------------- geometry
@pytest.mark.parametrize("triangles", [False, True])
def test_rectangle_is_recovered_from_its_mesh(triangles):
    eu = np.array([1.0, 0.0, 1.0]) / np.sqrt(2.0)
    ev = np.array([0.0, 1.0, 0.0])
    mesh = plate_mesh([0.1, 0.2, 0.3], eu, ev, (0.3, 0.2), (6, 4), 0.015, triangles)
    (p,) = plates_from_interface(mesh, ["deck"])
    assert p["name"] == "deck" and p["nodes"] == slice(0, 35)
    assert p["thickness"] == 0.015
    np.testing.assert_allclose(p["normal"], np.cross(eu, ev), atol=1e-12)
    np.testing.assert_allclose(np.cross(p["t1"], p["t2"]), p["normal"], atol=1e-12)
    assert sorted(p["size"]) == pytest.approx([0.2, 0.3], rel=1e-12)
    # every mesh point lies on the rectangle (origin, t1 L1, t2 L2)
    r = mesh.points - p["origin"]
    s1, s2 = r @ p["t1"], r @ p["t2"]
    assert s1.min() == pytest.approx(0, abs=1e-12) and s1.max() == pytest.approx(p["size"][0])
    assert s2.min() == pytest.approx(0, abs=1e-12) and s2.max() == pytest.approx(p["size"][1])


def test_non_rectangular_and_2d_meshes_are_refused():
    mesh = plate_mesh([0, 0, 0], [1, 0, 0], [0, 1, 0], (0.2, 0.2), (2, 2), 0.01)
    quads = mesh.cells["quad"][:3]  # an L-shaped outline
    l_shape = InterfaceMesh(mesh.points, mesh.normals, {"quad": quads}, 0.01)
    with pytest.raises(ValueError, match="rectangular plates only"):
        plates_from_interface(l_shape)
    beam = InterfaceMesh([[0, 0], [1, 0]], [[0, 1], [0, 1]], {"line": [[0, 1]]}, 0.01)
    with pytest.raises(ValueError, match="3D interface"):
        plates_from_interface(beam)


def shelf(size=(0.18, 0.06), thickness=L0, z=0.105):
    """A horizontal plate along x from the wall x = 0, across the tank's width (normal +z)."""
    return plate_mesh([0.0, 0.0, z], [1, 0, 0], [0, 1, 0], size, (6, 2), thickness)


def test_layout_areas_and_free_edges():
    fluid = fluid_section([([0, 0, 0], [0.25, 0.06, 0.2])], [0.25, 0.06, 0.3])
    surf = PlateSurface(shelf(), fluid, ["shelf"])
    (f,) = surf.frames
    # canonical frame: t1 = +x, t2 = +y for a horizontal plate with normal +z
    np.testing.assert_allclose([f.t1, f.t2, f.normal], np.eye(3), atol=1e-12)
    # only the edge at x = 0.18 is in the open (x = 0: wall; y = 0, 0.06: side walls)
    assert f.free == (False, True, False, False)
    assert f.edge_midpoints()[1][0] == pytest.approx(0.18)


def test_face_and_cap_areas_with_unequal_spacings():
    """A free-standing plate 0.18 x 0.055 m (h1 = l0, h2 = 0.055 / 6 != l0), 1.6 l0 thick:
    per side the face particles tile L1 L2, each edge's caps sum to (cap rows) x l0 x (edge
    length), corners take both; the area vectors of the closed body sum to zero."""
    fluid = fluid_section([([0, 0, 0], [0.25, 0.06, 0.2])], [0.25, 0.06, 0.3])
    T = 1.6 * L0
    mesh = plate_mesh([0.0, 0.0, 0.1], [1, 0, 0], [0, 1, 0], (0.18, 0.055), (6, 2), T)
    surf = PlateSurface(mesh, fluid, ["p"], free_edges=[(True,) * 4])
    (f,) = surf.frames
    cap_rows = 1  # rows whose depth (k + 1/2) l0 <= T/2: k = 0 only at T = 1.6 l0
    for sl in surf.sides:
        face = np.abs(sl.area @ f.normal) > 0
        assert np.abs(sl.area[face] @ f.normal).sum() == pytest.approx(0.18 * 0.055, rel=1e-12)
        for direction, edge_length in ((f.t1, 0.055), (-f.t1, 0.055), (f.t2, 0.18), (-f.t2, 0.18)):
            a = sl.area @ direction
            assert a[a > 0].sum() == pytest.approx(cap_rows * L0 * edge_length, rel=1e-12)
    total = sum(sl.area.sum(axis=0) for sl in surf.sides)
    np.testing.assert_allclose(total, 0.0, atol=1e-15)


def test_a_thick_plates_edge_caps_cover_the_whole_edge_face():
    """T = 12 l0 against 5 layers per side: the edge-cap columns reach the mid-plane, so each
    free edge is covered across its thickness, l0 apart (before: a 2 l0 hole in the middle), and
    the edge-face areas of both sides sum to T x edge length."""
    fluid = fluid_section([([0, 0, 0], [0.25, 0.06, 0.05])], [0.25, 0.06, 0.4])
    T = 12 * L0
    mesh = plate_mesh([0.0, 0.0, 0.2], [1, 0, 0], [0, 1, 0], (0.18, 0.06), (6, 2), T)
    surf = PlateSurface(mesh, fluid, ["p"], free_edges=[(True,) * 4])
    (f,) = surf.frames
    etas, edge_area = [], 0.0
    for sl in surf.sides:
        on_edge = (sl.area @ f.t1) > 0  # the free edge at x = 0.18
        etas.append((sl.pos[on_edge] - f.origin) @ f.normal)
        edge_area += (sl.area[on_edge] @ f.t1).sum()
    eta = np.unique(np.round(np.concatenate(etas), 12))
    assert eta[0] == pytest.approx(-0.055) and eta[-1] == pytest.approx(0.055)
    assert np.max(np.diff(eta)) == pytest.approx(L0)
    assert edge_area == pytest.approx(T * 0.06)


def test_mid_surface_height_field_is_exact_for_bilinear_deflection():
    """Plate particles moved by w = a + b s1 + c s2 + d s1 s2 along n: the column mid-points'
    height field (bilinear between them, edges extrapolated) gives w back everywhere on the
    rectangle, including the edge strips and corners."""
    from mpsfem.fluid_mps.thin_plate import _height

    fluid = fluid_section([([0, 0, 0], [0.25, 0.06, 0.2])], [0.25, 0.06, 0.3])
    mesh = plate_mesh([0.02, 0.0, 0.1], [1, 0, 0], [0, 1, 0], (0.15, 0.055), (5, 2), L0)
    fp = FluidParticipant(fluid, mesh, member_names=["p"])
    surf, s = fp.surface, fp.solver
    (f,) = surf.frames

    def w(s1, s2):
        return 1e-3 + 2e-2 * s1 - 3e-2 * s2 + 0.5 * s1 * s2

    r = s.pos[surf.index] - f.origin
    pos = s.pos.copy()
    pos[surf.index] += w(r @ f.t1, r @ f.t2)[:, None] * f.normal
    heights, hptr, grid = surf.mid_surface(pos)
    size = np.array([f.size])
    rng = np.random.default_rng(3)
    pts = rng.uniform(0, 1, size=(400, 2)) * f.size
    pts = np.vstack([pts, [[0, 0], [f.size[0], f.size[1]], [0, f.size[1]], [f.size[0], 0]]])
    got = [_height(0, a, b, size, grid, hptr, heights) for a, b in pts]
    np.testing.assert_allclose(got, w(pts[:, 0], pts[:, 1]), rtol=0, atol=1e-15)


def test_crossing_test_against_dense_sampling_on_a_curved_plate():
    """segment_crosses_plate on a plate bent by a half sine of amplitude 2 l0 (slopes up to
    0.4): for random segments with ends on opposite sides of the surface, the decision is that
    of 2000-point sampling of eta - eta_mid along the segment (segments whose sampled crossing
    is within 1e-3 l0 of the rectangle's boundary are skipped as ambiguous)."""
    from mpsfem.fluid_mps.thin_plate import _height, segment_crosses_plate

    L1, L2, n1, n2 = 0.1, 0.06, 10, 6
    h1, h2 = L1 / n1, L2 / n2
    nodes1 = np.r_[0.0, (np.arange(n1) + 0.5) * h1, L1]
    nodes2 = np.r_[0.0, (np.arange(n2) + 0.5) * h2, L2]
    hgt = 2 * L0 * np.sin(np.pi * nodes1 / L1)[:, None] * (1 + 0 * nodes2)[None, :]
    hgt += 0.3 * L0 * np.cos(np.pi * nodes2 / L2)[None, :]
    heights = np.ascontiguousarray(hgt.ravel())
    hptr = np.array([0, heights.size])
    grid = np.array([[n1, n2]])
    size = np.array([[L1, L2]])
    frame = np.array([[[0.3, 0.2, 0.1], [0, 1.0, 0], [0, 0, 1.0], [1.0, 0, 0]]])  # n = +x
    rng = np.random.default_rng(11)

    def local(p):
        r = p - frame[0, 0]
        return r @ frame[0, 1], r @ frame[0, 2], r @ frame[0, 3]

    def g(p):
        s1, s2, e = local(p)
        return e - _height(0, s1, s2, size, grid, hptr, heights)

    checked = crossing = 0
    tt = np.linspace(0, 1, 2001)
    while checked < 1500:
        c = (
            frame[0, 0]
            + rng.uniform(-0.03, 0.13) * frame[0, 1]
            + rng.uniform(-0.03, 0.09) * (frame[0, 2])
        )
        a = c + rng.normal(size=3) * 0.02
        b = c + rng.normal(size=3) * 0.02
        ga, gb = g(a), g(b)
        if ga * gb >= 0:
            continue
        gs = np.array([g(a + t * (b - a)) for t in tt])
        k = np.flatnonzero(np.sign(gs[:-1]) != np.sign(gs[1:]))
        x = a + tt[k[:, None]] * (b - a)
        s1, s2, _ = np.array([local(q) for q in x]).T
        margin = np.minimum.reduce([s1, L1 - s1, s2, L2 - s2])
        if np.any(np.abs(margin) < 1e-3 * L0):
            continue
        ref = bool(np.any(margin > 0))
        assert segment_crosses_plate(a, b, 0, frame, size, grid, hptr, heights) == ref
        checked += 1
        crossing += ref
    assert 0.2 * checked < crossing < 0.95 * checked


@pytest.mark.parametrize("axis", ["t1", "t2"])
def test_small_rotation_moves_every_layer_rigidly(axis):
    """Face particles given u = omega x r (linearised rotation about a plate axis through the
    origin): the dummies' rigid link gives the same field on every layer, exactly."""
    fluid = fluid_section([([0, 0, 0], [0.25, 0.06, 0.2])], [0.25, 0.06, 0.3])
    fp = FluidParticipant(fluid, shelf(), member_names=["shelf"])
    surf = fp.surface
    (f,) = surf.frames
    omega = 1e-3 * getattr(f, axis)
    r = surf.ref - f.origin
    u_exact = np.cross(omega, r)
    u_if = u_exact[surf.interface_local]
    out = np.zeros_like(surf.ref)
    surf._rigid_link(u_if, out)
    np.testing.assert_allclose(out, u_exact, atol=1e-15)


# ---------------------------------------------------------------------------- filter
def _crosses(a, b, f, L1, L2) -> bool:
    """Segment a-b through the flat rectangle (origin, t1 L1, t2 L2)? (brute force)"""
    ea, eb = (a - f.origin) @ f.normal, (b - f.origin) @ f.normal
    if ea * eb >= 0:
        return False
    x = a + ea / (ea - eb) * (b - a)
    s1, s2 = (x - f.origin) @ f.t1, (x - f.origin) @ f.t2
    return 0 <= s1 <= L1 and 0 <= s2 <= L2


def test_filter_against_brute_force():
    """A tilted plate 0.6 l0 thick with free edges in a cloud of fluid on both sides and
    beyond its edges: fluid pairs survive exactly when their segment misses the plate, fluid
    beside the plate sees only its own face's layers, the two sides never see each other."""
    eu = np.array([np.cos(0.3), 0.0, np.sin(0.3)])
    mesh = plate_mesh([0.1, 0.1, 0.1], eu, [0, 1, 0], (0.06, 0.06), (3, 3), 0.6 * L0)
    fluid = fluid_section([([0.05, 0.05, 0.05], [0.2, 0.21, 0.2])], [0.3, 0.3, 0.3])
    fp = FluidParticipant(fluid, mesh, member_names=["p"])
    s = fp.solver
    (f,) = fp.surface.frames
    L1, L2 = f.size
    rng = np.random.default_rng(7)
    fl = np.flatnonzero(s.kind == FLUID)
    s.pos[fl] += rng.uniform(-0.3 * L0, 0.3 * L0, size=(fl.size, 3))
    raw = NeighbourSearch(3, s.search_radius).build(s.pos)
    rows_raw = [raw.indices[raw.indptr[i] : raw.indptr[i + 1]] for i in range(s.n)]
    nb = fp.filter(raw.__class__(raw.indptr.copy(), raw.indices.copy(), raw.radius), s.pos, s.kind)
    rows = [nb.indices[nb.indptr[i] : nb.indptr[i + 1]] for i in range(s.n)]
    assert all(np.all(np.diff(r) > 0) for r in rows)
    kept = [set(r.tolist()) for r in rows]
    member_of, side_of = fp.surface.member_of, fp.surface.side_of
    r = s.pos - f.origin
    s1, s2, eta = r @ f.t1, r @ f.t2, r @ f.normal
    beside = (s1 >= 0) & (s1 <= L1) & (s2 >= 0) & (s2 <= L2)
    near = np.flatnonzero(
        (s.kind == FLUID) & (np.abs(eta) < 0.06) & (s1 > -0.05) & (s1 < L1 + 0.05)
    )
    checked = {"fluid-fluid": 0, "crossing": 0, "beside": 0, "member": 0, "beyond": 0}
    for i in near:
        for j in rows_raw[i]:
            if s.kind[j] == FLUID:
                cross = _crosses(s.pos[i], s.pos[j], f, L1, L2)
                assert (j in kept[i]) == (not cross), (i, j)
                checked["fluid-fluid"] += 1
                checked["crossing"] += cross
            elif member_of[j] == 0 and beside[i]:
                assert (j in kept[i]) == (np.sign(eta[i]) == side_of[j]), (i, j)
                checked["beside"] += 1
    for i in np.flatnonzero(member_of == 0):
        for j in rows_raw[i]:
            if member_of[j] == 0:
                assert (j in kept[i]) == (side_of[i] == side_of[j])
                checked["member"] += 1
    # beyond an edge fluid sees the body only (nothing virtual) and, next to the edge, sees it:
    # the plate is thinner than l0, so it sees the rows nearest the mid-surface (body_half)
    out1 = np.maximum(np.maximum(-s1, s1 - L1), 0.0)
    out2 = np.maximum(np.maximum(-s2, s2 - L2), 0.0)
    beyond = (s.kind == FLUID) & ~beside & (np.hypot(out1, out2) < L0) & (np.abs(eta) < 0.5 * L0)
    for i in np.flatnonzero(beyond):
        seen = [j for j in kept[i] if member_of[j] == 0]
        assert seen, i
        assert (np.abs(eta[seen]) <= max(0.5 * f.thickness, 0.5 * L0) + 1e-9).all()
        checked["beyond"] += 1
    print("checked pairs:", checked)
    assert min(checked.values()) > 0, checked


# ---------------------------------------------------------------------------- still water
def run(fluid, mesh, use_filter=True):
    fp = FluidParticipant(fluid, mesh, member_names=["m"])
    if not use_filter:
        fp.solver.neighbour_filter = None
    for _ in range(STEPS):
        fp.advance(min(fp.max_dt(), DT))
    return fp


def near_error(fp, mask, level):
    """rms of p - rho g (level - z) over the fluid particles in ``mask`` (Pa)."""
    s = fp.solver
    err = s.p[mask] - RHO * G * (level - s.pos[mask, 2])
    return float(np.sqrt(np.mean(err**2)))


W = 0.06  # tank width (y)


def partition_scene():
    """A vertical plate at x = 0.125 (faces 0.12 and 0.13) from the floor to z = 0.2 across the
    tank's width, 0.15 m of water on its left, 0.08 m on its right; normal +x."""
    fluid = fluid_section(
        [([0, 0, 0], [0.12, W, 0.15]), ([0.13, 0, 0], [0.25, W, 0.08])], [0.25, W, 0.25]
    )
    mesh = plate_mesh([0.125, 0.0, 0.0], [0, 1, 0], [0, 0, 1], (W, 0.2), (2, 6), L0)
    return fluid, mesh


def shelf_scene():
    fluid = fluid_section([([0, 0, 0], [0.25, W, 0.2])], [0.25, W, 0.3])
    return fluid, shelf()


def test_partition_keeps_two_hydrostatic_levels():
    fp = run(*partition_scene())
    s = fp.solver
    f = (s.kind == FLUID) & (np.abs(s.pos[:, 0] - 0.125) < 0.04)
    left = f & (s.pos[:, 0] < 0.125) & (s.pos[:, 2] < 0.15 - 3 * L0)
    right = f & (s.pos[:, 0] > 0.125) & (s.pos[:, 2] < 0.08 - 3 * L0)
    e_left, e_right = near_error(fp, left, 0.15), near_error(fp, right, 0.08)
    force = fp.member_force("m")
    exact = 0.5 * RHO * G * (0.15**2 - 0.08**2) * W
    print(
        f"3D partition after {STEPS} steps: rms p error left {e_left:.1f} Pa, right "
        f"{e_right:.1f} Pa (tolerance {P_TOL:.1f}); force {force} vs [{exact:.3f}, 0, 0] N"
    )
    assert e_left < P_TOL and e_right < P_TOL
    # the load pushes the plate towards the shallow side, along its normal +x; a face resolved
    # to +-l0/2 with a hydrostatic layer of l0/2 gives O(l0 / H) on each side: 5 %
    assert force[0] == pytest.approx(exact, rel=0.05)
    assert abs(force[1]) < 1e-9 and abs(force[2]) < 0.05 * exact


def test_shelf_keeps_water_above_and_below_hydrostatic():
    fp = run(*shelf_scene())
    s = fp.solver
    f = (s.kind == FLUID) & (s.pos[:, 0] < 0.18 - 3 * L0)
    above = f & (s.pos[:, 2] > 0.11) & (s.pos[:, 2] < 0.15)
    below = f & (s.pos[:, 2] < 0.10) & (s.pos[:, 2] > 0.06)
    e_above, e_below = near_error(fp, above, 0.2), near_error(fp, below, 0.2)
    fz = fp.member_force("m")[2]
    print(
        f"3D shelf: rms p error above {e_above:.1f} Pa, below {e_below:.1f} Pa; net vertical "
        f"force {fz:.3f} N (rho g T A = {RHO * G * L0 * 0.18 * W:.3f})"
    )
    assert e_above < P_TOL and e_below < P_TOL
    # the plate carries only the pressure difference across its thickness
    assert abs(fz) < 2.0 * RHO * G * L0 * 0.18 * W


def test_without_the_filter_the_shelf_fails():
    """The reference for the shelf test: the same scene with the filter switched off."""
    fluid, mesh = shelf_scene()
    try:
        fp = run(fluid, mesh, use_filter=False)
    except FluidRunError:
        return
    s = fp.solver
    f = (s.kind == FLUID) & (s.pos[:, 0] < 0.18 - 3 * L0)
    below = f & (s.pos[:, 2] < 0.10) & (s.pos[:, 2] > 0.06)
    assert near_error(fp, below, 0.2) > P_TOL
