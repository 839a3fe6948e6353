"""Neighbour filtering across 3D plates: nothing interacts through a plate.

The 3D counterpart of :mod:`~mpsfem.fluid_mps.thin_member`, with the same three rules (read its
docstring): (1) particles of the same plate but of different sides never interact; (2) fluid
beside a plate sees only the virtual solid of its own face, fluid beyond a free edge sees the body
once; (3) two fluid particles whose connecting segment passes through a plate's mid-surface do not
interact.

The mid-surface is the height field eta_mid(s1, s2) over the plate's reference rectangle
(:meth:`~mpsfem.fluid_mps.plate_surface.PlateSurface.mid_surface`: the current column mid-points,
bilinear between them, edges extrapolated). A particle at (s1, s2, eta) in the plate's frame is
classified by the sign of eta - eta_mid at its in-plane position clamped to the rectangle: +-1
inside the rectangle, +-2 beyond an edge, 0 farther than the reach from the mid-surface (beyond
an edge the surface is continued flat at the edge's height; the 2D filter continues the end
segment's slope: the two differ by the distance past the edge times the edge slope, a small
fraction of l0 for the small slopes of a Kirchhoff plate within the kernel radius). The rule-3
test for a pair beyond an edge clips the segment to the rectangle in plane and drops the pair if
eta - eta_mid changes sign over the clipped part (the crossing is on the rectangle). In-plane
coordinates are those of the reference configuration: a Kirchhoff plate has no membrane
displacement, and its faces' in-plane rotation terms cancel in the column mid-points.

Rows keep their ascending order (bit-identical for any thread count).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from mpsfem.fluid_mps.thin_member import (
    ThinMemberFilter,
    _sign,
    rules_1_2,
)

__all__ = ["ThinPlateFilter", "classify_plate_sides", "segment_crosses_plate"]


@njit(cache=True, inline="always")
def _bracket(s, h, n, L):
    """Node interval (j, weight) of s in [0, L] on the nodes 0, h/2, 3h/2, ..., L - h/2, L."""
    j = int(np.floor(s / h + 0.5))
    j = min(max(j, 0), n)
    a = 0.0 if j == 0 else (j - 0.5) * h
    b = L if j == n else (j + 0.5) * h
    w = (s - a) / (b - a) if b > a else 0.0
    return j, min(max(w, 0.0), 1.0)


@njit(cache=True, inline="always")
def _height(m, s1, s2, size, grid, hptr, heights):
    """Mid-surface offset eta_mid (m) of plate m at (s1, s2), clamped to its rectangle."""
    L1 = size[m, 0]
    L2 = size[m, 1]
    n1 = grid[m, 0]
    n2 = grid[m, 1]
    j1, w1 = _bracket(min(max(s1, 0.0), L1), L1 / n1, n1, L1)
    j2, w2 = _bracket(min(max(s2, 0.0), L2), L2 / n2, n2, L2)
    stride = n2 + 2
    q = hptr[m] + j1 * stride + j2
    f0 = (1.0 - w2) * heights[q] + w2 * heights[q + 1]
    f1 = (1.0 - w2) * heights[q + stride] + w2 * heights[q + stride + 1]
    return (1.0 - w1) * f0 + w1 * f1


@njit(cache=True, inline="always")
def _local(x, y, z, m, frame):
    """(s1, s2, eta) of a point in plate m's frame ``frame[m] = [origin, t1, t2, n]``."""
    rx = x - frame[m, 0, 0]
    ry = y - frame[m, 0, 1]
    rz = z - frame[m, 0, 2]
    s1 = rx * frame[m, 1, 0] + ry * frame[m, 1, 1] + rz * frame[m, 1, 2]
    s2 = rx * frame[m, 2, 0] + ry * frame[m, 2, 1] + rz * frame[m, 2, 2]
    e = rx * frame[m, 3, 0] + ry * frame[m, 3, 1] + rz * frame[m, 3, 2]
    return s1, s2, e


@njit(cache=True, parallel=True)
def classify_plate_sides(pos, frame, size, grid, hptr, heights, reach, side):
    """side[i, m] for every particle i and plate m: 0 if i is farther than ``reach[m]`` from the
    mid-surface, otherwise +-1 (in-plane position on the rectangle; sign of eta - eta_mid) or
    +-2 (beyond an edge; sign against the mid-surface at the nearest edge point)."""
    n = pos.shape[0]
    nm = frame.shape[0]
    hmax = np.zeros(nm)
    for m in range(nm):
        for q in range(hptr[m], hptr[m + 1]):
            hmax[m] = max(hmax[m], abs(heights[q]))
    for i in prange(n):
        for m in range(nm):
            side[i, m] = 0
            s1, s2, e = _local(pos[i, 0], pos[i, 1], pos[i, 2], m, frame)
            o1 = max(0.0, max(-s1, s1 - size[m, 0]))
            o2 = max(0.0, max(-s2, s2 - size[m, 1]))
            r = reach[m]
            if o1 >= r or o2 >= r or abs(e) >= r + hmax[m]:
                continue
            de = e - _height(m, s1, s2, size, grid, hptr, heights)
            if o1 * o1 + o2 * o2 + de * de >= r * r:
                continue
            s = 1 if de >= 0.0 else -1
            side[i, m] = 2 * s if (o1 > 0.0 or o2 > 0.0) else s


