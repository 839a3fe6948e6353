"""MPS differential operators on a shared neighbour list (numba, parallel over particles).

Every operator takes the CSR neighbour list (``indptr``, ``indices``) built at the largest radius
any operator needs, filters pairs by its own kernel radius ``re`` (``|r_ij| < re``), and writes one
row of ``out`` per particle (no write races, no allocation: results are bit-identical for any
thread count). ``wcode`` is the weight code from :func:`mpsfem.fluid_mps.kernels.weight_code`;
``n0`` and ``lambda0`` are the constants of the initial lattice for the operator's radius
(:func:`mpsfem.fluid_mps.lattice.lattice_constants`). Pairs at zero distance are skipped by the
gradient-type operators (their direction is undefined).

Formulas (thesis ch. 2.1, r_ij = r_j - r_i, w_ij = w(|r_ij|)):

- number density (eq. 2-5):   n_i = sum_j w_ij, over all neighbours of any kind.
- Laplacian (eqs. 2-16, 2-17): <lap phi>_i = 2 d / (lambda0 n0) sum_j (phi_j - phi_i) w_ij, over
  all neighbours (wall and dummy particles carry the wall velocity: no-slip); computed on FLUID
  only.
- divergence (eq. 2-15):     <div u>_i = d / n0 sum_j (u_j - u_i) . r_ij / |r_ij|^2 w_ij, over all
  neighbours; computed on particles that carry pressure (FLUID, WALL, STRUCTURE), 0 on dummies.
- pressure gradient, on FLUID only, two forms by name:
  ``"tanaka"`` (eq. 2-12): d / n0 sum_j (p_j + p_i) r_ij / |r_ij|^2 w_ij (momentum conserving);
  ``"pmin"`` (eq. 2-11, p_i -> p_min,i): d / n0 sum_j (p_j - p_min,i) r_ij / |r_ij|^2 w_ij, where
  p_min,i is the minimum of p over i and its neighbours within re (Koshizuka's stabilised form).
  Dummy neighbours (DUMMY, STRUCTURE_DUMMY) have no pressure: with ``skip_dummy=True`` (the
  default, as MPS-Basic does) they are left out of the sum and of the minimum; with
  ``skip_dummy=False`` they enter with whatever ``p`` holds for them (e.g. a caller that copies the
  nearest wall pressure into them).

Exactness on a perfect lattice (interior particles, full support; see tests): the gradient (both
forms) and the divergence of linear and quadratic fields are exact up to round-off (the odd moments
of the lattice vanish and sum r r^T w / r^2 = n0/d I); the Laplacian of a quadratic field is exact
up to round-off because lambda0 is the second moment of the same lattice. Cubic and higher terms
give O(l0^2) errors.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from .kernels import weight

TANAKA = 0
PMIN = 1
CORRECTED = 2
CORRECTED_PMIN = 3
CMPS = 4
GRADIENTS: dict[str, int] = {
    "tanaka": TANAKA,
    "pmin": PMIN,
    "corrected": CORRECTED,
    "corrected_pmin": CORRECTED_PMIN,
    "cmps": CMPS,
}
#: gradient forms whose fluid-fluid pair terms are antisymmetric (momentum conserving)
CONSERVATIVE = (TANAKA, CMPS)


def gradient_code(name) -> int:
    """Integer code of a pressure-gradient form given by name."""
    try:
        return GRADIENTS[name]
    except (KeyError, TypeError):
        raise ValueError(
            f"unknown pressure gradient form {name!r}; allowed: {', '.join(sorted(GRADIENTS))}"
        ) from None


def laplacian_coefficient(dim: int, n0: float, lambda0: float) -> float:
    """2 d / (lambda0 n0), the factor of the MPS Laplacian (eq. 2-16)."""
    return 2.0 * dim / (lambda0 * n0)


@njit(cache=True, parallel=True)
def number_density(pos, indptr, indices, re, wcode, out):
    """out[i] = sum_j w(|r_ij|) over neighbours within re (all kinds)."""
    n, dim = pos.shape
    for i in prange(n):
        s = 0.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 < re * re:
                s += weight(np.sqrt(r2), re, wcode)
        out[i] = s
    return out


@njit(cache=True, parallel=True)
def laplacian(pos, f, kind, indptr, indices, re, wcode, coef, out):
    """Laplacian of a vector field ``f`` (N, m) on FLUID particles; 0 elsewhere.

    out[i] = coef * sum_j (f_j - f_i) w_ij with coef = 2 d / (lambda0 n0) (eq. 2-16); for the
    viscous term multiply by nu. All neighbours count (walls carry the wall velocity).
    """
    n, dim = pos.shape
    m = f.shape[1]
    for i in prange(n):
        for c in range(m):
            out[i, c] = 0.0
        if kind[i] != 0:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 < re * re:
                w = weight(np.sqrt(r2), re, wcode)
                for c in range(m):
                    out[i, c] += (f[j, c] - f[i, c]) * w
        for c in range(m):
            out[i, c] *= coef
    return out


@njit(cache=True, parallel=True)
def divergence(pos, u, kind, indptr, indices, re, wcode, n0, out, fluid_only=False):
    """Divergence of a vector field ``u`` (N, dim) (eq. 2-15) on FLUID, WALL and STRUCTURE
    particles (the pressure equation's rows); 0 on dummy particles. ``fluid_only``: sum over FLUID
    neighbours only (the Neumann wall model, where walls enter through ghost pressures)."""
    n, dim = pos.shape
    c = dim / n0
    for i in prange(n):
        out[i] = 0.0
        ki = kind[i]
        if ki == 2 or ki == 4:
            continue
        s = 0.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if fluid_only and kind[j] != 0:
                continue
            r2 = 0.0
            dot = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
                dot += (u[j, d] - u[i, d]) * dx
            if r2 < re * re and r2 > 0.0:
                s += dot / r2 * weight(np.sqrt(r2), re, wcode)
        out[i] = c * s
    return out


@njit(cache=True, inline="always")
def corrected_vector(m00, m01, m02, m11, m12, m22, v0, v1, v2, dim, fallback):
    """(C^-1 v) for the symmetric moment matrix C = [[m00, m01, m02], [., m11, m12], [., ., m22]]
    (its leading dim x dim block). When C is near singular (a particle with neighbours in fewer
    than dim independent directions) the plain MPS normalisation ``fallback * v`` is returned."""
    if dim == 2:
        det = m00 * m11 - m01 * m01
        tr = m00 + m11
        if det <= 0.05 * tr * tr:  # eigenvalue ratio below ~0.05: ill-conditioned
            return fallback * v0, fallback * v1, 0.0
        return (m11 * v0 - m01 * v1) / det, (m00 * v1 - m01 * v0) / det, 0.0
    c00 = m11 * m22 - m12 * m12
    c01 = m02 * m12 - m01 * m22
    c02 = m01 * m12 - m02 * m11
    c11 = m00 * m22 - m02 * m02
    c12 = m02 * m01 - m00 * m12
    c22 = m00 * m11 - m01 * m01
    det = m00 * c00 + m01 * c01 + m02 * c02
    tr = m00 + m11 + m22
    if det <= 0.01 * tr * tr * tr:
        return fallback * v0, fallback * v1, fallback * v2
    return (
        (c00 * v0 + c01 * v1 + c02 * v2) / det,
        (c01 * v0 + c11 * v1 + c12 * v2) / det,
        (c02 * v0 + c12 * v1 + c22 * v2) / det,
    )


_NO_GRAVITY = np.zeros(3)
_NO_REFERENCE = np.zeros(0)
#: the ``wall_acc`` argument of the ghost kernels without wall accelerations (no rows)
NO_WALL_ACCELERATION = np.zeros((0, 3))


def pressure_gradient(
    pos, p, kind, indptr, indices, re, wcode, n0, form, skip_dummy, out, pref_all=None
):
    """Pressure gradient (N, dim) on FLUID particles, 0 elsewhere; every neighbour carries its
    own ``p`` (the ``pressure_layer`` wall model).

    ``form`` (:data:`GRADIENTS`): 0 Tanaka (eq. 2-12, p_j + p_i), 1 p_min (p_j - min p), 2
    corrected (C_i^-1 sum (p_j - p_i) r w / r^2), 3 corrected p_min (C_i^-1 sum (p_j - p_min) r w
    / r^2); C_i = sum w r r^T / r^2 (see :func:`gradient_kernel`). See the module docstring for
    dummy neighbours (``skip_dummy``).
    """
    pref_all = fill_reference_pressures(
        pos, p, kind, indptr, indices, re, form, skip_dummy, False, pref_all
    )
    return gradient_kernel(
        pos, p, kind, indptr, indices, re, wcode, n0, form, skip_dummy, False, kind, 0.0,
        _NO_GRAVITY, pref_all, out, False, NO_WALL_ACCELERATION, 0,
    )  # fmt: skip


@njit(cache=True, inline="always")
def row_reference_pressure(i, pos, p, kind, indptr, indices, re2, form, skip_dummy, ghost):
    """The reference pressure of fluid particle i's gradient row (Pa): p_i for the ``tanaka`` and
    ``corrected`` forms, the minimum over i and its neighbours within re for the p_min forms
    (fluid neighbours only with ``ghost``; dummies left out with ``skip_dummy``)."""
    dim = pos.shape[1]
    pref = p[i]
    if form == 1 or form == 3 or form == 4:
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            kj = kind[j]
            if ghost and kj != 0:
                continue
            if skip_dummy and (kj == 2 or kj == 4):
                continue
            if p[j] < pref:
                r2 = 0.0
                for d in range(dim):
                    dx = pos[j, d] - pos[i, d]
                    r2 += dx * dx
                if r2 < re2:
                    pref = p[j]
    return pref


@njit(cache=True, inline="always")
def pair_pressure(form, pj, pi, pref_i, pref_j):
    """The scalar of a gradient pair term (Pa): p_j + p_i (``tanaka``, thesis eq. 2-12),
    p_j + p_i - p_min,i - p_min,j (``cmps``, Khayyer & Gotoh 2008 eq. 9: antisymmetric and
    stabilised), p_j - p_ref,i (the p_min and corrected forms, eq. 2-11)."""
    if form == 0:
        return pj + pi
    if form == 4:
        return pj + pi - pref_i - pref_j
    return pj - pref_i


@njit(cache=True, parallel=True)
def reference_pressures(pos, p, kind, indptr, indices, re, form, skip_dummy, ghost, out):
    """out[i] = the reference pressure of FLUID particle i's gradient row
    (:func:`row_reference_pressure`), 0 elsewhere: the ``cmps`` form reads its neighbours'."""
    re2 = re * re
    for i in prange(pos.shape[0]):
        out[i] = 0.0
        if kind[i] == 0:
            out[i] = row_reference_pressure(
                i, pos, p, kind, indptr, indices, re2, form, skip_dummy, ghost
            )


def fill_reference_pressures(
    pos, p, kind, indptr, indices, re, form, skip_dummy, ghost, pref_all=None
) -> np.ndarray:
    """The ``pref_all`` argument of :func:`gradient_kernel`: for ``cmps`` every fluid
    particle's p_min, written into ``pref_all`` (an (N,) work array; allocated when None), an
    empty array for the other forms."""
    if form != CMPS:
        return _NO_REFERENCE
    if pref_all is None:
        pref_all = np.empty(len(p))
    reference_pressures(pos, p, kind, indptr, indices, re, form, skip_dummy, ghost, pref_all)
    return pref_all


@njit(cache=True, inline="always")
def neighbour_pressure(i, j, pos, p, kind, ghost, dry, rho, gravity, wall_acc, acc_offset):
    """(p_j as fluid particle i's gradient row sees it (Pa), whether j counts at all): with
    ``ghost`` a wet wall/dummy j is the ghost p_i + rho (g - a_j) . (x_j - x_i) (a_j the wall's
    acceleration, row j - acc_offset of ``wall_acc``, zero when it is empty), a dry wall
    particle has 0 and a dry dummy does not count (wall_boundary.py); otherwise j's own p."""
    kj = kind[j]
    if not ghost or kj == 0:
        return p[j], True
    if dry[j]:
        if kj == 2 or kj == 4:
            return 0.0, False
        return 0.0, True
    jump = 0.0
    for d in range(pos.shape[1]):
        field = gravity[d] if wall_acc.shape[0] == 0 else gravity[d] - wall_acc[j - acc_offset, d]
        jump += field * (pos[j, d] - pos[i, d])
    return p[i] + rho * jump, True


@njit(cache=True, inline="always")
def gradient_pair(
    i, j, pos, p, kind, re, re2, wcode, skip_dummy, ghost, dry, rho, gravity, wall_acc, acc_offset
):
    """Neighbour j of fluid particle i's gradient row: (counts, p_j as the row sees it (Pa,
    :func:`neighbour_pressure`), w_ij / r_ij^2 (1/m^2), r_ij components (m)); not counted when
    it is a dummy left out, outside ``re`` or at zero distance, or a dry dummy ghost. Shared by
    :func:`gradient_kernel` and the momentum budget's exchange, so both see the same pairs."""
    kj = kind[j]
    if skip_dummy and (kj == 2 or kj == 4):
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    dim = pos.shape[1]
    r2 = 0.0
    for d in range(dim):
        dx = pos[j, d] - pos[i, d]
        r2 += dx * dx
    if r2 >= re2 or r2 == 0.0:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    pj, counts = neighbour_pressure(
        i, j, pos, p, kind, ghost, dry, rho, gravity, wall_acc, acc_offset
    )
    if not counts:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0
    w = weight(np.sqrt(r2), re, wcode) / r2
    x0 = pos[j, 0] - pos[i, 0]
    x1 = pos[j, 1] - pos[i, 1]
    x2 = pos[j, 2] - pos[i, 2] if dim == 3 else 0.0
    return True, pj, w, x0, x1, x2


@njit(cache=True, parallel=True)
def gradient_kernel(
    pos, p, kind, indptr, indices, re, wcode, n0, form, skip_dummy, ghost, dry, rho, gravity,
    pref_all, out, fluid_pairs_only, wall_acc, acc_offset,
):  # fmt: skip
    """The pressure gradient on FLUID particles (Pa/m) for both wall models.

    ``ghost`` False: every neighbour carries its own p (dummies left out with ``skip_dummy``);
    the p_min search runs over all of them. ``ghost`` True (the ``neumann`` wall model,
    wall_boundary.py): a wet wall/dummy neighbour j is a ghost p_j = p_i + rho g . (x_j - x_i), a
    dry wall particle has p = 0, a dry dummy is left out, and p_min runs over the fluid only.

    ``form`` 0 ``tanaka``: d / n0 sum_j (p_j + p_i) r_ij w_ij / r_ij^2 (thesis eq. 2-12);
    1 ``pmin``: d / n0 sum_j (p_j - p_min,i) r_ij w_ij / r_ij^2 (eq. 2-11, p_i -> the minimum);
    2 ``corrected``: C_i^-1 sum_j (p_j - p_i) r_ij w_ij / r_ij^2 with the moment matrix
    C_i = sum_j w_ij r_ij r_ij^T / r_ij^2 (corrective matrix of Randles & Libersky 1996, used in
    MPS by Khayyer & Gotoh 2011): exact for linear fields on any neighbourhood;
    3 ``corrected_pmin``: C_i^-1 sum_j (p_j - p_min,i) r_ij w_ij / r_ij^2 (exact where p_i is the
    local minimum, the p_min form's repulsion elsewhere). A near-singular C_i (fewer than dim
    independent neighbour directions) falls back to d / n0;
    4 ``cmps``: d / n0 sum_j (p_j + p_i - p_min,i - p_min,j) r_ij w_ij / r_ij^2 (Khayyer &
    Gotoh 2008 eq. 9), ``pref_all`` holding every fluid particle's p_min
    (:func:`reference_pressures`; a boundary neighbour takes p_min,i): antisymmetric, so the
    fluid-fluid pairs conserve momentum (momentum_budget.py). Other forms ignore ``pref_all``.

    ``fluid_pairs_only``: sum the pair terms of FLUID neighbours only, with the same reference
    pressure and the same C_i (from all neighbours): the fluid-fluid share of the gradient
    (the momentum budget's internal imbalance). ``wall_acc``, ``acc_offset``: the walls'
    accelerations in the ghosts (:func:`neighbour_pressure`; empty: none)."""
    n, dim = pos.shape
    c = dim / n0
    re2 = re * re
    corrected = form == 2 or form == 3
    for i in prange(n):
        for d in range(dim):
            out[i, d] = 0.0
        if kind[i] != 0:
            continue
        pref = row_reference_pressure(
            i, pos, p, kind, indptr, indices, re2, form, skip_dummy, ghost
        )
        v0 = v1 = v2 = 0.0
        m00 = m01 = m02 = m11 = m12 = m22 = 0.0
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            kj = kind[j]
            ok, pj, w, x0, x1, x2 = gradient_pair(
                i, j, pos, p, kind, re, re2, wcode, skip_dummy, ghost, dry, rho, gravity,
                wall_acc, acc_offset,
            )  # fmt: skip
            if not ok:
                continue
            prj = pref_all[j] if form == 4 and kj == 0 else pref
            a = pair_pressure(form, pj, p[i], pref, prj) * w
            if fluid_pairs_only and kj != 0:
                a = 0.0
            v0 += a * x0
            v1 += a * x1
            v2 += a * x2
            if corrected:
                m00 += w * x0 * x0
                m01 += w * x0 * x1
                m02 += w * x0 * x2
                m11 += w * x1 * x1
                m12 += w * x1 * x2
                m22 += w * x2 * x2
        if corrected:
            v0, v1, v2 = corrected_vector(m00, m01, m02, m11, m12, m22, v0, v1, v2, dim, c)
        else:
            v0 *= c
            v1 *= c
            v2 *= c
        out[i, 0] = v0
        out[i, 1] = v1
        if dim == 3:
            out[i, 2] = v2
    return out
