"""Assembly of the MPS pressure Poisson equation (pressure_poisson.py): the mixed source term, the
negative-pressure clamp, the classification of unknowns and the two-pass CSR fill of the matrix,
the floating-set regularisation and the gather/scatter between particles and matrix rows (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .higher_order_laplacian import (
    pair_coefficient,
)
from .particle_kinds import is_dummy


# ----------------------------------------------------------------------------- source term
@njit(cache=True, parallel=True)
def mixed_source_term(div_u, number_density, kind, rho, dt, gamma, n0, out):
    """Right-hand side of eq. 2-23 per particle (0 on dummies):
    (1 - gamma) rho / dt div_u - gamma rho / dt^2 (n - n0) / n0."""
    a = (1.0 - gamma) * rho / dt
    c = gamma * rho / (dt * dt * n0)
    for i in prange(kind.shape[0]):
        k = kind[i]
        if k == 2 or k == 4:
            out[i] = 0.0
        else:
            out[i] = a * div_u[i] - c * (number_density[i] - n0)
    return out


@njit(cache=True, parallel=True)
def subtract_compressibility_source(p_prev, kind, coef, out):
    """out_i -= coef p_prev_i (not on dummies): the previous pressure's share of the
    artificial-compressibility term, coef = (1 - gamma) rho kappa / dt^2 (module docstring)."""
    for i in prange(kind.shape[0]):
        if not is_dummy(kind[i]):
            out[i] -= coef * p_prev[i]
    return out


@njit(cache=True, parallel=True)
def clamp_negative(p, mask):
    """p_i = max(p_i, 0) where mask_i is true (negative-pressure clamp)."""
    for i in prange(p.shape[0]):
        if mask[i] and p[i] < 0.0:
            p[i] = 0.0
    return p


@njit(cache=True, parallel=True)
def clamp_negative_except_at_structures(pos, p, kind, free_surface, indptr, indices, re, floor):
    """The clamp of ``fluid.pressure.structure_suction``: p_i = max(p_i, floor) (floor <= 0, Pa)
    on STRUCTURE particles and on FLUID particles with a STRUCTURE or STRUCTURE_DUMMY particle
    and no free-surface particle within ``re`` (m) in the pair list; p_i = max(p_i, 0) on every
    other particle (a surface layer's negative pressures are the number density's deficit, not
    suction)."""
    n, dim = pos.shape
    re2 = re * re
    for i in prange(n):
        k = kind[i]
        lo = 0.0
        if k == 3:
            lo = floor
        elif k == 0 and free_surface[i] == 0:
            near_structure = False
            near_surface = False
            for kk in range(indptr[i], indptr[i + 1]):
                j = indices[kk]
                kj = kind[j]
                if kj != 3 and kj != 4 and not (kj == 0 and free_surface[j] != 0):
                    continue
                r2 = 0.0
                for a in range(dim):
                    d = pos[j, a] - pos[i, a]
                    r2 += d * d
                if r2 < re2:
                    if kj == 0:
                        near_surface = True
                        break
                    near_structure = True
            if near_structure and not near_surface:
                lo = floor
        if p[i] < lo:
            p[i] = lo
    return p


# ----------------------------------------------------------------------------- assembly
@njit(cache=True)
def _row_map(kind, row_of):
    """Row of each pressure-carrying particle (FLUID, WALL, STRUCTURE) in particle order; -1 else."""
    m = 0
    for i in range(kind.shape[0]):
        k = kind[i]
        if k == 0 or k == 1 or k == 3:
            row_of[i] = m
            m += 1
        else:
            row_of[i] = -1
    return m


@njit(cache=True, parallel=True)
def _classify(pos, kind, free_surface, indptr, indices, re2, unknown, walls=True):
    """unknown[i] = 1 for non-surface FLUID, and non-surface WALL/STRUCTURE with a FLUID neighbour."""
    n, dim = pos.shape
    for i in prange(n):
        k = kind[i]
        u = 0
        if free_surface[i] == 0:
            if k == 0:
                u = 1
            elif walls and (k == 1 or k == 3):
                for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
                    j = np.uint32(indices[kk])
                    if kind[j] == 0:
                        r2 = 0.0
                        for d in range(dim):
                            dx = pos[j, d] - pos[i, d]
                            r2 += dx * dx
                        if r2 < re2:
                            u = 1
                            break
        unknown[i] = u


@njit(cache=True, parallel=True)
def _count(pos, unknown, row_of, indptr, indices, re2, re2_pre, counts, counts_pre):
    """First pass: nonzeros per row of the PPE matrix (radius^2 re2) and of the preconditioner's
    matrix (re2_pre <= re2; ignored when re2_pre <= 0)."""
    n, dim = pos.shape
    for i in prange(n):
        r = row_of[i]
        if r < 0:
            continue
        c = 1
        cp = 1
        if unknown[i]:
            for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
                j = np.uint32(indices[kk])
                if unknown[j]:
                    r2 = 0.0
                    for d in range(dim):
                        dx = pos[j, d] - pos[i, d]
                        r2 += dx * dx
                    if r2 < re2:
                        c += 1
                        if r2 < re2_pre:
                            cp += 1
        counts[r] = c
        counts_pre[r] = cp


@njit(cache=True)
def _prefix(counts, m, out):
    """Row pointer ``out`` (int32) from the row counts; returns the total in int64, which the
    caller checks against INT32_MAX (past it ``out`` has wrapped)."""
    out[0] = 0
    total = np.int64(0)
    for r in range(m):
        total += counts[r]
        out[r + 1] = total
    return total


@njit(cache=True, inline="always")
def _put_diagonal(a_idx, a_val, p, dpos, r, diag):
    """Close a row: the diagonal goes to its reserved slot, or to the end of the row."""
    if dpos < 0:
        dpos = p
    a_idx[dpos] = r
    a_val[dpos] = diag


@njit(cache=True, parallel=True)
def _fill(
    pos,
    kind,
    free_surface,
    unknown,
    row_of,
    indptr,
    indices,
    re,
    wcode,
    lap_code,
    coef,
    shift,
    decoupled,
    src,
    a_ptr,
    a_idx,
    a_val,
    b,
    dirichlet,
    re_pre,
    coef_pre,
    decoupled_pre,
    p_ptr,
    p_idx,
    p_val,
    p_dirichlet,
):
    """Second pass: the CSR rows (columns ascending, diagonal in place) of the PPE matrix and,
    when ``re_pre > 0``, of the preconditioner's matrix on radius re_pre, in one sweep over the
    neighbours; the right-hand side; whether each row touches a Dirichlet (free-surface)
    neighbour. ``lap_code``: the pair weight of the Laplacian, 0 the kernel (eq. 2-16), 1 the
    higher-order Laplacian's (higher_order_laplacian.py); ``coef`` its normalisation."""
    n, dim = pos.shape
    re2 = re * re
    re2p = re_pre * re_pre if re_pre > 0.0 else -1.0
    two = re_pre > 0.0
    for i in prange(n):
        r = row_of[i]
        if r < 0:
            continue
        p = a_ptr[r]
        q = p_ptr[r] if two else 0
        if unknown[i] == 0:
            a_idx[p] = r
            a_val[p] = decoupled
            b[r] = 0.0
            dirichlet[r] = 1
            if two:
                p_idx[q] = r
                p_val[q] = decoupled_pre
                p_dirichlet[r] = 1
            continue
        diag = 0.0
        dpos = -1
        touch = 0
        diag_p = 0.0
        dpos_p = -1
        touch_p = 0
        for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[kk])
            uj = unknown[j]
            if uj == 0 and free_surface[j] == 0:
                continue  # dummy, or a wall too far from the fluid: no pressure coupling
            kj = kind[j]
            if kj == 2 or kj == 4:
                continue
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 >= re2:
                continue
            rr = np.sqrt(r2)
            w = coef * pair_coefficient(rr, re, wcode, lap_code, dim)
            diag += w
            inner = r2 < re2p
            if inner:
                wp = coef_pre * pair_coefficient(rr, re_pre, wcode, lap_code, dim)
                diag_p += wp
            if uj:
                if dpos < 0 and j > i:
                    dpos = p
                    p += 1
                a_idx[p] = row_of[j]
                a_val[p] = -w
                p += 1
                if inner:
                    if dpos_p < 0 and j > i:
                        dpos_p = q
                        q += 1
                    p_idx[q] = row_of[j]
                    p_val[q] = -wp
                    q += 1
            else:
                touch = 1
                if inner:
                    touch_p = 1
        _put_diagonal(a_idx, a_val, p, dpos, r, diag + shift)
        dirichlet[r] = touch
        if two:
            _put_diagonal(p_idx, p_val, q, dpos_p, r, diag_p + shift)
            p_dirichlet[r] = touch_p
        b[r] = -src[i]


