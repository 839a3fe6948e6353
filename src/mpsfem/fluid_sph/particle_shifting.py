"""δ+-SPH particle shifting (``fluid.sph.shifting = "delta_plus"``), numba.

Once per time step, at the step's end, every fluid particle's position moves by

    δr_i = -C CFL Ma (2h)^2 sum_j [1 + R (W_ij / W(l0))^n] grad_i W_ij V_j

(Sun, Colagrossi, Marrone & Zhang 2017, CMAME 315, the δ+-SPH shifting law: a Fickian
shift down the gradient of the particle concentration, the R term a repulsion of pairs closer
than the lattice spacing l0, after Monaghan 2000's anti-clumping term; R = 0.2, n = 4). With
CFL = c0 dt / h and Ma = U / c0, CFL Ma (2h)^2 = 4 h U dt: the shift per unit time is fixed
by the flow's reference speed U (fluid.sph.reference_speed, default 2 sqrt(g H), the one c0
is built on) and does not depend on the integrator's step. C (``shifting_coefficient``) is 1
in the paper.

Free surface (Sun et al. 2017, after Marrone et al. 2010's detection, and Sun et al. 2019): with
lambda_i the smallest eigenvalue of B_i = sum_j (r_j - r_i) (x) grad_i W_ij V_j (1 inside the
fluid, about 0.5 on a flat surface), a particle with lambda_i < ``shifting_surface``
is a free-surface particle and is not shifted (0.6); one with lambda_i < ``shifting_layer`` (0.75), or
with a free-surface particle within its support, lies in the surface layer and is shifted
along the surface only, δr_i <- (I - n_i (x) n_i) δr_i, with the outward normal n_i = -M_i
sum_j grad_i W_ij V_j / |...| (Marrone et al. 2010; M_i = B_i^-1, the identity where det B_i <
delta_sph.DET_MIN). Wall and structure particles take part in the sums (a wall fills the
kernel's support as the fluid would) and are never shifted. A shift longer than
``shifting_max`` l0 is scaled back to that length (ours: the flow's own displacement per step,
U dt = CFL Ma h, is about 0.1 l0 at the RK4 defaults).

Positions only: velocities and densities are not touched, so the fluid's momentum is exactly
what the step left (the momentum budget is unchanged). The shift needs no state of its own (a
function of the positions, volumes and dt): restarts stay bit for bit. Every parallel loop runs
over rows i and sums its own row in ascending neighbour order: the same bits for any thread
count; the work arrays are sized once.
"""

from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, prange

from mpsfem.fluid_sph import delta_sph
from mpsfem.fluid_sph.delta_sph import DET_MIN
from mpsfem.fluid_sph.wendland import gradient_factor_fast, kernel_value


@njit(cache=True, inline="always")
def _smallest_eigenvalue_2(a00, a01, a11):
    """Smallest eigenvalue of the symmetric 2x2 matrix [[a00, a01], [a01, a11]]."""
    half = 0.5 * (a00 + a11)
    dif = 0.5 * (a00 - a11)
    return half - math.sqrt(dif * dif + a01 * a01)


@njit(cache=True, inline="always")
def _smallest_eigenvalue_3(a00, a01, a02, a11, a12, a22):
    """Smallest eigenvalue of a symmetric 3x3 matrix (trigonometric closed form, Smith 1961)."""
    p1 = a01 * a01 + a02 * a02 + a12 * a12
    q = (a00 + a11 + a22) / 3.0
    if p1 == 0.0:
        return min(a00, min(a11, a22))
    b0 = a00 - q
    b1 = a11 - q
    b2 = a22 - q
    p2 = b0 * b0 + b1 * b1 + b2 * b2 + 2.0 * p1
    p = math.sqrt(p2 / 6.0)
    # det((A - q I) / p) / 2, clipped to [-1, 1] against round-off
    det = b0 * (b1 * b2 - a12 * a12) - a01 * (a01 * b2 - a12 * a02) + a02 * (a01 * a12 - b1 * a02)
    r = det / (2.0 * p * p * p)
    r = min(1.0, max(-1.0, r))
    phi = math.acos(r) / 3.0
    return q + 2.0 * p * math.cos(phi + 2.0 * math.pi / 3.0)  # Smith 1961: the smallest root


