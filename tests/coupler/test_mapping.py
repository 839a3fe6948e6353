"""Mappings: constants exact for all; linear fields and rigid motion exact for shape functions;
force (and moment) kept by the conservative ones; faces summed; KFBI drift reported."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from geometry import beam_2d, plate_3d

from mpsfem.coupler.mapping import MAPPINGS, MappingCoverageError, create_mapping
from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.scenario.coupling import CouplingSection

KINDS = list(MAPPINGS)


def build(kind, fluid, structure, **params):
    """Mapping ``kind`` built for these meshes; a ``radius`` is passed to the kernel mappings
    only (for the shape-function mapping it means the search distance, default fine)."""
    if kind == "shape-function" and "radius" in params and params["radius"] is not None:
        params.pop("radius")
    cls = MAPPINGS.get(kind)
    m = cls(cls.Params(kind=kind, **params))
    m.build(fluid, structure)
    return m


def kernel_radius(structure, spacing):
    """A radius that reaches the nearest node from every particle (coarse elements)."""
    p = structure.points
    h = max(np.linalg.norm(p[c[:, 1]] - p[c[:, 0]], axis=1).max() for c in structure.cells.values())
    return max(2.1 * spacing, 0.75 * h)


def cases():
    yield "beam", *beam_2d(), 0.004
    yield "beam-coarse", *beam_2d(elements=6, offset=0.001), 0.004
    yield "plate-quad", *plate_3d(), 0.0075
    yield "plate-tri", *plate_3d(cell="triangle"), 0.0075
    yield "plate-mixed-distorted", *plate_3d(cell="mixed", distort=0.2), 0.0075


CASES = list(cases())
IDS = [c[0] for c in CASES]


def moment(points, forces):
    if points.shape[1] == 2:
        return float(np.sum(points[:, 0] * forces[:, 1] - points[:, 1] * forces[:, 0]))
    return np.cross(points, forces).sum(axis=0)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_constants_exact(kind, case):
    _, fluid, structure, l0 = case
    m = build(kind, fluid, structure, radius=kernel_radius(structure, l0))
    c = np.array([0.3, -0.2, 0.7][: fluid.dim])
    u = np.tile(c, (structure.n_points, 1))
    np.testing.assert_allclose(m.to_fluid(u), np.tile(c, (fluid.n_points, 1)), rtol=0, atol=1e-15)
    assert sp.isspmatrix_csr(m.to_fluid_matrix) and sp.isspmatrix_csr(m.to_structure_matrix)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_shape_function_linear_fields_exact_on_mid_surface(case):
    """Any linear field, evaluated at the projections (points on the mid-surface)."""
    _, fluid, structure, l0 = case
    rng = np.random.default_rng(1)
    dim = fluid.dim
    # points on the mid-surface: project the particles
    from mpsfem.coupler.mapping.shape_function import project

    xs, *_ = project(fluid.points, structure, 1.0)
    mid = InterfaceMesh(xs, fluid.normals)
    m = build("shape-function", mid, structure)
    A, b = rng.standard_normal((dim, dim)), rng.standard_normal(dim)
    u = structure.points @ A.T + b
    err = np.abs(m.to_fluid(u) - (xs @ A.T + b)).max()
    assert err < 1e-13, err


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_shape_function_rigid_motion_exact_at_faces(case):
    """Translation plus small rotation u = c + w x (x - x0) at the face particles (rigid link)."""
    _, fluid, structure, _ = case
    m = build("shape-function", fluid, structure)
    dim = fluid.dim
    x0 = structure.points.mean(axis=0)
    c = np.array([1e-3, -2e-3, 5e-4][:dim])

    def rigid(x):
        r = x - x0
        if dim == 2:
            return c + 1e-3 * np.c_[-r[:, 1], r[:, 0]]
        return c + np.cross(np.array([2e-3, -1e-3, 3e-3]), r)

    err = np.abs(m.to_fluid(rigid(structure.points)) - rigid(fluid.points)).max()
    assert err < 1e-15, err
    # without the rigid link the faces of a rotating member lag (the offset term matters)
    m_off = build("shape-function", fluid, structure, rotation=False)
    assert np.abs(m_off.to_fluid(rigid(structure.points)) - rigid(fluid.points)).max() > 1e-7


@pytest.mark.parametrize("kind", ["conservative-kernel", "shape-function"])
@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_total_force_kept_and_no_spurious_work(kind, case):
    _, fluid, structure, l0 = case
    m = build(kind, fluid, structure, radius=kernel_radius(structure, l0))
    rng = np.random.default_rng(2)
    F = rng.standard_normal(fluid.points.shape) * 10.0
    Fs = m.to_structure(F)
    np.testing.assert_allclose(Fs.sum(axis=0), F.sum(axis=0), rtol=1e-13, atol=1e-12)
    u = rng.standard_normal(structure.points.shape)
    assert np.isclose(np.vdot(F, m.to_fluid(u)), np.vdot(Fs, u), rtol=1e-12)


@pytest.mark.parametrize("case", CASES, ids=IDS)
def test_shape_function_keeps_moment(case):
    """Forces in any direction (shear at the faces too) keep their moment about any point."""
    _, fluid, structure, _ = case
    m = build("shape-function", fluid, structure)
    F = np.random.default_rng(3).standard_normal(fluid.points.shape)
    Fs = m.to_structure(F)
    for x0 in (np.zeros(fluid.dim), structure.points[3]):
        Mf = moment(fluid.points - x0, F)
        Ms = moment(structure.points - x0, Fs)
        np.testing.assert_allclose(Ms, Mf, rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("kind", KINDS)
def test_faces_summed_not_averaged(kind):
    """Pressure p1 on the upper face and p2 on the lower: the net load is (p2 - p1) L along the
    normal, for every mapping (KFBI at element length = spacing, where it is accurate)."""
    l0, length = 0.004, 0.3
    fluid, structure = beam_2d(length=length, elements=75, spacing=l0, tip=False, angle=0.0)
    m = build(kind, fluid, structure, radius=2.1 * l0)
    p1, p2 = 3000.0, 1000.0
    F = np.zeros(fluid.points.shape)
    F[:, 1] = -np.where(fluid.normals[:, 1] > 0, p1, -p2) * l0  # F = -p l0 n
    total = m.to_structure(F).sum(axis=0)
    exact = (p2 - p1) * length
    rel = abs(total[1] - exact) / abs(exact)
    tol = 0.02 if kind == "kfbi" else 1e-12
    assert rel < tol, (kind, total, exact)


def test_kfbi_drift_with_element_length():
    """How far KFBI's total force drifts when the element length h_e differs from the particle
    spacing l0 (uniform pressure on both faces of a beam). Printed as a table; the drift follows
    l0 / h_e, while the conservative mappings keep the force exactly."""
    l0, length, p = 0.002, 0.3, 1000.0
    rows = []
    for ratio in (0.5, 0.75, 1.0, 1.5, 2.0):
        elements = round(length / (ratio * l0))
        fluid, structure = beam_2d(length=length, elements=elements, spacing=l0, angle=0.0)
        F = -p * l0 * fluid.normals * (fluid.normals[:, 1:2] > 0)  # upper face only
        exact = F.sum(axis=0)[1]
        # consistent nodal loads of a uniform line load: p h_e inside, p h_e / 2 at the ends
        h = length / elements
        nodal = np.full(elements + 1, -p * h)
        nodal[[0, -1]] *= 0.5
        row = [ratio, elements]
        for kind in KINDS:
            m = build(kind, fluid, structure, radius=max(2.1 * l0, 0.75 * h))
            Fs = m.to_structure(F)[:, 1]
            row += [Fs.sum() / exact, np.abs(Fs[1:-1] - nodal[1:-1]).max() / (p * h)]
        rows.append(row)
    print("\nKFBI drift: uniform pressure on a beam, l0 = 2 mm, r_ei = max(2.1 l0, 0.75 h_e)")
    print(
        f"{'h_e/l0':>7} {'elems':>6} | "
        + " | ".join(f"{k:>22}" for k in KINDS)
        + "\n"
        + " " * 15
        + "| ".join(f"{'F_tot/exact':>11} {'max node err':>12} " for _ in KINDS)
    )
    for r in rows:
        cells = " | ".join(f"{r[2 + 2 * i]:11.4f} {r[3 + 2 * i]:12.4f}" for i in range(len(KINDS)))
        print(f"{r[0]:7.2f} {r[1]:6d} | {cells}")
    by_ratio = {r[0]: r for r in rows}
    kfbi = KINDS.index("kfbi")
    for ratio, r in by_ratio.items():
        total = r[2 + 2 * kfbi]
        assert abs(total - 1.0 / ratio) < 0.1 / ratio, (ratio, total)  # drift ~ l0 / h_e
        for i, k in enumerate(KINDS):
            if k != "kfbi":
                assert abs(r[2 + 2 * i] - 1.0) < 1e-12
    assert abs(by_ratio[1.0][2 + 2 * kfbi] - 1.0) < 0.02  # accurate only at h_e = l0


def test_coverage_error_names_points_and_key():
    fluid, structure = beam_2d(elements=3)
    with pytest.raises(MappingCoverageError, match=r"coupling.mapping.radius"):
        build("conservative-kernel", fluid, structure, radius=0.01)
    far = InterfaceMesh(fluid.points + [0.0, 1.0], fluid.normals)
    with pytest.raises(MappingCoverageError, match=r"point\(s\), e.g. #0"):
        build("shape-function", far, structure)


def test_rebuild_only_when_points_change():
    fluid, structure = beam_2d()
    m = build("shape-function", fluid, structure)
    same = InterfaceMesh(fluid.points.copy(), fluid.normals.copy())
    assert not m.needs_rebuild(same)
    moved = InterfaceMesh(fluid.points[:-1], fluid.normals[:-1])
    assert m.needs_rebuild(moved)


def test_kfbi_is_the_thesis_formula():
    """Eq. 2-53 (displacement) and 2-52 (force) evaluated by hand for one node and one particle."""
    from mpsfem.fluid_mps.kernels import weight_py

    l0 = 0.004
    fluid, structure = beam_2d(length=0.02, elements=5, spacing=l0, tip=False, angle=0.0)
    re = 2.1 * l0
    m = build("kfbi", fluid, structure, radius=re)
    half = 0.5 * structure.thickness[0]
    i = 2
    d = fluid.points[i] - structure.points
    r = np.hypot(d[:, 0], np.abs(d[:, 1]) - half)  # distance to the thickness fibre
    w = weight_py(r, re)
    u = np.random.default_rng(4).standard_normal(structure.points.shape)
    np.testing.assert_allclose(m.to_fluid(u)[i], (w[:, None] * u).sum(0) / w.sum(), rtol=1e-14)
    n = 3
    F = np.random.default_rng(5).standard_normal(fluid.points.shape)
    dn = fluid.points - structure.points[n]
    rn = np.hypot(dn[:, 0], np.abs(dn[:, 1]) - half)
    wn = weight_py(rn, re)
    up = fluid.normals[:, 1] > 0
    expect = sum((wn[g, None] * F[g]).sum(0) / wn[g].sum() for g in (up, ~up) if wn[g].sum() > 0)
    np.testing.assert_allclose(m.to_structure(F)[n], expect, rtol=1e-13)


def test_structure_participant_interface_is_accepted():
    """The structure solver's Interface (cells per member, per-point thickness) converts."""
    import sys
    from pathlib import Path

    sys.path.insert(0, str(Path(__file__).parents[1] / "structure_fem"))
    structure_cases = pytest.importorskip("structure_cases")
    from mpsfem.structure_fem.participant import StructureParticipant

    sp_ = StructureParticipant(structure_cases.section([structure_cases.PLATE]))
    mesh = as_interface_mesh(sp_.interface())
    assert mesh.dim == 3 and "quad" in mesh.cells and mesh.thickness.max() == 0.015
    sb = StructureParticipant(structure_cases.section([structure_cases.BEAM]))
    mb = as_interface_mesh(sb.interface())
    assert mb.dim == 2 and mb.cells["line"].shape == (10, 2)


