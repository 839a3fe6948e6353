"""Neighbour filtering across structure members: nothing interacts through a member.

A member thinner than the kernel radius (the thesis's 0.015 m plate at l0 = 0.004 m is under four
spacings) would let fluid on one face see the fluid on the other face, and the layers of each
face's virtual solid (see :mod:`~mpsfem.fluid_mps.structure_surface`) reach past the other face.
This filter runs after every neighbour search (``FluidSolver(neighbour_filter=...)``) and drops
the pairs that would act through a member, in place:

1. two particles of the same member but of different sides (their layers may overlap in space);
2. a member particle of side s and a fluid particle beside the member on the other side of its
   mid-line (fluid beside a member sees only the virtual solid of its own face). Beyond a free
   end the virtual layers would overlap the fluid that wraps round the end, so fluid there sees
   the body once: each side's particles on its own half of the body, and its own side's row
   nearest the mid-line when that row lies on the mid-line or less than half a spacing past it
   (:func:`body_half`; a member thinner than l0 has no row on its own half, and its tip would
   otherwise be invisible from beyond the end). The member particles' own rows keep all fluid
   beyond the end (a pressure particle at the end then has a full neighbourhood and is not
   taken for a dry, free-surface one); this is the only place where the list is not symmetric;
3. two fluid particles whose connecting segment crosses a member's mid-line: both beside the
   member on opposite sides, or, near an end, a segment that intersects the mid-line polyline.

Pairs with rigid walls and with other members are kept. The side of a particle is the sign of its
offset along the normal of the nearest segment of the member's *current* mid-line polyline (the
column mid-points of the two faces' pressure particles, ends extrapolated); beyond an end the
extended line decides the side, and rule 3 uses the exact segment test. Only particles within
``radius + (largest offset of the member's particles)`` of a polyline are classified, so the
cost is that of the particles near members; rows of all other particles are kept unchanged.

The filter keeps each row's ascending order, so the list stays a function of the positions
(bit-identical for any thread count).
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit, prange

from mpsfem.fluid_mps.neighbours import NeighbourList

__all__ = ["ThinMemberFilter", "body_half", "classify_sides", "segment_crosses_polyline"]

#: buffer headroom when the neighbour count grows
HEADROOM = 1.1


def body_half(side: int, eta: np.ndarray, l0: float) -> np.ndarray:
    """Half of the body each particle of one side's virtual solid is on, for rule 2 beyond an
    end: +1 on the side's own half (side * eta > 0), 0 on the mid-line or less than l0 / 2 past
    it (the row fluid beyond the end sees from that side), -1 farther past it. ``eta``: offsets
    from the mid-line / mid-surface (m)."""
    own = side * np.asarray(eta, dtype=np.float64)
    tol = 1e-9 * l0
    return np.where(own > tol, 1, np.where(own > -0.5 * l0 + tol, 0, -1)).astype(np.int8)


@njit(cache=True, parallel=True)
def classify_sides(pos, anchors, aptr, reach, side):
    """side[i, m] for every particle i and member m (polyline ``anchors[aptr[m]:aptr[m+1]]``):
    0 if i is farther than ``reach[m]`` from the polyline, otherwise +-1 (its projection lies
    within the member, sign of the offset along the nearest segment's normal n = (-e_y, e_x))
    or +-2 (beyond an end; sign on the extended end segment)."""
    n = pos.shape[0]
    nm = aptr.shape[0] - 1
    lo = np.empty((nm, 2))
    hi = np.empty((nm, 2))
    for m in range(nm):
        for a in range(2):
            lo[m, a] = np.inf
            hi[m, a] = -np.inf
        for q in range(aptr[m], aptr[m + 1]):
            for a in range(2):
                lo[m, a] = min(lo[m, a], anchors[q, a] - reach[m])
                hi[m, a] = max(hi[m, a], anchors[q, a] + reach[m])
    for i in prange(n):
        x = pos[i, 0]
        y = pos[i, 1]
        for m in range(nm):
            side[i, m] = 0
            if x < lo[m, 0] or x > hi[m, 0] or y < lo[m, 1] or y > hi[m, 1]:
                continue
            best = np.inf
            best_q = -1
            best_u = 0.0
            for q in range(aptr[m], aptr[m + 1] - 1):
                ex = anchors[q + 1, 0] - anchors[q, 0]
                ey = anchors[q + 1, 1] - anchors[q, 1]
                rx = x - anchors[q, 0]
                ry = y - anchors[q, 1]
                l2 = ex * ex + ey * ey
                u = (rx * ex + ry * ey) / l2 if l2 > 0.0 else 0.0
                uc = min(max(u, 0.0), 1.0)
                dx = rx - uc * ex
                dy = ry - uc * ey
                d2 = dx * dx + dy * dy
                if d2 < best:
                    best = d2
                    best_q = q
                    best_u = u
            if best >= reach[m] * reach[m]:
                continue
            q = best_q
            ex = anchors[q + 1, 0] - anchors[q, 0]
            ey = anchors[q + 1, 1] - anchors[q, 1]
            cross = ex * (y - anchors[q, 1]) - ey * (x - anchors[q, 0])  # e x r = |e| eta
            s = 1 if cross >= 0.0 else -1
            beyond = (q == aptr[m] and best_u < 0.0) or (q == aptr[m + 1] - 2 and best_u > 1.0)
            side[i, m] = 2 * s if beyond else s


@njit(cache=True, inline="always")
def _orient(ax, ay, bx, by, cx, cy):
    return (bx - ax) * (cy - ay) - (by - ay) * (cx - ax)


@njit(cache=True)
def segment_crosses_polyline(ax, ay, bx, by, anchors, q0, q1):
    """True if segment a-b intersects any segment of the polyline ``anchors[q0:q1]``."""
    for q in range(q0, q1 - 1):
        px, py = anchors[q, 0], anchors[q, 1]
        qx, qy = anchors[q + 1, 0], anchors[q + 1, 1]
        d1 = _orient(px, py, qx, qy, ax, ay)
        d2 = _orient(px, py, qx, qy, bx, by)
        if (d1 > 0.0 and d2 > 0.0) or (d1 < 0.0 and d2 < 0.0):
            continue
        d3 = _orient(ax, ay, bx, by, px, py)
        d4 = _orient(ax, ay, bx, by, qx, qy)
        if (d3 > 0.0 and d4 > 0.0) or (d3 < 0.0 and d4 < 0.0):
            continue
        if d1 == 0.0 and d2 == 0.0:  # collinear: no crossing from one side to the other
            continue
        return True
    return False


@njit(cache=True, inline="always")
def _sign(v):
    return 1 if v > 0 else (-1 if v < 0 else 0)


@njit(cache=True, inline="always")
def _fluid_sees(c, side_j, half_j):
    """Rule 2, row of a fluid particle classified ``c`` (see classify_sides): may it see a member
    particle of side ``side_j`` on half ``half_j`` of the body?"""
    if c == 0:
        return True
    if c == 1 or c == -1:
        return _sign(c) == side_j
    return half_j == 1 or (half_j == 0 and side_j == _sign(c))


@njit(cache=True, inline="always")
def _member_sees(c, side_i):
    """Rule 2, row of a member particle of side ``side_i``: may it see a fluid particle
    classified ``c``? (All fluid beyond an end, fluid beside the member on its own side.)"""
    return c == 0 or c == 2 or c == -2 or _sign(c) == side_i


@njit(cache=True, inline="always")
def rules_1_2(i, j, kind, member_of, side_of, half, side):
    """Rules 1 and 2 of the module docstring for the pair (row i, neighbour j): 1 keep, 0 drop,
    -1 both are fluid particles (rule 3 decides)."""
    mi = member_of[i]
    mj = member_of[j]
    if mi >= 0 and mj >= 0:
        return 0 if (mi == mj and side_of[i] != side_of[j]) else 1  # rule 1
    if mi >= 0:
        return 1 if (kind[j] != 0 or _member_sees(side[j, mi], side_of[i])) else 0
    if mj >= 0:
        return 1 if (kind[i] != 0 or _fluid_sees(side[i, mj], side_of[j], half[j])) else 0
    if kind[i] != 0 or kind[j] != 0:
        return 1
    return -1


@njit(cache=True, inline="always")
def _allowed(i, j, pos, kind, member_of, side_of, half, side, anchors, aptr):
    """May row i keep neighbour j? (rules of the module docstring)"""
    r = rules_1_2(i, j, kind, member_of, side_of, half, side)
    if r >= 0:
        return r == 1
    for m in range(side.shape[1]):  # rule 3
        si = side[i, m]
        sj = side[j, m]
        if si == 0 or sj == 0 or _sign(si) == _sign(sj):
            continue
        if abs(si) == 1 and abs(sj) == 1:
            return False
        if segment_crosses_polyline(
            pos[i, 0], pos[i, 1], pos[j, 0], pos[j, 1], anchors, aptr[m], aptr[m + 1]
        ):
            return False
    return True


@njit(cache=True, parallel=True)
def mark_pairs(
    pos, kind, indptr, indices, member_of, side_of, half, side, anchors, aptr, keep, drops
):
    """keep[q] = 1 for pairs that stay, 0 for pairs through a member; drops[i] = pairs dropped
    from row i. Returns the total."""
    n = indptr.shape[0] - 1
    nm = side.shape[1]
    for i in prange(n):
        a = indptr[i]
        b = indptr[i + 1]
        involved = member_of[i] >= 0
        if not involved:
            for m in range(nm):
                if side[i, m] != 0:
                    involved = True
                    break
        cnt = 0
        if involved:
            for q in range(a, b):
                j = indices[q]
                if _allowed(i, j, pos, kind, member_of, side_of, half, side, anchors, aptr):
                    keep[q] = 1
                else:
                    keep[q] = 0
                    cnt += 1
        drops[i] = cnt
    total = 0
    for i in range(n):
        total += drops[i]
    return total


@njit(cache=True)
def compact(indptr, indices, keep, drops):
    """Remove the pairs with keep = 0 in place (rows keep their order); returns the new nnz.
    Rows before the first one with a drop are untouched."""
    n = indptr.shape[0] - 1
    first = 0
    while first < n and drops[first] == 0:
        first += 1
    if first == n:
        return indptr[n]
    w = indptr[first]
    a = indptr[first]
    for i in range(first, n):
        b = indptr[i + 1]
        if drops[i] == 0:
            for q in range(a, b):
                indices[w] = indices[q]
                w += 1
        else:
            for q in range(a, b):
                if keep[q]:
                    indices[w] = indices[q]
                    w += 1
        indptr[i + 1] = w
        a = b
    return w


class ThinMemberFilter:
    """``neighbour_filter(nb, pos, kind) -> nb`` for :class:`~mpsfem.fluid_mps.solver.FluidSolver`
    (see the module docstring). Built from a :class:`~mpsfem.fluid_mps.structure_surface.
    StructureSurface`; :meth:`bind` it once the solver exists (the labels need particle
    indices)."""

    def __init__(self, surface) -> None:
        self.surface = surface
        self.member_of: np.ndarray | None = None
        self._keep = np.zeros(0, dtype=np.int8)
        self.dropped = 0  # pairs dropped by the last call
        self.seconds = 0.0  # wall time spent in the filter so far

    def bind(self, solver) -> None:
        s = self.surface
        if not s.bound:
            s.bind(solver)
        self.member_of = s.member_of
        self.side_of = s.side_of
        self.half = s.half
        n = solver.n
        self._side = np.zeros((n, len(s.frames)), dtype=np.int8)
        self._drops = np.zeros(n, dtype=np.int64)
        # a fluid particle within the search radius of any member particle is within
        # radius + (largest particle offset from the mid-line) of the mid-line
        self._extra = np.array(
            [
                max(float(np.abs(sl.eta).max()) for sl in s.sides if s.frames[sl.member] is f)
                for f in s.frames
            ]
        )

    def __call__(self, nb: NeighbourList, pos: np.ndarray, kind: np.ndarray) -> NeighbourList:
        if self.member_of is None:
            raise RuntimeError("ThinMemberFilter used before bind(solver)")
        tic = time.perf_counter()
        try:
            return self._filter(nb, pos, kind)
        finally:
            self.seconds += time.perf_counter() - tic

    #: the numba kernels of the member geometry: classify(pos, *geometry, reach, side) and
    #: mark(pos, kind, indptr, indices, member_of, side_of, half, side, *geometry, keep, drops)
    _classify = staticmethod(classify_sides)
    _mark = staticmethod(mark_pairs)

    def _geometry(self, pos: np.ndarray) -> tuple:
        """The members' current geometry for the kernels: the mid-line polylines."""
        return self.surface.anchors(pos)

    def _filter(self, nb: NeighbourList, pos: np.ndarray, kind: np.ndarray) -> NeighbourList:
        geometry = self._geometry(pos)
        reach = nb.radius + self._extra + self.surface.l0
        self._classify(pos, *geometry, reach, self._side)
        nnz = nb.indices.shape[0]
        if self._keep.shape[0] < nnz:
            self._keep = np.zeros(int(nnz * HEADROOM) + 16, dtype=np.int8)
        total = self._mark(
            pos,
            kind,
            nb.indptr,
            nb.indices,
            self.member_of,
            self.side_of,
            self.half,
            self._side,
            *geometry,
            self._keep,
            self._drops,
        )
        self.dropped = int(total)
        if total == 0:
            return nb
        w = compact(nb.indptr, nb.indices, self._keep, self._drops)
        return NeighbourList(nb.indptr, nb.indices[:w], nb.radius)

    def sides(self) -> np.ndarray:
        """Side classification of the last call, (n, members) int8 (see classify_sides)."""
        return self._side
