"""Particle shifting: a position-only regularisation of the particle distribution (the Fickian
shifting of Xu, Stansby & Laurence 2009 and Lind et al. 2012, in the MPS form of the
concentration gradient).

Why: the antisymmetric pressure gradients (``tanaka``, eq. 2-12) push every pair apart with
p_i + p_j, a compressive pre-stress on the particle lattice. The projection removes the lattice's
compressional response and leaves its shear modes, whose geometric stiffness under that
pre-stress is negative: still water loses its lattice within 0.03-0.04 s whatever the step
(docs/fluid.md). Shifting moves each interior fluid particle down the gradient of its neighbour
concentration,

    dr_i = -eps l0^2 <grad C>_i,   <grad C>_i = d / n0 sum_j r_ij w_ij / |r_ij|^2

(the MPS gradient of C = 1 over all neighbours within re, walls included; Lind et al. 2012
eq. 9 with the MPS gradient in place of the SPH kernel gradient), each shift capped at
``cap`` (m). Velocities are not changed, so the fluid's momentum is untouched; the particle's
velocity and pressure are not re-interpolated at the new position (a first-order error of size
|dr| |grad u|, like Xu et al.'s uncorrected shifting). Particles at the free surface or with a
surface neighbour within re are not moved (their concentration gradient is the surface's
normal, which shifting would turn into a spreading of the surface), and neither are particles
with a structure particle within re: a thin member is one or two layers without dummies behind,
so the concentration gradient there points into the fluid and shifting pushed particles through
the member (the elastic obstacle at L/20 stopped at 0.148 s with it; static walls have their
dummy layers and full support).

Jacobi style: every shift reads the positions before the call (bit-identical for any thread
count).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight


@njit(cache=True, parallel=True)
def shift_vectors(pos, kind, surface, indptr, indices, re, wcode, n0, eps_l02, cap, out):
    """out[i] = the shift (m) of FLUID particle i (0 for others, for surface particles and for
    particles with a surface or structure neighbour within re)."""
    n, dim = pos.shape
    c = dim / n0
    re2 = re * re
    for i in prange(n):
        for d in range(dim):
            out[i, d] = 0.0
        if kind[i] != 0 or surface[i]:
            continue
        g0 = g1 = g2 = 0.0
        near_surface = False
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            x0 = pos[j, 0] - pos[i, 0]
            x1 = pos[j, 1] - pos[i, 1]
            x2 = pos[j, 2] - pos[i, 2] if dim == 3 else 0.0
            r2 = x0 * x0 + x1 * x1 + x2 * x2
            if r2 >= re2 or r2 == 0.0:
                continue
            if (kind[j] == 0 and surface[j]) or kind[j] == 3 or kind[j] == 4:
                near_surface = True  # a surface or a member (whose support may be one layer)
                break
            w = weight(np.sqrt(r2), re, wcode) / r2
            g0 += w * x0
            g1 += w * x1
            g2 += w * x2
        if near_surface:
            continue
        s0 = -eps_l02 * c * g0
        s1 = -eps_l02 * c * g1
        s2 = -eps_l02 * c * g2
        size = np.sqrt(s0 * s0 + s1 * s1 + s2 * s2)
        if size > cap:
            s0 *= cap / size
            s1 *= cap / size
            s2 *= cap / size
        out[i, 0] = s0
        out[i, 1] = s1
        if dim == 3:
            out[i, 2] = s2


@njit(cache=True, parallel=True)
def _add(pos, shift):
    for i in prange(pos.shape[0]):
        for d in range(pos.shape[1]):
            pos[i, d] += shift[i, d]


def shift_particles(
    pos, kind, surface, indptr, indices, re: float, wcode: int, n0: float, eps: float,
    l0: float, cap: float, work,
) -> float:  # fmt: skip
    """Shift the interior fluid particles in place (``eps`` dimensionless, ``cap`` m, ``work``
    an (N, dim) scratch array). Returns the largest shift (m)."""
    shift_vectors(pos, kind, surface, indptr, indices, re, wcode, n0, eps * l0 * l0, cap, work)
    _add(pos, work)
    return float(np.sqrt((work * work).sum(axis=1).max())) if len(work) else 0.0
