"""Structure members as boundary particles of the MPS fluid (2D beams).

A member of the structure participant reaches the fluid as its interface mesh: the mid-line
nodes, segment cells and the geometric thickness T (what the fluid sees; structure_fem's
``geometric_thickness``). This module lays boundary particles along the member's geometric
surface, both faces, and moves them with the displacement the coupler writes.

Layout (member frame: arc length s in [0, L] along the tangent t from the first node, offset eta
along the normal n = (-t_y, t_x) of the structure; the faces are at eta = +-T/2):

- columns at s_a = (a + 1/2) h, h = L / round(L / l0) (h = l0 when L is a multiple of l0);
- each face ("side" +1: the face at +T/2, side -1: the face at -T/2) gets its own *virtual
  solid*: ``layers`` rows at depth (k + 1/2) l0 behind the face, eta = side (T/2 - (k + 1/2) l0),
  as if the member were a thick wall behind that face. Row 0 is the pressure layer (STRUCTURE),
  deeper rows are dummies (STRUCTURE_DUMMY). A member thinner than the kernel radius therefore
  has layers of one face reaching past the other face: :mod:`~mpsfem.fluid_mps.thin_member`
  keeps every particle of a side visible only to fluid on that side, so the fluid on each face
  sees a complete wall and never the fluid or the layers of the other face;
- a free end (one not touching a rigid wall of the fluid scene) closes each virtual solid with an
  end cap: the columns within ``layers`` of the end take the layer index of their distance from
  the end (as in :func:`~mpsfem.fluid_mps.geometry.solid_box`), and in a member thicker than
  2 ``layers`` l0 they reach down to the mid-plane (:func:`cap_rows`), so the cap covers the
  whole end face. Cap particles of the pressure
  layer carry pressure where they lie on the side's own half of the end face (depth <= T/2);
  the rest of the cap are dummies;
- each side of each member is one external patch (``"<member>+"`` / ``"<member>-"``), so a
  dummy's pressure / dry-state source is always a pressure particle of its own face.

The coupler's interface points are the pressure-layer particles (both faces, caps included), in
patch order, in the reference configuration. Their displacement and velocity are the mapped
values the coupler writes. Dummies follow rigidly: a dummy at depth offset d eta behind the
pressure particle of its column moves with it plus the exact rotation of the cross-section,
(R(theta) - I)(d eta n), where theta is the rotation of the column's current mid-line tangent
from the reference tangent t (atan2, unwrapped along the member), the mid-line being the column
mid-points x_mid = mean of the two faces' pressure particles (their rigid-link offsets cancel).
Velocity: its rate, omega z x R(theta)(d eta n) with omega = (x_mid' x v_mid') / |x_mid'|^2
(' = d/ds). For small rotations this is the linear link theta (z x d eta n) with theta the
slope of the mid-line deflection, to O(theta^2).

Force on the structure (fluid on structure, N/m in 2D): F_i = -p_i A_i n_i on every
pressure-layer particle (thesis eq. 2-51 with A_i = l0^(d-1): here h for a face particle, l0 for
an end-cap particle, both for a corner particle with the summed area vector); n_i points out of
the structure into the fluid and turns with its column, n_i = R(theta) n_i^ref (rigid
cross-sections; the same rotated normals are written to the solver's ``normal`` rows of the
structure patches, which its force probes use). Dry particles have p = 0 and give no force.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.fluid_mps.geometry import ExternalPatch, default_dummy_layers
from mpsfem.fluid_mps.particle_kinds import STRUCTURE, STRUCTURE_DUMMY
from mpsfem.fluid_mps.thin_member import body_half
from mpsfem.scenario.fluid import FluidSection

__all__ = [
    "InterfaceMotionInputs",
    "MemberFrame",
    "SideLayout",
    "StructureSurface",
    "members_from_interface",
]

#: fluid particles closer than this fraction of l0 to a face (or a free end) are not generated
FACE_MARGIN = 0.5 - 1e-6


class InterfaceMotionInputs:
    """The fluid participants' ``write``: the structure's interface displacement and velocity
    for the end of the next step, checked (shape, finiteness) and kept in ``_d`` / ``_v``."""

    _d: np.ndarray
    _v: np.ndarray

    def write(self, name: str, array: np.ndarray) -> None:
        """``"displacement"`` (m) or ``"velocity"`` (m/s), (n_interface, dim), for the end of
        the next step."""
        arr = np.array(array, dtype=np.float64)
        if arr.shape != self._d.shape:
            raise ValueError(f"fluid {name} of shape {arr.shape}, expected {self._d.shape}")
        if not np.isfinite(arr).all():
            raise FloatingPointError(f"non-finite {name} written to the fluid")
        if name == "displacement":
            self._d = arr
        elif name == "velocity":
            self._v = arr
        else:
            raise KeyError(f"the fluid takes 'displacement' or 'velocity', not {name!r}")


@dataclass(frozen=True)
class MemberFrame:
    """A straight 2D member in its reference configuration.

    origin: first node (m); tangent, normal: unit vectors (normal = tangent turned 90 degrees
    anticlockwise, the structure's convention); length L (m); thickness T (m, as the fluid sees
    it); free_start / free_end: whether an end cap closes the member at s = 0 / s = L; nodes:
    slice of the structure's interface points that belong to this member.
    """

    name: str
    origin: np.ndarray
    tangent: np.ndarray
    normal: np.ndarray
    length: float
    thickness: float
    free_start: bool
    free_end: bool
    nodes: slice

    def local(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(s, eta) of scene points: arc length along the tangent and offset along the normal."""
        r = np.asarray(points, dtype=np.float64) - self.origin
        return r @ self.tangent, r @ self.normal

    def inside(self, points: np.ndarray, margin: float) -> np.ndarray:
        """Points in the body or within ``margin`` of its faces (and of its free ends)."""
        s, eta = self.local(points)
        lo = -margin if self.free_start else 0.0
        hi = self.length + (margin if self.free_end else 0.0)
        return (np.abs(eta) < 0.5 * self.thickness + margin) & (s > lo) & (s < hi)


