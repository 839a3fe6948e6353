"""Potential-flow added-mass operator of a plate forming a tank's whole bottom, 2D.

The problem (the linear sloshing problem's added-mass part in the limit of frequencies far
above the sloshing ones, where the free-surface condition becomes phi = 0: Faltinsen & Timokha
2009, *Sloshing*, ch. 5, the modal solution of the 2D rectangular tank; Ibrahim 2005, *Liquid
Sloshing Dynamics*, ch. 1 and 3, the same potentials): a rectangular tank of width W with rigid
vertical walls (d phi / dx = 0), water depth H, phi = 0 on the free surface, and the bottom
y = 0, the elastic plate, moving with normal acceleration a_n(x) into the liquid. With the
tank's cosine modes, k_n = n pi / W,

    a_n(x) = sum_n A_n cos(k_n x),   p(x, 0) = sum_n m_n A_n cos(k_n x),
    m_0 = rho H,   m_n = rho tanh(k_n H) / k_n   (n >= 1)

(the n = 0 term lifts the whole column, phi linear in depth; the others decay as
sinh(k_n (H - y)) / cosh(k_n H)). With the member nodes' hat functions N_i and the projections
g_ni = int_0^W N_i cos(k_n x) dx (exact: linear times cosine on every element),
A_n = c_n sum_i g_ni a_i, c_0 = 1 / W, c_n = 2 / W, and the nodal forces f_i = int N_i p dx:

    M_a = sum_n m_n c_n g_n g_n^T   (kg per m of depth, symmetric positive semi-definite)

summed to ``modes`` terms (m_n g_ni^2 falls as k_n^-5 past the element's wavenumber: with the
default 200 x elements the tail is below 1e-9 of the diagonal). Rigid heave (a_n = 1) is exact
for any truncation: sum_i g_ni = int cos(k_n x) dx = 0 for n >= 1, so the heave force is
rho H W. A cosine mode interpolated at the nodes gets its m_n to second order in the element
length (tests/structure_fem/test_added_mass_tank.py).

Against :mod:`.added_mass_potential` (the impact operator: phi = 0 on the free surface
continuing the patch's line, infinite depth): on the hydrostatic plate (W = 1 m, H = 2 m) the
clamped plate's first mode sin^2(pi x / W) carries 1386 kg/m^2 here, 401 there; the
antisymmetric second mode 210 against 163. The difference is the column above a tank bottom:
a volume-changing motion must lift it.
"""

from __future__ import annotations

import numpy as np

__all__ = ["tank_bottom_added_mass", "tank_mode_projections"]

#: cosine modes per member element summed by :func:`tank_bottom_added_mass` by default
MODES_PER_ELEMENT = 200


def tank_mode_projections(s: np.ndarray, wavenumbers: np.ndarray) -> np.ndarray:
    """g (len(wavenumbers), len(s)), m: g_ni = int N_i(x) cos(k_n x) dx over [s_0, s_-1], x
    from s_0, N_i the hat functions of the nodes at ``s`` (m, increasing); exact: on an element
    [a, b] with f linear from f_a to f_b, int f cos(k x) = [f sin(k x) / k]_a^b + (f_b - f_a) /
    (b - a) [cos(k x) / k^2]_a^b (k = 0: the tributary lengths)."""
    s = np.asarray(s, dtype=float)
    if s.ndim != 1 or s.size < 2 or np.any(np.diff(s) <= 0.0):
        raise ValueError(f"plate node positions must be >= 2 increasing numbers, got {s!r}")
    x = s - s[0]
    k = np.asarray(wavenumbers, dtype=float)[:, None]
    a, b = x[:-1][None, :], x[1:][None, :]
    h = b - a
    zero = k[:, 0] == 0.0
    ks = np.where(k == 0.0, 1.0, k)
    sa, sb = np.sin(ks * a), np.sin(ks * b)
    ca, cb = np.cos(ks * a), np.cos(ks * b)
    # element integrals of the rising (0 -> 1) and falling (1 -> 0) halves of the hats
    rise = sb / ks + (cb - ca) / (ks * ks * h)
    fall = -sa / ks - (cb - ca) / (ks * ks * h)
    rise[zero] = 0.5 * h[0]
    fall[zero] = 0.5 * h[0]
    g = np.zeros((k.shape[0], s.size))
    g[:, 1:] += rise
    g[:, :-1] += fall
    return g


def tank_bottom_added_mass(
    s: np.ndarray, density: float, depth: float, modes: int | None = None
) -> np.ndarray:
    """M_a (kg per m of depth, (n, n)): nodal normal forces f = M_a a_n (N/m) of a plate with
    nodes at ``s`` (m, increasing) forming the whole bottom of a 2D tank (rigid walls at s_0 and
    s_-1), liquid of ``density`` (kg/m^3) to ``depth`` H (m) above it, phi = 0 on the free
    surface (module docstring); ``modes`` cosine modes including n = 0 (default 200 x
    elements)."""
    if not density > 0.0:
        raise ValueError(f"density = {density!r}: the fluid density must be > 0 (kg/m^3)")
    if not depth > 0.0:
        raise ValueError(f"depth = {depth!r}: the water depth over the plate must be > 0 (m)")
    s = np.asarray(s, dtype=float)
    n_modes = MODES_PER_ELEMENT * max(s.size - 1, 1) if modes is None else int(modes)
    if n_modes < 1:
        raise ValueError(f"modes = {modes!r}: need at least the n = 0 mode")
    width = float(s[-1] - s[0])
    k = np.pi * np.arange(n_modes) / width
    g = tank_mode_projections(s, k)
    m = np.empty(n_modes)
    m[0] = density * depth  # the column lifted as a whole (Faltinsen & Timokha 2009, ch. 5)
    m[1:] = density * np.tanh(k[1:] * depth) / k[1:]  # rho tanh(k_n H) / k_n, same source
    c = np.full(n_modes, 2.0 / width)
    c[0] = 1.0 / width
    M = (g * (m * c)[:, None]).T @ g
    return 0.5 * (M + M.T)
