"""The hand-written preconditioned conjugate gradient of the MPS pressure solve (pressure_poisson.py):
matrix-vector product, dot products in fixed chunks summed in a fixed order (bit-identical for a
given thread count), the fused CG updates and the Jacobi preconditioner (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange

_NCHUNK = 128  # dot products: fixed chunks summed in a fixed order (thread-count independent)


@njit(cache=True, parallel=True)
def _spmv(a_ptr, a_idx, a_val, x, y):
    for r in prange(y.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[r]), np.uint64(a_ptr[r + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        y[r] = s


@njit(cache=True, parallel=True)
def _dot(x, y, part):
    n = x.shape[0]
    for c in prange(_NCHUNK):
        lo = c * n // _NCHUNK
        hi = (c + 1) * n // _NCHUNK
        s = 0.0
        for k in range(lo, hi):
            s += x[k] * y[k]
        part[c] = s
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _residual(a_ptr, a_idx, a_val, x, b, r, part):
    """r = b - A x; returns ||r||^2."""
    m = b.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            s = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                s += a_val[k] * x[np.uint32(a_idx[k])]
            v = b[i] - s
            r[i] = v
            acc += v * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _direction_and_product(a_ptr, a_idx, a_val, z, d, beta, q, part):
    """d = z + beta d (all rows first), then q = A d; returns d.q."""
    m = z.shape[0]
    for i in prange(m):
        d[i] = z[i] + beta * d[i]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            s = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                s += a_val[k] * d[np.uint32(a_idx[k])]
            q[i] = s
            acc += d[i] * s
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _update(x, r, d, q, alpha, part):
    """x += alpha d, r -= alpha q; returns ||r||^2."""
    m = x.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            x[i] += alpha * d[i]
            v = r[i] - alpha * q[i]
            r[i] = v
            acc += v * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s


@njit(cache=True, parallel=True)
def _jacobi_apply(a_ptr, a_idx, a_val, r, z, part):
    """z = D^-1 r; returns r.z."""
    m = r.shape[0]
    for c in prange(_NCHUNK):
        lo = c * m // _NCHUNK
        hi = (c + 1) * m // _NCHUNK
        acc = 0.0
        for i in range(lo, hi):
            dg = 1.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                if a_idx[k] == i:
                    dg = a_val[k]
            v = r[i] / dg
            z[i] = v
            acc += r[i] * v
        part[c] = acc
    s = 0.0
    for c in range(_NCHUNK):
        s += part[c]
    return s