@njit(cache=True, inline="always")
def _clip(p, d, L, t0, t1):
    """Clip the parameter range [t0, t1] of p + t d to 0 <= p + t d <= L (empty: t0 > t1)."""
    if d == 0.0:
        if p < 0.0 or p > L:
            return 1.0, 0.0
        return t0, t1
    ta = -p / d
    tb = (L - p) / d
    if ta > tb:
        ta, tb = tb, ta
    return max(t0, ta), min(t1, tb)


@njit(cache=True)
def segment_crosses_plate(a, b, m, frame, size, grid, hptr, heights):
    """True if segment a-b (points (3,)) passes through plate m's mid-surface on its rectangle:
    the part of the segment over the rectangle (clipped in plane) has eta - eta_mid of opposite
    signs, or zero, at its two ends. Exact for one crossing (the caller's pairs are on opposite
    sides, so they cross an odd number of times; beyond the rectangle the height field is flat)."""
    sa1, sa2, ea = _local(a[0], a[1], a[2], m, frame)
    sb1, sb2, eb = _local(b[0], b[1], b[2], m, frame)
    t0, t1 = _clip(sa1, sb1 - sa1, size[m, 0], 0.0, 1.0)
    t0, t1 = _clip(sa2, sb2 - sa2, size[m, 1], t0, t1)
    if t0 > t1:
        return False
    g0 = ea + t0 * (eb - ea)
    g0 -= _height(m, sa1 + t0 * (sb1 - sa1), sa2 + t0 * (sb2 - sa2), size, grid, hptr, heights)
    g1 = ea + t1 * (eb - ea)
    g1 -= _height(m, sa1 + t1 * (sb1 - sa1), sa2 + t1 * (sb2 - sa2), size, grid, hptr, heights)
    return (g0 <= 0.0 and g1 >= 0.0) or (g0 >= 0.0 and g1 <= 0.0)


@njit(cache=True, inline="always")
def _allowed(i, j, pos, kind, member_of, side_of, half, side, frame, size, grid, hptr, heights):
    """May row i keep neighbour j? (rules of thin_member's docstring, plate crossing test)"""
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
        if segment_crosses_plate(pos[i], pos[j], m, frame, size, grid, hptr, heights):
            return False
    return True


@njit(cache=True, parallel=True)
def mark_plate_pairs(
    pos,
    kind,
    indptr,
    indices,
    member_of,
    side_of,
    half,
    side,
    frame,
    size,
    grid,
    hptr,
    heights,
    keep,
    drops,
):
    """keep[q] = 1 for pairs that stay, 0 for pairs through a plate; drops[i] = pairs dropped
    from row i. Returns the total. The loop of :func:`~mpsfem.fluid_mps.thin_member.mark_pairs`
    with the plate's crossing test: kept as its own kernel so numba compiles the crossing test
    inline (a function argument would cost a call per pair and defeat caching)."""
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
                if _allowed(
                    i, j, pos, kind, member_of, side_of, half, side, frame, size, grid, hptr,
                    heights,
                ):  # fmt: skip
                    keep[q] = 1
                else:
                    keep[q] = 0
                    cnt += 1
        drops[i] = cnt
    total = 0
    for i in range(n):
        total += drops[i]
    return total


class ThinPlateFilter(ThinMemberFilter):
    """``neighbour_filter(nb, pos, kind) -> nb`` for 3D plates (see the module docstring). Built
    from a :class:`~mpsfem.fluid_mps.plate_surface.PlateSurface`; :meth:`bind` it once the
    solver exists."""

    def bind(self, solver) -> None:
        super().bind(solver)
        s = self.surface
        self._frame = np.array([[f.origin, f.t1, f.t2, f.normal] for f in s.frames])
        self._size = np.array([f.size for f in s.frames], dtype=np.float64)

    _classify = staticmethod(classify_plate_sides)
    _mark = staticmethod(mark_plate_pairs)

    def _geometry(self, pos: np.ndarray) -> tuple:
        """The plates' frames, sizes and current mid-surface height fields."""
        heights, hptr, grid = self.surface.mid_surface(pos)
        return self._frame, self._size, grid, hptr, heights