def test_default_mapping_from_schema():
    m = create_mapping(CouplingSection().mapping)
    assert m.kind == "shape-function" and m.conservative


# ------------------------------------------------------------------ large rotations (2D beams)
BEAMS = [c for c in CASES if c[0].startswith("beam")]
BEAM_IDS = [c[0] for c in BEAMS]


def exact(fluid, structure):
    """The large-rotation shape-function mapping for these meshes."""
    return build("shape-function", fluid, structure, large_rotation=True)


def rotate_2d(x, angle, centre):
    """Points x (n, 2) turned by ``angle`` (rad) about ``centre``."""
    c, s = np.cos(angle), np.sin(angle)
    r = x - centre
    return centre + np.c_[c * r[:, 0] - s * r[:, 1], s * r[:, 0] + c * r[:, 1]]


def bent(structure, amplitude):
    """A large, smooth displacement of a beam: a rigid turn of 1.2 rad about its first node plus
    a bending wave (m)."""
    X = structure.points
    s = np.linalg.norm(X - X[0], axis=1)
    u = rotate_2d(X, 1.2, X[0]) - X
    return u + amplitude * np.c_[np.sin(7.0 * s), np.cos(5.0 * s) - 1.0]


@pytest.mark.parametrize("angle", [np.pi / 2, 2.5, -np.pi / 2, 7.0])
@pytest.mark.parametrize("case", BEAMS, ids=BEAM_IDS)
def test_large_rotation_rigid_motion_exact(case, angle):
    """A rigid turn (90 degrees, 2.5 rad, and past 2 pi) plus a translation moves every fluid
    interface point exactly: the linear rigid link misses by ~angle^2 T/4."""
    _, fluid, structure, _ = case
    m = exact(fluid, structure)
    c0, shift = np.array([0.25, 0.05]), np.array([0.03, -0.01])
    d = rotate_2d(structure.points, angle, c0) + shift - structure.points
    want = rotate_2d(fluid.points, angle, c0) + shift - fluid.points
    err = np.abs(m.displacement_to_fluid(d) - want).max()
    assert err < 1e-12 * (1.0 + abs(angle)), err
    np.testing.assert_allclose(np.cos(m.rotation_angle(d)), np.cos(angle), rtol=0, atol=1e-13)
    assert np.abs(m.to_fluid(d) - want).max() > 1e-3  # the linear formula is far off here
    # rigid spin omega about c0 at that configuration: v = omega z x (x - c0), exact
    omega = 3.0
    v = omega * np.c_[-(structure.points + d - c0)[:, 1], (structure.points + d - c0)[:, 0]]
    xf = fluid.points + want
    v_want = omega * np.c_[-(xf - c0)[:, 1], (xf - c0)[:, 0]]
    err_v = np.abs(m.velocity_to_fluid(v, d) - v_want).max()
    assert err_v < 1e-12 * omega, err_v


