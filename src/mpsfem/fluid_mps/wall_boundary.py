"""Neumann wall boundary: wall and dummy particles as pressure ghosts of each fluid particle.

The thesis's wall model (its ch. 2.1.3) makes the first wall layer an unknown of the pressure
equation and leaves the dummy layers out. Its wall rows are not consistent with the fluid rows (a
one-sided Laplacian against a divergence on another radius), so the wall pressure of still water
is off by 1-4 % of rho g l0-scaled differences, which the pressure gradient of the next fluid layer
turns into accelerations of order g: still water does not stay still.

This module implements the alternative wall model ``"neumann"``, the projection method's wall
condition dp/dn = (rho / dt) (u* - u_w) . n written in two parts:

- Laplacian and gradient: for a fluid particle i, every wall or dummy neighbour j is a ghost with
  the hydrostatic pressure p_j = p_i + D_ij, D_ij = rho g . (x_j - x_i) (dp/dn = rho g . n, the
  part of the condition that holds a fluid at rest on the wall);
- divergence: the rest of the condition enters the source term as the flux through the wall:
  boundary neighbours count in the velocity divergence (thesis eq. 2-15) with the velocity
  u_w + g dt, so a fluid at rest (u* = g dt) has zero divergence there while fluid approaching
  or leaving the wall relative to it feels the compression or expansion, as in the thesis's
  model.

Dry boundary particles (a pressure-layer particle the free-surface detector
flags, or one with no fluid within the density radius, and the dummies behind it) are no ghosts:
a dry wall particle is a free-surface (p = 0) neighbour, a dry dummy is left out, so the
hydrostatic continuation never reaches above the water line. For still water D_ij is exactly the hydrostatic
difference, so the discrete pressure equation, the gradient and the wall pressure all reproduce
p = rho g (H - y). A fluid particle moving away from a wall sees no normal ghost jump (separation
is free). Walls are then not unknowns of the pressure equation; their pressure (for probes and
coupling forces) is rebuilt from the fluid by :func:`wall_pressure`.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from mpsfem.fluid_mps.kernels import weight
from mpsfem.fluid_mps.operators import (
    NO_WALL_ACCELERATION,
    fill_reference_pressures,
    gradient_kernel,
)
from mpsfem.fluid_mps.particle_kinds import is_dummy


@njit(cache=True, inline="always")
def ghost_field(j, a, gravity, wall_acc, acc_offset):
    """Component a of the field a wall/dummy ghost j's pressure follows, m/s^2: gravity, less
    the wall's own acceleration a_j where ``wall_acc`` holds one row per boundary particle
    (``fluid.pressure.wall_acceleration``; dp/dn = rho (g - a_w) . n, the normal momentum of
    fluid that moves with an accelerating wall); gravity alone when ``wall_acc`` is empty."""
    if wall_acc.shape[0] == 0:
        return gravity[a]
    return gravity[a] - wall_acc[j - acc_offset, a]


@njit(cache=True, inline="always")
def ghost_jump(i, j, pos, rho, gravity, wall_acc, acc_offset):
    """D_ij = p_j - p_i = rho (g - a_j) . (x_j - x_i) of a wall/dummy ghost j seen from fluid
    particle i (a_j = 0 without ``wall_acc``: the hydrostatic jump)."""
    acc = 0.0
    for a in range(pos.shape[1]):
        acc += ghost_field(j, a, gravity, wall_acc, acc_offset) * (pos[j, a] - pos[i, a])
    return rho * acc


@njit(cache=True, parallel=True)
def ghost_rhs(
    pos,
    vel,
    kind,
    dry,
    indptr,
    indices,
    re,
    wcode,
    coef,
    re_div,
    n0_div,
    gamma,
    rho,
    dt,
    gravity,
    wall_acc,
    acc_offset,
    out,
):
    """Known part of each fluid row of the pressure equation from its wet boundary neighbours:

    out_i = coef sum_j w(r_ij; re) D_ij                      (ghosts in the Laplacian, eq. 2-16)
            - (1 - gamma) rho / dt d / n0_div sum_j (u_j + (g - a_j) dt - u*_i) . r_ij / r_ij^2
              w(r_ij; re_div)                               (wall flux, eqs. 2-15, 2-23)

    (Pa/m^2); 0 on non-fluid particles. The row A p = b of particle i gets b_i += out_i. With
    ``wall_acc`` the wall's acceleration a_j moves from the flux (u_j - a_j dt is the wall's
    velocity before the step) into the ghosts' jump (:func:`ghost_jump`)."""
    n, dim = pos.shape
    re2 = re * re
    rd2 = re_div * re_div
    cdiv = (1.0 - gamma) * rho / dt * dim / n0_div
    for i in prange(n):
        out[i] = 0.0
        if kind[i] != 0:
            continue
        lap = 0.0
        div = 0.0
        for k in range(indptr[i], indptr[i + 1]):
            j = indices[k]
            if kind[j] == 0 or dry[j]:
                continue
            r2 = 0.0
            dot = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                r2 += dx * dx
                field = ghost_field(j, a, gravity, wall_acc, acc_offset)
                dot += (vel[j, a] + field * dt - vel[i, a]) * dx
            if r2 < re2:
                jump = ghost_jump(i, j, pos, rho, gravity, wall_acc, acc_offset)
                lap += weight(np.sqrt(r2), re, wcode) * jump
            if r2 < rd2 and r2 > 0.0:
                div += dot / r2 * weight(np.sqrt(r2), re_div, wcode)
        out[i] = coef * lap - cdiv * div


