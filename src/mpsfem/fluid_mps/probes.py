"""Fluid-side probes: the exact definition of each kind lives in its function's docstring.

All sums run in a fixed (serial) order, so probe values are bit-reproducible.
"""

from __future__ import annotations

import numpy as np
from numba import njit

# probe kind -> (unit, components)
PROBE_UNITS = {
    "pressure": ("Pa", ()),
    "wave_gauge": ("m", ()),
    "front": ("m", ()),
    "force": ("N", ("fx", "fy", "fz")),
    "energy": ("J", ("kinetic", "potential")),
    "displacement": ("m", ("ux", "uy", "uz")),
}


@njit(cache=True)
def pressure_at(pos, p, kind, point, radius):
    """Mean pressure (Pa) of fluid (0) and pressure-wall (1, 3) particles within ``radius`` of
    ``point``; NaN when no such particle is there (the gauge is dry)."""
    r2 = radius * radius
    acc = 0.0
    cnt = 0
    dim = pos.shape[1]
    for i in range(pos.shape[0]):
        k = kind[i]
        if k != 0 and k != 1 and k != 3:
            continue
        d2 = 0.0
        for a in range(dim):
            dx = pos[i, a] - point[a]
            d2 += dx * dx
        if d2 <= r2:
            acc += p[i]
            cnt += 1
    return acc / cnt if cnt > 0 else np.nan


@njit(cache=True)
def surface_height(pos, kind, horizontal, half_width, up_axis, l0):
    """Free-surface height (m) at a horizontal position: the highest fluid particle whose
    horizontal coordinates are within ``half_width`` of ``horizontal``, plus l0/2 (a surface
    particle's centre lies half a spacing below the surface it represents). NaN when no fluid
    particle is in the column."""
    dim = pos.shape[1]
    top = -np.inf
    for i in range(pos.shape[0]):
        if kind[i] != 0:
            continue
        inside = True
        j = 0
        for a in range(dim):
            if a == up_axis:
                continue
            if abs(pos[i, a] - horizontal[j]) > half_width:
                inside = False
                break
            j += 1
        if inside and pos[i, up_axis] > top:
            top = pos[i, up_axis]
    if top == -np.inf:
        return np.nan
    return top + 0.5 * l0


@njit(cache=True)
def _find(parent, i):
    root = i
    while parent[root] != root:
        root = parent[root]
    while parent[i] != root:  # path compression
        nxt = parent[i]
        parent[i] = root
        i = nxt
    return root


@njit(cache=True)
def front_position(pos, kind, indptr, indices, link, axis, min_fraction, l0, parent, size):
    """Surge front (m): the largest coordinate along ``axis`` among fluid particles of every
    cluster holding at least ``min_fraction`` of the largest cluster's particles, plus l0/2 (the
    edge of the outermost particle's cell). Clusters are the connected components of fluid
    particles closer than ``link`` (m), so lone droplets do not count."""
    n = pos.shape[0]
    dim = pos.shape[1]
    link2 = link * link
    for i in range(n):
        parent[i] = i
        size[i] = 0
    for i in range(n):
        if kind[i] != 0:
            continue
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if j <= i or kind[j] != 0:
                continue
            d2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                d2 += dx * dx
            if d2 < link2:
                ri = _find(parent, i)
                rj = _find(parent, j)
                if ri != rj:
                    if ri < rj:
                        parent[rj] = ri
                    else:
                        parent[ri] = rj
    largest = 0
    for i in range(n):
        if kind[i] == 0:
            r = _find(parent, i)
            size[r] += 1
            if size[r] > largest:
                largest = size[r]
    front = -np.inf
    for i in range(n):
        if kind[i] == 0 and size[_find(parent, i)] >= min_fraction * largest:
            if pos[i, axis] > front:
                front = pos[i, axis]
    return front + 0.5 * l0


@njit(cache=True)
def patch_force(p, normal, start, stop, kind, area):
    """Pressure force (N; N/m in 2D) of the fluid on wall particles ``start:stop``: the sum of
    -p_i A n_i over pressure-layer particles, n_i the unit normal towards the fluid and
    A = l0^(d-1) the area a particle represents (thesis eq. 2-51, F_i = P_i l0^(d-1) n_i)."""
    dim = normal.shape[1]
    f = np.zeros(dim)
    for i in range(start, stop):
        if kind[i] != 1 and kind[i] != 3:
            continue
        for a in range(dim):
            f[a] -= p[i] * area * normal[i, a]
    return f


@njit(cache=True)
def fluid_energy(pos, vel, kind, mass, gravity):
    """Kinetic sum(m v^2 / 2) and potential sum(-m g . x) energy of the fluid particles, J (J/m
    in 2D); the potential energy's zero is the origin."""
    dim = pos.shape[1]
    ek = 0.0
    ep = 0.0
    for i in range(pos.shape[0]):
        if kind[i] != 0:
            continue
        v2 = 0.0
        gx = 0.0
        for a in range(dim):
            v2 += vel[i, a] * vel[i, a]
            gx += gravity[a] * pos[i, a]
        ek += 0.5 * mass * v2
        ep -= mass * gx
    return ek, ep
