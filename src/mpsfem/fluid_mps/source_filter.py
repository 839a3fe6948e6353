"""A low-pass filter of the velocity divergence in the pressure equation's source
(``fluid.pressure.source_filter``).

Why it was built: the projection's gradient (2.1 l0) cannot produce particle-scale velocity
changes, so the particle-scale part of div u* survives the correction (84-96 % of the interior
divergence is left after it; docs/fluid.md, "Where the per-step noise comes from"), and the
standard source term asks for it anew every step at rho / dt. Was that MPS's white load noise?
Measured on the stiff obstacle: no. With the filter the load kicks as hard (138 N/m, ringing
0.190, inside the default's spread), so the kicks come from the kernel-scale divergence (same
section, "The noise is not the particle-scale divergence"); the switch stays, off by default,
to keep that finding reproducible. The filter replaces the divergence of a FLUID particle by
its kernel average over itself and its non-surface FLUID neighbours,

    <div>_i = (div_i + sum_j W(r_ij) div_j) / (1 + sum_j W(r_ij)),
    W(r) = (1 - r/re)^4 (1 + 4 r/re)   (Wendland's C2 function, W(0) = 1),

which keeps a divergence that varies linearly across the kernel (on a symmetric neighbourhood)
and damps a checkerboard-like one. Free-surface particles do not contribute: their divergence
is the truncated kernel's, not the flow's. Wall and structure rows (the pressure-layer wall
model) and dummies keep theirs.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

#: allowed values of ``fluid.pressure.source_filter``
SOURCE_FILTERS = ("none", "kernel_average")


@njit(cache=True, inline="always")
def _wendland(q):
    """Wendland's C2 function of q = r / re, 1 at q = 0, 0 from q = 1 (dimensionless)."""
    if q >= 1.0:
        return 0.0
    a = 1.0 - q
    return a * a * a * a * (1.0 + 4.0 * q)


@njit(cache=True, parallel=True)
def kernel_average_divergence(div, pos, kind, free_surface, indptr, indices, re, out):
    """out_i = the Wendland-weighted average of ``div`` (1/s) over FLUID particle i and its
    non-surface FLUID neighbours within ``re`` (m); out_i = div_i on every other particle.
    ``out`` must not be ``div``."""
    n, dim = pos.shape
    for i in prange(n):
        if kind[i] != 0:
            out[i] = div[i]
            continue
        s = div[i]
        wsum = 1.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if kind[j] != 0 or free_surface[j]:
                continue
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 >= re * re or r2 == 0.0:
                continue
            w = _wendland(np.sqrt(r2) / re)
            s += w * div[j]
            wsum += w
        out[i] = s / wsum
    return out