def _make_shift_sums(DIM):  # noqa: N803 (a compile-time constant of the closure)
    """:func:`shift_sums` compiled for ``DIM`` = 2 or 3 (the branches on it fold away)."""

    @njit(cache=True, parallel=True)
    def shift_sums_dim(pos, vol, rho, indptr, indices, r2max, n_fluid, h, inv_h, norm, coef,
                       inv_wdx, r_coef, n_exp, lam, normal, raw, grad_rho):  # fmt: skip
        for i in prange(n_fluid):
            b00 = b01 = b02 = b11 = b12 = b22 = 0.0
            s0 = s1 = s2 = 0.0  # sum_j grad_i W_ij V_j
            g0 = g1 = g2 = 0.0  # sum_j (rho_j - rho_i) grad_i W_ij V_j
            rho_i = rho[i]
            t0 = t1 = t2 = 0.0  # sum_j [1 + R (W_ij / W(l0))^n] grad_i W_ij V_j
            x0 = pos[i, 0]
            x1 = pos[i, 1]
            x2 = pos[i, 2] if DIM == 3 else 0.0
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                d0 = x0 - pos[j, 0]
                d1 = x1 - pos[j, 1]
                r2 = d0 * d0 + d1 * d1
                if DIM == 3:
                    d2 = x2 - pos[j, 2]
                    r2 += d2 * d2
                if r2 >= r2max:
                    continue  # a candidate beyond the radius
                r = math.sqrt(r2)
                f = gradient_factor_fast(r, inv_h, coef) * vol[j]  # grad_i W_ij V_j = f r_ij
                ratio = kernel_value(r, h, norm) * inv_wdx
                fac = 1.0 + r_coef * ratio**n_exp  # Sun et al. 2017: 1 + R (W_ij / W(l0))^n
                # B_i = sum (r_j - r_i) (x) grad_i W_ij V_j = -f r_ij (x) r_ij (symmetric)
                b00 -= f * d0 * d0
                b01 -= f * d0 * d1
                b11 -= f * d1 * d1
                s0 += f * d0
                s1 += f * d1
                drho = rho[j] - rho_i
                g0 += drho * f * d0
                g1 += drho * f * d1
                t0 += fac * f * d0
                t1 += fac * f * d1
                if DIM == 3:
                    b02 -= f * d0 * d2
                    b12 -= f * d1 * d2
                    b22 -= f * d2 * d2
                    s2 += f * d2
                    g2 += drho * f * d2
                    t2 += fac * f * d2
            # outward normal -M_i sum grad_i W_ij V_j (Marrone et al. 2010)
            if DIM == 2:
                lam[i] = _smallest_eigenvalue_2(b00, b01, b11)
                det = b00 * b11 - b01 * b01
                if det > DET_MIN:
                    m0 = (b11 * s0 - b01 * s1) / det
                    m1 = (b00 * s1 - b01 * s0) / det
                    grad_rho[i, 0] = (b11 * g0 - b01 * g1) / det  # <grad rho> = M sum ...
                    grad_rho[i, 1] = (b00 * g1 - b01 * g0) / det
                else:
                    m0 = s0
                    m1 = s1
                    grad_rho[i, 0] = g0
                    grad_rho[i, 1] = g1
                nn = math.sqrt(m0 * m0 + m1 * m1)
                if nn > 0.0:
                    normal[i, 0] = -m0 / nn
                    normal[i, 1] = -m1 / nn
                else:
                    normal[i, 0] = 0.0
                    normal[i, 1] = 0.0
                raw[i, 0] = t0
                raw[i, 1] = t1
            else:
                lam[i] = _smallest_eigenvalue_3(b00, b01, b02, b11, b12, b22)
                c00 = b11 * b22 - b12 * b12
                c01 = b02 * b12 - b01 * b22
                c02 = b01 * b12 - b02 * b11
                det = b00 * c00 + b01 * c01 + b02 * c02
                if det > DET_MIN:
                    c11 = b00 * b22 - b02 * b02
                    c12 = b02 * b01 - b00 * b12
                    c22 = b00 * b11 - b01 * b01
                    m0 = (c00 * s0 + c01 * s1 + c02 * s2) / det
                    m1 = (c01 * s0 + c11 * s1 + c12 * s2) / det
                    m2 = (c02 * s0 + c12 * s1 + c22 * s2) / det
                    grad_rho[i, 0] = (c00 * g0 + c01 * g1 + c02 * g2) / det
                    grad_rho[i, 1] = (c01 * g0 + c11 * g1 + c12 * g2) / det
                    grad_rho[i, 2] = (c02 * g0 + c12 * g1 + c22 * g2) / det
                else:
                    m0 = s0
                    m1 = s1
                    m2 = s2
                    grad_rho[i, 0] = g0
                    grad_rho[i, 1] = g1
                    grad_rho[i, 2] = g2
                nn = math.sqrt(m0 * m0 + m1 * m1 + m2 * m2)
                if nn > 0.0:
                    normal[i, 0] = -m0 / nn
                    normal[i, 1] = -m1 / nn
                    normal[i, 2] = -m2 / nn
                else:
                    normal[i, 0] = 0.0
                    normal[i, 1] = 0.0
                    normal[i, 2] = 0.0
                raw[i, 0] = t0
                raw[i, 1] = t1
                raw[i, 2] = t2

    return shift_sums_dim


