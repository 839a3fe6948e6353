"""Higher-order Laplacian (HL) of Khayyer & Gotoh for the pressure equation (``laplacian =
"higher_order"``).

The standard MPS Laplacian (thesis eq. 2-16) weighs a pair with the kernel itself,
``<lap p>_i = 2 d / (lambda0 n0) sum_j (p_j - p_i) w_ij``. Khayyer & Gotoh (2010, "A higher order
Laplacian model for enhancement and stabilization of pressure calculation by the MPS method",
Appl. Ocean Res. 32, 124-131) take instead the divergence of the kernel-gradient model, which weighs
a pair with second derivatives of the kernel:

    <lap p>_i = C sum_j (p_j - p_i) f(r_ij),   f(r) = w''(r) + (d - 3) w'(r) / r

- 2D (their 2010 paper): f = w'' - w' / r; with Koshizuka's kernel w = re / r - 1 it is
  3 re / r^3;
- 3D (Khayyer & Gotoh 2012, "A 3D higher order Laplacian model for enhancement and stabilization
  of pressure calculation in 3D MPS-based simulations", Appl. Ocean Res. 37, 120-126): f = w'';
  with Koshizuka's kernel 2 re / r^3.

The same pair function serves the project's kernel (``"improved"``, thesis eq. 2-4, w = re / s - 1
with s = 0.85 r + 0.15 re): w' = -0.85 re / s^2, w'' = 2 0.85^2 re / s^3. f > 0 for r < re, so the
matrix keeps the signs of the standard one (symmetric, positive definite with a Dirichlet
neighbour). Normalisation: the papers write C = 1 / n0. Here C = 2 d / sum_j r_j^2 f(r_j) over the
initial lattice (:func:`hl_constants`), which makes the Laplacian of a quadratic field exact on
that lattice, the role lambda0 plays for eq. 2-16; with 1 / n0 the Laplacian, and with it every
divergence-driven pressure, would carry a kernel- and radius-dependent constant factor (the
lattice gives C n0 = 0.72 for the improved kernel at 4.01 l0 in 2D, 0.57 for Koshizuka's, 1.28
and 0.98 in 3D).

Known neighbours (the Neumann wall model's ghosts p_j = p_i + D_ij, wall_boundary.py, and the
free-surface Dirichlet values p_s,j, surface_pressure.py) enter the right-hand side of the
pressure equation through those modules with the standard weight ``coef w_ij``;
:func:`known_neighbour_correction` adds the difference to the HL weight, so that both sides of the
equation use the same Laplacian and still water stays exactly hydrostatic.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight, weight_code
from .lattice import lattice_offsets

STANDARD = 0
HIGHER_ORDER = 1
LAPLACIANS: dict[str, int] = {"standard": STANDARD, "higher_order": HIGHER_ORDER}


def laplacian_code(name: str) -> int:
    """Integer code of a PPE Laplacian given by name."""
    try:
        return LAPLACIANS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown PPE Laplacian {name!r}; allowed: {', '.join(sorted(LAPLACIANS))}"
        ) from None


@njit(cache=True, inline="always")
def hl_shape(r, re, wcode, dim):
    """f(r) = w''(r) + (d - 3) w'(r) / r (1/m^2 for a dimensionless w and r, re in m), 0 for
    r >= re; r is floored at 1e-6 re as in kernels.weight."""
    if r >= re:
        return 0.0
    rr = r if r > 1e-6 * re else 1e-6 * re
    if wcode == 0:  # improved kernel, thesis eq. 2-4: w = re / s - 1, s = 0.85 r + 0.15 re
        s = 0.85 * rr + 0.15 * re
        d1 = -0.85 * re / (s * s)
        d2 = 2.0 * 0.85 * 0.85 * re / (s * s * s)
    else:  # Koshizuka's kernel w = re / r - 1
        d1 = -re / (rr * rr)
        d2 = 2.0 * re / (rr * rr * rr)
    return d2 + (dim - 3.0) * d1 / rr  # Khayyer & Gotoh 2010 (2D) / 2012 (3D), HL pair weight


@njit(cache=True, inline="always")
def pair_coefficient(r, re, wcode, lap_code, dim):
    """The pair weight of the PPE Laplacian before its normalisation: w(r) (eq. 2-16) for
    ``lap_code`` 0, the HL pair function f(r) for 1."""
    if lap_code == 0:
        return weight(r, re, wcode)
    return hl_shape(r, re, wcode, dim)


def hl_shape_py(r: np.ndarray, re: float, weight_name: str, dim: int) -> np.ndarray:
    """NumPy version of :func:`hl_shape` (lattice constants, tests)."""
    code = weight_code(weight_name)
    r = np.maximum(np.asarray(r, dtype=np.float64), 1e-6 * re)
    if code == 0:
        s = 0.85 * r + 0.15 * re
        d1 = -0.85 * re / s**2
        d2 = 2.0 * 0.85**2 * re / s**3
    else:
        d1 = -re / r**2
        d2 = 2.0 * re / r**3
    return np.where(r < re, d2 + (dim - 3.0) * d1 / r, 0.0)


def hl_constants(
    dim: int, l0: float, re: float, weight_name: str = "improved"
) -> tuple[float, float]:
    """``(C, F0)`` on the initial lattice of spacing l0 (m): C = 2 d / sum_j r_j^2 f(r_j) (the HL
    normalisation, exact Laplacian of quadratic fields there; 1/m^0 when f is in 1/m^2: C f is in
    1/m^2) and F0 = sum_j f(r_j) (for the diagonal of decoupled rows)."""
    pts = lattice_offsets(dim, l0, re)
    r2 = (pts * pts).sum(axis=1)
    f = hl_shape_py(np.sqrt(r2), re, weight_name, dim)
    return float(2.0 * dim / (f * r2).sum()), float(f.sum())


@njit(cache=True, parallel=True)
def known_neighbour_correction(
    pos,
    kind,
    dry,
    surface_values,
    indptr,
    indices,
    re,
    wcode,
    dim,
    coef_std,
    coef_hl,
    rho,
    gravity,
    out,
):
    """out_i += sum_j (coef_hl f_ij - coef_std w_ij) q_j (Pa/m^2) on FLUID rows i that are not
    free surface, over the known neighbours within re: wet wall/dummy ghosts (q_j = D_ij =
    rho g . (x_j - x_i), wall_boundary.py) and free-surface FLUID neighbours with a Dirichlet value
    (q_j = surface_values[j], surface_pressure.py; pass zeros when they are 0). This turns the
    standard-Laplacian known terms those modules put on the right-hand side into HL ones."""
    n = pos.shape[0]
    re2 = re * re
    for i in prange(n):
        if kind[i] != 0 or dry[i] != 0:
            continue
        acc = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            kj = kind[j]
            if kj == 0:
                if dry[j] == 0 or surface_values[j] == 0.0:
                    continue
            elif dry[j] != 0:
                continue
            r2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                r2 += dx * dx
            if r2 >= re2:
                continue
            r = np.sqrt(r2)
            c = coef_hl * hl_shape(r, re, wcode, dim) - coef_std * weight(r, re, wcode)
            if kj == 0:
                q = surface_values[j]
            else:
                q = 0.0
                for a in range(dim):
                    q += gravity[a] * (pos[j, a] - pos[i, a])
                q *= rho
            acc += c * q
        out[i] += acc
