"""Khayyer & Gotoh's source terms of the pressure equation: the higher-order source (HS) and the
error-compensating source (ECS).

HS (Khayyer & Gotoh 2009, "Modified moving particle semi-implicit methods for the prediction of
2D wave impact pressure", Coastal Eng. 56, 419-440): the time derivative of the number density
written exactly from the kernel derivative and the pair velocities,

    Dn_i/Dt = sum_j w'(r_ij) (r_ij . u_ij) / r_ij,     r_ij = x_j - x_i, u_ij = u_j - u_i

(with Koshizuka's kernel w'(r) / r = -re / r^3, their form), instead of the thesis's divergence
(eq. 2-15) in the velocity part of the mixed source term (eq. 2-23). Continuity, n ~ rho, makes
div u = -(1/n) Dn/Dt; here the divergence estimate is ``-(1/nu0) Dn/Dt`` with
nu0 = -(1/d) sum_j r_j w'(r_j) over the initial lattice (:func:`rate_constant`), which is exact for
a linear velocity field there, as eq. 2-15 is (the papers divide by n0, which on the lattice
overstates the divergence by nu0 / n0: 1.34 for the improved kernel at 2.1 l0 in 2D, 1.03 in 3D). The source of the pressure equation then
reads (1 - gamma) rho / dt <div u*>_HS - gamma rho / dt^2 (n* - n0) / n0: HS replaces the
divergence, the thesis's small number-density part (gamma) stays.

ECS (Khayyer & Gotoh 2011, "Enhancement of stability and accuracy of the MPS method by
error-compensating source term", J. Comput. Phys. 230, 3093-3118): two terms added to the source,
built from the number density and its rate at the start of the step (time level k), each with a
dynamic coefficient that vanishes when its error does:

    ECS_i = -alpha rho / (n0 dt) (Dn/Dt)^k_i - beta rho / dt^2 (n^k_i - n0) / n0,
    alpha = |n^k_i - n0| / n0,   beta = |dt / n0 (Dn/Dt)^k_i|

(in the sign convention of eq. 2-23, where compression gives a negative source). Both terms push
towards n = n0 and Dn/Dt = 0; on an unperturbed lattice ECS = 0 whatever the velocities. The state
at level k is rebuilt from the predictor's: x^k = x* - dt u* (exact for fluid particles, whose
predictor and collision shift move them by dt times their velocity change; walls move with their
velocity), and the pair velocities of u* equal those of u^k up to the viscous increment (gravity
is the same on every fluid particle; wall ghosts of the Neumann model carry u_w + g dt, as in
wall_boundary.py).

Neighbours: with the pressure-layer wall model every neighbour counts with its own velocity (as
eq. 2-15 does); with the Neumann model fluid neighbours count with their velocity, wet wall and
dummy neighbours with u_w + g dt, dry ones not at all (wall_boundary.py's wall flux). That model's
wall flux also enters through wall_boundary.ghost_rhs in the standard divergence form, on the
right-hand side the solver receives; :func:`hs_source` returns that part (``wall_std``) so that the
pressure solver can take it back out.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight, weight_code
from .lattice import lattice_offsets

SOURCE_TERMS = ("thesis_mixed", "higher_order")


@njit(cache=True, inline="always")
def kernel_slope_over_r(r, re, wcode):
    """w'(r) / r (1/m^2 for r, re in m), 0 for r >= re; r floored at 1e-6 re."""
    if r >= re:
        return 0.0
    rr = r if r > 1e-6 * re else 1e-6 * re
    if wcode == 0:  # improved kernel, thesis eq. 2-4
        s = 0.85 * rr + 0.15 * re
        return -0.85 * re / (s * s * rr)
    return -re / (rr * rr * rr)  # Khayyer & Gotoh 2009, HS pair factor -re / r^3


def rate_constant(dim: int, l0: float, re: float, weight_name: str = "improved") -> float:
    """nu0 = -(1/d) sum_j r_j w'(r_j) over the initial lattice (dimensionless): a linear velocity
    field u = G x gives Dn/Dt = -nu0 tr(G) there."""
    code = weight_code(weight_name)
    pts = lattice_offsets(dim, l0, re)
    r = np.sqrt((pts * pts).sum(axis=1))
    rr = np.maximum(r, 1e-6 * re)
    if code == 0:
        s = 0.85 * rr + 0.15 * re
        slope = -0.85 * re / s**2
    else:
        slope = -re / rr**2
    return float(-(r * slope).sum() / dim)