_SHIFT_SUMS = {2: _make_shift_sums(2), 3: _make_shift_sums(3)}


def shift_sums(pos, vol, rho, indptr, indices, r2max, n_fluid, h, inv_h, norm, coef, inv_wdx,
               r_coef, n_exp, lam, normal, raw, grad_rho):  # fmt: skip
    """Per fluid particle i: ``lam[i]``, the smallest eigenvalue of B_i = sum_j (r_j - r_i) (x)
    grad_i W_ij V_j (dimensionless); ``normal[i]``, the unit outward normal -M_i sum_j grad_i
    W_ij V_j / |...| (zero where that sum vanishes); ``raw[i]`` = sum_j [1 + R (W_ij /
    W(l0))^n] grad_i W_ij V_j (1/m); ``grad_rho[i]`` = M_i sum_j (rho_j - rho_i) grad_i W_ij
    V_j (kg/m^4, the CSPM density gradient of delta_sph.correction at these positions), over
    every neighbour (fluid and wall). ``inv_wdx`` = 1 /
    W(l0) (m^dim), ``r_coef`` = R, ``n_exp`` = n; kernel constants as delta_sph.correction.
    Rows: ascending candidates, the pairs at r^2 >= r2max skipped."""
    _SHIFT_SUMS[pos.shape[1]](pos, vol, rho, indptr, indices, r2max, n_fluid, h, inv_h, norm,
                              coef, inv_wdx, r_coef, n_exp, lam, normal, raw,
                              grad_rho)  # fmt: skip


@njit(cache=True, parallel=True)
def shift_vectors(pos, indptr, indices, r2max, n_fluid, lam, normal, raw, scale, lam_surface,
                  lam_layer, max_shift, shift):  # fmt: skip
    """δr_i (m) of every fluid particle into ``shift``: -scale raw_i (``scale`` = C CFL Ma (2h)^2,
    m^2), zero for a free-surface particle (lam_i < lam_surface), projected on the surface
    (I - n_i (x) n_i) in the surface layer (lam_i < lam_layer, or a fluid neighbour closer than
    the radius with lam_j < lam_surface; Sun et al. 2017), then no longer than ``max_shift``
    (m). Reads ``pos``; writes only ``shift``."""
    dim = pos.shape[1]
    for i in prange(n_fluid):
        if lam[i] < lam_surface:  # a free-surface particle stays where it is
            for a in range(dim):
                shift[i, a] = 0.0
            continue
        layer = lam[i] < lam_layer
        if not layer:
            for k in range(indptr[i], indptr[i + 1]):
                j = indices[k]
                if j >= n_fluid:
                    break  # ascending rows: the walls last
                if lam[j] >= lam_surface:
                    continue
                r2 = 0.0
                for a in range(dim):
                    d = pos[i, a] - pos[j, a]
                    r2 += d * d
                if r2 < r2max:
                    layer = True
                    break
        dot = 0.0
        for a in range(dim):
            shift[i, a] = -scale * raw[i, a]  # Sun et al. 2017: δr = -C CFL Ma (2h)^2 sum ...
            dot += shift[i, a] * normal[i, a]
        if layer:  # tangential only: (I - n (x) n) δr
            for a in range(dim):
                shift[i, a] -= dot * normal[i, a]
        length = 0.0
        for a in range(dim):
            length += shift[i, a] * shift[i, a]
        length = math.sqrt(length)
        if length > max_shift:
            c = max_shift / length
            for a in range(dim):
                shift[i, a] *= c


@njit(cache=True, parallel=True)
def apply_shift(pos, shift, n_fluid, rho, grad_rho, taylor):
    """r_i += δr_i for the fluid particles; with ``taylor``, also rho_i += δr_i . <grad rho>_i
    (the density field at the new position to first order; Lind et al. 2012)."""
    dim = pos.shape[1]
    for i in prange(n_fluid):
        dr = 0.0
        for a in range(dim):
            pos[i, a] += shift[i, a]
            dr += shift[i, a] * grad_rho[i, a]
        if taylor:
            rho[i] += dr  # Lind et al. 2012: rho(r + dr) = rho + dr . grad rho


