"""Structure members as boundary particles of the MPS fluid: layout, motion, forces.

References: the layout conventions of fluid_mps.geometry (pressure layer half a spacing behind
the face, dummies at l0 intervals), the rigid-link kinematics of a beam cross-section, and the
hydrostatic force rho g H^2 / 2 per unit width on a vertical face.
"""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.fluid_mps.participant import FluidParticipant
from mpsfem.fluid_mps.particle_kinds import FLUID, STRUCTURE, STRUCTURE_DUMMY
from mpsfem.fluid_mps.structure_surface import StructureSurface, members_from_interface
from mpsfem.scenario.fluid import FluidSection

L0 = 0.01
RHO, G = 1000.0, 9.81


def beam_mesh(start, end, n_el, thickness, offset=0):
    """Interface mesh of one straight beam (structure_fem's conventions)."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    pts = start + np.linspace(0.0, 1.0, n_el + 1)[:, None] * (end - start)
    t = (end - start) / np.linalg.norm(end - start)
    nrm = np.tile([-t[1], t[0]], (n_el + 1, 1))
    cells = np.c_[np.arange(n_el), np.arange(1, n_el + 1)] + offset
    return pts, nrm, cells, np.full(n_el + 1, thickness)


def tank_fluid(blocks, width=0.41, height=0.4, spacing=L0) -> FluidSection:
    return FluidSection.model_validate(
        {
            "spacing": spacing,
            "blocks": [{"lower": lo, "upper": hi} for lo, hi in blocks],
            "walls": [{"shape": "tank", "name": "tank", "lower": [0, 0], "upper": [width, height]}],
        }
    )


def partition(thickness=L0, xc=0.205, top=0.3):
    """A vertical member standing on the tank floor at x = xc (normal -x: side +1 faces left)."""
    pts, nrm, cells, th = beam_mesh([xc, 0.0], [xc, top], 10, thickness)
    return InterfaceMesh(pts, nrm, {"line": cells}, th)


def test_members_are_split_in_interface_order():
    a = beam_mesh([0, 0], [1, 0], 4, 0.02)
    b = beam_mesh([0, 1], [0, 2], 3, 0.05, offset=5)
    mesh = InterfaceMesh(
        np.vstack([a[0], b[0]]), np.vstack([a[1], b[1]]), {"line": np.vstack([b[2], a[2]])},
        np.r_[a[3], b[3]],
    )  # fmt: skip
    got = members_from_interface(mesh, ["floor", "post"])
    assert [g[0] for g in got] == ["floor", "post"]
    assert got[0][1].tolist() == [0, 1, 2, 3, 4] and got[1][1].tolist() == [5, 6, 7, 8]
    assert [g[2] for g in got] == [0.02, 0.05]
    with pytest.raises(ValueError, match="2 member"):
        members_from_interface(mesh, ["only_one"])


def test_layout_faces_layers_caps_and_free_ends():
    fluid = tank_fluid([([0, 0], [0.2, 0.2])])
    T = 0.03
    surf = StructureSurface(partition(T), fluid, ["wall"])
    (frame,) = surf.frames
    assert not frame.free_start and frame.free_end  # on the floor, tip in the open
    assert surf.layers == 5  # re = 4.01 l0: the pressure layer plus four dummy layers
    for sl in surf.sides:
        s, eta = frame.local(sl.pos)
        depth = 0.5 * T - sl.side * eta  # behind the side's own face
        assert np.allclose(np.unique(np.round(depth / L0, 9)), np.arange(5) + 0.5)
        assert np.allclose(np.unique(np.round(s / L0, 9)), np.arange(30) + 0.5)
        press = sl.kind == STRUCTURE
        assert set(np.unique(sl.kind)) == {STRUCTURE, STRUCTURE_DUMMY}
        # the face row carries pressure, and so does the end cap on the side's own half
        face = press & (sl.row == 0)
        assert face.sum() == 30
        cap = press & (sl.row > 0)
        assert np.all(np.isclose(s[cap], 0.295)) and np.all(depth[cap] <= 0.5 * T)
        assert cap.sum() == 1  # depths 0.005 (corner) and 0.015 <= T/2 = 0.015
        # area vectors: the face h n side per particle, the cap l0 t
        area = sl.area[press].sum(axis=0)
        expect = sl.side * frame.normal * frame.length + frame.tangent * 2 * L0
        assert np.allclose(area, expect, rtol=0, atol=1e-12)
        assert np.allclose(np.linalg.norm(sl.normal[press], axis=1), 1.0)
        assert np.all(sl.normal[~press] == 0.0)


def test_a_thick_members_end_cap_covers_the_whole_end_face():
    """T = 0.14 m = 14 l0 against 5 layers per side (10 l0): the cap columns reach the mid-plane,
    so the end face's pressure particles are l0 apart across the whole thickness (before: none
    between eta = -2 and +2 l0, a hole the fluid could enter) and their areas sum to T; columns
    away from the end keep 5 layers."""
    fluid = tank_fluid([([0, 0], [0.1, 0.2])], width=0.61)
    T = 0.14
    surf = StructureSurface(partition(T, xc=0.4), fluid, ["wall"])
    (frame,) = surf.frames
    etas, cap_area = [], 0.0
    for sl in surf.sides:
        s, eta = frame.local(sl.pos)
        cap = (sl.kind == STRUCTURE) & np.isclose(s, 0.295)
        etas.append(eta[cap])
        cap_area += (sl.area[cap] @ frame.tangent).sum()
        inner = s < 0.25  # more than 5 columns from the free end
        assert np.all(sl.row[inner] < 5) and (sl.row[inner] == 4).any()
    eta = np.sort(np.concatenate(etas))
    assert eta[0] == pytest.approx(-0.065) and eta[-1] == pytest.approx(0.065)
    assert np.max(np.diff(eta)) == pytest.approx(L0)
    assert cap_area == pytest.approx(T)


def test_fluid_is_not_generated_inside_the_member():
    fluid = tank_fluid([([0, 0], [0.41, 0.2])])
    surf = StructureSurface(partition(L0), fluid, ["wall"])
    x = np.array([[0.195, 0.1], [0.205, 0.1], [0.215, 0.1], [0.205, 0.303], [0.205, 0.305]])
    # closer than l0 / 2 to a face or the free end: not generated; l0 / 2 away (lattice) kept
    assert surf.inside(x).tolist() == [False, True, False, True, False]


@pytest.fixture(scope="module")
def two_levels():
    """Still water 0.2 m deep left of a partition of thickness l0 and 0.1 m deep right of it."""
    fluid = tank_fluid([([0, 0], [0.2, 0.2]), ([0.2, 0], [0.41, 0.1])])
    return FluidParticipant(fluid, partition(L0), member_names=["wall"])


def test_initial_force_is_the_hydrostatic_resultant(two_levels):
    fp = two_levels
    f = fp.member_force("wall")
    exact = 0.5 * RHO * G * (0.2**2 - 0.1**2)  # acts towards +x (from the deeper side)
    assert f[0] == pytest.approx(exact, rel=1e-12) and abs(f[1]) < 1e-9 * exact
    F = fp.read("forces")
    assert F.shape == fp.interface().points.shape
    assert np.allclose(F.sum(axis=0), f, rtol=1e-14, atol=1e-12)


def test_rigid_motion_moves_every_layer_rigidly(two_levels):
    """A small rigid rotation theta about c, u = theta z x (x - c), written at the interface
    points moves the dummies by the same field (the column slope is exact for linear w)."""
    fp = two_levels
    s = fp.surface
    theta, c = 1e-3, np.array([0.205, 0.0])
    rot = lambda x: theta * np.c_[-(x[:, 1] - c[1]), x[:, 0] - c[0]]  # noqa: E731
    ref_if = fp.interface().points
    u_all = np.zeros_like(s.ref)
    s._rigid_link(rot(ref_if), u_all)
    assert np.allclose(u_all, rot(s.ref), rtol=0, atol=1e-15)
    # and a translation plus velocity reaches the solver's arrays through place()
    solver = fp.solver
    before = solver.pos[s.index].copy()
    d = np.tile([1e-4, -2e-4], (s.n_interface, 1))
    s.place(solver, d, 3.0 * d)
    assert np.allclose(solver.pos[s.index] - before, [1e-4, -2e-4], rtol=0, atol=1e-15)
    assert np.allclose(solver.vel[s.index], [3e-4, -6e-4], rtol=0, atol=1e-15)
    s.place(solver, 0.0 * d, 0.0 * d)
    assert np.array_equal(solver.pos[s.index], before)


def test_interface_is_the_pressure_layer(two_levels):
    fp = two_levels
    mesh = fp.interface()
    k = fp.solver.kind[fp.surface.interface_index]
    assert np.all(k == STRUCTURE) and mesh.n_points == np.count_nonzero(fp.solver.kind == 3)
    assert fp.solver.kind[fp.surface.index].tolist().count(STRUCTURE_DUMMY) > 0
    assert not np.any(fp.solver.kind[fp.surface.index] == FLUID)


def test_checkpoint_restore_repeats_steps_bit_for_bit(two_levels):
    fp = two_levels
    fp.checkpoint()
    d = np.tile([0.0, -1e-5], (fp.surface.n_interface, 1))
    runs = []
    for _ in range(2):
        fp.write("displacement", d)
        fp.write("velocity", d / 1e-3)
        dt = fp.max_dt()
        fp.advance(min(dt, 1e-3))
        fp.advance(min(fp.max_dt(), 1e-3))
        runs.append((fp.solver.pos.copy(), fp.solver.p.copy(), fp.read("forces")))
        fp.restore()
    for a, b in zip(*runs, strict=True):
        assert np.array_equal(a, b)


def turn(x, angle, c):
    """Points x (n, 2) turned by ``angle`` (rad) anticlockwise about c."""
    cs, sn = np.cos(angle), np.sin(angle)
    r = x - c
    return c + np.c_[cs * r[:, 0] - sn * r[:, 1], sn * r[:, 0] + cs * r[:, 1]]


@pytest.fixture(scope="module")
def thick_member():
    """A partition 3 l0 thick (pressure layers at eta = +-l0, dummies up to 4 l0 deep) with
    water on its left."""
    fluid = tank_fluid([([0, 0], [0.15, 0.15])])
    return FluidParticipant(fluid, partition(3 * L0), member_names=["wall"])


@pytest.mark.parametrize("angle", [np.pi / 2, np.pi / 3, -2.0, 3.5])
def test_large_rigid_rotation_moves_particles_and_normals_exactly(thick_member, angle):
    """A rigid turn (90, 60 degrees, -2 rad, 3.5 rad: past pi, the atan2 branch) plus a
    translation, written at the interface points, puts every layer and end-cap particle where
    the rigid body puts it, turns every normal and force by R(angle), and a rigid spin omega
    gives v = omega z x (x - c) everywhere (to round-off)."""
    fp = thick_member
    s, solver = fp.surface, fp.solver
    c, shift, omega = np.array([0.205, 0.0]), np.array([0.01, -0.02]), 2.0
    ref_if = fp.interface().points
    pos_if = turn(ref_if, angle, c) + shift
    spin = lambda x: omega * np.c_[-(x - c - shift)[:, 1], (x - c - shift)[:, 0]]  # noqa: E731
    p_ref = np.linspace(50.0, 150.0, solver.n)  # any pressure field (Pa)
    F0 = s.forces(p_ref)
    s.place(solver, pos_if - ref_if, spin(pos_if))
    want = turn(s.ref, angle, c) + shift
    assert np.abs(solver.pos[s.index] - want).max() < 1e-12
    assert np.abs(solver.vel[s.index] - spin(want)).max() < 1e-12 * omega
    n_ref = s.normal_ref
    assert np.abs(solver.normal[s.index] - turn(n_ref, angle, np.zeros(2))).max() < 1e-12
    assert np.allclose(np.cos(s.rotation), np.cos(angle), rtol=0, atol=1e-12)
    F = s.forces(p_ref)
    assert np.abs(F - turn(F0, angle, np.zeros(2))).max() < 1e-12 * np.abs(F0).max()
    s.place(solver, 0.0 * ref_if, 0.0 * ref_if)  # back to the reference for the other tests
    assert np.allclose(solver.pos[s.index], s.ref, rtol=0, atol=1e-15)
    assert np.array_equal(solver.normal[s.index], n_ref)


def test_small_rotation_agrees_with_the_linear_link_to_second_order(thick_member):
    """A bent member (deflection a sin(pi s / 2 L), s from the floor): the exact link and the
    linear one differ by O(a^2) (halving a quarters it)."""
    fp = thick_member
    s = fp.surface
    ref_if = fp.interface().points
    (frame,) = s.frames
    diffs = []
    for a in (4e-3, 2e-3, 1e-3):
        sc, _ = frame.local(ref_if)
        u_if = a * np.sin(0.5 * np.pi * sc / frame.length)[:, None] * frame.normal
        lin = np.zeros_like(s.ref)
        s._rigid_link(u_if, lin)
        s._rigid_motion(u_if, 0.0 * u_if)
        diffs.append(np.abs(s._u - lin).max())
    assert diffs[0] < 1e-5, diffs
    assert 3.5 < diffs[0] / diffs[1] < 4.5 and 3.5 < diffs[1] / diffs[2] < 4.5, diffs
