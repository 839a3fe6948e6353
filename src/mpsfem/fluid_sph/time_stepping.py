"""Explicit integrators of the δ-SPH fluid state (positions, velocities, densities), numba.

``symplectic``: kick-drift-kick leapfrog (velocity Verlet; Leimkuhler & Reich 2004), one
right-hand side per step, second order, the right-hand side at the end of a step reused as the
first kick of the next (it is part of the checkpointed state). ``rk4``: the classical four-stage
Runge-Kutta scheme (the seed paper's), fourth order in dt. Only fluid rows i < n_fluid change.
"""

from __future__ import annotations

from numba import njit, prange


@njit(cache=True, parallel=True)
def kick(vel, rho, acc, drho, n_fluid, dt):
    """u += dt a, rho += dt drho/dt (a half step dt/2 of the leapfrog when called so)."""
    dim = vel.shape[1]
    for i in prange(n_fluid):
        for a in range(dim):
            vel[i, a] += dt * acc[i, a]
        rho[i] += dt * drho[i]


@njit(cache=True, parallel=True)
def drift(pos, vel, n_fluid, dt):
    """r += dt u."""
    dim = pos.shape[1]
    for i in prange(n_fluid):
        for a in range(dim):
            pos[i, a] += dt * vel[i, a]


@njit(cache=True, parallel=True)
def rk_stage(pos0, vel0, rho0, vel, acc, drho, n_fluid, c, pos, vel_out, rho):
    """Stage state y = y0 + c k with k = (u, a, drho/dt) of the previous stage (RK4)."""
    dim = pos.shape[1]
    for i in prange(n_fluid):
        for a in range(dim):
            pos[i, a] = pos0[i, a] + c * vel[i, a]
            vel_out[i, a] = vel0[i, a] + c * acc[i, a]
        rho[i] = rho0[i] + c * drho[i]


@njit(cache=True, parallel=True)
def rk_accumulate(spos, svel, srho, vel, acc, drho, n_fluid, w, first):
    """Weighted sum of the stage slopes: s = (first ? 0 : s) + w k (RK4 weights 1, 2, 2, 1)."""
    dim = spos.shape[1]
    for i in prange(n_fluid):
        for a in range(dim):
            if first:
                spos[i, a] = w * vel[i, a]
                svel[i, a] = w * acc[i, a]
            else:
                spos[i, a] += w * vel[i, a]
                svel[i, a] += w * acc[i, a]
        if first:
            srho[i] = w * drho[i]
        else:
            srho[i] += w * drho[i]


@njit(cache=True, parallel=True)
def rk_finish(pos0, vel0, rho0, spos, svel, srho, n_fluid, c, pos, vel, rho):
    """y^{n+1} = y^n + (dt/6) (k1 + 2 k2 + 2 k3 + k4), ``c`` = dt / 6."""
    dim = pos.shape[1]
    for i in prange(n_fluid):
        for a in range(dim):
            pos[i, a] = pos0[i, a] + c * spos[i, a]
            vel[i, a] = vel0[i, a] + c * svel[i, a]
        rho[i] = rho0[i] + c * srho[i]


@njit(cache=True)
def max_norm(x, n_fluid):
    """Largest |x_i| over the fluid rows (max is exact in any order)."""
    dim = x.shape[1]
    best = 0.0
    for i in range(n_fluid):
        s = 0.0
        for a in range(dim):
            s += x[i, a] * x[i, a]
        if s > best:
            best = s
    return best**0.5
