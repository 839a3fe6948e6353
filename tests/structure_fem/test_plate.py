"""Kirchhoff plates against ../shared/references.md section 4 (unit square, D = 1 scaling)."""

import numpy as np
import pytest
import scipy.sparse.linalg as sla

from mpsfem.structure_fem.modal import natural_modes
from mpsfem.structure_fem.plate import PlateModel

LAMBDA2 = {"simply_supported": 2 * np.pi**2, "clamped": 35.985}  # Leissa
W_CENTRE = {"simply_supported": 0.0040624, "clamped": 0.001265}  # w D / (q a^4)


def square(element, bc, n, *, a=1.0, E=2.0e3, nu=0.3, h=0.1, rho=7.0):
    return PlateModel.create(
        name="p", element=element, E=E, nu=nu, density=rho, thickness=h,
        bcs=[bc] * 4, rectangle=(a, a, n, n),
    )  # fmt: skip


def lambda2(m, a=1.0):
    omega = natural_modes(m, 1).omega[0]
    return omega * a**2 * np.sqrt(m.rho_h / m.D)


def centre_coefficient(m, a=1.0, q=3.0):
    f = m.free
    u = np.zeros(m.n_dof)
    u[f] = sla.spsolve(m.K[f][:, f].tocsc(), m.pressure_load(q)[f])
    w = (m.point_matrix(np.array([a / 2, a / 2, 0.0])) @ u)[2]
    return w * m.D / (q * a**4)


@pytest.mark.parametrize("bc", ["simply_supported", "clamped"])
def test_bfs_16x16(bc):
    m = square("bfs", bc, 16)
    l2 = lambda2(m)
    wc = centre_coefficient(m)
    e_l, e_w = l2 / LAMBDA2[bc] - 1, wc / W_CENTRE[bc] - 1
    print(f"BFS 16x16 {bc}: lambda^2 = {l2:.6f} ({e_l:+.2e}), w D/(q a^4) = {wc:.7f} ({e_w:+.2e})")
    assert abs(e_l) < 1e-3
    assert abs(e_w) < 5e-3


@pytest.mark.parametrize("bc", ["simply_supported", "clamped"])
def test_morley_converges_at_order_two(bc):
    """Morley: non-conforming, energy from below (more flexible); errors O(h^2)."""
    e_l, e_w = [], []
    for n in (8, 16, 32):
        m = square("morley", bc, n)
        e_l.append(lambda2(m) / LAMBDA2[bc] - 1)
        e_w.append(centre_coefficient(m) / W_CENTRE[bc] - 1)
    e_l, e_w = np.array(e_l), np.array(e_w)
    p_l = np.log2(e_l[:-1] / e_l[1:])
    p_w = np.log2(e_w[:-1] / e_w[1:])
    print(f"Morley {bc}: lambda^2 errors {e_l}, orders {p_l}; centre errors {e_w}, orders {p_w}")
    assert np.all(e_l < 0) and np.all(e_w > 0)
    assert abs(p_l[-1] - 2.0) < 0.25
    assert abs(p_w[-1] - 2.0) < 0.25


