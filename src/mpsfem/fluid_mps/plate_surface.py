"""Structure members as boundary particles of the MPS fluid: 3D rectangular plates.

The 3D counterpart of :mod:`~mpsfem.fluid_mps.structure_surface` (read its docstring first: the
layout, the virtual solids, the patches and the forces follow the same rules). A plate member of
the structure participant reaches the fluid as its mid-surface mesh (quadrilaterals or triangles,
one flat rectangle per member), its normal n and the geometric thickness T.

Layout (member frame: in-plane coordinates (s1, s2) in [0, L1] x [0, L2] along the orthonormal
tangents t1, t2 from the rectangle's corner, t1 x t2 = n, offset eta along n; faces at
eta = +-T/2):

- columns at (s1, s2) = ((a1 + 1/2) h1, (a2 + 1/2) h2), h_i = L_i / round(L_i / l0);
- each face (side +1 at +T/2, side -1 at -T/2) gets its own virtual solid of ``layers`` rows at
  depth (k + 1/2) l0 behind it; row 0 is the pressure layer (STRUCTURE), deeper rows dummies;
- each free edge (one not within one spacing of a rigid wall of the fluid scene) closes the
  virtual solids with an edge cap: a column at column-distance d from the nearest free edge has
  its rows k >= d in layer min(k, d) (as :func:`~mpsfem.fluid_mps.geometry.solid_box` does for a
  box); cap particles of the pressure layer on the side's own half of the edge face carry
  pressure;
- one external patch per side (``"<member>+"`` / ``"<member>-"``).

Motion: pressure particles take the mapped displacement and velocity; a dummy at offset d eta
behind the face particle of its column follows it plus the rotation of the plate normal,
-d eta grad_s w (Kirchhoff: u = -z grad w), w = u_mid . n the mid-surface deflection of the
column (mean of its two faces' pressure particles), grad_s by central differences over the column
grid.

Force on the structure (N): F_i = -p_i A_i n_i on every pressure particle (thesis eq. 2-51 with
A_i = l0^(d-1): h1 h2 for a face particle, l0 h for an edge-cap particle of an edge with column
spacing h, the vector sum at corners).

Only flat rectangular plates are laid out (the structure's rectangles, meshed by quads or
triangles); another outline stops with a clear error.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from mpsfem.coupler.participant import as_interface_mesh
from mpsfem.fluid_mps.particle_kinds import STRUCTURE, STRUCTURE_DUMMY
from mpsfem.fluid_mps.structure_surface import (
    SideLayout,
    StructureSurface,
    cap_rows,
    wall_clearance,
)
from mpsfem.scenario.fluid import FluidSection

__all__ = ["PlateFrame", "PlateSurface", "lay_plate_side", "plates_from_interface"]

#: edges of a plate in the order of PlateFrame.free: s1 = 0, s1 = L1, s2 = 0, s2 = L2
EDGES = ("s1=0", "s1=L1", "s2=0", "s2=L2")
#: t1 is the rectangle's side direction with the largest dot product with this vector: the one
#: pointing most along +x, then +y, then +z
_AXIS_PRIORITY = np.array([1.0, 1e-3, 1e-6])


@dataclass(frozen=True)
class PlateFrame:
    """A flat rectangular plate in its reference configuration.

    origin: corner (s1, s2) = (0, 0) (m); t1, t2: in-plane unit tangents along its sides (t1:
    the side direction pointing most along +x, then +y, then +z), normal n = t1 x t2 (the
    structure's normal); size: (L1, L2) (m); thickness T (m, as the fluid sees
    it); free: whether an edge cap closes the plate at s1 = 0, s1 = L1, s2 = 0, s2 = L2; nodes:
    slice of the structure's interface points that belong to this member.
    """

    name: str
    origin: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    normal: np.ndarray
    size: tuple[float, float]
    thickness: float
    free: tuple[bool, bool, bool, bool]
    nodes: slice

    def local(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(s1, s2, eta) of scene points (m)."""
        r = np.asarray(points, dtype=np.float64) - self.origin
        return r @ self.t1, r @ self.t2, r @ self.normal

    def inside(self, points: np.ndarray, margin: float) -> np.ndarray:
        """Points in the body or within ``margin`` of its faces (and of its free edges)."""
        s1, s2, eta = self.local(points)
        L1, L2 = self.size
        f = self.free
        ok1 = (s1 > (-margin if f[0] else 0.0)) & (s1 < L1 + (margin if f[1] else 0.0))
        ok2 = (s2 > (-margin if f[2] else 0.0)) & (s2 < L2 + (margin if f[3] else 0.0))
        return (np.abs(eta) < 0.5 * self.thickness + margin) & ok1 & ok2

    def edge_midpoints(self) -> np.ndarray:
        """Mid-points (4, 3) of the edges s1 = 0, s1 = L1, s2 = 0, s2 = L2 (m)."""
        L1, L2 = self.size
        uv = [(0.0, 0.5 * L2), (L1, 0.5 * L2), (0.5 * L1, 0.0), (0.5 * L1, L2)]
        return np.array([self.origin + a * self.t1 + b * self.t2 for a, b in uv])


