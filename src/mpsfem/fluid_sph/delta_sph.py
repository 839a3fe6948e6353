"""The δ-SPH right-hand side in numba: equation of state, dummy-wall pressure, the CSPM
correction matrix with the renormalised density gradient, and the pair pass of continuity,
density diffusion, pressure gradient (plain or δ-SPHC) and artificial viscosity.

Seed: Huang, Sun, Lyu & Zhong 2022 (Chinese Journal of Theoretical and Applied Mechanics 54(6),
eqs. 1-13); δ-SPH after Antuono et al. 2010/2012; dummy-wall pressure after Adami, Hu & Adams
2012 (eq. 27). Every parallel loop runs over rows i and sums its own row in the neighbour list's
ascending order, so the results are bit-identical for any thread count; nothing allocates.

Speed (docs/fluid_sph.md, "Speed"): the rows may be Verlet candidates (the kernels skip the
pairs at r^2 >= radius^2, the neighbour search's own test); the correction pass keeps each pair's
F V_j for the pair pass and p_i M_i per particle; the two pair kernels are compiled per
dimension (a closure over ``DIM``), so 2D does no arithmetic on a third axis. Each change keeps
the operations and their order: the results are those of the plain formulation, bit for bit.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from mpsfem.fluid_sph.wendland import gradient_factor_fast, kernel_value

#: det(B_i) below this: the correction matrix M_i = B_i^-1 is replaced by the identity (a
#: particle with so few neighbours that B_i is near singular: a splash or a lone drop)
DET_MIN = 0.1
#: 0.01 h^2 in the denominators of the diffusion and viscous terms (seed eqs. 2, 3)
ETA2 = 0.01


@njit(cache=True, parallel=True)
def equation_of_state(rho, p, n_fluid, rho0, c0):
    """p_i = c0^2 (rho_i - rho0), Pa, for the fluid particles (seed eq. 1, linear EOS)."""
    c2 = c0 * c0
    for i in prange(n_fluid):
        p[i] = c2 * (rho[i] - rho0)  # seed eq. 1: p = c0^2 (rho - rho0)


@njit(cache=True, parallel=True)
def particle_volume(rho, mass, vol):
    """V_i = m / rho_i, m^dim (m^2 in 2D), of every particle."""
    for i in prange(rho.shape[0]):
        vol[i] = mass / rho[i]


@njit(cache=True, inline="always")
def squared_distance(pos, i, j, dim):
    """|r_i - r_j|^2, m^2, summed over the first ``dim`` axes in order."""
    r2 = 0.0
    for a in range(dim):
        d = pos[i, a] - pos[j, a]
        r2 += d * d
    return r2


@njit(cache=True, parallel=True)
def wall_pressure(pos, rho, p, kind, indptr, indices, r2max, n_fluid, gravity, omega2, center,
                  wall_acc, h, norm, rho0, c0):  # fmt: skip
    """Pressure (Pa) and density (kg/m^3) of every wall / dummy particle i >= n_fluid,
    extrapolated from its fluid neighbours: p_w = (sum_f p_f W_wf + (b . sum_f rho_f r_wf W_wf))
    / sum_f W_wf with b = g - Omega^2 (r_w - c) - a_w, the body force at the wall less the wall's
    own acceleration ``wall_acc[i - n_fluid]`` (m/s^2; Adami et al. 2012, eq. 27); rho_w = rho0 +
    p_w / c0^2 (inverse linear EOS). Without fluid neighbours p_w = 0, rho_w = rho0.

    Rows (``indptr``, ``indices``): ascending, a superset of the pairs closer than sqrt(r2max)
    (m; candidate rows, fluid_sph.candidate_pairs): the pairs at r^2 >= r2max are skipped."""
    n = pos.shape[0]
    dim = pos.shape[1]
    inv_c2 = 1.0 / (c0 * c0)
    for i in prange(n_fluid, n):
        sw = 0.0
        sp = 0.0
        sb = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j >= n_fluid:
                break  # ascending rows: the fluid neighbours come first
            r2 = squared_distance(pos, i, j, dim)
            if r2 >= r2max:
                continue  # a candidate beyond the radius
            bdot = 0.0
            for a in range(dim):
                d = pos[i, a] - pos[j, a]
                b = gravity[a] - omega2 * (pos[i, a] - center[a]) - wall_acc[i - n_fluid, a]
                bdot += b * d
            w = kernel_value(np.sqrt(r2), h, norm)
            sw += w
            sp += p[j] * w
            sb += rho[j] * bdot * w
        if sw > 0.0:
            p[i] = (sp + sb) / sw  # Adami et al. 2012, eq. 27
        else:
            p[i] = 0.0
        rho[i] = rho0 + p[i] * inv_c2


@njit(cache=True)
def clamp_wall_pressure(p, rho, n_fluid, rho0):
    """``fluid.sph.wall_pressure = "clamped"``: p_w <- max(p_w, 0) (Pa) for every wall / dummy
    particle after :func:`wall_pressure`, with its density rho_w = rho0 + p_w / c0^2 = rho0
    where clamped: no wall pulls on the fluid (PySPH's ClampWallPressure for Adami's walls), the
    real suction of a wall pulled out of water included."""
    for i in range(n_fluid, p.shape[0]):
        if p[i] < 0.0:
            p[i] = 0.0
            rho[i] = rho0


#: "wetted" walls (fluid.sph.wall_pressure): a pressure-layer particle is wholly wet while the
#: fluid in front of it reaches to within WET_GAP spacings of the wall face and wholly dry from
#: DRY_GAP on (face-to-surface gaps, in l0: the fluid's first row sits (gap + 1) l0 from the
#: pressure layer); between the two its weight falls linearly with the fluid's kernel sum. A
#: lattice resolves contact to half a cell: the ramp is centred on an empty half cell between
#: the face and the surface and spans +- l0 / 4 so the load stays continuous in time
WET_GAP = 0.25
DRY_GAP = 0.75


def half_space_support(dim: int, ratio: float, distance: float) -> float:
    """sum_f W_wf V_f (dimensionless) of a wall particle facing a fluid lattice (spacing l0,
    V_f = l0^dim) that fills the half-space from ``distance`` l0 in front of it on, rows aligned
    with the particle; Wendland C2 at h = ``ratio`` l0 (lengths in l0). Used to turn the gaps
    WET_GAP and DRY_GAP into thresholds on the fluid's kernel sum (:func:`dry_walls`)."""
    reach = int(np.ceil(2.0 * ratio)) + 1
    lateral = np.arange(-reach, reach + 1, dtype=np.float64)
    normal = distance + np.arange(0, reach + 1, dtype=np.float64)
    if dim == 2:
        grid = np.meshgrid(lateral, normal, indexing="ij")
    else:
        grid = np.meshgrid(lateral, lateral, normal, indexing="ij")
    r = np.sqrt(sum(g * g for g in grid)).ravel()
    norm = 7.0 / (4.0 * np.pi * ratio**2) if dim == 2 else 21.0 / (16.0 * np.pi * ratio**3)
    q = r / ratio
    t = np.clip(1.0 - 0.5 * q, 0.0, None)
    return float(np.sum(norm * t**4 * (2.0 * q + 1.0)))  # Wendland C2, V_f = 1 in l0 units