def test_rectangle_bc_order_and_orientation():
    """Edges are v=0, u=a, v=b, u=0: SS on u=0 and u=a, free on v=0 and v=b bends like a beam
    of span a; with free sides its rigidity lies between the beam's E h^3 / 12 = D (1 - nu^2)
    (narrow strip) and the plate strip's D (cylindrical bending), so frequency and sag do too."""
    a, b = 1.0, 0.3
    m = PlateModel.create(
        name="strip", element="bfs", E=1.0e4, nu=0.3, density=2.0, thickness=0.05,
        bcs=["free", "simply_supported", "free", "simply_supported"], rectangle=(a, b, 16, 4),
        origin=(1.0, 2.0, 3.0), axis_u=(0.0, 1.0, 0.0), axis_v=(0.0, 0.0, 1.0),
    )  # fmt: skip
    assert np.allclose(m.normal, [1.0, 0.0, 0.0])
    omega = natural_modes(m, 1).omega[0]
    strip = (np.pi / a) ** 2 * np.sqrt(m.D / m.rho_h)
    assert strip * np.sqrt(1 - 0.3**2) < omega < strip
    f = m.free
    u = np.zeros(m.n_dof)
    u[f] = sla.spsolve(m.K[f][:, f].tocsc(), m.pressure_load(1.0)[f])
    mid = m.point_matrix(np.array([1.0, 2.0 + a / 2, 3.0 + b / 2])) @ u
    assert mid[0] > 0 and abs(mid[1]) == 0 and abs(mid[2]) == 0
    sag = 5 / 384 * a**4 / m.D
    assert sag < mid[0] < sag / (1 - 0.3**2)


def test_morley_clamped_circle_polygon():
    """Clamped circular plate (128-gon outline): centre deflection q R^4 / (64 D)."""
    R = 0.5
    th = np.linspace(0, 2 * np.pi, 128, endpoint=False)
    outline = np.column_stack([R * np.cos(th), R * np.sin(th)]).tolist()
    m = PlateModel.create(
        name="disc", element="morley", E=1.0e3, nu=0.3, density=1.0, thickness=0.1,
        bcs=["clamped"] * 128, polygon=(outline, 0.02),
    )  # fmt: skip
    f = m.free
    u = np.zeros(m.n_dof)
    u[f] = sla.spsolve(m.K[f][:, f].tocsc(), m.pressure_load(1.0)[f])
    w = (m.point_matrix(np.array([0.0, 0.0, 0.0])) @ u)[2]
    ref = R**4 / (64 * m.D)
    print(f"clamped disc: w/w_ref - 1 = {w / ref - 1:+.3e}")
    assert abs(w / ref - 1) < 1e-2


def test_morley_polygon_fast():
    """An L-shaped outline meshes, every edge gets facets, supports hold, point data works."""
    outline = [[0, 0], [1, 0], [1, 0.5], [0.5, 0.5], [0.5, 1], [0, 1]]
    m = PlateModel.create(
        name="L", element="morley", E=1.0e3, nu=0.3, density=1.0, thickness=0.1,
        bcs=["clamped", "free", "free", "free", "free", "simply_supported"],
        polygon=(outline, 0.1),
    )  # fmt: skip
    assert all(len(e) > 0 for e in m.edge_facets)
    # the mesh covers the outline exactly: area, and every boundary facet on one outline edge
    p, t = m.mesh.p, m.mesh.t
    area = 0.5 * np.abs(
        (p[0, t[1]] - p[0, t[0]]) * (p[1, t[2]] - p[1, t[0]])
        - (p[1, t[1]] - p[1, t[0]]) * (p[0, t[2]] - p[0, t[0]])
    )
    assert abs(area.sum() - 0.75) < 1e-12
    assert sum(len(e) for e in m.edge_facets) == len(m.mesh.boundary_facets())
    f = m.free
    u = np.zeros(m.n_dof)
    u[f] = sla.spsolve(m.K[f][:, f].tocsc(), m.pressure_load(1.0)[f])
    # clamped edge v = 0 and simply supported edge u = 0 do not move
    for pt in ([0.5, 0.0, 0.0], [0.0, 0.5, 0.0]):
        assert abs((m.point_matrix(np.array(pt)) @ u)[2]) < 1e-14
    # the free corner (1, 0.5) and the re-entrant region deflect along +z
    assert (m.point_matrix(np.array([1.0, 0.5, 0.0])) @ u)[2] > 0
    # a point off the planform reads the nearest planform point
    off = m.point_matrix(np.array([0.9, 0.9, 0.2])) @ u
    near = m.point_matrix(np.array([0.7, 0.5, 0.0])) @ u
    assert off[2] > 0 and np.isfinite(near).all()