def members_from_interface(mesh, names: Sequence[str] | None = None) -> list[tuple]:
    """Split a 2D interface mesh into straight members: connected chains of its line cells,
    ordered by their first point index (structure_fem concatenates members in scenario order).

    Returns (name, node indices along the chain, thickness) per member. Raises ValueError for a
    3D mesh, a mesh without line cells, a branched or closed chain, or a curved one.
    """
    m = as_interface_mesh(mesh)
    if m.dim != 2:
        raise ValueError(
            "the fluid participant lays structure surfaces for 2D beam members only; a 3D "
            "(plate) interface is not supported yet"
        )
    lines = m.cells.get("line")
    if lines is None or lines.size == 0:
        raise ValueError("the structure interface has no line cells (2D beam members expected)")
    n = m.n_points
    adj: list[list[int]] = [[] for _ in range(n)]
    for a, b in lines:
        adj[int(a)].append(int(b))
        adj[int(b)].append(int(a))
    seen = np.zeros(n, dtype=bool)
    chains = []
    for start in range(n):
        if seen[start] or not adj[start]:
            continue
        # walk to one end of this component, then along it
        comp = _component(adj, start)
        ends = [i for i in comp if len(adj[i]) == 1]
        if any(len(adj[i]) > 2 for i in comp) or len(ends) != 2:
            raise ValueError(
                f"structure interface points {sorted(comp)[:6]}...: a member must be an open "
                "chain of segments (no branches, no loops)"
            )
        chain = [min(ends)]
        prev = -1
        while len(chain) < len(comp):
            nxt = [j for j in adj[chain[-1]] if j != prev]
            prev = chain[-1]
            chain.append(nxt[0])
        seen[comp] = True
        chains.append(np.array(chain, dtype=np.int64))
    chains.sort(key=lambda c: int(c.min()))
    if names is not None and len(names) != len(chains):
        raise ValueError(
            f"the structure interface holds {len(chains)} member(s) but {len(names)} name(s) "
            f"were given: {list(names)}"
        )
    out = []
    for k, chain in enumerate(chains):
        pts = m.points[chain]
        d = pts[-1] - pts[0]
        L = float(np.hypot(*d))
        t = d / L
        off = (pts - pts[0]) @ np.array([-t[1], t[0]])
        if np.abs(off).max() > 1e-9 * max(L, 1.0):
            raise ValueError(f"member {k}: the fluid participant needs straight members")
        name = names[k] if names is not None else f"member{k}"
        out.append((name, chain, float(m.thickness[chain].max())))
    return out


