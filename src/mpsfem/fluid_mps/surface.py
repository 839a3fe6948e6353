"""Free-surface detection, selectable by name (:data:`DETECTORS`, :func:`make_surface_detector`).

Output: int8 flags, 1 = free-surface particle (Dirichlet p = 0 in the pressure equation), 0 = not.
Candidates are particles that carry pressure (FLUID, WALL, STRUCTURE); dummy particles are never
flagged. Wall and dummy particles count in the number density, so fluid next to a wall is not a
surface; a pressure-wall particle is flagged only where the fluid leaves it exposed (above the water
line), where p = 0 is the right value for it.

- ``"density"`` (thesis eq. 2-18): surface where ``n_i < beta n0`` (beta default 0.97).
- ``"density_asymmetry"`` (thesis eqs. 2-18 to 2-20, Zhang et al.): ``n_i <= beta_low n0``
  (default 0.8) is surface; ``n_i >= beta n0`` (0.97) is not; in between the particle is surface
  when the neighbour-asymmetry vector

      F_i = d / n0 sum_{j != i} (r_i - r_j) / |r_ij| w_ij            (eq. 2-19)

  (all neighbours within the density radius, any kind) satisfies ``|F_i| > alpha`` (eq. 2-20)
  with ``alpha = asymmetry * |F|^0``. ``|F|^0`` is |F| of a particle on a flat free surface of the
  initial lattice (computed on the lattice, :func:`flat_surface_asymmetry`); the thesis takes
  asymmetry = 0.9. The asymmetry test is for FLUID particles; a pressure-wall particle (one-sided
  by construction: dummies behind it) is a surface when ``n_i < beta n0``, as with ``"density"``.
  Known limitation (3D): at a vertical edge where two walls meet, the walls above the water raise
  a top-layer fluid particle's n into the band and shrink its |F| below the threshold, so it is
  missed (see tests/fluid_mps/test_surface.py).

``n0`` is the lattice number density for the detector's radius ``re`` (the density radius).
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight, weight_code, weight_py
from .lattice import lattice_constants, lattice_offsets


def flat_surface_asymmetry(dim: int, l0: float, re: float, weight="improved") -> float:
    """|F|^0 (eq. 2-19) of a lattice particle whose neighbours fill only the half-space below it."""
    n0, _ = lattice_constants(dim, l0, re, weight)
    off = lattice_offsets(dim, l0, re)
    off = off[off[:, -1] <= 0.0]  # keep the particle's own layer and those below
    r = np.sqrt((off * off).sum(axis=1))
    w = weight_py(r, re, weight)
    f = dim / n0 * ((-off) / r[:, None] * w[:, None]).sum(axis=0)
    return float(np.sqrt((f * f).sum()))


@njit(cache=True, parallel=True)
def _detect_density(kind, number_density, threshold, out):
    for i in prange(kind.shape[0]):
        k = kind[i]
        out[i] = 1 if ((k == 0 or k == 1 or k == 3) and number_density[i] < threshold) else 0
    return out


@njit(cache=True, parallel=True)
def _detect_asymmetry(
    pos, kind, number_density, indptr, indices, re, wcode, n0, low, high, alpha, out
):
    n, dim = pos.shape
    c = dim / n0
    a2 = alpha * alpha
    for i in prange(n):
        k = kind[i]
        if not (k == 0 or k == 1 or k == 3):
            out[i] = 0
            continue
        ni = number_density[i]
        if ni <= low:
            out[i] = 1
            continue
        if ni >= high:
            out[i] = 0
            continue
        if k != 0:  # pressure walls: the density test alone (they are one-sided by construction)
            out[i] = 1
            continue
        f0 = 0.0
        f1 = 0.0
        f2 = 0.0
        for kk in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[kk])
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 < re * re and r2 > 0.0:
                r = np.sqrt(r2)
                s = weight(r, re, wcode) / r
                f0 -= (pos[j, 0] - pos[i, 0]) * s
                f1 -= (pos[j, 1] - pos[i, 1]) * s
                if dim == 3:
                    f2 -= (pos[j, 2] - pos[i, 2]) * s
        out[i] = 1 if c * c * (f0 * f0 + f1 * f1 + f2 * f2) > a2 else 0
    return out


class SurfaceDetector:
    """Base: ``detect(pos, kind, number_density, nb, out) -> out`` (int8 flags)."""

    name = "base"

    def __init__(self, *, dim, l0, re, weight="improved", beta=0.97, **_ignored):
        if dim not in (2, 3):
            raise ValueError(f"dim must be 2 or 3, got {dim!r}")
        if not 0.0 < beta < 1.0:
            raise ValueError(f"beta must be in (0, 1), got {beta!r}")
        self.dim, self.l0, self.re = dim, float(l0), float(re)
        self.wcode = weight_code(weight)
        self.weight = weight
        self.beta = float(beta)
        self.n0, _ = lattice_constants(dim, l0, re, weight)

    def detect(self, pos, kind, number_density, nb, out):  # pragma: no cover - abstract
        raise NotImplementedError


class DensityDetector(SurfaceDetector):
    """n_i < beta n0 (eq. 2-18)."""

    name = "density"

    def detect(self, pos, kind, number_density, nb, out):
        return _detect_density(kind, number_density, self.beta * self.n0, out)


class DensityAsymmetryDetector(SurfaceDetector):
    """Number-density thresholds plus the neighbour-asymmetry test (eqs. 2-18 to 2-20)."""

    name = "density_asymmetry"

    def __init__(self, *, beta_low=0.8, asymmetry=0.9, **kw):
        super().__init__(**kw)
        if not 0.0 < beta_low < self.beta:
            raise ValueError(f"beta_low must be in (0, beta={self.beta}), got {beta_low!r}")
        if not asymmetry > 0.0:
            raise ValueError(f"asymmetry must be positive, got {asymmetry!r}")
        self.beta_low = float(beta_low)
        self.asymmetry = float(asymmetry)
        self.f0 = flat_surface_asymmetry(self.dim, self.l0, self.re, self.weight)
        self.alpha = self.asymmetry * self.f0

    def detect(self, pos, kind, number_density, nb, out):
        if nb.radius < self.re * (1 - 1e-12):
            raise ValueError(f"neighbour list radius {nb.radius} < detector radius {self.re}")
        return _detect_asymmetry(
            pos,
            kind,
            number_density,
            nb.indptr,
            nb.indices,
            self.re,
            self.wcode,
            self.n0,
            self.beta_low * self.n0,
            self.beta * self.n0,
            self.alpha,
            out,
        )


DETECTORS: dict[str, type[SurfaceDetector]] = {
    "density": DensityDetector,
    "density_asymmetry": DensityAsymmetryDetector,
}


def make_surface_detector(name: str, **kwargs) -> SurfaceDetector:
    """Detector by name (see :data:`DETECTORS`); keywords: dim, l0, re, weight, beta, and for
    ``density_asymmetry`` also beta_low and asymmetry."""
    try:
        cls = DETECTORS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown free-surface detector {name!r}; allowed: {', '.join(sorted(DETECTORS))}"
        ) from None
    return cls(**kwargs)
