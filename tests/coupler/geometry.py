"""Interface geometries for the coupler tests: thin members with particles on both faces."""

from __future__ import annotations

import numpy as np

from mpsfem.coupler.participant import InterfaceMesh


def rotation_2d(angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s], [s, c]])


def rotation_3d(a: float, b: float) -> np.ndarray:
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    rz = np.array([[ca, -sa, 0], [sa, ca, 0], [0, 0, 1]])
    rx = np.array([[1, 0, 0], [0, cb, -sb], [0, sb, cb]])
    return rz @ rx


def beam_2d(
    length=0.3,
    elements=15,
    thickness=0.015,
    spacing=0.004,
    angle=0.3,
    origin=(0.2, 0.1),
    tip=True,
    offset=0.0,
):
    """A beam mid-line (``elements`` segments) and fluid particles on both faces (and the tip
    face), rotated by ``angle``. Face particles sit ``offset`` inside the face."""
    R = rotation_2d(angle)
    o = np.asarray(origin)
    x = np.linspace(0.0, length, elements + 1)
    nodes = np.c_[x, np.zeros_like(x)] @ R.T + o
    n_up = np.array([0.0, 1.0]) @ R.T
    structure = InterfaceMesh(
        nodes,
        np.tile(n_up, (x.size, 1)),
        {"line": np.c_[np.arange(elements), np.arange(1, elements + 1)]},
        thickness,
    )
    h = 0.5 * thickness - offset
    xp = np.arange(0.5 * spacing, length, spacing)
    pts = [np.c_[xp, np.full(xp.size, h)], np.c_[xp, np.full(xp.size, -h)]]
    nrm = [np.tile([0.0, 1.0], (xp.size, 1)), np.tile([0.0, -1.0], (xp.size, 1))]
    if tip:
        yp = np.arange(-0.5 * thickness + 0.5 * spacing, 0.5 * thickness, spacing)
        pts.append(np.c_[np.full(yp.size, length), yp])
        nrm.append(np.tile([1.0, 0.0], (yp.size, 1)))
    fluid = InterfaceMesh(np.vstack(pts) @ R.T + o, np.vstack(nrm) @ R.T)
    return fluid, structure


def plate_3d(
    size=(0.3, 0.15),
    divisions=(10, 5),
    thickness=0.015,
    spacing=0.0075,
    cell="quad",
    distort=0.0,
    seed=0,
):
    """A plate mid-surface (quads, or triangles from splitting them) in a rotated plane, and
    fluid particles on both faces."""
    R = rotation_3d(0.4, 0.7)
    o = np.array([0.1, -0.2, 0.3])
    nx, ny = divisions
    gx, gy = np.meshgrid(np.linspace(0, size[0], nx + 1), np.linspace(0, size[1], ny + 1))
    p2 = np.c_[gx.ravel(), gy.ravel()]
    if distort:
        rng = np.random.default_rng(seed)
        inner = (p2[:, 0] > 0) & (p2[:, 0] < size[0]) & (p2[:, 1] > 0) & (p2[:, 1] < size[1])
        h = min(size[0] / nx, size[1] / ny)
        p2[inner] += distort * h * rng.uniform(-1, 1, (inner.sum(), 2))
    idx = np.arange((nx + 1) * (ny + 1)).reshape(ny + 1, nx + 1)
    quads = np.c_[
        idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
    ]
    if cell == "quad":
        cells = {"quad": quads}
    elif cell == "triangle":
        cells = {"triangle": np.vstack([quads[:, [0, 1, 2]], quads[:, [0, 2, 3]]])}
    else:  # mixed
        half = quads.shape[0] // 2
        cells = {
            "quad": quads[:half],
            "triangle": np.vstack([quads[half:, [0, 1, 2]], quads[half:, [0, 2, 3]]]),
        }
    nodes = np.c_[p2, np.zeros(p2.shape[0])] @ R.T + o
    up = np.array([0.0, 0.0, 1.0]) @ R.T
    structure = InterfaceMesh(nodes, np.tile(up, (nodes.shape[0], 1)), cells, thickness)
    fx, fy = np.meshgrid(
        np.arange(0.5 * spacing, size[0], spacing), np.arange(0.5 * spacing, size[1], spacing)
    )
    f2 = np.c_[fx.ravel(), fy.ravel()]
    top = np.c_[f2, np.full(f2.shape[0], 0.5 * thickness)]
    bot = np.c_[f2, np.full(f2.shape[0], -0.5 * thickness)]
    nrm = np.vstack(
        [np.tile([0, 0, 1.0], (f2.shape[0], 1)), np.tile([0, 0, -1.0], (f2.shape[0], 1))]
    )
    fluid = InterfaceMesh(np.vstack([top, bot]) @ R.T + o, nrm @ R.T)
    return fluid, structure
