"""Pressure of dummy wall particles, so that the gradient sees a full kernel near walls.

Dummy particles are not unknowns of the pressure equation. Each takes the pressure of the nearest
pressure-layer particle of its own wall, extrapolated hydrostatically across the layers:
p_d = p_w + rho g . (x_d - x_w) (g the gravity vector), the first-order wall-pressure
extrapolation of Adami et al. (2012) with the wall at rest. Without it, Tanaka's
momentum-conserving gradient, which is not zero-order consistent, sees a one-sided kernel next to a
wall and pulls fluid into it.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from scipy.spatial import cKDTree

from mpsfem.fluid_mps.particle_kinds import dummy_mask, pressure_wall_mask


def dummy_sources(pos: np.ndarray, kind: np.ndarray, ranges: list[tuple[int, int]]) -> np.ndarray:
    """For each particle, the index of the pressure-layer particle a dummy copies (-1 otherwise).

    ``ranges`` lists the (start, stop) index range of each rigid wall; sources are looked up
    within the same wall, so two walls close together never mix.
    """
    src = np.full(len(pos), -1, dtype=np.int32)
    for start, stop in ranges:
        k = kind[start:stop]
        press = np.flatnonzero(pressure_wall_mask(k)) + start
        dummy = np.flatnonzero(dummy_mask(k)) + start
        if len(press) == 0 or len(dummy) == 0:
            continue
        _, nearest = cKDTree(pos[press]).query(pos[dummy])
        src[dummy] = press[nearest]
    return src


@njit(cache=True, parallel=True)
def extrapolate_dummy_pressure(pos, p, src, rho, gravity):
    """p_d = p_w + rho g . (x_d - x_w) for every dummy particle d with source w = src[d] (Pa)."""
    dim = pos.shape[1]
    for i in prange(pos.shape[0]):
        w = src[i]
        if w < 0:
            continue
        acc = 0.0
        for a in range(dim):
            acc += gravity[a] * (pos[i, a] - pos[w, a])
        p[i] = max(p[w] + rho * acc, 0.0)