@njit(cache=True, parallel=True)
def dry_walls(pos, rho, p, indptr, indices, r2max, n_fluid, mass, h, norm, rho0, c0,
              pressure_layer, wall_patch, s_dry, s_wet, r2_adjacent, wet_own, wet):  # fmt: skip
    """``fluid.sph.wall_pressure = "wetted"``: scales the pressure :func:`wall_pressure` gave
    each wall particle by its wetness w in [0, 1] (``wet[i - n_fluid]``, written here), Pa;
    rho_w = rho0 + p_w / c0^2 again. A dry wall particle (w = 0) has p_w = 0 and exchanges
    only the fluid particles' own pressure p_i in the pair terms, as air at p = 0 would.

    Pressure layer (``pressure_layer[i - n_fluid]``): S = sum_f W_wf V_f over its fluid
    neighbours (V_f = m / rho_f); w = 1 for S >= ``s_wet``, 0 for S <= ``s_dry``, linear in S
    between (the thresholds are :func:`half_space_support` at the gaps WET_GAP and DRY_GAP: the
    free surface within l0 / 4 of the wall face is contact, 3 l0 / 4 or more is an air gap);
    that own value is ``wet_own``, and a pressure-layer particle takes the largest own value of
    itself and its same-patch pressure-layer neighbours closer than sqrt(``r2_adjacent``) (m;
    1.5 l0: its neighbours along the face), so a tank's corner, which sees the fluid only
    diagonally, is as wet as the faces beside it. Dummy layers: w = the largest w of the pressure-layer particles of the same wall patch
    (``wall_patch``) within the kernel's support (their column's among them), so a wall's
    dummies are as wet as its face. Rows as :func:`wall_pressure` (pairs at r^2 >= r2max
    skipped); they must hold the wall-wall pairs. Deterministic for any thread count."""
    n = pos.shape[0]
    dim = pos.shape[1]
    inv_c2 = 1.0 / (c0 * c0)
    inv_span = 1.0 / (s_wet - s_dry)
    for i in prange(n_fluid, n):
        if not pressure_layer[i - n_fluid]:
            continue
        s = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j >= n_fluid:
                break  # ascending rows: the fluid neighbours come first
            r2 = squared_distance(pos, i, j, dim)
            if r2 >= r2max:
                continue
            s += kernel_value(np.sqrt(r2), h, norm) * mass / rho[j]  # Shepard sum W_wf V_f
        wet_own[i - n_fluid] = min(1.0, max(0.0, (s - s_dry) * inv_span))
    for i in prange(n_fluid, n):
        if not pressure_layer[i - n_fluid]:
            continue
        w = wet_own[i - n_fluid]
        own = wall_patch[i - n_fluid]
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j < n_fluid or w == 1.0:
                continue
            if not pressure_layer[j - n_fluid] or wall_patch[j - n_fluid] != own:
                continue
            r2 = squared_distance(pos, i, j, dim)
            if r2 < r2_adjacent:
                w = max(w, wet_own[j - n_fluid])
        wet[i - n_fluid] = w
        if w < 1.0:
            p[i] *= w
            rho[i] = rho0 + p[i] * inv_c2
    for i in prange(n_fluid, n):
        if pressure_layer[i - n_fluid]:
            continue
        w = 0.0
        own = wall_patch[i - n_fluid]
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if j < n_fluid:
                continue
            if not pressure_layer[j - n_fluid] or wall_patch[j - n_fluid] != own:
                continue
            r2 = squared_distance(pos, i, j, dim)
            if r2 >= r2max:
                continue
            w = max(w, wet[j - n_fluid])
        wet[i - n_fluid] = w
        if w < 1.0:
            p[i] *= w
            rho[i] = rho0 + p[i] * inv_c2