def _cell_area(pts: np.ndarray, cell: np.ndarray) -> float:
    """Area of a triangle or of a planar quadrilateral (two triangles), m^2."""
    p = pts[cell]
    a = 0.5 * np.linalg.norm(np.cross(p[1] - p[0], p[2] - p[0]))
    if len(cell) == 4:
        a += 0.5 * np.linalg.norm(np.cross(p[2] - p[0], p[3] - p[0]))
    return float(a)


def plates_from_interface(mesh, names: Sequence[str] | None = None) -> list[dict]:
    """Split a 3D interface mesh into flat rectangular plates: connected sets of its triangle /
    quad cells, ordered by their first point index (structure_fem concatenates members in
    scenario order).

    Returns per member a dict with name, nodes (slice), thickness T, origin, t1, t2, normal and
    size (L1, L2). Raises ValueError for a 2D mesh, a mesh without surface cells, a member whose
    points are not contiguous, a curved member or an outline that is not a rectangle.
    """
    m = as_interface_mesh(mesh)
    if m.dim != 3:
        raise ValueError("plates_from_interface needs a 3D interface (2D beams: structure_surface)")
    cells = [c for t in ("triangle", "quad") for c in m.cells.get(t, np.zeros((0, 0), int))]
    if not cells:
        raise ValueError("the structure interface has no triangle or quad cells (3D plates)")
    rows, cols = [], []
    for c in cells:
        for a in range(len(c)):
            rows.append(int(c[a]))
            cols.append(int(c[(a + 1) % len(c)]))
    n = m.n_points
    graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
    ncomp, label = connected_components(graph, directed=False)
    used = np.zeros(n, dtype=bool)
    used[np.array(rows)] = True
    comps = sorted(
        (np.flatnonzero((label == c) & used) for c in range(ncomp) if used[label == c].any()),
        key=lambda idx: int(idx.min()),
    )
    if names is not None and len(names) != len(comps):
        raise ValueError(
            f"the structure interface holds {len(comps)} member(s) but {len(names)} name(s) "
            f"were given: {list(names)}"
        )
    cell_comp = [int(label[c[0]]) for c in cells]
    out = []
    for k, idx in enumerate(comps):
        name = names[k] if names is not None else f"member{k}"
        lo, hi = int(idx.min()), int(idx.max()) + 1
        if idx.size != hi - lo:
            raise ValueError(f"member {name!r}: its interface points are not contiguous")
        pts = m.points[idx]
        nrm = m.normals[idx]
        normal = nrm.mean(axis=0)
        normal /= np.linalg.norm(normal)
        span = float(np.ptp(pts, axis=0).max())
        if np.abs(nrm - normal).max() > 1e-9 or np.abs((pts - pts[0]) @ normal).max() > 1e-9 * span:
            raise ValueError(f"member {name!r}: the fluid participant needs flat plates")
        mine = [c for c, lab in zip(cells, cell_comp, strict=True) if lab == label[idx[0]]]
        area = sum(_cell_area(m.points, c) for c in mine)
        # the rectangle's sides: the cell-edge direction with the smallest bounding rectangle
        best = None
        for c in mine:
            for a in range(len(c)):
                e = m.points[c[(a + 1) % len(c)]] - m.points[c[a]]
                e = e - (e @ normal) * normal
                t1 = e / np.linalg.norm(e)
                t2 = np.cross(normal, t1)
                box = np.ptp(np.c_[(pts - pts[0]) @ t1, (pts - pts[0]) @ t2], axis=0)
                if best is None or box.prod() < best[0] - 1e-12 * span**2:
                    best = (float(box.prod()), t1, t2, box)
        box_area, t1, t2, box = best
        if abs(area - box_area) > 1e-9 * box_area:
            raise ValueError(
                f"member {name!r}: the fluid participant lays rectangular plates only (its cells "
                f"cover {area:.6g} m^2 of the {box[0]:.6g} x {box[1]:.6g} m rectangle around them)"
            )
        # canonical sides, whatever the cells' vertex order: t1 is the side direction pointing
        # most along +x (then +y, then +z), t2 = n x t1
        cands = [t1, -t1, t2, -t2]
        t1 = max(cands, key=lambda d: float(d @ _AXIS_PRIORITY))
        t2 = np.cross(normal, t1)
        s = np.c_[(pts - pts[0]) @ t1, (pts - pts[0]) @ t2]
        smin, box = s.min(axis=0), np.ptp(s, axis=0)
        origin = pts[0] + smin[0] * t1 + smin[1] * t2
        out.append(
            {
                "name": name,
                "nodes": slice(lo, hi),
                "thickness": float(m.thickness[idx].max()),
                "origin": origin,
                "t1": t1,
                "t2": t2,
                "normal": normal,
                "size": (float(box[0]), float(box[1])),
            }
        )
    return out


