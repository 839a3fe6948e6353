"""Hybrid (block-parallel) Gauss-Seidel smoothing of the AMG V-cycle (amg_pcg.py), with its residual
and accumulating matrix-vector product (numba)."""

from __future__ import annotations

import numpy as np
from numba import njit, prange


@njit(cache=True, parallel=True)
def _hybrid_gs(a_ptr, a_idx, a_val, x, b, xold, nblocks, backward):
    """One l1 hybrid Gauss-Seidel sweep (Baker, Falgout, Kolev & Yang 2011) in place on x.

    The rows are cut into ``nblocks`` fixed contiguous blocks, swept in parallel; inside a block
    it is Gauss-Seidel (forward or backward), across blocks Jacobi on the values from before the
    sweep, with the off-block absolute row sum added to the diagonal, which makes the sweep
    convergent for any SPD matrix. The result depends on nblocks, not on the thread count. A
    forward sweep as pre-smoother and a backward one as post-smoother keep the V-cycle symmetric.
    """
    m = x.shape[0]
    for i in prange(m):
        xold[i] = x[i]
    for c in prange(nblocks):
        lo = c * m // nblocks
        hi = (c + 1) * m // nblocks
        width = np.uint64(hi - lo)
        for t in range(hi - lo):
            i = hi - 1 - t if backward else lo + t
            s = b[i]
            dg = 0.0
            l1 = 0.0
            for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
                j = np.uint32(a_idx[k])
                v = a_val[k]
                if np.uint64(np.int64(j) - lo) < width:  # in block (diagonal included)
                    s -= v * x[j]
                    if j == i:
                        dg = v
                else:
                    s -= v * xold[j]
                    l1 += abs(v)
            x[i] += s / (dg + l1)


@njit(cache=True, parallel=True)
def _residual_only(a_ptr, a_idx, a_val, x, b, r):
    for i in prange(b.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        r[i] = b[i] - s


@njit(cache=True, parallel=True)
def _spmv_add(a_ptr, a_idx, a_val, x, y):
    """y += A x."""
    for i in prange(y.shape[0]):
        s = 0.0
        for k in range(np.uint64(a_ptr[i]), np.uint64(a_ptr[i + 1])):
            s += a_val[k] * x[np.uint32(a_idx[k])]
        y[i] += s