@pytest.mark.parametrize("case", BEAMS, ids=BEAM_IDS)
def test_large_rotation_velocity_is_the_rate_of_the_displacement(case):
    """velocity_to_fluid(v, d) is the derivative of displacement_to_fluid along v: central
    differences with step h agree to O(h^2)."""
    _, fluid, structure, _ = case
    m = exact(fluid, structure)
    d = bent(structure, 0.01)
    v = np.random.default_rng(5).standard_normal(d.shape)
    errs = []
    for h in (1e-5, 5e-6):
        fd = (m.displacement_to_fluid(d + h * v) - m.displacement_to_fluid(d - h * v)) / (2 * h)
        errs.append(np.abs(fd - m.velocity_to_fluid(v, d)).max())
    assert errs[0] < 1e-5, errs  # h^2 |v / element length|^3 T / 12 ~ 1e-6
    assert 3.0 < errs[0] / errs[1] < 5.0, errs  # second order


@pytest.mark.parametrize("case", BEAMS, ids=BEAM_IDS)
def test_large_rotation_force_and_moment_kept(case):
    """Forces in any direction keep their total and their moment about any point of the current
    configuration, at a large, bent configuration; no spurious work on a virtual motion."""
    _, fluid, structure, _ = case
    m = exact(fluid, structure)
    d = bent(structure, 0.01)
    rng = np.random.default_rng(6)
    F = rng.standard_normal(fluid.points.shape)
    Fs = m.forces_to_structure(F, d)
    np.testing.assert_allclose(Fs.sum(axis=0), F.sum(axis=0), rtol=1e-13, atol=1e-13)
    xs, xf = structure.points + d, fluid.points + m.displacement_to_fluid(d)
    for x0 in (np.zeros(2), xs[3], np.array([-1.0, 2.0])):
        np.testing.assert_allclose(moment(xs - x0, Fs), moment(xf - x0, F), rtol=1e-12, atol=1e-12)
    du = rng.standard_normal(d.shape)
    assert np.isclose(np.vdot(F, m.velocity_to_fluid(du, d)), np.vdot(Fs, du), rtol=1e-12)


