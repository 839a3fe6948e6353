"""Particle collision (anti-penetration) model, after Koshizuka / Arai et al. (as in MPS-Basic).

A FLUID particle i and a neighbour j closer than ``distance`` (typically 0.5 l0 .. 0.9 l0) that
approach each other along e_ij = (r_j - r_i) / |r_j - r_i|, a = (u_i - u_j) . e_ij > 0, collide
inelastically with restitution coefficient ``restitution`` (0 .. 1), normal direction only:

- FLUID j (equal masses): u_i -= (1 + e) / 2 * a * e_ij; j gets the opposite change in its own row,
  so the pair's momentum is conserved and its relative normal velocity becomes -e a.
- any wall or structure j (WALL, DUMMY, STRUCTURE, STRUCTURE_DUMMY; prescribed motion, infinite
  mass): u_i -= (1 + e) * a * e_ij, i.e. the normal velocity relative to the wall becomes -e a.

With a ramp (``ramp`` > 0, a fraction of ``distance``) the impulse of a pair fades linearly to
zero between (1 - ramp) ``distance`` and ``distance``: w(r) = min(1, (distance - r) / (ramp
distance)). The hard threshold (ramp = 0, the default) makes a pair's impulse jump from zero to
(1 + e) a m as it crosses ``distance``; a member's load, which holds the impulses its particles
receive, then jumps with a displacement of any size, so a coupling window's fixed point may not
exist (docs/coupler.md, "Contact that fades in"). With the ramp the impulse is continuous in the
positions.

All pairs use the velocities from before the call (Jacobi style): the changes of each particle are
summed over its own neighbours in a fixed order and applied afterwards, in parallel over i with no
write races, so results are bit-identical for any thread count. Only FLUID velocities change. The
caller moves the particles by dt times the velocity change if it wants the positions corrected too.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, inline="always")
def approach_speed(i, j, pos, vel, d2max):
    """(a, r): the speed a = (u_i - u_j) . e_ij (m/s) at which i and j approach along
    e_ij = r_ij / r, and their distance r (m); a = 0 when they are not closer than
    sqrt(d2max) or coincide. A pair collides where a > 0. Shared by the collision model and the
    momentum budget's collision exchange, so both see the same collisions."""
    dim = pos.shape[1]
    r2 = 0.0
    for d in range(dim):
        dx = pos[j, d] - pos[i, d]
        r2 += dx * dx
    if r2 >= d2max or r2 == 0.0:
        return 0.0, 0.0
    r = np.sqrt(r2)
    a = 0.0
    for d in range(dim):
        a += (vel[i, d] - vel[j, d]) * (pos[j, d] - pos[i, d])
    a /= r
    return a, r


@njit(cache=True, inline="always")
def ramp_weight(r, distance, ramp):
    """Share w of a colliding pair's impulse at distance r (m): 1 up to (1 - ramp) distance,
    falling linearly to 0 at distance; exactly 1 everywhere when ramp = 0 (the hard threshold:
    the impulse keeps its bits)."""
    if ramp > 0.0:
        inner = (1.0 - ramp) * distance
        if r > inner:  # linear fade, ours (docs/fluid.md, "A collision that fades in")
            return (distance - r) / (ramp * distance)
    return 1.0


@njit(cache=True, parallel=True)
def collision_velocity_change(pos, vel, kind, indptr, indices, distance, restitution, ramp, dv):
    """dv[i] = velocity change of FLUID particle i from all its collisions (0 for others);
    ``ramp``: see :func:`ramp_weight` (0: the hard threshold).

    Returns nothing; dv has the shape of vel."""
    n, dim = pos.shape
    d2max = distance * distance
    for i in prange(n):
        for d in range(dim):
            dv[i, d] = 0.0
        if kind[i] != 0:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            a, r = approach_speed(i, j, pos, vel, d2max)
            if a <= 0.0:
                continue  # separating, or not within the distance
            f = (1.0 + restitution) * a / r * ramp_weight(r, distance, ramp)
            if kind[j] == 0:
                f *= 0.5
            for d in range(dim):
                dv[i, d] -= f * (pos[j, d] - pos[i, d])


@njit(cache=True, parallel=True)
def _add(vel, dv):
    for i in prange(vel.shape[0]):
        for d in range(vel.shape[1]):
            vel[i, d] += dv[i, d]


class _Work:
    buf = np.empty((0, 0))


def collide(pos, vel, kind, indptr, indices, distance, restitution, work=None, ramp=0.0):
    """Apply the collision model to ``vel`` in place (FLUID rows only).

    ``distance`` is absolute (e.g. 0.5 l0); ``restitution`` in [0, 1]; ``ramp`` in [0, 1), the
    share of ``distance`` over which a pair's impulse fades out (:func:`ramp_weight`). ``work``
    is an optional (N, dim) float64 scratch array; without it a module-level buffer is reused
    (grown when needed), so repeated calls do not allocate. Returns the velocity change array
    (a view of the scratch buffer, valid until the next call)."""
    if not 0.0 <= restitution <= 1.0:
        raise ValueError(f"restitution must be in [0, 1], got {restitution!r}")
    if not distance > 0.0:
        raise ValueError(f"collision distance must be positive, got {distance!r}")
    if not 0.0 <= ramp < 1.0:
        raise ValueError(f"collision ramp must be in [0, 1), got {ramp!r}")
    if work is None:
        if _Work.buf.shape != vel.shape:
            _Work.buf = np.empty(vel.shape)
        work = _Work.buf
    collision_velocity_change(pos, vel, kind, indptr, indices, distance, restitution, ramp, work)
    _add(vel, work)
    return work