def column_grid(frame: PlateFrame, l0: float) -> tuple[int, int, float, float]:
    """Columns (n1, n2) along t1, t2 and their spacings (h1, h2) in m."""
    n1 = max(1, int(round(frame.size[0] / l0)))
    n2 = max(1, int(round(frame.size[1] / l0)))
    return n1, n2, frame.size[0] / n1, frame.size[1] / n2


def lay_plate_side(frame: PlateFrame, member: int, side: int, l0: float, layers: int) -> SideLayout:
    """Particles of the virtual solid behind face ``side`` (+1 or -1) of a plate; columns in
    row-major order (column index a1 n2 + a2), ``layers`` rows per column."""
    T = frame.thickness
    n1, n2, h1, h2 = column_grid(frame, l0)
    rows = cap_rows(T, l0, layers)
    col = np.repeat(np.arange(n1 * n2), rows)
    k = np.tile(np.arange(rows), n1 * n2)
    a1, a2 = col // n2, col % n2
    never = np.full_like(col, 1 << 30)
    dist = [
        a1 if frame.free[0] else never,
        (n1 - 1 - a1) if frame.free[1] else never,
        a2 if frame.free[2] else never,
        (n2 - 1 - a2) if frame.free[3] else never,
    ]
    keep = (k < layers) | (np.minimum.reduce(dist) < layers)  # deeper rows fill the edge caps
    col, k, a1, a2 = col[keep], k[keep], a1[keep], a2[keep]
    dist = [d[keep] for d in dist]
    d_edge = np.minimum.reduce(dist)
    depth = (k + 0.5) * l0
    eta = side * (0.5 * T - depth)
    layer = np.minimum(k, d_edge)
    on_face = k == 0
    on_cap = (d_edge == 0) & (depth <= 0.5 * T + 1e-12 * max(T, l0))
    pressure = (layer == 0) & (on_face | on_cap)
    t1, t2, n = frame.t1, frame.t2, frame.normal
    area = np.zeros((col.size, 3))
    area[on_face] += side * n * (h1 * h2)  # face particle: its share h1 h2 of the face
    cap = pressure & (d_edge == 0)
    outward = (-t1, t1, -t2, t2)
    width = (h2, h2, h1, h1)  # an edge cap particle covers l0 (depth) x the edge-wise spacing
    for d, direction, w in zip(dist, outward, width, strict=True):
        on = cap & (d == 0)
        area[on] += direction * (l0 * w)
    norm = np.linalg.norm(area, axis=1, keepdims=True)
    pressure &= norm[:, 0] > 0.0
    area[~pressure] = 0.0
    normal = np.divide(area, norm, out=np.zeros_like(area), where=norm > 0)
    s1, s2 = (a1 + 0.5) * h1, (a2 + 0.5) * h2
    pos = frame.origin + s1[:, None] * t1 + s2[:, None] * t2 + eta[:, None] * n
    kind = np.where(pressure, STRUCTURE, STRUCTURE_DUMMY).astype(np.int8)
    return SideLayout(member, side, pos, kind, normal, area, col.astype(np.int64), k, eta)