def _make_correction(DIM):  # noqa: N803 (a compile-time constant of the closure)
    """:func:`correction` compiled for ``DIM`` = 2 or 3 (the branches on it fold away)."""

    @njit(cache=True, parallel=True)
    def correction_dim(pos, rho, vol, p, indptr, indices, r2max, n_fluid, inv_h, coef, M, pM,
                       grad_rho, pair_j, fv_pair, row_end):  # fmt: skip
        for i in prange(n_fluid):
            b00 = b01 = b02 = b10 = b11 = b12 = b20 = b21 = b22 = 0.0
            g0 = g1 = g2 = 0.0
            x0 = pos[i, 0]
            x1 = pos[i, 1]
            x2 = pos[i, 2] if DIM == 3 else 0.0
            rho_i = rho[i]
            out = indptr[i]  # the kept pairs fill the row's first slots, in order
            for k in range(indptr[i], indptr[i + 1]):
                j = np.uint32(indices[k])  # unsigned: no negative-index wrap test
                d0 = x0 - pos[j, 0]
                d1 = x1 - pos[j, 1]
                r2 = d0 * d0 + d1 * d1
                if DIM == 3:
                    d2 = x2 - pos[j, 2]
                    r2 += d2 * d2
                if r2 >= r2max:
                    continue  # a candidate beyond the radius
                f = gradient_factor_fast(np.sqrt(r2), inv_h, coef) * vol[j]  # F V_j
                pair_j[out] = j
                fv_pair[out] = f  # grad_i W_ij V_j = F V_j r_ij, reused by pair_terms
                out += 1
                gw0 = f * d0
                gw1 = f * d1
                # (r_j - r_i) (x) grad_i W_ij V_j, r_j - r_i = -d
                b00 -= d0 * gw0
                b01 -= d0 * gw1
                b10 -= d1 * gw0
                b11 -= d1 * gw1
                drho = rho[j] - rho_i
                g0 += drho * gw0
                g1 += drho * gw1
                if DIM == 3:
                    gw2 = f * d2
                    b02 -= d0 * gw2
                    b12 -= d1 * gw2
                    b20 -= d2 * gw0
                    b21 -= d2 * gw1
                    b22 -= d2 * gw2
                    g2 += drho * gw2
            row_end[i] = out
            p_i = p[i]
            if DIM == 2:
                det = b00 * b11 - b01 * b10
                if det > DET_MIN:
                    m00 = b11 / det
                    m01 = -b01 / det
                    m10 = -b10 / det
                    m11 = b00 / det
                else:
                    m00 = m11 = 1.0
                    m01 = m10 = 0.0
                M[i, 0, 0] = m00
                M[i, 0, 1] = m01
                M[i, 1, 0] = m10
                M[i, 1, 1] = m11
                grad_rho[i, 0] = m00 * g0 + m01 * g1
                grad_rho[i, 1] = m10 * g0 + m11 * g1
            else:
                c00 = b11 * b22 - b12 * b21
                c01 = b02 * b21 - b01 * b22
                c02 = b01 * b12 - b02 * b11
                det = b00 * c00 + b10 * c01 + b20 * c02
                if det > DET_MIN:
                    inv = 1.0 / det
                    M[i, 0, 0] = c00 * inv
                    M[i, 0, 1] = c01 * inv
                    M[i, 0, 2] = c02 * inv
                    M[i, 1, 0] = (b12 * b20 - b10 * b22) * inv
                    M[i, 1, 1] = (b00 * b22 - b02 * b20) * inv
                    M[i, 1, 2] = (b02 * b10 - b00 * b12) * inv
                    M[i, 2, 0] = (b10 * b21 - b11 * b20) * inv
                    M[i, 2, 1] = (b01 * b20 - b00 * b21) * inv
                    M[i, 2, 2] = (b00 * b11 - b01 * b10) * inv
                else:
                    for a in range(3):
                        for c in range(3):
                            M[i, a, c] = 1.0 if a == c else 0.0
                for a in range(3):
                    grad_rho[i, a] = M[i, a, 0] * g0 + M[i, a, 1] * g1 + M[i, a, 2] * g2
            for a in range(DIM):
                for c in range(DIM):
                    pM[i, a, c] = p_i * M[i, a, c]  # p_i M_i of seed eq. 12, once per particle

    return correction_dim


