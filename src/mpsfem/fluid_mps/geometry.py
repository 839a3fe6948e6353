"""Particle generation from the geometry primitives of a scenario (boxes, tanks).

Conventions (every dimension):
- fluid particles sit at the cell centres ``origin + (i + 1/2) l0`` of one square (cubic)
  lattice of spacing l0 whose origin is the first fluid block's lower corner
  (:func:`lattice_origin`); every block's corners are moved to the nearest lattice line, so a
  block of size L holds ``round(L / l0)`` particles per axis and overlapping blocks share sites;
- a wall box (tank or solid) also holds a whole number ``round(L / l0)`` of cells per axis. Per
  axis it keeps, as given, the face nearer a lattice line (the lower face on a tie, and always
  the floor of a tank) and the other face follows (:func:`wall_corners`). A box whose fluid-side
  face is on the lattice, whatever its thickness (a paddle at x = 0 in front of water starting at
  x = 0), thus has its pressure layer a whole spacing from the first fluid particle, while a face
  off the lattice (a deck above the water) stays where the scenario puts it.
  :func:`lattice_notes` lists every face the particles move (``mpsfem run`` and ``validate``
  print them);
- a wall's physical surface is the face of its box; the pressure layer sits half a spacing
  behind it and dummy layers follow at l0 intervals;
- a wall particle's layer is its lattice distance behind the face (the largest over the axes),
  layer 0 is the pressure layer (kind WALL) and deeper layers are DUMMY;
- wall normals are unit vectors from the particle towards the fluid side (for force probes).

Polygon walls (2D, ``shape = "polygon"``; :func:`polygon_wall`): inclined faces cannot sit on the
lattice, so their particles are laid along the outline instead. Layer m (0 = pressure layer) is
the outline offset inward by (m + 1/2) l0, as a box's layers are: along each face a row parallel
to it, from corner to corner of the offset outline, cut into round(length / l0) equal pieces
(spacing within l0 (1 +- 1/(2 n)) on a face n spacings long); a convex corner holds one particle
at the mitre point of its two offset faces (normal: the two faces' normals averaged), a reflex
corner an arc of radius (m + 1/2) l0 around the vertex. A particle closer than (m + 1/4) l0 to the
outline or outside it (a layer deeper than the polygon is thick) is dropped, as is one closer
than l0 / 2 to a particle laid before it (shallower layers first). An axis-aligned rectangle with
corners on the lattice gives exactly a box's particles. The vertices are kept as given (not
snapped); fluid particles inside the outline or closer than l0 / 2 to it are removed, the gap a
lattice-aligned box face leaves to its nearest fluid row.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from mpsfem.fluid_mps.particle_kinds import DUMMY, FLUID, WALL
from mpsfem.scenario.fluid import FluidSection, Wall


@dataclass
class WallPatch:
    """Contiguous index range of one wall's particles in the particle arrays (``spec`` is None
    for a patch whose motion another participant drives, e.g. a structure surface)."""

    name: str
    start: int
    stop: int
    spec: Wall | None


@dataclass
class ExternalPatch:
    """Boundary particles handed in by another participant (a structure's surface layers).

    ``kind`` holds STRUCTURE (pressure layer) or STRUCTURE_DUMMY codes, ``normal`` the unit
    normals towards the fluid (zeros for dummies); ``inside(points) -> bool mask`` tells which
    fluid particles the body occupies (they are not generated)."""

    name: str
    pos: np.ndarray
    kind: np.ndarray
    normal: np.ndarray
    inside: Callable[[np.ndarray], np.ndarray] | None = None


@dataclass
class ParticleSet:
    """Initial particles: positions, velocities, kinds and wall normals (zeros for fluid)."""

    pos: np.ndarray
    vel: np.ndarray
    kind: np.ndarray
    normal: np.ndarray
    n_fluid: int
    patches: list[WallPatch] = field(default_factory=list)
    #: int8 per particle, 1 on the pressure layer of polygon walls: wet by fluid contact alone
    #: (wall_boundary.mark_dry); empty when the scene has no polygon wall
    contact_wet: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))


def default_dummy_layers(max_re: float) -> int:
    """Wall layers (pressure layer included) that give the pressure layer full kernel support."""
    return int(math.ceil(max_re - 0.5)) + 1


#: a corner closer than this (in spacings) to a lattice line is on the lattice and kept as given
ON_LATTICE = 1e-6


def lattice_origin(fluid: FluidSection) -> np.ndarray:
    """Origin of the scene's particle lattice (m): the first fluid block's lower corner (the
    fluid is what the lattice is for; the walls follow it)."""
    return np.asarray(fluid.blocks[0].lower, dtype=np.float64)


def snap_to_lattice(x, origin: np.ndarray, l0: float) -> np.ndarray:
    """``x`` (m) moved to the nearest lattice line ``origin + k l0`` per axis; coordinates within
    ``ON_LATTICE`` l0 of a line are kept bit for bit."""
    x = np.asarray(x, dtype=np.float64)
    snapped = origin + np.rint((x - origin) / l0) * l0
    return np.where(np.abs(x - snapped) <= ON_LATTICE * l0, x, snapped)


def wall_corners(
    lower, upper, l0: float, origin: np.ndarray, floor_axis: int | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The corners (m) a wall box's particles fill: ``round(L / l0)`` cells per axis, keeping the
    face nearer a lattice line of ``origin`` as given (the lower face on a tie, and always along
    ``floor_axis``, a tank's floor)."""
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    cells = np.rint((hi - lo) / l0)
    off_lo = np.abs(lo - snap_to_lattice(lo, origin, l0))
    off_hi = np.abs(hi - snap_to_lattice(hi, origin, l0))
    keep_upper = off_hi < off_lo - ON_LATTICE * l0
    if floor_axis is not None:
        keep_upper[floor_axis] = False
    new_lo = np.where(keep_upper, hi - cells * l0, lo)
    new_hi = np.where(keep_upper, hi, lo + cells * l0)
    return new_lo, new_hi


def scene_corners(fluid: FluidSection) -> list[tuple[str, np.ndarray, np.ndarray]]:
    """(key, lower, upper) of the boxes the particles fill (m), blocks then walls in scenario
    order: blocks snapped to the lattice, walls by :func:`wall_corners`."""
    l0 = fluid.spacing
    origin = lattice_origin(fluid)
    out = [
        (
            f"fluid.blocks[{i}]",
            snap_to_lattice(b.lower, origin, l0),
            snap_to_lattice(b.upper, origin, l0),
        )
        for i, b in enumerate(fluid.blocks)
    ]
    for i, w in enumerate(fluid.walls):
        if w.shape == "polygon":  # laid along its faces, not on the lattice: its bounding box
            box = (np.asarray(w.lower, dtype=np.float64), np.asarray(w.upper, dtype=np.float64))
            out.append((f"fluid.walls[{i}]", *box))
            continue
        floor = fluid.vertical_axis if w.shape == "tank" else None
        out.append((f"fluid.walls[{i}]", *wall_corners(w.lower, w.upper, l0, origin, floor)))
    return out


def _short(v) -> list[float]:
    return [float(f"{x:.6g}") for x in v]


def lattice_notes(fluid: FluidSection) -> list[str]:
    """One line per block or wall whose particles put a face elsewhere than the scenario does
    (by more than ``ON_LATTICE`` l0): the key, the corners given and the corners filled."""
    l0 = fluid.spacing
    given = [*fluid.blocks, *fluid.walls]
    notes = []
    for item, (key, lo, hi) in zip(given, scene_corners(fluid), strict=True):
        moved = max(
            float(np.max(np.abs(np.asarray(item.lower) - lo))),
            float(np.max(np.abs(np.asarray(item.upper) - hi))),
        )
        if moved > ON_LATTICE * l0:
            name = f" ({item.name})" if getattr(item, "name", None) else ""
            notes.append(
                f"{key}{name}: lower = {list(item.lower)}, upper = {list(item.upper)} filled as "
                f"{_short(lo)} .. {_short(hi)} (whole spacings of {l0:.6g} m; faces moved by up "
                f"to {moved / l0:.3g} l0)"
            )
    return notes


def _lattice(lower: np.ndarray, counts: np.ndarray, l0: float, start: np.ndarray) -> np.ndarray:
    """Cell centres ``lower + (start + i + 1/2) l0`` for i in range(counts) per axis."""
    axes = [lower[k] + (start[k] + np.arange(counts[k]) + 0.5) * l0 for k in range(len(lower))]
    grid = np.meshgrid(*axes, indexing="ij")
    return np.stack([g.ravel() for g in grid], axis=1)


def fluid_block(lower, upper, l0: float) -> np.ndarray:
    """Fluid particle positions (n x dim, m) filling the box ``lower..upper`` (lattice corners:
    :func:`snap_to_lattice`)."""
    lo = np.asarray(lower, dtype=np.float64)
    counts = np.rint((np.asarray(upper) - lo) / l0).astype(np.int64)
    return _lattice(lo, counts, l0, np.zeros_like(counts))


def tank_walls(lower, upper, l0: float, layers: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Floor and side walls around the box ``lower..upper`` (top open).

    Returns positions (n x dim), layer index (n,) and normals towards the fluid (n x dim).
    """
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    d = lo.size
    counts = np.rint((hi - lo) / l0).astype(np.int64)
    start = -layers * np.ones(d, dtype=np.int64)
    ext = counts + 2 * layers
    ext[d - 1] = counts[d - 1] + layers  # no lid: the vertical axis starts below the floor only
    pts = _lattice(lo, ext, l0, start)
    idx = np.rint((pts - lo) / l0 - 0.5).astype(np.int64)  # lattice index relative to the box
    below = np.maximum(-idx, 0)  # layers behind the lower faces (1 = pressure layer)
    above = np.maximum(idx - counts + 1, 0)  # layers behind the upper faces
    depth = np.maximum(below, above)
    outside = depth.max(axis=1) > 0
    pts, depth, below, above = pts[outside], depth[outside], below[outside], above[outside]
    layer = depth.max(axis=1) - 1
    direction = (below > 0).astype(np.float64) - (above > 0).astype(np.float64)
    direction *= (below + above) == depth.max(axis=1, keepdims=True)
    normal = direction / np.linalg.norm(direction, axis=1, keepdims=True)
    return pts, layer, normal


def solid_box(lower, upper, l0: float, layers: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wall particles of a solid obstacle filling ``lower..upper`` to ``layers`` deep."""
    lo = np.asarray(lower, dtype=np.float64)
    hi = np.asarray(upper, dtype=np.float64)
    counts = np.rint((hi - lo) / l0).astype(np.int64)
    pts = _lattice(lo, counts, l0, np.zeros_like(counts))
    idx = np.rint((pts - lo) / l0 - 0.5).astype(np.int64)
    from_low = idx  # layers from the lower faces
    from_high = counts - 1 - idx
    depth = np.minimum(from_low, from_high)
    layer = depth.min(axis=1)
    keep = layer < layers
    pts, layer = pts[keep], layer[keep]
    from_low, from_high = from_low[keep], from_high[keep]
    nearest = layer[:, None]
    direction = -(from_low == nearest).astype(np.float64) + (from_high == nearest).astype(
        np.float64
    )
    norm = np.linalg.norm(direction, axis=1, keepdims=True)
    normal = np.divide(direction, norm, out=np.zeros_like(direction), where=norm > 0)
    return pts, layer, normal


def polygon_outline(vertices) -> np.ndarray:
    """The vertices (m) as an (n, 2) float64 array in counter-clockwise order (shoelace area
    positive); the schema has checked that they form a simple polygon."""
    v = np.asarray(vertices, dtype=np.float64)
    x, y = v[:, 0], v[:, 1]
    area2 = float(np.sum(x * np.roll(y, -1) - np.roll(x, -1) * y))  # shoelace formula
    return v if area2 > 0.0 else v[::-1].copy()


def inside_polygon(pts: np.ndarray, vertices) -> np.ndarray:
    """Mask of the points (m, (n, 2)) strictly inside the polygon (even-odd crossing rule; a point
    on the outline may fall either way)."""
    v = np.asarray(vertices, dtype=np.float64)
    x, y = pts[:, 0], pts[:, 1]
    inside = np.zeros(len(pts), dtype=bool)
    for a, b in zip(v, np.roll(v, -1, axis=0), strict=True):
        straddles = (a[1] > y) != (b[1] > y)
        with np.errstate(divide="ignore", invalid="ignore"):
            x_cross = a[0] + (y - a[1]) * (b[0] - a[0]) / (b[1] - a[1])
        inside ^= straddles & (x < x_cross)
    return inside


def outline_distance(pts: np.ndarray, vertices) -> np.ndarray:
    """Distance (m) of each point ((n, 2), m) to the polygon's outline (its nearest edge)."""
    v = np.asarray(vertices, dtype=np.float64)
    best = np.full(len(pts), np.inf)
    for a, b in zip(v, np.roll(v, -1, axis=0), strict=True):
        e = b - a
        s = np.clip((pts - a) @ e / float(e @ e), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(pts - (a + s[:, None] * e), axis=1))
    return best


def _first_apart(pts: np.ndarray, gap: float) -> np.ndarray:
    """Indices of the points kept when each is dropped if a point kept before it lies closer
    than ``gap`` (m), in order."""
    from scipy.spatial import cKDTree

    tree = cKDTree(pts)
    kept = np.zeros(len(pts), dtype=bool)
    for i in range(len(pts)):
        near = tree.query_ball_point(pts[i], gap * (1.0 - 1e-9))
        if not any(kept[j] for j in near if j < i):
            kept[i] = True
    return np.flatnonzero(kept)


def polygon_wall(vertices, l0: float, layers: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Wall particles of a solid 2D polygon (fluid outside) to ``layers`` deep, laid along its
    faces (module docstring). Returns positions (n x 2, m), layer index (n,) and unit normals
    towards the fluid (n x 2; meaningful on layer 0)."""
    v = polygon_outline(vertices)
    nv = len(v)
    edge = np.roll(v, -1, axis=0) - v
    tang = edge / np.linalg.norm(edge, axis=1, keepdims=True)
    out_n = np.stack([tang[:, 1], -tang[:, 0]], axis=1)  # outward normal of a CCW outline
    prev = np.roll(np.arange(nv), 1)
    # turn at vertex k from edge k-1 to edge k: > 0 convex, < 0 reflex (CCW outline)
    turn = tang[prev, 0] * tang[:, 1] - tang[prev, 1] * tang[:, 0]
    convex = turn >= -1e-12
    pts, lay, nrm = [], [], []
    for m in range(layers):
        d = (m + 0.5) * l0
        bis = out_n[prev] + out_n
        mitre = v - d * bis / (1.0 + np.sum(out_n[prev] * out_n, axis=1))[:, None]
        for k in range(nv):
            k1 = (k + 1) % nv
            start = mitre[k] if convex[k] else v[k] - d * out_n[k]
            end = mitre[k1] if convex[k1] else v[k1] - d * out_n[k]
            length = float((end - start) @ tang[k])
            if length < -1e-9 * l0:
                continue  # the polygon is thinner than this layer here
            count = max(1, round(length / l0))
            row = start + np.arange(count)[:, None] / count * (end - start)
            normals = np.repeat(out_n[k][None, :], count, axis=0)
            if convex[k]:
                normals[0] = bis[k] / np.linalg.norm(bis[k])
            pts.append(row)
            nrm.append(normals)
            lay.append(np.full(count, m))
            if not convex[k1]:  # reflex corner: an arc around the vertex to the next face
                a0 = math.atan2(out_n[k][1], out_n[k][0])
                a1 = math.atan2(out_n[k1][1], out_n[k1][0])
                sweep = (a1 - a0 + math.pi) % (2.0 * math.pi) - math.pi
                steps = max(1, round(abs(sweep) * d / l0))
                ang = a0 + sweep * np.arange(1, steps) / steps
                u = np.stack([np.cos(ang), np.sin(ang)], axis=1)
                pts.append(v[k1] - d * u)
                nrm.append(u)
                lay.append(np.full(len(u), m))
    if not pts:
        return np.zeros((0, 2)), np.zeros(0, dtype=np.int64), np.zeros((0, 2))
    pos, layer, normal = np.concatenate(pts), np.concatenate(lay), np.concatenate(nrm)
    depth = (layer + 0.5) * l0
    ok = inside_polygon(pos, v) & (outline_distance(pos, v) >= depth - 0.25 * l0)
    pos, layer, normal = pos[ok], layer[ok], normal[ok]
    keep = _first_apart(pos, 0.5 * l0)
    return pos[keep], layer[keep], normal[keep]


def _inside_any(pts: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]]) -> np.ndarray:
    mask = np.zeros(len(pts), dtype=bool)
    for lo, hi in boxes:
        mask |= np.all((pts > lo) & (pts < hi), axis=1)
    return mask


def _refuse_overlapping_walls(wall_pos: list[np.ndarray], patches: list[WallPatch], l0: float):
    """Raise when particles of the walls (``wall_pos[k]``: wall k's, m) share a site (walls
    overlapping: the kernel of the pair is singular or huge), naming the walls involved."""
    if not wall_pos:
        return
    owner = np.repeat(np.arange(len(wall_pos)), [len(p) for p in wall_pos])
    pos = np.concatenate(wall_pos)
    site = np.rint(pos / l0 * 1e3).astype(np.int64)  # 1e-3 l0 apart is the same site
    _, inverse, counts = np.unique(site, axis=0, return_inverse=True, return_counts=True)
    inverse = inverse.ravel()
    shared = counts[inverse] > 1
    if not shared.any():
        return
    same = np.flatnonzero(inverse == inverse[np.argmax(shared)])
    walls = " and ".join(
        f"fluid.walls[{k}] ({patches[k].name})" for k in np.unique(owner[same]).tolist()
    )
    where = [float(f"{x:.6g}") for x in pos[same[0]]]
    raise ValueError(
        f"{walls} put {len(same)} wall particles at {where}: the walls overlap "
        f"({int((counts > 1).sum())} shared sites); walls must not overlap, shorten or move one "
        "(a box resting on a tank's floor starts at the floor's face)"
    )


def _refuse_walls_near_polygons(
    wall_pos: list[np.ndarray], patches: list[WallPatch], walls: Sequence[Wall], l0: float
):
    """Raise when another wall's particle lies within l0 / 2 of a polygon wall's particle (off
    the lattice, an overlap need not share a site), naming both walls."""
    from scipy.spatial import cKDTree

    for k, w in enumerate(walls):
        if w.shape != "polygon" or len(wall_pos[k]) == 0:
            continue
        tree = cKDTree(wall_pos[k])
        for j, other in enumerate(wall_pos):
            if j == k or len(other) == 0:
                continue
            dist, _ = tree.query(other)
            if dist.min() < 0.5 * l0:
                where = [float(f"{x:.6g}") for x in other[int(np.argmin(dist))]]
                raise ValueError(
                    f"fluid.walls[{k}] ({patches[k].name}) and fluid.walls[{j}] "
                    f"({patches[j].name}) have particles {dist.min() / l0:.3g} l0 apart near "
                    f"{where}: the walls overlap or touch; keep them at least one spacing apart"
                )


def build_particles(fluid: FluidSection, external: Sequence[ExternalPatch] = ()) -> ParticleSet:
    """All particles of a scene: fluid first, then each wall's particles in scenario order, then
    the external patches."""
    l0 = fluid.spacing
    k = fluid.kernel
    max_re = max(k.re_density, k.re_gradient, k.re_laplacian, k.re_pressure)
    layers = fluid.dummy_layers + 1 if fluid.dummy_layers else default_dummy_layers(max_re)

    corners = [(lo, hi) for _, lo, hi in scene_corners(fluid)]
    block_corners = corners[: len(fluid.blocks)]
    wall_boxes = corners[len(fluid.blocks) :]
    solids = [c for c, w in zip(wall_boxes, fluid.walls, strict=True) if w.shape == "box"]
    polygons = [polygon_outline(w.vertices) for w in fluid.walls if w.shape == "polygon"]
    fluid_pts, fluid_vel = [], []
    for b, (lo, hi) in zip(fluid.blocks, block_corners, strict=True):
        pts = fluid_block(lo, hi, l0)
        pts = pts[~_inside_any(pts, solids)]
        for poly in polygons:  # inside or within l0/2: a lattice-aligned box face's gap
            near = outline_distance(pts, poly) < 0.5 * l0 * (1.0 - 1e-9)
            pts = pts[~(near | inside_polygon(pts, poly))]
        for ext in external:
            if ext.inside is not None:
                pts = pts[~np.asarray(ext.inside(pts), dtype=bool)]
        fluid_pts.append(pts)
        v = np.zeros_like(pts)
        if b.velocity is not None:
            v[:] = np.asarray(b.velocity, dtype=np.float64)
        fluid_vel.append(v)
    all_pos = np.concatenate(fluid_pts)
    all_vel = np.concatenate(fluid_vel)
    # overlapping blocks: keep the first particle at each lattice site, in generation order
    site = np.rint(all_pos / l0 * 1e6).astype(np.int64)
    _, first = np.unique(site, axis=0, return_index=True)
    keep = np.sort(first)
    fpos, fvel = all_pos[keep], all_vel[keep]
    d = fluid.dim

    pos = [fpos]
    vel = [fvel]
    kind = [np.full(len(fpos), FLUID, dtype=np.int8)]
    normal = [np.zeros_like(fpos)]
    patches: list[WallPatch] = []
    n = len(fpos)
    for i, (w, (lo, hi)) in enumerate(zip(fluid.walls, wall_boxes, strict=True)):
        if w.shape == "tank":
            pts, layer, nrm = tank_walls(lo, hi, l0, layers)
        elif w.shape == "polygon":
            pts, layer, nrm = polygon_wall(w.vertices, l0, layers)
        else:
            pts, layer, nrm = solid_box(lo, hi, l0, layers)
        kinds = np.where(layer == 0, WALL, DUMMY).astype(np.int8)
        pos.append(pts)
        vel.append(np.zeros_like(pts))
        kind.append(kinds)
        normal.append(np.where((layer == 0)[:, None], nrm, 0.0))
        patches.append(WallPatch(w.name or f"wall{i}", n, n + len(pts), w))
        n += len(pts)
    _refuse_overlapping_walls(pos[1:], patches, l0)
    _refuse_walls_near_polygons(pos[1:], patches, fluid.walls, l0)
    for ext in external:
        pos.append(np.asarray(ext.pos, dtype=np.float64))
        vel.append(np.zeros_like(pos[-1]))
        kind.append(np.asarray(ext.kind, dtype=np.int8))
        normal.append(np.asarray(ext.normal, dtype=np.float64))
        patches.append(WallPatch(ext.name, n, n + len(ext.pos), None))
        n += len(ext.pos)
    contact_wet = np.zeros(0, dtype=np.int8)
    if polygons:
        contact_wet = np.zeros(n, dtype=np.int8)
        for pt in patches:
            if pt.spec is not None and pt.spec.shape == "polygon":
                k = np.concatenate(kind)[pt.start : pt.stop]
                contact_wet[pt.start : pt.stop] = k == WALL
    out = ParticleSet(
        contact_wet=contact_wet,
        pos=np.ascontiguousarray(np.concatenate(pos)),
        vel=np.ascontiguousarray(np.concatenate(vel)),
        kind=np.concatenate(kind),
        normal=np.ascontiguousarray(np.concatenate(normal)),
        n_fluid=len(fpos),
        patches=patches,
    )
    assert out.pos.shape[1] == d
    return out


def _columns(pos: np.ndarray, kind: np.ndarray, up: np.ndarray, l0: float):
    """The fluid's lattice columns along ``up``: heights h, horizontal offsets, the column index
    of every fluid particle, and each column's top and bottom (its highest / lowest fluid
    particle plus / minus l0/2), all in m."""
    h = pos @ up
    horiz = pos - np.outer(h, up)
    fluid = kind == FLUID
    key = np.rint(horiz[fluid] / (0.5 * l0)).astype(np.int64)
    cols, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    top = np.full(len(cols), -np.inf)
    np.maximum.at(top, inv, h[fluid])
    bottom = np.full(len(cols), np.inf)
    np.minimum.at(bottom, inv, h[fluid])
    return h, horiz, fluid, inv, top + 0.5 * l0, bottom - 0.5 * l0


def hydrostatic_pressure(
    pos: np.ndarray, kind: np.ndarray, gravity: np.ndarray, rho: float, l0: float
) -> np.ndarray:
    """Initial pressure p = rho |g| (h_top - h) of still water (Pa).

    ``h`` is the height against gravity; ``h_top`` is the top of the fluid column the particle
    belongs to (highest fluid particle of the same lattice column plus l0/2). Wall pressure
    particles within 2 l0 of the fluid take the column of the nearest fluid particle across the
    horizontal axes; other wall and dummy particles get 0. A column that
    :func:`compress_still_water` moved gets its equilibrium pressure too: MPS's momentum
    equation carries the reference density, so still water's pressure is linear in height.
    """
    g = float(np.linalg.norm(gravity))
    p = np.zeros(len(pos))
    if g == 0.0:
        return p
    up = -np.asarray(gravity, dtype=np.float64) / g
    if not (kind == FLUID).any():
        return p
    h, horiz, fluid, inv, top, _ = _columns(pos, kind, up, l0)
    p[fluid] = rho * g * (top[inv] - h[fluid])
    wall = np.flatnonzero(kind == WALL)
    if wall.size:
        from scipy.spatial import cKDTree

        # only walls the water touches (a fluid particle within 2 l0) start wet
        dist, _ = cKDTree(pos[fluid]).query(pos[wall])
        wall = wall[dist < 2.0 * l0]
        _, nearest = cKDTree(horiz[fluid]).query(horiz[wall])
        p[wall] = rho * g * np.maximum(top[inv[nearest]] - h[wall], 0.0)
    return np.maximum(p, 0.0)


def compress_still_water(
    pos: np.ndarray,
    kind: np.ndarray,
    gravity: np.ndarray,
    rho: float,
    l0: float,
    strain_per_pa: float,
) -> float:
    """Move still water into its compressed equilibrium under gravity, in place.

    Weakly compressible MPS (pressure_poisson.py) holds still water at p = rho |g| (H' - h), H'
    the compressed column's top (its momentum equation carries the reference density rho), with
    every layer compressed by 1 + k p, k = ``strain_per_pa`` (1/Pa). Each lattice column keeps
    its bottom h_b (lowest fluid particle less l0/2) and its particles; the layer at
    uncompressed height z moves to h_b + u with z - h_b = u + a (D' u - u^2 / 2), a = k rho
    |g|, D' = (sqrt(1 + 2 a D) - 1) / a the compressed depth of a column D deep. Only heights
    change. Returns the largest drop of a column's top D - D' (m), a D^2 / 2 (1 - a D) to
    O((a D)^2).
    """
    g = float(np.linalg.norm(gravity))
    k = float(strain_per_pa)
    if g == 0.0 or k <= 0.0 or not (kind == FLUID).any():
        return 0.0
    up = -np.asarray(gravity, dtype=np.float64) / g
    h, _, fluid, inv, top, bottom = _columns(pos, kind, up, l0)
    a = k * rho * g
    depth = top - bottom
    compressed = np.sqrt(1.0 + 2.0 * a * depth) - 1.0  # a D'
    hf = h[fluid]
    b = 1.0 + compressed[inv]  # the quadratic a/2 u^2 - (1 + a D') u + (z - h_b) = 0
    u = (b - np.sqrt(b * b - 2.0 * a * (hf - bottom[inv]))) / a
    pos[fluid] += np.outer(bottom[inv] + u - hf, up)
    return float(np.max(depth - compressed / a))


def check_bounds(pos: np.ndarray, lower: np.ndarray, upper: np.ndarray) -> None:
    """Raise if any initial particle is outside the domain box."""
    bad = np.any((pos < lower) | (pos > upper), axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise ValueError(f"particle {i} at {pos[i].tolist()} lies outside the domain")
