"""Dirichlet value of free-surface particles.

A surface particle stands for the fluid up to half a spacing beyond its centre, so p = 0 belongs
there, not at the particle (the thesis's p = 0 at the particle puts the whole pressure field
rho g l0 / 2 low under gravity). With the pressure gradient G_i of the previous step at the
particle (normal to the surface, where p is constant along it):

    p_s,i = l0 / 2 |G_i|                       (linear continuation to p = 0 at l0 / 2 outward)

This is 0 in free fall (G = 0) and rho g l0 / 2 at a surface at rest. The values enter the
pressure equation as known neighbours of the unknown rows (their right-hand side) and are
written into p after the solve.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight


@njit(cache=True, parallel=True)
def surface_values(kind, free_surface, grad_prev, l0, out):
    """out_i = l0 / 2 |grad_prev_i| (Pa) on free-surface FLUID particles, 0 elsewhere."""
    n, dim = grad_prev.shape
    for i in prange(n):
        v = 0.0
        if kind[i] == 0 and free_surface[i] != 0:
            g2 = 0.0
            for a in range(dim):
                g2 += grad_prev[i, a] * grad_prev[i, a]
            v = 0.5 * l0 * np.sqrt(g2)
        out[i] = v


@njit(cache=True, parallel=True)
def add_dirichlet_rhs(pos, kind, free_surface, p_surface, indptr, indices, re, wcode, coef, rhs):
    """rhs_i += coef sum_j w(r_ij; re) p_s,j over free-surface FLUID neighbours j of every
    non-surface FLUID row i (the known neighbours of the PPE Laplacian, eq. 2-16; Pa/m^2)."""
    n, dim = pos.shape
    re2 = re * re
    for i in prange(n):
        if kind[i] != 0 or free_surface[i] != 0:
            continue
        acc = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if kind[j] != 0 or free_surface[j] == 0 or p_surface[j] == 0.0:
                continue
            r2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                r2 += dx * dx
            if r2 < re2:
                acc += weight(np.sqrt(r2), re, wcode) * p_surface[j]
        rhs[i] += coef * acc


@njit(cache=True, parallel=True)
def write_surface_values(kind, free_surface, p_surface, p):
    """p_i = p_s,i on free-surface FLUID particles (after the solve, which leaves them 0)."""
    for i in prange(p.shape[0]):
        if kind[i] == 0 and free_surface[i] != 0:
            p[i] = p_surface[i]