_CORRECTION = {2: _make_correction(2), 3: _make_correction(3)}


def correction(pos, rho, vol, p, indptr, indices, r2max, n_fluid, inv_h, coef, M, pM, grad_rho,
               pair_j, fv_pair, row_end):  # fmt: skip
    """CSPM correction M_i = [sum_j (r_j - r_i) (x) grad_i W_ij V_j]^-1 (seed eq. 7; identity
    where det < DET_MIN) and the renormalised density gradient <grad rho>_i = M_i sum_j
    (rho_j - rho_i) grad_i W_ij V_j (seed eq. 7, used by the diffusion term eq. 2), over every
    neighbour (fluid and wall), for the fluid particles; also ``pM`` = p_i M_i (Pa).

    Rows (``indptr``, ``indices``): ascending, a superset of the pairs closer than sqrt(r2max)
    (m; candidate rows, fluid_sph.candidate_pairs); the pairs at r^2 >= r2max are skipped. The
    pairs kept are written for :func:`pair_terms`, in order, to the first slots of each row:
    ``pair_j[k]`` = j and ``fv_pair[k]`` = F(r_ij) V_j (1/m^2 in 2D; grad_i W_ij V_j = F V_j
    r_ij) for k in ``indptr[i] .. row_end[i] - 1``. ``p`` must hold the fluid pressures (EOS
    first).

    Compiled per dimension: the 2D kernel does no arithmetic on a third axis."""
    _CORRECTION[pos.shape[1]](pos, rho, vol, p, indptr, indices, r2max, n_fluid, inv_h, coef, M,
                              pM, grad_rho, pair_j, fv_pair, row_end)  # fmt: skip


@njit(cache=True, parallel=True)
def viscosity_ramp(pos, n_fluid, alpha0, alpha_damp, axis, start, inv_length, alpha):
    """alpha_i = max(alpha0, alpha_damp r_z(x_i)) with r_z = (x - start_z) / (end_z - start_z)
    in [0, 1] inside damping zone z (seed eq. 4: alpha rises linearly across the zone)."""
    for i in prange(n_fluid):
        a = alpha0
        for z in range(axis.shape[0]):
            r = (pos[i, axis[z]] - start[z]) * inv_length[z]
            if 0.0 <= r <= 1.0:
                a = max(a, alpha_damp * r)  # seed eq. 4
        alpha[i] = a