@njit(cache=True, parallel=True)
def number_density_rate(
    pos, vel, kind, dry, indptr, indices, re, wcode, neumann, gravity, dt, shift, out_n, out_rate
):
    """Number density n_i (eq. 2-5) and its rate Dn_i/Dt (1/s, HS form) on non-dummy particles
    (0 on dummies), at positions x - shift dt u (``shift`` 0: as given; 1: the start of the step,
    for ECS). Neighbours as in the module docstring (``neumann``: boundary ghosts at u_w + g dt,
    dry ones left out of the rate; every neighbour counts in n, as in eq. 2-5)."""
    n, dim = pos.shape
    re2 = re * re
    s = shift * dt
    for i in prange(n):
        ki = kind[i]
        out_n[i] = 0.0
        out_rate[i] = 0.0
        if ki == 2 or ki == 4:
            continue
        dens = 0.0
        rate = 0.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            kj = kind[j]
            r2 = 0.0
            for a in range(dim):
                dx = (pos[j, a] - s * vel[j, a]) - (pos[i, a] - s * vel[i, a])
                r2 += dx * dx
            if r2 >= re2:
                continue
            r = np.sqrt(r2)
            dens += weight(r, re, wcode)
            if r2 == 0.0:
                continue
            boundary = neumann and kj != 0
            if boundary and dry[j] != 0:
                continue
            dot = 0.0
            for a in range(dim):
                dx = (pos[j, a] - s * vel[j, a]) - (pos[i, a] - s * vel[i, a])
                du = vel[j, a] - vel[i, a]
                if boundary:
                    du += gravity[a] * dt
                dot += du * dx
            rate += kernel_slope_over_r(r, re, wcode) * dot  # Khayyer & Gotoh 2009, HS (Dn/Dt)
        out_n[i] = dens
        out_rate[i] = rate
    return out_n, out_rate


@njit(cache=True, parallel=True)
def hs_source(
    pos,
    vel,
    kind,
    dry,
    indptr,
    indices,
    re,
    wcode,
    neumann,
    gravity,
    dt,
    nu0,
    n0,
    number_density,
    rho,
    gamma,
    out,
):
    """Source term (Pa/m^2) of the pressure equation with HS, per particle (0 on dummies):

    out_i = (1 - gamma) rho / dt (-(1/nu0) Dn*_i/Dt - wall_std_i) - gamma rho / dt^2 (n*_i - n0)/n0

    where wall_std_i is, with the Neumann model, the standard-form wall flux d / n0 sum_j
    (u_j + g dt - u_i) . r_ij / r_ij^2 w_ij over wet boundary neighbours (eq. 2-15 as in
    wall_boundary.ghost_rhs, which the caller adds to the right-hand side; taken back out here),
    0 with the pressure-layer model. The right-hand side b = -out + ghost_rhs then holds the
    HS divergence over all neighbours."""
    n, dim = pos.shape
    re2 = re * re
    a_div = (1.0 - gamma) * rho / dt
    c_den = gamma * rho / (dt * dt * n0)
    c_std = dim / n0
    for i in prange(n):
        ki = kind[i]
        out[i] = 0.0
        if ki == 2 or ki == 4:
            continue
        rate = 0.0
        wall = 0.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            kj = kind[j]
            boundary = neumann and kj != 0
            if boundary and dry[j] != 0:
                continue
            r2 = 0.0
            dot = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                du = vel[j, a] - vel[i, a]
                if boundary:
                    du += gravity[a] * dt
                r2 += dx * dx
                dot += du * dx
            if r2 >= re2 or r2 == 0.0:
                continue
            r = np.sqrt(r2)
            rate += kernel_slope_over_r(r, re, wcode) * dot  # Khayyer & Gotoh 2009, HS (Dn/Dt)
            if boundary:
                wall += dot / r2 * weight(r, re, wcode)  # thesis eq. 2-15 (the caller's part)
        div_hs = -rate / nu0  # HS divergence, normalised on the lattice (module docstring)
        # thesis eq. 2-23 with HS in the velocity part, less the caller's standard wall flux
        out[i] = a_div * (div_hs - c_std * wall) - c_den * (number_density[i] - n0)
    return out


@njit(cache=True, parallel=True)
def add_error_compensation(n_k, rate_k, kind, rho, dt, n0, out):
    """out_i += ECS_i (Pa/m^2) on non-dummy particles, from the number density n_k and its rate
    rate_k (1/s) at the start of the step (module docstring)."""
    e1 = rho / (n0 * dt)
    e2 = rho / (dt * dt)
    for i in prange(kind.shape[0]):
        k = kind[i]
        if k == 2 or k == 4:
            continue
        strain = (n_k[i] - n0) / n0
        alpha = abs(strain)
        beta = abs(dt * rate_k[i] / n0)
        # Khayyer & Gotoh 2011, ECS: -alpha rho/(n0 dt) (Dn/Dt)^k - beta rho/dt^2 (n^k - n0)/n0
        out[i] += -alpha * e1 * rate_k[i] - beta * e2 * strain
    return out