class ParticleShifting:
    """The δ+-SPH shift of a :class:`~mpsfem.fluid_sph.solver.DeltaSPHSolver`'s fluid (module
    docstring); :meth:`apply` once per step. ``speed``: U, m/s, of Ma = U / c0."""

    def __init__(self, solver, speed: float) -> None:
        sph = solver.sph
        if not (math.isfinite(speed) and speed > 0.0):
            raise ValueError(
                f"fluid.sph.shifting = {sph.shifting!r}: the reference speed U of Ma = U / c0 is "
                f"{speed!r} (no gravity, no block velocity); give fluid.sph.reference_speed > 0"
            )
        self.speed = float(speed)
        self.coefficient = sph.shifting_coefficient
        self.r_coef = sph.shifting_r
        self.n_exp = int(sph.shifting_n)  # an integer power: repeated products, not pow()
        self.lam_surface = sph.shifting_surface
        self.lam_layer = sph.shifting_layer
        self.max_shift = sph.shifting_max * solver.l0  # m
        self.inv_wdx = 1.0 / kernel_value(solver.l0, solver.h, solver.norm)  # 1 / W(l0)
        nf, dim = solver.n_fluid, solver.dim
        self.lam = np.ones(nf)
        self.normal = np.zeros((nf, dim))
        self.raw = np.zeros((nf, dim))
        self.shift = np.zeros((nf, dim))
        self.grad_rho = np.zeros((nf, dim))
        self.taylor = sph.shifting_density == "taylor"
        #: wall time spent shifting, s
        self.seconds = 0.0

    def scale(self, solver, dt: float) -> float:
        """C CFL Ma (2h)^2 = C 4 h U dt, m^2, with CFL = c0 dt / h and Ma = U / c0."""
        cfl = solver.c0 * dt / solver.h
        mach = self.speed / solver.c0
        return self.coefficient * cfl * mach * (2.0 * solver.h) ** 2  # Sun et al. 2017

    def compute(self, solver, dt: float) -> np.ndarray:
        """δr of every fluid particle (m) at the solver's positions into :attr:`shift`."""
        nb = solver.neighbour_rows()  # candidate rows (filtered through a member's filter)
        delta_sph.particle_volume(solver.rho, solver.mass, solver.vol)  # V = m / rho
        r2max = solver.radius * solver.radius
        nf = solver.n_fluid
        shift_sums(
            solver.pos, solver.vol, solver.rho, nb.indptr, nb.indices, r2max, nf, solver.h,
            solver.inv_h, solver.norm, solver.grad_coef, self.inv_wdx, self.r_coef, self.n_exp,
            self.lam, self.normal, self.raw, self.grad_rho,
        )  # fmt: skip
        shift_vectors(
            solver.pos, nb.indptr, nb.indices, r2max, nf, self.lam, self.normal, self.raw,
            self.scale(solver, dt), self.lam_surface, self.lam_layer, self.max_shift, self.shift,
        )  # fmt: skip
        return self.shift

    def apply(self, solver, dt: float) -> None:
        """Shift the solver's fluid particles for a step of ``dt`` (s); velocities untouched."""
        tic = time.perf_counter()
        self.compute(solver, dt)
        apply_shift(solver.pos, self.shift, solver.n_fluid, solver.rho, self.grad_rho, self.taylor)
        self.seconds += time.perf_counter() - tic


def build(solver) -> ParticleShifting | None:
    """The shifting of ``fluid.sph.shifting`` for ``solver``, or None for ``"none"``. U: the
    solver's reference speed (fluid.sph.reference_speed, default 2 sqrt(g H) with H the tallest
    block, or the fastest block's speed if higher), as in the default c0."""
    sph = solver.sph
    if sph.shifting == "none":
        return None
    spec = solver.spec
    if sph.reference_speed is not None:
        u_ref = float(sph.reference_speed)
    else:
        g = float(np.linalg.norm(solver.gravity))
        up = spec.vertical_axis
        height = max(b.upper[up] - b.lower[up] for b in spec.blocks) if spec.blocks else 0.0
        u_ref = 2.0 * math.sqrt(g * height)
    u_block = max(
        (float(np.linalg.norm(b.velocity)) for b in spec.blocks if b.velocity), default=0.0
    )
    return ParticleShifting(solver, max(u_ref, u_block))