def _rotate(v: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Vectors v (n, 2) turned anticlockwise by theta (n,) rad: R(theta) v."""
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1]], axis=1)


def _component(adj: list[list[int]], start: int) -> list[int]:
    stack, comp, seen = [start], [], {start}
    while stack:
        i = stack.pop()
        comp.append(i)
        for j in adj[i]:
            if j not in seen:
                seen.add(j)
                stack.append(j)
    return comp


def wall_clearance(point: np.ndarray, fluid: FluidSection) -> float:
    """Distance (m) from a scene point to the nearest rigid wall of the fluid scene: a 'box'
    obstacle (0 inside it) or the floor / side walls of a 'tank' (0 outside its open box)."""
    p = np.asarray(point, dtype=np.float64)
    best = math.inf
    for w in fluid.walls:
        lo, hi = np.asarray(w.lower, float), np.asarray(w.upper, float)
        if w.shape == "box":
            gap = np.maximum(np.maximum(lo - p, p - hi), 0.0)
            best = min(best, float(np.linalg.norm(gap)))
        else:
            inside = np.all(p[:-1] > lo[:-1]) and np.all(p[:-1] < hi[:-1]) and p[-1] > lo[-1]
            if not inside:
                return 0.0
            best = min(best, float(min((p[:-1] - lo[:-1]).min(), (hi[:-1] - p[:-1]).min())))
            best = min(best, float(p[-1] - lo[-1]))
    return best


@dataclass
class SideLayout:
    """The particles of one side's virtual solid (reference configuration).

    kind: STRUCTURE / STRUCTURE_DUMMY; normal: unit normals out of the structure (zeros for
    dummies); area: the area vector A_i n_i of pressure particles (m in 2D; zeros for dummies);
    column: column index a; row: layer k; eta: offset from the mid-line (m)."""

    member: int
    side: int
    pos: np.ndarray
    kind: np.ndarray
    normal: np.ndarray
    area: np.ndarray
    column: np.ndarray
    row: np.ndarray
    eta: np.ndarray


def cap_rows(thickness: float, l0: float, layers: int) -> int:
    """Rows of a side's virtual solid in the columns of an end cap: ``layers``, or as many as
    reach the member's mid-plane (a thick member: T > 2 layers l0), so the cap closes the whole
    end face (no hole between the two sides' solids wider than a spacing)."""
    return max(layers, int(np.floor(thickness / (2.0 * l0) - 0.5 + 1e-9)) + 1)


def lay_side(frame: MemberFrame, member: int, side: int, l0: float, layers: int) -> SideLayout:
    """Particles of the virtual solid behind face ``side`` (+1 or -1) of a member."""
    L, T = frame.length, frame.thickness
    ncol = max(1, int(round(L / l0)))
    h = L / ncol
    rows = cap_rows(T, l0, layers)
    a = np.repeat(np.arange(ncol), rows)
    k = np.tile(np.arange(rows), ncol)
    from_start = a if frame.free_start else np.full_like(a, 1 << 30)
    from_end = (ncol - 1 - a) if frame.free_end else np.full_like(a, 1 << 30)
    d_end = np.minimum(from_start, from_end)
    keep = (k < layers) | (d_end < layers)  # rows past `layers` only fill the end caps
    a, k, from_start, from_end, d_end = (x[keep] for x in (a, k, from_start, from_end, d_end))
    s = (a + 0.5) * h
    depth = (k + 0.5) * l0
    eta = side * (0.5 * T - depth)
    layer = np.minimum(k, d_end)
    on_face = k == 0
    on_cap = (d_end == 0) & (depth <= 0.5 * T + 1e-12 * max(T, l0))
    pressure = (layer == 0) & (on_face | on_cap)
    t, n = frame.tangent, frame.normal
    # outward direction of the end face a column is on (0 if none)
    cap_dir = np.zeros((a.size, 2))
    cap_dir[from_end == 0] += t
    cap_dir[from_start == 0] -= t
    area = np.zeros((a.size, 2))
    area[on_face] += side * n * h  # face particle: its share h of the face
    cap = pressure & (d_end == 0)
    area[cap] += cap_dir[cap] * l0  # end-cap particle: l0 of the end face
    norm = np.linalg.norm(area, axis=1, keepdims=True)
    pressure &= norm[:, 0] > 0.0
    area[~pressure] = 0.0
    normal = np.divide(area, norm, out=np.zeros_like(area), where=norm > 0)
    pos = frame.origin + s[:, None] * t + eta[:, None] * n
    kind = np.where(pressure, STRUCTURE, STRUCTURE_DUMMY).astype(np.int8)
    return SideLayout(member, side, pos, kind, normal, area, a.astype(np.int64), k, eta)


class StructureSurface:
    """The boundary particles of every structure member, their motion and their forces.

    Parameters
    ----------
    interface:
        The structure participant's interface mesh (reference configuration; an
        :class:`~mpsfem.coupler.participant.InterfaceMesh` or anything
        :func:`~mpsfem.coupler.participant.as_interface_mesh` accepts).
    fluid:
        The ``[fluid]`` section (spacing, kernel radii, walls).
    names:
        Member names in interface order (default ``member0``, ...).
    free_ends:
        Per member (free at s = 0, free at s = L); default: an end is free unless it lies within
        one spacing of a rigid wall of the fluid scene.
    """

    def __init__(
        self,
        interface,
        fluid: FluidSection,
        names: Sequence[str] | None = None,
        free_ends: Sequence[tuple[bool, bool]] | None = None,
    ) -> None:
        mesh = self._setup(interface, fluid)
        l0 = self.l0
        self.frames: list[MemberFrame] = []
        for i, (name, chain, T) in enumerate(members_from_interface(mesh, names)):
            p0, p1 = mesh.points[chain[0]], mesh.points[chain[-1]]
            L = float(np.hypot(*(p1 - p0)))
            t = (p1 - p0) / L
            n = np.array([-t[1], t[0]])
            if free_ends is not None:
                fs, fe = free_ends[i]
            else:
                fs = wall_clearance(p0, fluid) > l0
                fe = wall_clearance(p1, fluid) > l0
            lo, hi = int(chain.min()), int(chain.max()) + 1
            if not np.array_equal(np.sort(chain), np.arange(lo, hi)):
                raise ValueError(f"member {name!r}: its interface points are not contiguous")
            self.frames.append(
                MemberFrame(name, p0.copy(), t, n, L, T, bool(fs), bool(fe), slice(lo, hi))
            )
        self.sides = [
            lay_side(f, i, side, l0, self.layers)
            for i, f in enumerate(self.frames)
            for side in (+1, -1)
        ]

    def _setup(self, interface, fluid: FluidSection) -> InterfaceMesh:
        """Common set-up: the mesh, l0 and the layer count (enough for the largest kernel)."""
        mesh = as_interface_mesh(interface)
        self.structure_mesh = mesh
        self.l0 = float(fluid.spacing)
        k = fluid.kernel
        max_re = max(k.re_density, k.re_gradient, k.re_laplacian, k.re_pressure)
        self.layers = fluid.dummy_layers + 1 if fluid.dummy_layers else default_dummy_layers(max_re)
        self.bound = False
        return mesh

    # ------------------------------------------------------------------ fluid set-up
    @property
    def names(self) -> list[str]:
        return [f.name for f in self.frames]

    @staticmethod
    def patch_name(member: str, side: int) -> str:
        return f"{member}{'+' if side > 0 else '-'}"

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Fluid lattice points the members occupy (or closer than FACE_MARGIN l0 to a face)."""
        mask = np.zeros(len(points), dtype=bool)
        for f in self.frames:
            mask |= f.inside(points, FACE_MARGIN * self.l0)
        return mask

    def patches(self) -> list[ExternalPatch]:
        """External patches for :class:`~mpsfem.fluid_mps.solver.FluidSolver`, one per side."""
        out = []
        for j, sl in enumerate(self.sides):
            out.append(
                ExternalPatch(
                    self.patch_name(self.frames[sl.member].name, sl.side),
                    sl.pos,
                    sl.kind,
                    sl.normal,
                    self.inside if j == 0 else None,
                )
            )
        return out

    def bind(self, solver) -> None:
        """Record where the patches landed in ``solver``'s particle arrays and build the index
        arrays of the motion and force maps."""
        starts = []
        for sl in self.sides:
            pt = solver.patch(self.patch_name(self.frames[sl.member].name, sl.side))
            if pt.stop - pt.start != len(sl.pos):
                raise RuntimeError("structure patch size mismatch")
            starts.append(pt.start)
        self.n_particles = solver.n
        glob = [st + np.arange(len(sl.pos)) for st, sl in zip(starts, self.sides, strict=True)]
        self.index = np.concatenate(glob)  # every structure particle, patch order
        self.ref = np.concatenate([sl.pos for sl in self.sides])
        kind = np.concatenate([sl.kind for sl in self.sides])
        press = kind == STRUCTURE
        self.interface_local = np.flatnonzero(press)  # into the structure-particle arrays
        self.interface_index = self.index[press]  # into the solver's arrays
        self.interface_normals = np.concatenate([sl.normal for sl in self.sides])[press]
        self.interface_area = np.concatenate([sl.area for sl in self.sides])[press]
        self.interface_member = np.concatenate(
            [np.full(len(sl.pos), sl.member) for sl in self.sides]
        )[press]
        # per member: columns' face pressure particles of side +1 and -1 (local indices)
        offs = np.cumsum([0] + [len(sl.pos) for sl in self.sides])
        self.col_plus, self.col_minus = [], []
        for m in range(len(self.frames)):
            plus, minus = self.sides[2 * m], self.sides[2 * m + 1]
            self.col_plus.append(offs[2 * m] + np.flatnonzero(plus.row == 0))
            self.col_minus.append(offs[2 * m + 1] + np.flatnonzero(minus.row == 0))
        # position of each structure particle within its column: the face particle it follows
        loc_of_if = np.full(len(self.ref), -1, dtype=np.int64)
        loc_of_if[self.interface_local] = np.arange(self.interface_local.size)
        src, dn, col, mem = [], [], [], []
        for j, sl in enumerate(self.sides):
            face = offs[j] + np.flatnonzero(sl.row == 0)  # by column
            src.append(face[sl.column])
            dn.append(sl.eta - sl.eta[sl.row == 0][sl.column])
            col.append(sl.column)
            mem.append(np.full(len(sl.pos), sl.member))
        self.follow = np.concatenate(src)  # local index of the face particle each one follows
        self.offset = np.concatenate(dn)  # eta offset from it (m)
        self.column = np.concatenate(col)
        self.member_of_local = np.concatenate(mem)
        self.is_interface = loc_of_if >= 0
        # per member: its dummies' local indices, columns, offsets and followed face particles
        self._dummies = []
        for m in range(len(self.frames)):
            sel = np.flatnonzero((self.member_of_local == m) & ~self.is_interface)
            self._dummies.append((sel, self.column[sel], self.offset[sel], self.follow[sel]))
        self._u = np.zeros_like(self.ref)
        self._v = np.zeros_like(self.ref)
        self._theta = np.zeros(len(self.ref))
        self.normal_ref = np.concatenate([sl.normal for sl in self.sides])
        self.patch_ranges = [
            (self.patch_name(self.frames[sl.member].name, sl.side), slice(o, o + len(sl.pos)))
            for sl, o in zip(self.sides, offs[:-1], strict=True)
        ]
        # labels for the neighbour filter, over the solver's particles
        self.member_of = np.full(solver.n, -1, dtype=np.int32)
        self.side_of = np.zeros(solver.n, dtype=np.int8)
        self.half = np.zeros(solver.n, dtype=np.int8)
        for st, sl in zip(starts, self.sides, strict=True):
            self.member_of[st : st + len(sl.pos)] = sl.member
            self.side_of[st : st + len(sl.pos)] = sl.side
            # +1: on the side's own half of the body, 0: the row on the mid-line or less than
            # l0/2 past it, -1: farther past it (thin_member.body_half)
            self.half[st : st + len(sl.pos)] = body_half(sl.side, sl.eta, self.l0)
        self.bound = True

    # ------------------------------------------------------------------ coupler view
    def interface_mesh(self) -> InterfaceMesh:
        """The fluid's interface points: pressure-layer particles, reference configuration."""
        return InterfaceMesh(self.ref[self.interface_local], self.interface_normals)

    @property
    def n_interface(self) -> int:
        return int(self.interface_local.size)

    # ------------------------------------------------------------------ motion
    def _rigid_link(self, vals_if: np.ndarray, out: np.ndarray) -> None:
        """Linear rigid link (the geometrically linear members of a subclass, 3D plates
        override it): dummies follow their face particle plus theta (z x d eta n), theta the
        slope of the mid-line value's normal component. Not used for 2D beams (see
        :meth:`_rigid_motion`); kept as the small-rotation reference of the tests."""
        out[self.interface_local] = vals_if
        for m, f in enumerate(self.frames):
            mid = 0.5 * (out[self.col_plus[m]] + out[self.col_minus[m]])
            w = mid @ f.normal
            h = f.length / len(self.col_plus[m])  # column spacing (m)
            theta = np.gradient(w, h) if w.size > 1 else np.zeros_like(w)
            sel, col, off, fol = self._dummies[m]
            # z x (d_eta n) = d_eta (-n_y, n_x)
            out[sel] = out[fol] + (theta[col] * off)[:, None] * np.array(
                [-f.normal[1], f.normal[0]]
            )

    def _rigid_motion(self, u_if: np.ndarray, v_if: np.ndarray) -> None:
        """Fill ``self._u``, ``self._v`` (every structure particle) from the interface points'
        displacement (m) and velocity (m/s): pressure particles take them as given, dummies turn
        rigidly with their column (module docstring); ``self._theta`` gets each particle's
        column rotation (rad)."""
        u, v = self._u, self._v
        u[self.interface_local] = u_if
        v[self.interface_local] = v_if
        for m, f in enumerate(self.frames):
            theta, omega = self._column_rotation(m, f)
            sel, col, off, fol = self._dummies[m]
            d = off[:, None] * f.normal  # d eta n, reference offset from the face particle
            Rd = _rotate(d, theta[col])
            # rigid cross-section: u = u_face + (R(theta) - I) d; v = v_face + omega z x R d
            u[sel] = u[fol] + Rd - d
            v[sel] = v[fol] + omega[col][:, None] * np.stack([-Rd[:, 1], Rd[:, 0]], axis=1)
            mine = self.member_of_local == m
            self._theta[mine] = theta[self.column[mine]]

    def _column_rotation(self, m: int, f: MemberFrame) -> tuple[np.ndarray, np.ndarray]:
        """Per column of member m: rotation theta (rad, unwrapped along the member) of the
        current mid-line from the reference tangent, and its rate omega (rad/s), from
        ``self._u`` / ``self._v`` at the face pressure particles."""
        cp, cm = self.col_plus[m], self.col_minus[m]
        if len(cp) > 1:
            h = f.length / len(cp)  # column spacing (m)
            x = 0.5 * (self.ref[cp] + self.ref[cm] + self._u[cp] + self._u[cm])
            g = np.gradient(x, h, axis=0)  # current tangent dx_mid/ds
            gd = np.gradient(0.5 * (self._v[cp] + self._v[cm]), h, axis=0)
            ref = f.tangent
        else:
            # one column: the segment from the -1 face particle to the +1 one (a normal fibre)
            g = self.ref[cp] + self._u[cp] - self.ref[cm] - self._u[cm]
            gd = self._v[cp] - self._v[cm]
            ref = self.ref[cp[0]] - self.ref[cm[0]]
            if np.linalg.norm(ref) < 1e-3 * self.l0:  # faces' particles coincide: no fibre
                return np.zeros(1), np.zeros(1)
        cross = ref[0] * g[:, 1] - ref[1] * g[:, 0]
        # rotation of the tangent (Crisfield 1991, vol. 1, sec. 7.2), continuous along s
        theta = np.unwrap(np.arctan2(cross, g @ ref))
        # d/dt atan2: (g x g_dot) / |g|^2
        omega = (g[:, 0] * gd[:, 1] - g[:, 1] * gd[:, 0]) / np.einsum("kd,kd->k", g, g)
        return theta, omega

    def place(self, solver, displacement: np.ndarray, velocity: np.ndarray) -> None:
        """Put every structure particle at ``ref + u`` with velocity ``v`` for the end of the
        solver's next step and turn its normal with its column; ``displacement``, ``velocity``:
        (n_interface, dim) at the interface points (m, m/s)."""
        if self.ref.shape[1] == 2:
            self._rigid_motion(displacement, velocity)
        else:  # plates (a subclass): the linear link, reference normals
            self._rigid_link(displacement, self._u)
            self._rigid_link(velocity, self._v)
        pos = self.ref + self._u
        for name, sl in self.patch_ranges:
            solver.set_patch_state(name, pos[sl], self._v[sl])
        if self.ref.shape[1] == 2:
            solver.normal[self.index] = _rotate(self.normal_ref, self._theta)

    @property
    def rotation(self) -> np.ndarray:
        """Column rotation (rad) of every structure particle at the last :meth:`place`."""
        return self._theta

    def current_area(self) -> np.ndarray:
        """Area vectors A_i n_i of the interface points turned with their columns (m in 2D;
        plates: the reference ones)."""
        if self.ref.shape[1] != 2:
            return self.interface_area
        return _rotate(self.interface_area, self._theta[self.interface_local])

    # ------------------------------------------------------------------ forces
    def forces(self, p: np.ndarray) -> np.ndarray:
        """F_i = -p_i A_i n_i at the interface points (N/m in 2D): fluid on structure."""
        return -p[self.interface_index, None] * self.current_area()

    def member_force(self, p: np.ndarray, member: str) -> np.ndarray:
        """Total fluid force on a member, both faces summed (N/m in 2D)."""
        m = self.names.index(member)
        f = self.forces(p)[self.interface_member == m]
        return f.sum(axis=0)

    # ------------------------------------------------------------------ thin-member filter
    def anchors(self, pos: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Current mid-line polylines: per member the column mid-points (mean of the two faces'
        pressure particles) plus both ends extrapolated; (points (n, 2), pointer (M + 1,))."""
        pts, ptr = [], [0]
        for m, f in enumerate(self.frames):
            mid = 0.5 * (pos[self.index[self.col_plus[m]]] + pos[self.index[self.col_minus[m]]])
            if len(mid) > 1:
                first = 1.5 * mid[0] - 0.5 * mid[1]
                last = 1.5 * mid[-1] - 0.5 * mid[-2]
            else:
                half = 0.5 * f.length * f.tangent
                first, last = mid[0] - half, mid[0] + half
            poly = np.vstack([first, mid, last])
            pts.append(poly)
            ptr.append(ptr[-1] + len(poly))
        return np.ascontiguousarray(np.vstack(pts)), np.array(ptr, dtype=np.int64)
