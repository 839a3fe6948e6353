"""The δ-SPH fluid's momentum budget (``fluid.momentum_budget = true``), in the layout of MPS's
``/momentum_budget`` (``fluid_mps.momentum_budget``; docs/results.md, docs/fluid_sph.md).

The fluid's velocity changes only through the right-hand side of ``delta_sph.pair_terms``:
m du_i/dt = -V_i <grad p>_i + m (g - Omega^2 (r_i - c)) + m pi_i (seed eqs. 1, 3, 12, 13), with
V_i = m / rho_i. The pressure pair of two fluid particles is antisymmetric (V_i V_j (p_i M_i +
p_j M_j) F_ij r_ij, seed eq. 12), so is the artificial viscosity's (V_i V_j h c0 rho0 alpha_ij
phi_ij F_ij r_ij, seed eq. 3); their sums are the *internal imbalance*, round-off. A pressure
pair of a fluid particle and a wall / dummy particle j is the *exchange*: its negative is the
force on j. Wall pairs carry no viscosity (free slip), no collision model exists: those columns
are zero. The split is taken at every right-hand side and weighted as the integrator weights
it (leapfrog dt/2 + dt/2, RK4 dt (1, 2, 2, 1) / 6), so the ledger closes to round-off.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from mpsfem.fluid_mps.momentum_budget import range_sums
from mpsfem.fluid_sph.delta_sph import ETA2


@njit(cache=True)
def split_forces(pos, vel, rho, vol, p, row_start, row_end, pair_j, fv_pair, n_fluid, h, rho0, c0,
                 mass, corrected, M, pM, alpha, internal, wall, project, wall_group, ext_dir,
                 ext_keep, wall_wet=None):  # fmt: skip
    """The pair forces of one right-hand side, split (N; N/m in 2D): ``internal[0]`` the sum over
    fluid-fluid pressure pairs of -V_i <grad p>_i's share, ``internal[1]`` the same for the
    artificial viscosity, ``wall[j - n_fluid]`` the pressure force of the fluid on wall / dummy
    particle j (the reaction to the pair term fluid particle i received, seed eqs. 6, 12). Same
    pairs and arithmetic as ``delta_sph.pair_terms``: the pair table ``pair_j``, ``fv_pair`` (F
    V_j) of rows ``row_start[i] .. row_end[i] - 1`` that ``delta_sph.correction`` wrote for
    this right-hand side, and its products ``pM`` = p_i M_i (the products this kernel formed
    itself before: the same bits). Serial in index order (deterministic); the sums run in local
    variables in the order the earlier array accumulators took, so the bits are theirs.
    With ``project`` a wall particle of group g = ``wall_group[j - n_fluid]`` >= 0 books only
    sum_k keep[g, k] (c . e_k) e_k of its pair (``fluid.sph.structure_load = "normal_pairs"``, as
    ``pair_terms`` gives it to the fluid). ``wall_wet`` (``fluid.sph.wall_pressure =
    "wetted"``; None: 1): each wall's wetness w_j weighs p_i in its pairs, w_j p_i + p_j, as
    ``pair_terms``."""
    dim = pos.shape[1]
    eta2 = ETA2 * h * h
    nvis = 2.0 * (dim + 2)
    wall[:] = 0.0
    ip0 = ip1 = ip2 = 0.0  # internal pressure
    iv0 = iv1 = iv2 = 0.0  # internal viscous
    for i in range(n_fluid):
        inv_rho = 1.0 / rho[i]
        vi = vol[i]  # V_i = m / rho_i
        visc = mass * h * c0 * rho0 * inv_rho  # m alpha h c0 rho0 / rho_i, seed eq. 3
        p_own = p[i]
        for k in range(row_start[i], row_end[i]):
            fv = fv_pair[k]  # F V_j; grad_i W_ij V_j = F r_ij V_j
            if fv == 0.0:
                continue
            j = pair_j[k]
            d0 = pos[i, 0] - pos[j, 0]
            d1 = pos[i, 1] - pos[j, 1]
            d2 = pos[i, 2] - pos[j, 2] if dim == 3 else 0.0
            g0 = fv * d0
            g1 = fv * d1
            g2 = fv * d2
            pj = p[j]
            fluid_j = j < n_fluid
            pi = p_own
            if wall_wet is not None and not fluid_j:
                pi = p_own * wall_wet[j - n_fluid]  # w_j p_i at a wetted wall (dry_walls)
            if corrected and fluid_j:  # (p_i M_i + p_j M_j) grad_i W_ij V_j, seed eq. 12
                gp0 = (pM[i, 0, 0] + pM[j, 0, 0]) * g0
                gp0 += (pM[i, 0, 1] + pM[j, 0, 1]) * g1
                gp1 = (pM[i, 1, 0] + pM[j, 1, 0]) * g0
                gp1 += (pM[i, 1, 1] + pM[j, 1, 1]) * g1
                gp2 = 0.0
                if dim == 3:
                    gp0 += (pM[i, 0, 2] + pM[j, 0, 2]) * g2
                    gp1 += (pM[i, 1, 2] + pM[j, 1, 2]) * g2
                    gp2 = (pM[i, 2, 0] + pM[j, 2, 0]) * g0
                    gp2 += (pM[i, 2, 1] + pM[j, 2, 1]) * g1
                    gp2 += (pM[i, 2, 2] + pM[j, 2, 2]) * g2
            elif corrected:  # a wall particle: M_j = M_i, p_i weighed by its wetness
                jj = i
                gp0 = (pi * M[i, 0, 0] + pj * M[jj, 0, 0]) * g0
                gp0 += (pi * M[i, 0, 1] + pj * M[jj, 0, 1]) * g1
                gp1 = (pi * M[i, 1, 0] + pj * M[jj, 1, 0]) * g0
                gp1 += (pi * M[i, 1, 1] + pj * M[jj, 1, 1]) * g1
                gp2 = 0.0
                if dim == 3:
                    gp0 += (pi * M[i, 0, 2] + pj * M[jj, 0, 2]) * g2
                    gp1 += (pi * M[i, 1, 2] + pj * M[jj, 1, 2]) * g2
                    gp2 = (pi * M[i, 2, 0] + pj * M[jj, 2, 0]) * g0
                    gp2 += (pi * M[i, 2, 1] + pj * M[jj, 2, 1]) * g1
                    gp2 += (pi * M[i, 2, 2] + pj * M[jj, 2, 2]) * g2
            else:
                s = pi + pj  # seed eq. 6
                gp0 = s * g0
                gp1 = s * g1
                gp2 = s * g2
            if fluid_j:
                r2 = d0 * d0 + d1 * d1 + d2 * d2
                u_d = (vel[j, 0] - vel[i, 0]) * d0 + (vel[j, 1] - vel[i, 1]) * d1
                if dim == 3:
                    u_d += (vel[j, 2] - vel[i, 2]) * d2
                w = visc * 0.5 * (alpha[i] + alpha[j]) * (-nvis * u_d / (r2 + eta2))  # eq. 3
                ip0 -= vi * gp0
                ip1 -= vi * gp1
                iv0 += w * g0
                iv1 += w * g1
                if dim == 3:
                    ip2 -= vi * gp2
                    iv2 += w * g2
            else:
                t = j - n_fluid
                grp = wall_group[t] if project else -1
                if grp >= 0:  # projected and gated as delta_sph.pair_terms
                    q0, q1, q2 = gp0, gp1, gp2
                    gp0 = gp1 = gp2 = 0.0
                    for e in range(2):
                        w_ = q0 * ext_dir[grp, e, 0] + q1 * ext_dir[grp, e, 1]
                        if dim == 3:
                            w_ += q2 * ext_dir[grp, e, 2]
                        w_ *= ext_keep[grp, e]
                        gp0 += w_ * ext_dir[grp, e, 0]
                        gp1 += w_ * ext_dir[grp, e, 1]
                        if dim == 3:
                            gp2 += w_ * ext_dir[grp, e, 2]
                wall[t, 0] += vi * gp0
                wall[t, 1] += vi * gp1
                if dim == 3:
                    wall[t, 2] += vi * gp2
    internal[:] = 0.0
    internal[0, 0] = ip0
    internal[0, 1] = ip1
    internal[1, 0] = iv0
    internal[1, 1] = iv1
    if dim == 3:
        internal[0, 2] = ip2
        internal[1, 2] = iv2


@njit(cache=True)
def body_force(pos, n_fluid, mass, gravity, omega2, center, out):
    """out = sum_i m (g - Omega^2 (r_i - c)) over the fluid, N (N/m in 2D) (seed eq. 13)."""
    dim = pos.shape[1]
    for a in range(dim):
        out[a] = 0.0
    for i in range(n_fluid):
        for a in range(dim):
            out[a] += mass * (gravity[a] - omega2 * (pos[i, a] - center[a]))


@njit(cache=True)
def fluid_momentum(vel, n_fluid, mass, out):
    """out = m sum_i u_i over the fluid rows, N s (N s/m in 2D), in index order."""
    dim = vel.shape[1]
    for a in range(dim):
        out[a] = 0.0
    for i in range(n_fluid):
        for a in range(dim):
            out[a] += vel[i, a]
    for a in range(dim):
        out[a] *= mass
    return out


# ledger rows, impulses since the last take() (N s; N s/m in 2D); then two rows per patch
START = 0  # fluid momentum at the start of the period
BODY = 1  # gravity and the central field
PRESSURE_INTERNAL = 2  # fluid-fluid pressure pairs (round-off)
VISCOUS_INTERNAL = 3  # fluid-fluid artificial-viscosity pairs (round-off)
PATCH_ROWS = 4  # per patch: pressure exchange (on the patch), reported
PER_PATCH = 2


class SPHMomentumBudget:
    """The δ-SPH momentum ledger. ``split`` (body, internal pressure, internal viscous) and
    ``wall_force`` hold the last right-hand side's split (state: the leapfrog's first kick reuses
    it); ``ledger`` accumulates between :meth:`take` calls (state). Exchanged and reported
    quantities are impulses on the patch; ``reported`` is what the run reports: the pressure
    integral (``DeltaSPHSolver.boundary_force``) at each step's end for a wall patch, the
    step-mean reaction (``reaction_step``) for a patch an external participant drives."""

    full = True

    def __init__(self, names: list[str], starts, stops, external: list[bool], dim: int,
                 n_wall: int, mass: float, model: str, sponge: bool = False) -> None:  # fmt: skip
        self.names = list(names)
        self.model = model
        self.dim = dim
        self.mass = mass
        self.starts = np.asarray(starts, dtype=np.int64)
        self.stops = np.asarray(stops, dtype=np.int64)
        self.external = np.asarray(external, dtype=bool)
        self.split = np.zeros((3, dim))
        self.wall_force = np.zeros((n_wall, dim))
        self._internal = np.zeros((2, dim))
        self._patch = np.zeros((len(names), dim))
        self._mom = np.zeros(dim)
        #: fluid.sph.damping = "sponge": one more ledger row (the last), the sponge's impulse
        #: m sum (u_after - u_before) (as MPS's ``sponge``); without it the layout is unchanged
        self.sponge = sponge
        self._before = np.zeros(dim)
        self._end = PATCH_ROWS + PER_PATCH * len(names)  # past the patches' rows
        self.ledger = np.zeros((self._end + (1 if sponge else 0), dim))

    def evaluate(self, s, nb) -> None:
        """Split the right-hand side just computed by the solver ``s`` on the list ``nb``."""
        split_forces(s.pos, s.vel, s.rho, s.vol, s.p, nb.indptr, s.row_end, s.pair_j, s.fv_pair,
                     s.n_fluid, s.h, s.rho0, s.c0, s.mass, s.corrected, s.M, s.pM, s.alpha,
                     self._internal, self.wall_force, s.project_load, s.wall_group, s.ext_dir,
                     s.ext_keep, s.wall_wet if s.wetted_walls else None)  # fmt: skip
        body_force(s.pos, s.n_fluid, s.mass, s.gravity, s.omega2, s.center, self.split[0])
        self.split[1:] = self._internal

    def book(self, weight: float) -> None:
        """Add ``weight`` (s) times the last split to the ledger (the integrator's weight of that
        right-hand side in the velocity update)."""
        led = self.ledger
        led[BODY] += weight * self.split[0]
        led[PRESSURE_INTERNAL] += weight * self.split[1]
        led[VISCOUS_INTERNAL] += weight * self.split[2]
        range_sums(self.wall_force, self.starts, self.stops, self._patch)
        led[PATCH_ROWS : self._end : PER_PATCH] += weight * self._patch

    def sponge_begin(self, vel: np.ndarray, n_fluid: int) -> None:
        """The fluid momentum just before the sponge damps ``vel`` (m/s)."""
        self._before[:] = fluid_momentum(vel, n_fluid, self.mass, self._mom)

    def sponge_end(self, vel: np.ndarray, n_fluid: int) -> None:
        """Book the sponge's impulse m sum (u_after - u_before), N s (N s/m in 2D)."""
        self.ledger[-1] += fluid_momentum(vel, n_fluid, self.mass, self._mom) - self._before

    def report(self, dt: float, forces: np.ndarray) -> None:
        """Book the step's reported impulse: ``forces`` per patch, N (N/m in 2D), over ``dt``."""
        self.ledger[PATCH_ROWS + 1 : self._end : PER_PATCH] += dt * forces

    def start(self, vel: np.ndarray, n_fluid: int) -> None:
        """Start the first period at the fluid state ``vel``."""
        self.ledger[:] = 0.0
        self.ledger[START] = fluid_momentum(vel, n_fluid, self.mass, self._mom)

    def take(self, vel: np.ndarray, kind: np.ndarray) -> dict[str, np.ndarray]:
        """The period's budget in MPS's keys (``fluid_mps.momentum_budget.MomentumBudget.take``),
        impulses N s (N s/m in 2D), and start a new period. ``gravity`` holds all body forces
        (gravity and the central field); ``sponge``, ``collision``, ``internal_collision`` and
        the patches' ``viscous`` and ``collision`` are zero (the viscosity damping zones are
        artificial viscosity, internal; wall pairs are free slip; no collision model); with
        ``fluid.sph.damping = "sponge"`` the ``sponge`` row is the sponge's impulse."""
        led = self.ledger
        n_fluid = int(np.count_nonzero(kind == 0))
        now = fluid_momentum(vel, n_fluid, self.mass, self._mom).copy()
        rows = led[PATCH_ROWS : self._end].reshape(len(self.names), PER_PATCH, self.dim)
        sponge = led[-1].copy() if self.sponge else np.zeros(self.dim)
        zero = np.zeros(self.dim)
        exchange = rows[:, 0].sum(axis=0)
        reported = rows[:, 1].sum(axis=0)
        out = {
            "fluid_momentum": now,
            "momentum_change": now - led[START],
            "gravity": led[BODY].copy(),
            "sponge": sponge,
            "viscous": led[VISCOUS_INTERNAL].copy(),
            "collision": zero.copy(),
            "pressure": led[PRESSURE_INTERNAL] - exchange,
            "internal_pressure": led[PRESSURE_INTERNAL].copy(),
            "internal_viscous": led[VISCOUS_INTERNAL].copy(),
            "internal_collision": zero.copy(),
        }
        explained = out["gravity"] + out["internal_pressure"] + out["internal_viscous"] + sponge
        out["residual"] = out["momentum_change"] - explained + reported
        out["residual_external"] = out["momentum_change"] - out["gravity"] - sponge + reported
        for k, name in enumerate(self.names):
            out[f"{name}/pressure"] = rows[k, 0].copy()
            out[f"{name}/viscous"] = zero.copy()
            out[f"{name}/collision"] = zero.copy()
            out[f"{name}/exchange"] = rows[k, 0].copy()
            out[f"{name}/reported"] = rows[k, 1].copy()
        led[:] = 0.0
        led[START] = now
        return out
