"""Explicit prediction and pressure correction of the semi-implicit MPS step (numba).

Thesis ch. 2.1 (Koshizuka & Oka 1996): u* = u^n + dt (nu lap(u) + g), r* = r^n + dt u*; after the
pressure equation, u^{n+1} = u* - dt grad(p) / rho and r^{n+1} = r* + dt (u^{n+1} - u*).
Only fluid particles move here; walls follow their prescribed motion.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def predict(pos, vel, kind, lap_u, nu, gravity, dt):
    """u* = u + dt (nu lap(u) + g), r* = r + dt u* for fluid particles (thesis eqs. 2-24, 2-25)."""
    dim = pos.shape[1]
    for i in prange(pos.shape[0]):
        if kind[i] != 0:
            continue
        for a in range(dim):
            vel[i, a] += dt * (nu * lap_u[i, a] + gravity[a])
            pos[i, a] += dt * vel[i, a]


@njit(cache=True, parallel=True)
def predict_inviscid(pos, vel, kind, gravity, dt):
    """u* = u + dt g, r* = r + dt u* for fluid particles (no viscosity in the scene)."""
    dim = pos.shape[1]
    for i in prange(pos.shape[0]):
        if kind[i] != 0:
            continue
        for a in range(dim):
            vel[i, a] += dt * gravity[a]
            pos[i, a] += dt * vel[i, a]


@njit(cache=True, parallel=True)
def correct(pos, vel, kind, grad_p, rho, dt):
    """u^{n+1} = u* - dt grad(p) / rho, r^{n+1} = r* + dt (u^{n+1} - u*) (thesis eqs. 2-27, 2-28)."""
    dim = pos.shape[1]
    c = dt / rho
    for i in prange(pos.shape[0]):
        if kind[i] != 0:
            continue
        for a in range(dim):
            du = -c * grad_p[i, a]
            vel[i, a] += du
            pos[i, a] += dt * du


@njit(cache=True, parallel=True)
def shift_by_velocity_change(pos, vel, vel_before, kind, dt):
    """r += dt (u - u_before) for fluid particles (after the collision model changed u)."""
    dim = pos.shape[1]
    for i in prange(pos.shape[0]):
        if kind[i] != 0:
            continue
        for a in range(dim):
            pos[i, a] += dt * (vel[i, a] - vel_before[i, a])


@njit(cache=True)
def max_speed(vel, kind):
    """Largest fluid particle speed, m/s (max is exact in any order)."""
    dim = vel.shape[1]
    best = 0.0
    for i in range(vel.shape[0]):
        if kind[i] != 0:
            continue
        s = 0.0
        for a in range(dim):
            s += vel[i, a] * vel[i, a]
        if s > best:
            best = s
    return np.sqrt(best)


@njit(cache=True)
def first_bad_particle(pos, vel, p, kind, lo, hi):
    """Index of the first fluid particle with a non-finite state or outside the box lo..hi
    (-1 if none), and a code: 1 non-finite position/velocity, 2 non-finite pressure, 3 escaped."""
    dim = pos.shape[1]
    for i in range(pos.shape[0]):
        if not np.isfinite(p[i]):
            return i, 2
        if kind[i] != 0:
            continue
        for a in range(dim):
            if not (np.isfinite(pos[i, a]) and np.isfinite(vel[i, a])):
                return i, 1
        for a in range(dim):
            if pos[i, a] < lo[a] or pos[i, a] > hi[a]:
                return i, 3
    return -1, 0


def step_towards(t: float, t_end: float, dt_next: float) -> float:
    """The next step (s) from ``t`` towards ``t_end`` for a solver whose stable step is
    ``dt_next``: that step, except that the last one or two split the remainder equally (never
    a tiny last step; both fluid solvers)."""
    remaining = t_end - t
    n_left = math.ceil(remaining / dt_next * (1.0 - 1e-12))
    return remaining / n_left if n_left <= 2 else dt_next


def split_window(window: float, dt_next: float) -> tuple[int, float]:
    """``window`` (s) split into n equal steps no longer than ``dt_next`` (s): (n, step)."""
    n = max(1, math.ceil(window / dt_next * (1.0 - 1e-12)))
    return n, window / n