def _make_pair_terms(DIM):  # noqa: N803 (a compile-time constant of the closure)
    """:func:`pair_terms` compiled for ``DIM`` = 2 or 3 (the branches on it fold away)."""

    @njit(cache=True, parallel=True)
    def pair_terms_dim(pos, vel, rho, p, row_start, row_end, pair_j, fv_pair, n_fluid, h, rho0,
                       c0, delta, corrected, M, pM, grad_rho, alpha, gravity, omega2, center, acc,
                       drho, project, wall_group, ext_dir, ext_keep, wetted, wall_wet):  # fmt: skip
        eta2 = ETA2 * h * h
        nvis = 2.0 * (DIM + 2)
        for i in prange(n_fluid):
            div = 0.0
            diff = 0.0
            gp0 = gp1 = gp2 = 0.0  # <grad p>_i
            vi0 = vi1 = vi2 = 0.0  # sum_j alpha_ij phi_ij grad_i W_ij V_j
            x0 = pos[i, 0]
            x1 = pos[i, 1]
            x2 = pos[i, 2] if DIM == 3 else 0.0
            v0 = vel[i, 0]
            v1 = vel[i, 1]
            v2 = vel[i, 2] if DIM == 3 else 0.0
            p_i = p[i]
            rho_i = rho[i]
            alpha_i = alpha[i]
            gr0 = grad_rho[i, 0]
            gr1 = grad_rho[i, 1]
            gr2 = grad_rho[i, 2] if DIM == 3 else 0.0
            m00, m01, m10, m11 = M[i, 0, 0], M[i, 0, 1], M[i, 1, 0], M[i, 1, 1]
            q00, q01, q10, q11 = pM[i, 0, 0], pM[i, 0, 1], pM[i, 1, 0], pM[i, 1, 1]
            if DIM == 3:
                m02, m12, m20, m21, m22 = M[i, 0, 2], M[i, 1, 2], M[i, 2, 0], M[i, 2, 1], M[i, 2, 2]
                q02, q12, q20, q21, q22 = (pM[i, 0, 2], pM[i, 1, 2], pM[i, 2, 0], pM[i, 2, 1],
                                           pM[i, 2, 2])  # fmt: skip
            for k in range(row_start[i], row_end[i]):
                fv = fv_pair[k]  # F V_j from correction()
                if fv == 0.0:
                    continue
                j = np.uint32(pair_j[k])
                d0 = x0 - pos[j, 0]
                d1 = x1 - pos[j, 1]
                r2 = d0 * d0 + d1 * d1
                g0 = fv * d0  # grad_i W_ij V_j = F r_ij V_j
                g1 = fv * d1
                u0 = vel[j, 0] - v0
                u1 = vel[j, 1] - v1
                dot = u0 * g0 + u1 * g1
                if DIM == 3:
                    d2 = x2 - pos[j, 2]
                    r2 += d2 * d2
                    g2 = fv * d2
                    u2 = vel[j, 2] - v2
                    dot += u2 * g2
                div += dot  # (u_j - u_i) . grad_i W_ij V_j
                fluid_j = j < n_fluid
                grp = -1
                if project and not fluid_j:
                    grp = wall_group[j - n_fluid]
                if grp >= 0:
                    # a projected wall particle (structure_load = "normal_pairs"): the pressure pair
                    # term c = (p_i + p_j) M_i grad_i W_ij V_j (seed eqs. 6, 12) keeps only
                    # sum_k keep_k (c . e_k) e_k, the components wall_reaction_projected hands on
                    s = (p_i * wall_wet[j - n_fluid] if wetted else p_i) + p[j]
                    if corrected:
                        c0_ = s * (m00 * g0 + m01 * g1)
                        c1_ = s * (m10 * g0 + m11 * g1)
                        c2_ = 0.0
                        if DIM == 3:
                            c0_ += s * m02 * g2
                            c1_ += s * m12 * g2
                            c2_ = s * (m20 * g0 + m21 * g1 + m22 * g2)
                    else:
                        c0_ = s * g0
                        c1_ = s * g1
                        c2_ = 0.0
                        if DIM == 3:
                            c2_ = s * g2
                    for e in range(2):
                        w_ = c0_ * ext_dir[grp, e, 0] + c1_ * ext_dir[grp, e, 1]
                        if DIM == 3:
                            w_ += c2_ * ext_dir[grp, e, 2]
                        w_ *= ext_keep[grp, e]
                        gp0 += w_ * ext_dir[grp, e, 0]
                        gp1 += w_ * ext_dir[grp, e, 1]
                        if DIM == 3:
                            gp2 += w_ * ext_dir[grp, e, 2]
                elif corrected:
                    # (p_i M_i + p_j M_j) grad_i W_ij V_j, seed eq. 12 (M_j = M_i at a wall)
                    if fluid_j:
                        a00 = q00 + pM[j, 0, 0]
                        a01 = q01 + pM[j, 0, 1]
                        a10 = q10 + pM[j, 1, 0]
                        a11 = q11 + pM[j, 1, 1]
                        if DIM == 3:
                            a02 = q02 + pM[j, 0, 2]
                            a12 = q12 + pM[j, 1, 2]
                            a20 = q20 + pM[j, 2, 0]
                            a21 = q21 + pM[j, 2, 1]
                            a22 = q22 + pM[j, 2, 2]
                    else:
                        # a wetted wall of wetness w: w p_i + p_j (p_j = w p_Adami; dry_walls)
                        s = (p_i * wall_wet[j - n_fluid] if wetted else p_i) + p[j]
                        a00, a01, a10, a11 = s * m00, s * m01, s * m10, s * m11
                        if DIM == 3:
                            a02, a12, a20, a21, a22 = s * m02, s * m12, s * m20, s * m21, s * m22
                    if DIM == 2:
                        gp0 += a00 * g0 + a01 * g1
                        gp1 += a10 * g0 + a11 * g1
                    else:
                        gp0 += a00 * g0 + a01 * g1 + a02 * g2
                        gp1 += a10 * g0 + a11 * g1 + a12 * g2
                        gp2 += a20 * g0 + a21 * g1 + a22 * g2
                else:
                    s = p_i + p[j]  # seed eq. 6
                    if wetted and not fluid_j:  # w p_i + p_j at a wetted wall (dry_walls)
                        s = p_i * wall_wet[j - n_fluid] + p[j]
                    gp0 += s * g0
                    gp1 += s * g1
                    if DIM == 3:
                        gp2 += s * g2
                if fluid_j:
                    # psi_ji = rho_j - rho_i - (<grad rho>_i + <grad rho>_j) . (r_j - r_i) / 2,
                    # seed eq. 2
                    psi = rho[j] - rho_i
                    psi += 0.5 * ((gr0 + grad_rho[j, 0]) * d0 + (gr1 + grad_rho[j, 1]) * d1)
                    if DIM == 3:
                        psi += 0.5 * (gr2 + grad_rho[j, 2]) * d2
                    inv = 1.0 / (r2 + eta2)
                    # (r_j - r_i) . grad_i W_ij V_j = -F r^2 V_j, seed eq. 2
                    diff -= psi * fv * r2 * inv
                    # phi_ij = 2 (n + 2) (u_j - u_i) . (r_j - r_i) / (r^2 + 0.01 h^2), seed eq. 3
                    ud = u0 * d0 + u1 * d1
                    if DIM == 3:
                        ud += u2 * d2
                    phi = -nvis * ud * inv
                    w = 0.5 * (alpha_i + alpha[j]) * phi
                    vi0 += w * g0
                    vi1 += w * g1
                    if DIM == 3:
                        vi2 += w * g2
            drho[i] = -rho_i * div + delta * h * c0 * 2.0 * diff  # seed eqs. 1, 2
            inv_rho = 1.0 / rho_i
            visc = h * c0 * rho0 * inv_rho  # seed eq. 3: alpha h c0 rho0 / rho_i
            acc[i, 0] = -gp0 * inv_rho + gravity[0] - omega2 * (x0 - center[0]) + visc * vi0
            acc[i, 1] = -gp1 * inv_rho + gravity[1] - omega2 * (x1 - center[1]) + visc * vi1
            if DIM == 3:
                acc[i, 2] = -gp2 * inv_rho + gravity[2] - omega2 * (x2 - center[2]) + visc * vi2

    return pair_terms_dim