@njit(cache=True)
def _floating_rows(a_ptr, a_idx, dirichlet, m, mark, queue):
    """Mark (mark[r] = 0) rows not connected to any Dirichlet-touching row; return their count.

    Breadth-first search from all rows that touch a free-surface particle (decoupled rows count as
    grounded). O(nnz), serial."""
    head = 0
    tail = 0
    for r in range(m):
        if dirichlet[r]:
            mark[r] = 1
            queue[tail] = r
            tail += 1
        else:
            mark[r] = 0
    while head < tail:
        r = queue[head]
        head += 1
        for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
            c = a_idx[k]
            if mark[c] == 0:
                mark[c] = 1
                queue[tail] = c
                tail += 1
    return m - tail


@njit(cache=True)
def _shift_floating(a_ptr, a_idx, a_val, mark, m, shift):
    for r in range(m):
        if mark[r] == 0:
            for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
                if a_idx[k] == r:
                    a_val[k] += shift


@njit(cache=True, parallel=True)
def _gather(p, row_of, unknown, x):
    for i in prange(p.shape[0]):
        r = row_of[i]
        if r >= 0:
            x[r] = p[i] if unknown[i] else 0.0


@njit(cache=True, parallel=True)
def _scatter(x, row_of, unknown, p):
    for i in prange(p.shape[0]):
        r = row_of[i]
        p[i] = x[r] if (r >= 0 and unknown[i]) else 0.0


# ----------------------------------------------------------------------------- CG kernels
