"""Planar meshes of plate planforms in local (u, v) coordinates.

* Rectangles: tensor-product grids, quadrilaterals (BFS) or each cell split into two triangles
  (Morley).
* Polygons (Morley): boundary points every ``h`` along each edge, interior points on an equilateral
  triangular lattice of spacing ``h`` kept at least ``h/2`` from the boundary, a Delaunay
  triangulation, and the triangles whose centroid lies outside the polygon dropped. Adequate for
  convex and mildly non-convex outlines; it keeps every polygon edge as a chain of mesh facets so
  that supports can be assigned per edge.

Every mesh comes with ``edge_facets``: for each planform edge (rectangle: v = 0, u = a, v = b,
u = 0; polygon: vertex i to i + 1) the indices of the boundary facets lying on it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import Delaunay
from skfem import MeshQuad1, MeshTri1

__all__ = ["rectangle_mesh", "polygon_mesh", "edge_facets"]


def rectangle_mesh(a: float, b: float, nx: int, ny: int, kind: str):
    """Tensor mesh of [0, a] x [0, b] with nx x ny cells: ``kind`` ``"quad"`` or ``"tri"``."""
    x = np.linspace(0.0, a, nx + 1)
    y = np.linspace(0.0, b, ny + 1)
    if kind == "quad":
        mesh = MeshQuad1.init_tensor(x, y)
    elif kind == "tri":
        mesh = MeshTri1.init_tensor(x, y)
    else:
        raise ValueError(f"unknown cell kind {kind!r}; allowed: 'quad', 'tri'")
    outline = np.array([[0.0, 0.0], [a, 0.0], [a, b], [0.0, b]])
    return mesh, edge_facets(mesh, outline, tol=1e-9 * max(a, b))


def _points_in_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    inside = np.zeros(len(pts), dtype=bool)
    x, y = pts[:, 0], pts[:, 1]
    for (x0, y0), (x1, y1) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        crosses = (y0 > y) != (y1 > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            xc = x0 + (y - y0) * (x1 - x0) / (y1 - y0)
        inside ^= crosses & (x < xc)
    return inside


def _distance_to_polygon(pts: np.ndarray, poly: np.ndarray) -> np.ndarray:
    d = np.full(len(pts), np.inf)
    for p0, p1 in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        e = p1 - p0
        s = np.clip(((pts - p0) @ e) / (e @ e), 0.0, 1.0)
        d = np.minimum(d, np.linalg.norm(pts - p0 - s[:, None] * e, axis=1))
    return d


def polygon_mesh(outline, h: float):
    """Triangle mesh of an anticlockwise polygon with target edge length `h`."""
    poly = np.asarray(outline, dtype=float)
    size = float(np.max(np.ptp(poly, axis=0)))
    tol = 1e-9 * size
    bpts = []
    for p0, p1 in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        n = max(1, math.ceil(np.linalg.norm(p1 - p0) / h - 1e-9))
        s = np.arange(n)[:, None] / n
        bpts.append(p0 + s * (p1 - p0))
    bpts = np.vstack(bpts)
    lo, hi = poly.min(axis=0), poly.max(axis=0)
    dy = h * math.sqrt(3.0) / 2.0
    rows = []
    for j, yy in enumerate(np.arange(lo[1], hi[1] + dy, dy)):
        xs = np.arange(lo[0] + (0.5 * h if j % 2 else 0.0), hi[0] + h, h)
        rows.append(np.column_stack([xs, np.full_like(xs, yy)]))
    ipts = np.vstack(rows)
    keep = _points_in_polygon(ipts, poly) & (_distance_to_polygon(ipts, poly) > 0.5 * h)
    pts = np.vstack([bpts, ipts[keep]])
    tri = Delaunay(pts).simplices
    cent = pts[tri].mean(axis=1)
    tri = tri[_points_in_polygon(cent, poly) & (_distance_to_polygon(cent, poly) > tol)]
    # anticlockwise triangles
    a, b, c = pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]
    area2 = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    tri = tri[np.abs(area2) > tol * tol]
    neg = area2[np.abs(area2) > tol * tol] < 0
    tri[neg] = tri[neg][:, [0, 2, 1]]
    used = np.unique(tri)
    remap = -np.ones(len(pts), dtype=np.int64)
    remap[used] = np.arange(len(used))
    mesh = MeshTri1(np.ascontiguousarray(pts[used].T), np.ascontiguousarray(remap[tri].T))
    return mesh, edge_facets(mesh, poly, tol=1e-6 * size)


def edge_facets(mesh, outline: np.ndarray, tol: float) -> list[np.ndarray]:
    """For each edge of `outline` the boundary facets of `mesh` whose both ends lie on it."""
    bf = mesh.boundary_facets()
    ends = mesh.p[:, mesh.facets[:, bf]]  # (2, 2, nbf): coord, end, facet
    out = []
    for p0, p1 in zip(outline, np.roll(outline, -1, axis=0), strict=True):
        e = p1 - p0
        on = np.ones(len(bf), dtype=bool)
        for k in range(2):
            q = ends[:, k, :].T
            s = ((q - p0) @ e) / (e @ e)
            d = np.linalg.norm(q - p0 - s[:, None] * e, axis=1)
            on &= (d <= tol) & (s >= -1e-9) & (s <= 1 + 1e-9)
        out.append(bf[on])
    return out
