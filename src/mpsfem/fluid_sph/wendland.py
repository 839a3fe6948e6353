"""Wendland C2 kernel (Wendland 1995) with support 2h, in 2D and 3D.

W(q) = a_d (1 - q/2)^4 (2q + 1), q = r/h < 2, a_2 = 7 / (4 pi h^2), a_3 = 21 / (16 pi h^3);
grad_i W_ij = F(r) (r_i - r_j) with F = W'(r) / r = -5 a_d (1 - q/2)^3 / h^2.
"""

from __future__ import annotations

import math

from numba import njit


def wendland_norm(dim: int, h: float) -> float:
    """a_d of the Wendland C2 kernel, 1/m^dim (Wendland 1995; Dehnen & Aly 2012, table 1)."""
    if dim == 2:
        return 7.0 / (4.0 * math.pi * h * h)  # 2D: 7 / (4 pi h^2)
    if dim == 3:
        return 21.0 / (16.0 * math.pi * h**3)  # 3D: 21 / (16 pi h^3)
    raise ValueError(f"dim must be 2 or 3, got {dim!r}")


@njit(cache=True, inline="always")
def kernel_value(r, h, norm):
    """W(r), 1/m^dim: a_d (1 - q/2)^4 (2q + 1) for q = r/h < 2, else 0."""
    q = r / h
    if q >= 2.0:
        return 0.0
    t = 1.0 - 0.5 * q
    return norm * t * t * t * t * (2.0 * q + 1.0)


@njit(cache=True, inline="always")
def gradient_factor_fast(r, inv_h, coef):
    """F(r) as :func:`gradient_factor` with the constants hoisted: ``inv_h`` = 1/h, ``coef`` =
    -5 a_d / h^2 (:func:`gradient_coefficient`)."""
    t = 1.0 - 0.5 * r * inv_h
    if t <= 0.0:
        return 0.0
    return coef * t * t * t


def gradient_coefficient(dim: int, h: float) -> float:
    """-5 a_d / h^2 of F(r) = -5 a_d (1 - q/2)^3 / h^2, 1/m^(dim+2)."""
    return -5.0 * wendland_norm(dim, h) / (h * h)


@njit(cache=True, inline="always")
def gradient_factor(r, h, norm):
    """F(r) = W'(r) / r, 1/m^(dim+2), so that grad_i W_ij = F (r_i - r_j): -5 a_d (1-q/2)^3 / h^2."""
    q = r / h
    if q >= 2.0:
        return 0.0
    t = 1.0 - 0.5 * q
    return -5.0 * norm * t * t * t / (h * h)
