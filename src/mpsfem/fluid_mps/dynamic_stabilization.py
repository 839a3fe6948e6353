"""Dynamic stabilisation of close fluid pairs (after Tsuruta, Khayyer & Gotoh 2013, "A short
note on Dynamic Stabilization of Moving Particle Semi-implicit method", Comput. Fluids 82).

An antisymmetric (momentum-conserving) repulsion that only acts on FLUID pairs closer than the
stabilisation distance r_DS = alpha l0: each such pair is given the velocity change that
separates it back to r_DS within one step, shared equally,

    du_i = -(r_DS - r_ij) / (2 dt) e_ij,   du_j = -du_i,   e_ij = r_ij / |r_ij|,

(written as a pair pressure in the gradient of eq. 2-12, dP_ij = rho n0 r_ij (r_DS - r_ij) /
(2 d w_ij dt^2): the form derived in docs/fluid.md for this solver, not Tsuruta et al.'s
coefficients). The caller moves the particles by dt du as well (the pressure correction's
position update). Wall, dummy and structure neighbours are left out: their contact is the
collision model's (collision.py, credited to them by ``fluid.boundary_force``), so this term is
internal to the fluid and changes its momentum by round-off only.

Jacobi style like the collision model: every pair reads the positions before the call, each
particle sums its own pairs in neighbour order (no write races, bit-identical for any thread
count).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def stabilisation_velocity(pos, kind, indptr, indices, distance, dt, dv):
    """dv[i] = the velocity change (m/s) of FLUID particle i from all its fluid pairs closer
    than ``distance`` (m) in a step of ``dt`` (s); 0 for other particles. Returns nothing."""
    n, dim = pos.shape
    d2 = distance * distance
    for i in prange(n):
        for d in range(dim):
            dv[i, d] = 0.0
        if kind[i] != 0:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if kind[j] != 0:
                continue
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 >= d2 or r2 == 0.0:
                continue
            r = np.sqrt(r2)
            f = 0.5 * (distance - r) / (dt * r)  # half the overlap per step, over r for e_ij
            for d in range(dim):
                dv[i, d] -= f * (pos[j, d] - pos[i, d])


@njit(cache=True, parallel=True)
def apply_velocity_change(pos, vel, kind, dv, dt):
    """vel += dv and pos += dt dv on FLUID rows."""
    for i in prange(pos.shape[0]):
        if kind[i] != 0:
            continue
        for d in range(pos.shape[1]):
            vel[i, d] += dv[i, d]
            pos[i, d] += dt * dv[i, d]


def stabilise(pos, vel, kind, indptr, indices, distance: float, dt: float, work) -> float:
    """Apply the dynamic stabilisation in place; ``work`` an (N, dim) scratch array. Returns
    the largest velocity change (m/s), 0 when no pair is closer than ``distance``."""
    if not distance > 0.0:
        raise ValueError(f"stabilisation distance must be positive, got {distance!r}")
    stabilisation_velocity(pos, kind, indptr, indices, distance, dt, work)
    apply_velocity_change(pos, vel, kind, work, dt)
    return float(np.sqrt((work * work).sum(axis=1).max())) if len(work) else 0.0