@pytest.mark.parametrize("case", BEAMS, ids=BEAM_IDS)
def test_large_rotation_agrees_with_linear_to_second_order(case):
    """Small motion: the exact rigid link and the linear one differ by O(theta^2) (halving the
    motion quarters the difference); at zero motion they are identical."""
    _, fluid, structure, _ = case
    m = exact(fluid, structure)
    lin = build("shape-function", fluid, structure)  # the default: linear
    assert lin._chord is None
    X = structure.points
    s = np.linalg.norm(X - X[0], axis=1)
    shape = np.c_[np.sin(4.0 * s), 0.5 * s**2] * 0.05 + np.array([1e-3, 2e-3])
    diffs = []
    for a in (1e-2, 5e-3, 2.5e-3):
        d = a * shape
        diffs.append(np.abs(m.displacement_to_fluid(d) - lin.displacement_to_fluid(d)).max())
    assert diffs[0] < 1e-5, diffs
    assert 3.5 < diffs[0] / diffs[1] < 4.5 and 3.5 < diffs[1] / diffs[2] < 4.5, diffs
    z = np.zeros_like(X)
    assert np.array_equal(m.displacement_to_fluid(z), np.zeros_like(fluid.points))
    F = np.random.default_rng(7).standard_normal(fluid.points.shape)
    np.testing.assert_allclose(m.forces_to_structure(F, z), lin.to_structure(F), atol=1e-13)
