"""Impact (high-frequency) potential-flow added-mass operator of a straight wetted patch, 2D.

The problem (Faltinsen 1990, *Sea Loads on Ships and Offshore Structures*, ch. 9: the
slamming limit, accelerations far above g / displacement; the von Kármán / Wagner flat plate):
fluid on one face of a straight patch of length l of a 2D member, infinite depth; the
potential phi of a normal acceleration a_n(s) (phi per unit of it: the pressure is p = rho phi)
has d phi / dn = a_n on the patch and phi = 0 on the free surface that continues the patch's
line beyond its ends. The nodal forces are f_i = int N_i p ds with N_i the linear hat function
of node i, so f = M_a a with M_a (kg per m of depth) symmetric positive definite on the nodes'
normal translations.

Why hat functions and not the beam's Hermite functions: the fictitious mass acts on the nodal
translations the coupler exchanges (the interface forces and displacements of the nodes,
:mod:`.fictitious_mass`), and the hat functions are the interpolation of those values whose
row sums are the lumped method's tributary lengths (the lumped M_f is this operator's
counterpart with phi replaced by m_f times the local acceleration).

Discretisation: reflecting oddly across the free-surface line (phi = 0 there) turns the problem
into a plate (a cut) in an infinite plane with a potential jump mu = 2 phi across it and a
continuous normal derivative a_n: a dipole sheet, whose normal velocity is the hypersingular
operator of mu. Its Galerkin weak form (integrated by parts twice, mu = 0 at the patch's ends,
where the potential meets the free surface)

    (1 / 2 pi) int int mu'(x) psi'(xi) ln(1 / |x - xi|) dx dxi = int psi a_n dx

(the vortex-sheet form, gamma = mu', of the hypersingular operator; e.g. Hsiao & Wendland 2008,
*Boundary Integral Equations*, ch. 1-2, the screen problem) is symmetric positive definite on
functions vanishing at the ends. mu is piecewise linear on a panel mesh of ``refine`` x (elements)
points cosine-spaced over the patch (dense at its ends, where mu ~ sqrt(distance)) merged with
the member's nodes (:func:`_panel_points`); the log double integrals over two panels are exact
(:func:`_log_panel_integrals`). With H the Galerkin matrix and G_ki = int psi_k N_i ds,

    M_a = (rho / 2) G^T H^{-1} G

is symmetric positive definite by construction. Uniform a_n gives mu = 2 a sqrt(c^2 - x^2)
(c = l / 2; the elliptic loading of the flat plate) and the rigid-heave added mass
rho pi l^2 / 8 per m of depth (Newman 1977, *Marine Hydrodynamics*, Table 4.2: rho pi a^2 for
both faces, a = l / 2; one face here): tests/structure_fem/test_added_mass_potential.py.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla

__all__ = ["patch_added_mass", "patch_coordinates", "patch_dipole"]

#: panels of the dipole mesh per member element (the default of :func:`patch_added_mass`);
#: rigid heave within 2e-2 / n_el^2 of rho pi l^2 / 8 (n_el the patch's elements; 1.9e-2 on
#: one, 2.1e-3 on three, 1.9e-4 on ten: tests/structure_fem/test_added_mass_potential.py)
REFINE = 8


def _g2(t: np.ndarray) -> np.ndarray:
    """Second antiderivative of ln|t|: t^2 / 2 ln|t| - 3 t^2 / 4 (0 at t = 0)."""
    t = np.asarray(t, dtype=float)
    out = -0.75 * t * t
    nz = t != 0.0
    out[nz] += 0.5 * t[nz] ** 2 * np.log(np.abs(t[nz]))
    return out


def _log_panel_integrals(x: np.ndarray) -> np.ndarray:
    """L_ef = int_{panel e} int_{panel f} ln|x - xi| dxi dx for the panels [x_e, x_e+1] of the
    increasing points x (m^2 ln m), exact: from the second antiderivative of ln|t|."""
    a1, a2 = x[:-1, None], x[1:, None]
    b1, b2 = x[None, :-1], x[None, 1:]
    return _g2(a2 - b1) - _g2(a1 - b1) - _g2(a2 - b2) + _g2(a1 - b2)


def _panel_points(s: np.ndarray, refine: int) -> np.ndarray:
    """Panel points: ``refine`` x (elements) points cosine-spaced over the patch (dense towards
    its ends, where mu ~ sqrt(distance): x = c (1 - cos theta), theta uniform) merged with the
    member nodes; a cosine point closer than a quarter of its spacing to a node is dropped (no
    slivers). The member nodes are panel points, so the hat functions are linear on every
    panel and G is exact."""
    n = refine * (s.size - 1)
    x = s[0] + (s[-1] - s[0]) * 0.5 * (1.0 - np.cos(np.pi * np.arange(n + 1) / n))
    gap = np.gradient(x)
    near = np.abs(x[:, None] - s[None, :]).min(axis=1) < 0.25 * gap
    return np.union1d(s, x[~near])


def patch_dipole(
    s: np.ndarray, a_n: np.ndarray, refine: int = REFINE
) -> tuple[np.ndarray, np.ndarray]:
    """(panel points x, m; phi at them, m^2/s^2 per the a_n's unit) of the patch with nodes at
    arc lengths ``s`` (increasing, m) under the nodal normal accelerations ``a_n`` (m/s^2,
    interpolated linearly): phi = mu / 2, 0 at the ends."""
    s = np.asarray(s, dtype=float)
    x, H, G, _ = _galerkin(s, refine)
    mu = np.zeros(x.size)
    mu[1:-1] = sla.cho_solve(sla.cho_factor(H), G @ np.asarray(a_n, dtype=float))
    return x, 0.5 * mu


def _galerkin(s: np.ndarray, refine: int):
    """(panel points, H, G, N): the Galerkin matrix of the dipole sheet over the interior panel
    points, G_ki = int psi_k N_i ds, N the member nodes' hat functions at the panel points."""
    if s.ndim != 1 or s.size < 2 or np.any(np.diff(s) <= 0.0):
        raise ValueError(f"patch node positions must be >= 2 increasing numbers, got {s!r}")
    if int(refine) < 1:
        raise ValueError(f"refine = {refine!r}: need at least 1 panel per element")
    x = _panel_points(s, int(refine))
    h = np.diff(x)
    n = x.size
    # D (bidiagonal): panel slopes of the interior points' hat functions psi_k (mu = 0 at both
    # ends): psi_k rises by 1 / h_k on the panel left of point k + 1, falls by 1 / h_k+1 right
    L = _log_panel_integrals(x) / h[:, None] / h[None, :]  # L_ef / (h_e h_f)
    LD = L[:, :-1] - L[:, 1:]  # L D, up to the 1 / h factors folded into L
    DLD = LD[:-1] - LD[1:]
    # (1 / 2 pi) int int psi_k' psi_l' ln(1 / |x - xi|): the dipole sheet's weak form
    H = -DLD / (2.0 * np.pi)
    H = 0.5 * (H + H.T)
    # hat functions of the member nodes at the panel points (linear inside each element)
    N = np.zeros((n, s.size))
    for i in range(s.size):
        N[:, i] = np.interp(x, s, np.eye(s.size)[i])
    # int psi_k N_i exactly (both linear on every panel: h / 6 (2 f1 g1 + f1 g2 + f2 g1 + 2 f2 g2))
    k = np.arange(1, n - 1)
    G = (h[k - 1, None] * (N[k - 1] + 2.0 * N[k]) + h[k, None] * (2.0 * N[k] + N[k + 1])) / 6.0
    return x, H, G, N


def patch_added_mass(s: np.ndarray, density: float, refine: int = REFINE) -> np.ndarray:
    """M_a (kg per m of depth, (n, n), symmetric positive definite): nodal normal forces
    f = M_a a_n (N/m) of the straight wetted patch with nodes at arc lengths ``s`` (m,
    increasing) under nodal normal accelerations a_n, fluid of ``density`` (kg/m^3) on one face,
    phi = 0 on the free surface continuing the patch's line, infinite depth (module docstring).
    """
    if not density > 0.0:
        raise ValueError(f"density = {density!r}: the fluid density must be > 0 (kg/m^3)")
    s = np.asarray(s, dtype=float)
    _, H, G, _ = _galerkin(s, refine)
    c = sla.cho_factor(H)
    M = 0.5 * density * (G.T @ sla.cho_solve(c, G))  # f_i = rho int N_i mu / 2
    return 0.5 * (M + M.T)


def patch_coordinates(points: np.ndarray, tolerance: float = 1e-9) -> np.ndarray:
    """Arc lengths (m) of ``points`` ((n, dim), ordered along a straight patch) from the first,
    along the chord; ValueError when they do not lie on one straight line (within ``tolerance``
    of the patch length) or are not ordered."""
    p = np.asarray(points, dtype=float)
    if p.shape[0] < 2:
        raise ValueError("a patch needs at least 2 nodes")
    chord = p[-1] - p[0]
    length = float(np.linalg.norm(chord))
    if not length > 0.0:
        raise ValueError("a patch's end nodes coincide")
    e = chord / length
    rel = p - p[0]
    s = rel @ e
    off = np.linalg.norm(rel - s[:, None] * e[None, :], axis=1)
    if off.max() > tolerance * length:
        raise ValueError(
            f"the wetted patch is not straight: a node lies {off.max():.3g} m off its chord "
            f"({length:.3g} m); the potential-flow fictitious mass needs straight members"
        )
    if np.any(np.diff(s) <= 0.0):
        raise ValueError("the patch's nodes are not ordered along it")
    return s