_PAIR_TERMS = {2: _make_pair_terms(2), 3: _make_pair_terms(3)}


#: no projected wall particles (the arguments pair_terms passes when not given)
_NO_GROUP = np.zeros(0, np.int64)
_NO_DIR = np.zeros((0, 2, 2))
_NO_KEEP = np.zeros((0, 2))
#: no wetted walls (fluid.sph.wall_pressure = "adami")
_NO_WET = np.zeros(0)


def pair_terms(pos, vel, rho, p, row_start, row_end, pair_j, fv_pair, n_fluid, h, rho0, c0, delta,
               corrected, M, pM, grad_rho, alpha, gravity, omega2, center, acc, drho,
               wall_group=None, ext_dir=None, ext_keep=None, wall_wet=None):  # fmt: skip
    """Right-hand side of the fluid particles (seed eq. 13):

    drho_i/dt = -rho_i sum_j (u_j - u_i) . grad_i W_ij V_j + delta h c0 D_i      (eqs. 1, 2)
    du_i/dt   = -(1/rho_i) <grad p>_i + g - Omega^2 (r_i - c) + pi_i              (eqs. 1, 13)

    <grad p>_i = sum_j (p_i M_i + p_j M_j) grad_i W_ij V_j (δ-SPHC, eq. 12; M_j = M_i for a wall
    neighbour) or sum_j (p_i + p_j) grad_i W_ij V_j (δ-SPH, eq. 6). D_i (eq. 2) and the
    artificial viscosity pi_i (eq. 3, n = dim, alpha_ij = (alpha_i + alpha_j) / 2) run over
    fluid neighbours only: no diffusion into the walls, no viscous force on them (free slip).

    The pairs of row i are ``pair_j[k]`` with ``fv_pair[k]`` = F V_j for k in ``row_start[i]
    .. row_end[i] - 1``, as :func:`correction` wrote them (with ``M``, ``pM``, ``grad_rho``; a
    pair with F = 0 is skipped). Compiled per dimension, as :func:`correction`.

    Projected walls (``fluid.sph.structure_load = "normal_pairs"``): a wall particle j with
    ``wall_group[j - n_fluid]`` = g >= 0 gives fluid particle i only the part
    sum_k keep[g, k] (c . e_k) e_k of its pressure pair term c, with the unit vectors
    ``ext_dir[g, k]`` (or zero) and gates ``ext_keep[g, k]`` (0 or 1) that
    :func:`wall_reaction_projected` computed at this right-hand side: the fluid loses exactly the
    force the structure receives. Without ``wall_group`` every pair is whole.

    Wetted walls (``fluid.sph.wall_pressure = "wetted"``): ``wall_wet[j - n_fluid]`` = w_j, the
    wetness :func:`dry_walls` gave wall particle j, weighs the fluid particle's own pressure in
    the pair: (w_j p_i + p_j) with p_j = w_j p_Adami, so a dry wall (w = 0) exchanges no force
    and a wet one (w = 1) the whole pair, bit for bit. Without ``wall_wet`` w = 1."""
    project = wall_group is not None
    if not project:
        wall_group, ext_dir, ext_keep = _NO_GROUP, _NO_DIR, _NO_KEEP
    wetted = wall_wet is not None
    if not wetted:
        wall_wet = _NO_WET
    _PAIR_TERMS[pos.shape[1]](pos, vel, rho, p, row_start, row_end, pair_j, fv_pair, n_fluid, h,
                              rho0, c0, delta, corrected, M, pM, grad_rho, alpha, gravity, omega2,
                              center, acc, drho, project, wall_group, ext_dir, ext_keep, wetted,
                              wall_wet)  # fmt: skip