class PlateSurface(StructureSurface):
    """The boundary particles of every plate member, their motion and their forces (3D).

    A :class:`~mpsfem.fluid_mps.structure_surface.StructureSurface` whose members are plates:
    the patches, the binding to the solver, the placement and the forces are the beam's; the
    layout, the rigid link and the filter geometry (:meth:`mid_surface`) are the plate's.

    Parameters
    ----------
    interface:
        The structure participant's interface mesh (reference configuration).
    fluid:
        The ``[fluid]`` section (spacing, kernel radii, walls).
    names:
        Member names in interface order (default ``member0``, ...).
    free_edges:
        Per member, whether each edge (s1 = 0, s1 = L1, s2 = 0, s2 = L2 of its
        :class:`PlateFrame`: t1 points most along +x, then +y, then +z) is free; default: an
        edge is free unless its mid-point lies within one spacing of a rigid wall of the scene.
    """

    def __init__(
        self,
        interface,
        fluid: FluidSection,
        names: Sequence[str] | None = None,
        free_edges: Sequence[Sequence[bool]] | None = None,
    ) -> None:
        mesh = self._setup(interface, fluid)
        l0 = self.l0
        self.frames: list[PlateFrame] = []  # type: ignore[assignment]
        for i, p in enumerate(plates_from_interface(mesh, names)):
            frame = PlateFrame(
                p["name"],
                p["origin"],
                p["t1"],
                p["t2"],
                p["normal"],
                p["size"],
                p["thickness"],
                (True,) * 4,
                p["nodes"],
            )
            if free_edges is not None:
                if len(free_edges[i]) != 4:
                    raise ValueError(
                        f"free_edges[{i}] = {list(free_edges[i])}: 4 flags expected "
                        f"(edges {', '.join(EDGES)})"
                    )
                free = tuple(bool(f) for f in free_edges[i])
            else:
                free = tuple(wall_clearance(q, fluid) > l0 for q in frame.edge_midpoints())
            self.frames.append(replace(frame, free=free))
        self.grids = [column_grid(f, l0) for f in self.frames]
        # the height fields' layout (mid_surface): (n1 + 2) x (n2 + 2) nodes per member
        self._grid = np.array([g[:2] for g in self.grids], dtype=np.int64)
        self._hptr = np.concatenate([[0], np.cumsum((self._grid + 2).prod(axis=1))])
        self.sides = [
            lay_plate_side(f, i, side, l0, self.layers)
            for i, f in enumerate(self.frames)
            for side in (+1, -1)
        ]

    # ------------------------------------------------------------------ motion
    def _slopes(self, m: int, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """grad_s w on the column grid of member m: (dw/ds1, dw/ds2) per column (row-major)."""
        n1, n2, h1, h2 = self.grids[m]
        g = w.reshape(n1, n2)
        g1 = np.gradient(g, h1, axis=0) if n1 > 1 else np.zeros_like(g)
        g2 = np.gradient(g, h2, axis=1) if n2 > 1 else np.zeros_like(g)
        return g1.ravel(), g2.ravel()

    def _rigid_link(self, vals_if: np.ndarray, out: np.ndarray) -> None:
        """Fill ``out`` (every structure particle) from interface-point values: pressure
        particles take them as given, dummies follow their face particle plus the rotation of
        the normal, -d_eta grad_s w (Kirchhoff's u = -z grad w)."""
        out[self.interface_local] = vals_if
        for m, f in enumerate(self.frames):
            mid = 0.5 * (out[self.col_plus[m]] + out[self.col_minus[m]])
            g1, g2 = self._slopes(m, mid @ f.normal)
            sel, c, d, fol = self._dummies[m]
            out[sel] = out[fol] - d[:, None] * (g1[c, None] * f.t1 + g2[c, None] * f.t2)

    def anchors(self, pos: np.ndarray):
        """The 2D filter's mid-line polylines do not exist for plates: use :meth:`mid_surface`."""
        raise NotImplementedError("plates give their mid-surface as mid_surface(pos)")

    # ------------------------------------------------------------------ thin-plate filter
    def mid_surface(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The current mid-surfaces as height fields over the reference rectangles, for
        :class:`~mpsfem.fluid_mps.thin_plate.ThinPlateFilter`.

        Per member the offset along n of the column mid-points (mean of the two faces'
        pressure particles) on the (n1 + 2) x (n2 + 2) node grid s = 0, h/2, 3h/2, ..., L
        (edge rows extrapolated linearly). Returns (heights (sum of grid sizes,) m,
        pointer (members + 1,), grid (members, 2) = (n1, n2))."""
        out = []
        for m, f in enumerate(self.frames):
            n1, n2, _, _ = self.grids[m]
            mid = 0.5 * (pos[self.index[self.col_plus[m]]] + pos[self.index[self.col_minus[m]]])
            g = ((mid - f.origin) @ f.normal).reshape(n1, n2)
            out.append(_extend(_extend(g, 0), 1).ravel())
        return np.concatenate(out), self._hptr, self._grid


def _extend(g: np.ndarray, axis: int) -> np.ndarray:
    """Add the edge values s = 0 and s = L along ``axis`` by linear extrapolation from the
    first / last two column mid-points (constant for a single column)."""
    g = np.moveaxis(g, axis, 0)
    if g.shape[0] > 1:
        first, last = 1.5 * g[0] - 0.5 * g[1], 1.5 * g[-1] - 0.5 * g[-2]
    else:
        first, last = g[0], g[-1]
    return np.moveaxis(np.concatenate([first[None], g, last[None]]), 0, axis)
