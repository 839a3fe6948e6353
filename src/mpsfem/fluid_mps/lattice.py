"""Constants of the initial particle lattice: number density n0 and the Laplacian's lambda0.

MPS compares the particle number density with ``n0`` (thesis eq. 2-5) and scales the Laplacian with
``2 d / (lambda0 n0)`` (eqs. 2-16, 2-17). Both are evaluated once, for each kernel radius, on the
perfect square (2D) or cubic (3D) lattice of spacing ``l0`` around a particle with full support:

    n0      = sum_{j != i} w(|r_ij|)
    lambda0 = sum_{j != i} w(|r_ij|) |r_ij|^2 / n0
"""

from __future__ import annotations

import itertools

import numpy as np

from .kernels import weight_code, weight_py


def lattice_offsets(dim: int, l0: float, re: float) -> np.ndarray:
    """Offsets (M, dim) of all lattice sites j != 0 with |r_j| < re, in lexicographic order."""
    if dim not in (2, 3):
        raise ValueError(f"dim must be 2 or 3, got {dim!r}")
    if not (l0 > 0 and re > 0):
        raise ValueError(f"l0 and re must be positive, got l0={l0!r}, re={re!r}")
    m = int(np.ceil(re / l0)) + 1
    rng = range(-m, m + 1)
    pts = np.array([p for p in itertools.product(rng, repeat=dim) if any(p)], dtype=np.float64) * l0
    r = np.sqrt((pts * pts).sum(axis=1))
    return pts[r < re]


def lattice_constants(dim: int, l0: float, re: float, weight="improved") -> tuple[float, float]:
    """``(n0, lambda0)`` of the perfect lattice of spacing ``l0`` for kernel radius ``re``."""
    weight_code(weight)  # validates the name
    pts = lattice_offsets(dim, l0, re)
    r2 = (pts * pts).sum(axis=1)
    w = weight_py(np.sqrt(r2), re, weight)
    n0 = float(w.sum())
    lam = float((w * r2).sum() / n0)
    return n0, lam


def uniaxial_density_response(dim: int, l0: float, re: float, weight="improved") -> float:
    """``s = (1 / n0) dn / d eps``: how the number density of the perfect lattice answers a
    compression by eps along one axis (dimensionless).

    A continuum's density rises by eps; the kernel sum rises by s eps, s = (1 / n0) sum_j
    -w'(r_j) (r_j . e)^2 / r_j (in 2D at re = 2.1 l0: 1.34 with the improved weight, 1.42 with
    the original), so still water whose number density reads n0 (1 + kappa p) is compressed by
    kappa p / s. Central difference over eps = +-1e-6 of the offsets within re (1 + 1e-3), those
    that enter the radius included.
    """
    pts = lattice_offsets(dim, l0, re * (1.0 + 1e-3))
    n0 = lattice_constants(dim, l0, re, weight)[0]
    eps = 1e-6
    n = []
    for e in (eps, -eps):
        q = pts.copy()
        q[:, -1] *= 1.0 - e
        n.append(float(weight_py(np.sqrt((q * q).sum(axis=1)), re, weight).sum()))
    return (n[0] - n[1]) / (2.0 * eps * n0)