@njit(cache=True, inline="always")
def pressure_pair_reaction(pos, vol, p, i, j, vi, inv_h, coef, corrected, M, dim, wj):
    """Reaction R_ij = V_i (w_j p_i + p_j) M_i grad_i W_ij V_j of wall particle j to the pressure
    pair term fluid particle i receives in :func:`pair_terms` (δ-SPHC, seed eq. 12 with
    M_j = M_i at a wall; plain δ-SPH without M, eq. 6), N (N/m in 2D); w_j = ``wj``, the wall's
    wetness (:func:`dry_walls`; 1 for Adami's walls). Returns (nonzero, R_x, R_y, R_z); nonzero
    is False beyond the kernel's support (R = 0)."""
    d0 = pos[i, 0] - pos[j, 0]
    d1 = pos[i, 1] - pos[j, 1]
    d2 = pos[i, 2] - pos[j, 2] if dim == 3 else 0.0
    f = gradient_factor_fast(np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), inv_h, coef)
    if f == 0.0:
        return False, 0.0, 0.0, 0.0
    fv = f * vol[j] * (p[i] * wj + p[j]) * vi  # V_i (w_j p_i + p_j) F V_j
    g0 = fv * d0
    g1 = fv * d1
    g2 = fv * d2
    if not corrected:  # seed eq. 6
        return True, g0, g1, g2
    r0 = M[i, 0, 0] * g0 + M[i, 0, 1] * g1 + (M[i, 0, 2] * g2 if dim == 3 else 0.0)
    r1 = M[i, 1, 0] * g0 + M[i, 1, 1] * g1 + (M[i, 1, 2] * g2 if dim == 3 else 0.0)
    r2 = M[i, 2, 0] * g0 + M[i, 2, 1] * g1 + M[i, 2, 2] * g2 if dim == 3 else 0.0
    return True, r0, r1, r2


@njit(cache=True)
def wall_reaction(pos, rho, vol, p, indptr, indices, n_fluid, inv_h, coef, corrected, M, slot,
                  out, wall_wet=None):  # fmt: skip
    """Force of the fluid on each externally driven wall particle (``slot[j] >= 0``), N (N/m in
    2D): the reaction to the pressure pair term the fluid particle i received from j in
    :func:`pair_terms`, F_j = sum_i V_i (p_i + p_j) M_i grad_i W_ij V_j (δ-SPHC, seed eq. 12
    with M_j = M_i at a wall; without M for δ-SPH, eq. 6): m_i du_i/dt loses exactly -F_j, so
    the fluid's and the wall's momentum balance pair by pair (Newton's third law). Wall pairs
    carry no viscous force (free slip). Serial over the fluid rows (a scatter), in the
    neighbour list's order: deterministic. ``wall_wet``: the walls' wetness (:func:`dry_walls`,
    ``fluid.sph.wall_pressure = "wetted"``; None: 1), weighing p_i in each pair as
    :func:`pair_terms` does."""
    dim = pos.shape[1]
    out[:] = 0.0
    for i in range(n_fluid):
        vi = vol[i]
        for k in range(indptr[i + 1] - 1, indptr[i] - 1, -1):
            j = indices[k]
            if j < n_fluid:
                break  # ascending rows: walls last
            s = slot[j]
            if s < 0:
                continue
            wj = 1.0 if wall_wet is None else wall_wet[j - n_fluid]
            hit, r0, r1, r2 = pressure_pair_reaction(pos, vol, p, i, j, vi, inv_h, coef,
                                                     corrected, M, dim, wj)  # fmt: skip
            if not hit:
                continue
            out[s, 0] += r0
            out[s, 1] += r1
            if dim == 3:
                out[s, 2] += r2