def pressure_gradient_ghost(
    pos, p, kind, dry, indptr, indices, re, wcode, n0, form, rho, gravity, out, pref_all=None,
    wall_acc=None, acc_offset=0,
):  # fmt: skip
    """Pressure gradient on fluid particles (Pa/m) with wet wall/dummy neighbours as ghosts
    p_j = p_i + D_ij, dry wall particles at p = 0 and dry dummies left out; ``form`` as in
    :func:`mpsfem.fluid_mps.operators.gradient_kernel` (``pref_all``: its (N,) work array for
    ``cmps``, allocated when None; ``wall_acc``, ``acc_offset``: as :func:`ghost_field`)."""
    pref_all = fill_reference_pressures(
        pos, p, kind, indptr, indices, re, form, False, True, pref_all
    )
    if wall_acc is None:
        wall_acc = NO_WALL_ACCELERATION
    return gradient_kernel(
        pos, p, kind, indptr, indices, re, wcode, n0, form, False, True, dry, rho, gravity,
        pref_all, out, False, wall_acc, acc_offset,
    )  # fmt: skip


@njit(cache=True, parallel=True)
def wall_pressure(
    pos, p, kind, dry, indptr, indices, re, wcode, rho, gravity, wall_acc, acc_offset,
    structure_floor=0.0,
):  # fmt: skip
    """Pressure of pressure-wall particles (Pa) rebuilt from their fluid neighbours:
    p_w = sum_f w_fw (p_f + D_fw) / sum_f w_fw (0 where no fluid is within ``re``), at least 0
    (at least ``structure_floor`` <= 0 on STRUCTURE particles: fluid.pressure.structure_suction);
    dummies carry none (particle_kinds.py), 0."""
    n, dim = pos.shape
    re2 = re * re
    for j in prange(n):
        if kind[j] == 0:
            continue
        if is_dummy(kind[j]) or dry[j]:
            p[j] = 0.0
            continue
        num = 0.0
        den = 0.0
        for k in range(indptr[j], indptr[j + 1]):
            i = indices[k]
            if kind[i] != 0:
                continue
            r2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                r2 += dx * dx
            if r2 >= re2:
                continue
            w = weight(np.sqrt(r2), re, wcode)
            num += w * (p[i] + ghost_jump(i, j, pos, rho, gravity, wall_acc, acc_offset))
            den += w
        lo = structure_floor if kind[j] == 3 else 0.0
        p[j] = max(num / den, lo) if den > 0.0 else 0.0


@njit(cache=True, parallel=True)
def mark_dry(pos, kind, flags, src, indptr, indices, re, contact_wet, buried_wet):
    """Turn the detector's flags into dry flags of the boundary: a pressure-layer particle is dry
    when flagged or without fluid within ``re``; a dummy is dry when its source is. Fluid flags
    are left as they are.

    ``buried_wet`` (``fluid.pressure.buried_walls = "ghost"``): a pressure-layer particle the
    detector left unflagged (its neighbourhood full of wall, dummy or fluid particles) stays wet
    without fluid within ``re``: it is buried in the solid (a side wall's layer below the floor
    in a corner, a member's foot), and a dry one there is a p = 0 neighbour of the fluid within
    the pressure equation's radius. Measured on the piston column (validation/
    piston_added_mass.py): those corner neighbours drained 25 % of the pressure an accelerating
    floor's ghosts set up, and the fluid made the rest up a step later through the wall flux.

    ``contact_wet`` (int8, one per particle, or empty): where 1 (the pressure layer of a polygon
    wall, geometry.py), the detector's flag is not used and the particle is dry only without
    fluid within ``re``. The detector's wall test n_i < beta n0 assumes a wall layer on the
    fluid's lattice; laid along an inclined face, a wet wall particle's number density falls a
    few per cent below n0 wherever the lattice leaves a wider gap to the face, and the flag then
    came and went from step to step (p = 0 in 5-15 % of the steps on a 26.6 deg face under still
    water, its mean pressure 5 % of rho g H low; tests/fluid_mps/test_polygon_walls.py)."""
    n, dim = pos.shape
    re2 = re * re
    by_contact = contact_wet.shape[0] == n
    for i in prange(n):
        k = kind[i]
        if k != 1 and k != 3:
            continue
        if flags[i] and not (by_contact and contact_wet[i] == 1):
            continue
        wet = buried_wet and flags[i] == 0
        for q in range(indptr[i], indptr[i + 1]):
            j = indices[q]
            if kind[j] != 0:
                continue
            r2 = 0.0
            for a in range(dim):
                dx = pos[j, a] - pos[i, a]
                r2 += dx * dx
            if r2 < re2:
                wet = True
                break
        flags[i] = 0 if wet else 1
    for i in prange(n):
        if src[i] >= 0:
            flags[i] = flags[src[i]]