@njit(cache=True)
def wall_reaction_projected(pos, vol, p, indptr, indices, n_fluid, inv_h, coef, corrected, M,
                            slot, wall_group, slot_group, ext_dir, ext_push, comp, gsum, ext_keep,
                            out, wall_wet=None):  # fmt: skip
    """:func:`wall_reaction` with the free-slip projection of ``fluid.sph.structure_load =
    "normal_pairs"``, N (N/m in 2D). Each external wall particle j of group g = ``wall_group[j -
    n_fluid]`` >= 0 (a structure member's interface point and the dummies of its column) keeps
    of each pair reaction R_ij = V_i (p_i + p_j) M_i grad_i W_ij V_j only its components
    a_k = R_ij . e_k along the group's unit vectors e_k = ``ext_dir[g, k]`` (k = 0, 1: a face
    point's normal and zero; an end-cap point's zero and its cap normal; a corner's face and
    cap normals). Where ``ext_push[g, k]`` the component may only push: when the group's sum
    A_k = sum a_k over its particles and pairs is > 0 (out of the structure: a pull) the gate
    ``ext_keep[g, k]`` is 0, else 1. out[s] = sum_k keep_k (sum_i a_k) e_k; ``pair_terms`` gives
    the fluid the same projected, gated pair terms, so the fluid loses exactly -out (Newton's
    third law, pair by pair). Work arrays ``comp`` (slots, 2) and ``gsum`` (groups, 2). A
    particle of group -1 gets the whole reaction. Serial, in the neighbour list's order:
    deterministic. ``wall_wet`` as :func:`wall_reaction`."""
    dim = pos.shape[1]
    out[:] = 0.0
    comp[:] = 0.0
    gsum[:] = 0.0
    for i in range(n_fluid):
        vi = vol[i]
        for k in range(indptr[i + 1] - 1, indptr[i] - 1, -1):
            j = indices[k]
            if j < n_fluid:
                break  # ascending rows: walls last
            s = slot[j]
            if s < 0:
                continue
            wj = 1.0 if wall_wet is None else wall_wet[j - n_fluid]
            hit, r0, r1, r2 = pressure_pair_reaction(pos, vol, p, i, j, vi, inv_h, coef,
                                                     corrected, M, dim, wj)  # fmt: skip
            if not hit:
                continue
            grp = wall_group[j - n_fluid]
            if grp < 0:
                out[s, 0] += r0
                out[s, 1] += r1
                if dim == 3:
                    out[s, 2] += r2
                continue
            for e in range(2):
                a = r0 * ext_dir[grp, e, 0] + r1 * ext_dir[grp, e, 1]
                if dim == 3:
                    a += r2 * ext_dir[grp, e, 2]
                comp[s, e] += a
                gsum[grp, e] += a
    for g in range(gsum.shape[0]):
        for e in range(2):
            # a free end is pushed, never pulled: no tension from negative pressures
            ext_keep[g, e] = 0.0 if (ext_push[g, e] and gsum[g, e] > 0.0) else 1.0
    for s in range(slot_group.shape[0]):
        g = slot_group[s]
        if g < 0:
            continue
        for e in range(2):
            a = ext_keep[g, e] * comp[s, e]
            for c in range(dim):
                out[s, c] += a * ext_dir[g, e, c]


@njit(cache=True)
def patch_exchange(pos, vol, p, indptr, indices, n_fluid, inv_h, coef, corrected, M, wall_patch,
                   out, wall_wet=None):  # fmt: skip
    """Force of the fluid on each wall patch, N (N/m in 2D): the sum over the patch's particles
    (``wall_patch[j - n_fluid]`` = its index; -1: not summed) of :func:`wall_reaction`'s pair
    reactions V_i (p_i + p_j) M_i grad_i W_ij V_j (seed eqs. 6, 12): the momentum the fluid loses
    at the patch per unit time (``fluid.boundary_force = "momentum_exchange"``). Serial, in the
    neighbour list's order: deterministic. ``wall_wet``: the walls' wetness (:func:`dry_walls`,
    ``fluid.sph.wall_pressure = "wetted"``; None: 1), weighing p_i in each pair as
    :func:`pair_terms` does."""
    dim = pos.shape[1]
    out[:] = 0.0
    for i in range(n_fluid):
        vi = vol[i]
        for k in range(indptr[i + 1] - 1, indptr[i] - 1, -1):
            j = indices[k]
            if j < n_fluid:
                break  # ascending rows: walls last
            b = wall_patch[j - n_fluid]
            if b < 0:
                continue
            wj = 1.0 if wall_wet is None else wall_wet[j - n_fluid]
            hit, r0, r1, r2 = pressure_pair_reaction(pos, vol, p, i, j, vi, inv_h, coef,
                                                     corrected, M, dim, wj)  # fmt: skip
            if not hit:
                continue
            out[b, 0] += r0
            out[b, 1] += r1
            if dim == 3:
                out[b, 2] += r2
