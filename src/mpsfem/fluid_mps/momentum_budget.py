"""The fluid's momentum budget, and the forces boundaries receive as momentum exchange.

Every velocity change of a fluid particle in the MPS step (solver.py) is one of:

- gravity, m g dt per particle;
- the sponge's damping (thesis eq. 3-9), m (u_after - u_before);
- viscosity, m nu dt <lap u>_i = m nu dt coef sum_j w_ij (u_j - u_i) (thesis eq. 2-16);
- the collision model, m du_i = -m sum_j c_ij (1 + e) a_ij e_ij (collision.py);
- the pressure gradient, -m dt / rho <grad p>_i = -m dt / rho L_i sum_j a_ij r_ij w_ij / r_ij^2
  (thesis eqs. 2-11, 2-12, 2-27; L_i = d / n0 or the inverse moment matrix C_i^-1).

The last three are sums over neighbour pairs. A pair of two fluid particles is internal: the
viscous and collision pairs cancel exactly (antisymmetric), a pressure pair cancels only for an
antisymmetric gradient (``tanaka``); what they leave is the *internal imbalance*. A pair of a
fluid particle i and a boundary particle j (wall, structure, their dummies) is momentum that
the fluid takes from that boundary: its negative is the force (impulse) the boundary receives,
the *momentum exchange*. This module splits each pair sum into those parts with the same
arithmetic as the step (numba, sequential where it scatters onto boundary particles, so the
sums are in a fixed order and bit-identical for any thread count).

A dummy particle has no force of its own: what it exchanges is booked on the pressure-layer
particle it takes its pressure and dry state from (``dummy_pressure.dummy_sources``), so a
structure's interface points hold all that reaches the member.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange

from mpsfem.fluid_mps.collision import approach_speed, ramp_weight
from mpsfem.fluid_mps.kernels import weight
from mpsfem.fluid_mps.operators import (
    corrected_vector,
    gradient_kernel,
    gradient_pair,
    pair_pressure,
    row_reference_pressure,
)


@njit(cache=True)
def fluid_momentum(vel, kind, mass, out):
    """out = m sum_i u_i over FLUID particles, N s (N s/m in 2D), summed in index order."""
    dim = vel.shape[1]
    for a in range(dim):
        out[a] = 0.0
    for i in range(vel.shape[0]):
        if kind[i] != 0:
            continue
        for a in range(dim):
            out[a] += vel[i, a]
    for a in range(dim):
        out[a] *= mass
    return out


def booking_targets(kind: np.ndarray, dummy_src: np.ndarray) -> np.ndarray:
    """Per particle, the particle its exchanged momentum is booked on (int32): itself for fluid
    and pressure-layer particles, the source pressure particle for a dummy (itself where it has
    none)."""
    target = np.arange(len(kind), dtype=np.int32)
    has = dummy_src >= 0
    target[has] = dummy_src[has]
    return target


@njit(cache=True, parallel=True)
def touches_boundary(kind, indptr, indices, out):
    """out[i] = 1 for a FLUID particle with a non-fluid particle in its neighbour row, else 0
    (a superset of the particles the scatter kernels below need to visit)."""
    for i in prange(kind.shape[0]):
        out[i] = 0
        if kind[i] != 0:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            if kind[np.uint32(indices[k])] != 0:
                out[i] = 1
                break


@njit(cache=True)
def pressure_exchange(
    pos,
    p,
    kind,
    indptr,
    indices,
    re,
    wcode,
    n0,
    form,
    skip_dummy,
    ghost,
    dry,
    rho,
    gravity,
    wall_acc,
    acc_offset,
    visit,
    target,
    offset,
    scale,
    out,
):
    """out[target[j] - offset] += scale L_i a_ij r_ij w_ij / r_ij^2 for every pair of a FLUID
    particle i (with ``visit[i]``) and a boundary neighbour j of its gradient row (arguments as
    ``operators.gradient_kernel``, pairs by ``operators.gradient_pair``): with scale = m / rho
    (m^3; m^2 in 2D) this is the force of the fluid on j, N (N/m in 2D), the reaction to the
    pair's share of -m / rho <grad p>_i. Sequential in index order (bit-identical for any
    thread count); ``out`` is not cleared."""
    n, dim = pos.shape
    c = dim / n0
    re2 = re * re
    corrected = form == 2 or form == 3
    for i in range(n):
        if not visit[i]:
            continue
        pref = row_reference_pressure(
            i, pos, p, kind, indptr, indices, re2, form, skip_dummy, ghost
        )
        m00 = m01 = m02 = m11 = m12 = m22 = 0.0
        if corrected:  # C_i over the whole row, as the gradient has it
            for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
                ok, _, w, x0, x1, x2 = gradient_pair(
                    i, np.uint32(indices[k]), pos, p, kind, re, re2, wcode, skip_dummy, ghost,
                    dry, rho, gravity, wall_acc, acc_offset,
                )  # fmt: skip
                if not ok:
                    continue
                m00 += w * x0 * x0
                m01 += w * x0 * x1
                m02 += w * x0 * x2
                m11 += w * x1 * x1
                m12 += w * x1 * x2
                m22 += w * x2 * x2
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if kind[j] == 0:
                continue
            ok, pj, w, x0, x1, x2 = gradient_pair(
                i, j, pos, p, kind, re, re2, wcode, skip_dummy, ghost, dry, rho, gravity,
                wall_acc, acc_offset,
            )  # fmt: skip
            if not ok:
                continue
            a = pair_pressure(form, pj, p[i], pref, pref) * w  # a boundary j takes p_min,i
            x0 *= a
            x1 *= a
            x2 *= a
            if corrected:
                x0, x1, x2 = corrected_vector(m00, m01, m02, m11, m12, m22, x0, x1, x2, dim, c)
            else:
                x0 *= c
                x1 *= c
                x2 *= c
            t = target[j] - offset
            out[t, 0] += scale * x0
            out[t, 1] += scale * x1
            if dim == 3:
                out[t, 2] += scale * x2


@njit(cache=True)
def viscous_exchange(pos, vel, kind, indptr, indices, re, wcode, visit, target, offset, scale, out):
    """out[target[j] - offset] -= scale w_ij (u_j - u_i) for every pair of a FLUID particle i (with
    ``visit[i]``) and a boundary neighbour j within ``re``: with scale = m nu coef the force of
    the fluid on j, N (N/m in 2D), the reaction to the pair's share of m nu <lap u>_i (thesis eq.
    2-16). Sequential; ``out`` is not cleared here."""
    n, dim = pos.shape
    re2 = re * re
    for i in range(n):
        if not visit[i]:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if kind[j] == 0:
                continue
            r2 = 0.0
            for d in range(dim):
                dx = pos[j, d] - pos[i, d]
                r2 += dx * dx
            if r2 >= re2:
                continue
            w = weight(np.sqrt(r2), re, wcode)
            t = target[j] - offset
            for d in range(dim):
                out[t, d] -= scale * w * (vel[j, d] - vel[i, d])


@njit(cache=True)
def collision_exchange(pos, vel, kind, indptr, indices, distance, restitution, visit, target,
                       offset, mass, out, ramp=0.0):  # fmt: skip
    """out[target[j] - offset] += m (1 + e) w a_ij e_ij for every colliding pair of a FLUID particle i (with
    ``visit[i]``) and a boundary particle j (collision.py: closer than ``distance``,
    approaching, a_ij = (u_i - u_j) . e_ij > 0; w the ramp's share, 1 without one): the impulse
    the boundary receives, N s (N s/m in 2D), the reaction to the fluid particle's velocity
    change. ``pos`` and ``vel`` as the collision model saw them. Sequential; ``out`` is not
    cleared here."""
    n, dim = pos.shape
    d2max = distance * distance
    for i in range(n):
        if not visit[i]:
            continue
        for k in range(np.uint64(indptr[i]), np.uint64(indptr[i + 1])):
            j = np.uint32(indices[k])
            if kind[j] == 0:
                continue
            a, r = approach_speed(i, j, pos, vel, d2max)
            if a <= 0.0:
                continue
            f = mass * (1.0 + restitution) * a / r * ramp_weight(r, distance, ramp)
            t = target[j] - offset
            for d in range(dim):
                out[t, d] += f * (pos[j, d] - pos[i, d])


@njit(cache=True)
def range_sums(values, starts, stops, out):
    """out[k] = sum of values[starts[k]:stops[k]] in index order (per-patch totals)."""
    dim = values.shape[1]
    for k in range(starts.shape[0]):
        for d in range(dim):
            out[k, d] = 0.0
        for i in range(starts[k], stops[k]):
            for d in range(dim):
                out[k, d] += values[i, d]


@njit(cache=True)
def column_sum(values, kind, out):
    """out = sum over FLUID rows of values (N, dim), in index order."""
    dim = values.shape[1]
    for d in range(dim):
        out[d] = 0.0
    for i in range(values.shape[0]):
        if kind[i] != 0:
            continue
        for d in range(dim):
            out[d] += values[i, d]


# rows of the ledger (MomentumBudget.ledger): totals over the steps since the last take(), N s
# (N s/m in 2D), one column per axis; then four rows per boundary patch
START = 0  # fluid momentum at the start of the period
GRAVITY = 1  # m g dt, every fluid particle
SPONGE = 2  # the damping zones' velocity change
VISCOUS = 3  # the viscous term's velocity change, internal and boundary pairs
COLLISION = 4  # the collision model's velocity change
PRESSURE = 5  # the pressure gradient's velocity change
PRESSURE_INTERNAL = 6  # its share from fluid-fluid pairs (zero for an antisymmetric gradient)
PATCH_ROWS = 7  # first patch row; per patch: pressure, viscous, collision exchange, reported
PER_PATCH = 4


class MomentumBudget:
    """The momentum ledger of one fluid: what each stage of the step changed, what each boundary
    patch exchanged with the fluid, and the per-particle exchange force of the last step.

    Exchanged quantities are impulses *on the boundary* (the fluid receives their negative).
    ``reported`` is the impulse the run reports on the patch (force probes, coupling), by
    ``fluid.boundary_force``: ``"momentum_exchange"``, the exchange itself;
    ``"pressure_and_contact"``, the pressure integral (thesis eq. 2-51) at the end of each step
    plus the viscous and collision exchange (the pair interactions other than pressure);
    ``"pressure_integral"``, eq. 2-51 alone.

    ``ledger`` (rows above) accumulates from one :meth:`take` to the next and is state (a coupled
    run's implicit iterations restore it with the particles); ``viscous_force`` is the boundary
    share of the Laplacian the next step applies, state too.
    """

    def __init__(
        self,
        kind: np.ndarray,
        dummy_src: np.ndarray,
        n_fluid: int,
        patches: list[tuple[str, int, int]],
        dim: int,
        mass: float,
        rho: float,
        nu: float,
        gravity: np.ndarray,
        full: bool,
        model: str = "pressure_integral",
    ) -> None:
        """``patches``: (name, start, stop) index ranges, boundary particles only (fluid first);
        ``full``: keep the whole ledger (else only the forces the scene needs); ``model``: the
        reported boundary force, ``fluid.boundary_force``."""
        n = len(kind)
        self.offset = n_fluid
        nb = n - n_fluid
        self.dim = dim
        self.mass = mass
        self.rho = rho
        self.nu = nu
        self.gravity = np.asarray(gravity, dtype=np.float64)
        self.full = full
        self.model = model
        #: the pair scatters this scene needs: the pressure exchange for the full ledger or the
        #: exchange model, the viscous and collision exchange for any model but the pure
        #: pressure integral
        self.needs_pressure_pairs = full or model == "momentum_exchange"
        self.needs_contact_pairs = full or model != "pressure_integral"
        self.n_fluid_particles = int(np.count_nonzero(kind == 0))
        self.names = [name for name, _, _ in patches]
        self.starts = np.array([s - n_fluid for _, s, _ in patches], dtype=np.int64)
        self.stops = np.array([e - n_fluid for _, _, e in patches], dtype=np.int64)
        self.target = booking_targets(kind, dummy_src)
        self.visit = np.zeros(n, dtype=np.int8)
        #: this step's pressure exchange force per boundary particle (N; N/m in 2D)
        self.pressure_force = np.zeros((nb, dim))
        #: this step's collision impulse per boundary particle (N s; N s/m in 2D)
        self.collision_impulse = np.zeros((nb, dim))
        #: viscous exchange force of the Laplacian the next step applies (state)
        self.viscous_force = np.zeros((nb, dim))
        #: the last step's total exchange force per boundary particle, N (N/m in 2D)
        self.exchange_force = np.zeros((nb, dim))
        #: its viscous and collision share (pair interactions other than pressure)
        self.contact_force = np.zeros((nb, dim))
        self._collision_force = np.zeros((nb, dim))  # work: the collision impulse / dt
        self._reported = np.zeros((len(patches), dim))
        self.ledger = np.zeros((PATCH_ROWS + PER_PATCH * len(patches), dim))
        #: exchange impulse each patch received since t = 0, N s (N s/m in 2D) (state)
        self.patch_impulse = np.zeros((len(patches), dim))
        self._mom = np.zeros(dim)
        self._mark = np.zeros(dim)
        self._vec = np.zeros(dim)
        self._patch = np.zeros((len(patches), dim))
        self._collided = False
        self.reset(None)

    # ---------------------------------------------------------------- stages of a step
    def momentum(self, vel: np.ndarray, kind: np.ndarray) -> np.ndarray:
        """The fluid's momentum now (a work vector, valid until the next call)."""
        return fluid_momentum(vel, kind, self.mass, self._mom)

    def begin(self, vel: np.ndarray, kind: np.ndarray) -> None:
        """Start of a step: the stage differences are taken from here."""
        self.collision_impulse[:] = 0.0
        self._collided = False
        if self.full:
            self._mark[:] = self.momentum(vel, kind)

    def stage(self, row: int, vel: np.ndarray, kind: np.ndarray) -> None:
        """Book the fluid's momentum change since the previous stage on ``row`` (the
        prediction's change on VISCOUS: finish() moves the weight's share to GRAVITY)."""
        if self.full:
            now = self.momentum(vel, kind)
            self.ledger[row] += now - self._mark
            self._mark[:] = now

    def collision(
        self, pos, vel_before, kind, nb, distance: float, restitution: float, ramp: float = 0.0
    ) -> None:
        """The collision model's impulse on each boundary particle (``pos``, ``vel_before``: as
        the model saw them; ``nb`` the list it read; ``ramp`` its fade-out share)."""
        if not self.needs_contact_pairs:
            return
        touches_boundary(kind, nb.indptr, nb.indices, self.visit)
        collision_exchange(pos, vel_before, kind, nb.indptr, nb.indices, distance, restitution,
                           self.visit, self.target, self.offset, self.mass,
                           self.collision_impulse, ramp)  # fmt: skip
        self._collided = True

    def pressure(self, args: tuple, nb, scratch: np.ndarray, kind: np.ndarray) -> None:
        """The pressure gradient's exchange force on each boundary particle, and (full ledger)
        its internal share. ``args``: (pos, p, kind) and the gradient's arguments after the
        list, as ``operators.gradient_kernel`` takes them: (re, wcode, n0, form, skip_dummy,
        ghost, dry, rho, gravity, pref_all, wall_acc, acc_offset), ``pref_all`` as the step's
        gradient left it (``cmps``: every fluid particle's p_min); ``scratch``: an (N, dim)
        work array."""
        if not self.needs_pressure_pairs:
            return
        pos, p, kd, re, wcode, n0, form, skip, ghost, dry, rho, g, pref_all, acc, off = args
        touches_boundary(kind, nb.indptr, nb.indices, self.visit)
        self.pressure_force[:] = 0.0
        pressure_exchange(pos, p, kd, nb.indptr, nb.indices, re, wcode, n0, form, skip, ghost,
                          dry, rho, g, acc, off, self.visit, self.target, self.offset,
                          self.mass / self.rho, self.pressure_force)  # fmt: skip
        if self.full:  # the fluid-fluid share of the gradient, summed: the internal imbalance
            gradient_kernel(pos, p, kd, nb.indptr, nb.indices, re, wcode, n0, form, skip, ghost,
                            dry, rho, g, pref_all, scratch, True, acc, off)  # fmt: skip
            column_sum(scratch, kind, self._vec)  # read by finish()

    def viscous(self, pos, vel, kind, nb, re: float, wcode: int, coef: float) -> None:
        """The viscous exchange force of the Laplacian just computed (for the next step)."""
        self.viscous_force[:] = 0.0
        if self.nu <= 0.0 or not self.needs_contact_pairs:
            return
        touches_boundary(kind, nb.indptr, nb.indices, self.visit)
        viscous_exchange(pos, vel, kind, nb.indptr, nb.indices, re, wcode, self.visit,
                         self.target, self.offset, self.mass * self.nu * coef,
                         self.viscous_force)  # fmt: skip

    def finish(self, dt: float, pressure_integrals: np.ndarray | None) -> None:
        """End of a step of ``dt`` (s): the step's exchange and contact forces, the reported
        force per patch, the ledger's patch rows. ``pressure_integrals``: per patch, the
        pressure integral of thesis eq. 2-51 (N; N/m in 2D), needed by the models that report
        it (``model``), else None."""
        contact = self.contact_force
        np.copyto(contact, self.viscous_force)
        if self._collided:
            np.divide(self.collision_impulse, dt, out=self._collision_force)
            contact += self._collision_force
        ex = self.exchange_force
        np.add(self.pressure_force, contact, out=ex)
        rep = self._reported
        if self.model == "momentum_exchange":
            range_sums(ex, self.starts, self.stops, rep)
        else:
            rep[:] = pressure_integrals
            if self.model == "pressure_and_contact":
                range_sums(contact, self.starts, self.stops, self._patch)
                rep += self._patch
        self.patch_impulse += dt * rep
        if not self.full:
            return
        led = self.ledger
        weight_impulse = self.n_fluid_particles * self.mass * dt * self.gravity
        led[GRAVITY] += weight_impulse
        led[VISCOUS] -= weight_impulse  # the prediction stage books both
        led[PRESSURE_INTERNAL] -= dt * self.mass / self.rho * self._vec
        for col, row, scale in (
            (self.pressure_force, 0, dt),
            (self.viscous_force, 1, dt),
            (self.collision_impulse, 2, 1.0),
        ):
            range_sums(col, self.starts, self.stops, self._patch)
            led[PATCH_ROWS + row :: PER_PATCH] += scale * self._patch
        led[PATCH_ROWS + 3 :: PER_PATCH] += dt * rep

    # ---------------------------------------------------------------- records
    def reset(self, vel_kind: tuple[np.ndarray, np.ndarray] | None) -> None:
        """Start a new period (after :meth:`take`); ``vel_kind``: the fluid state now."""
        self.ledger[:] = 0.0
        if vel_kind is not None:
            self.ledger[START] = self.momentum(*vel_kind)

    def take(self, vel: np.ndarray, kind: np.ndarray) -> dict[str, np.ndarray]:
        """The period's budget (impulses since the last take, N s; N s/m in 2D) and start a new
        period. Keys: ``fluid_momentum`` (now), ``momentum_change``, ``gravity``, ``sponge``,
        ``viscous``, ``collision``, ``pressure`` (each stage's total change), ``internal_pressure``,
        ``internal_viscous``, ``internal_collision`` (what fluid-fluid pairs left), ``residual``
        (the change not explained by gravity, the sponge, the internal imbalance and the
        *reported* boundary impulses), ``residual_external`` (the change not explained by
        gravity, the sponge and the reported boundary impulses alone: the check of the
        reported forces where the internal imbalance is the walls' doing), and per patch ``<name>/{pressure, viscous, collision,
        exchange, reported}`` (impulse on the patch)."""
        led = self.ledger
        now = self.momentum(vel, kind).copy()
        rows = led[PATCH_ROWS:].reshape(len(self.names), PER_PATCH, self.dim)
        ex = rows[:, 0] + rows[:, 1] + rows[:, 2]
        out = {
            "fluid_momentum": now,
            "momentum_change": now - led[START],
            "gravity": led[GRAVITY].copy(),
            "sponge": led[SPONGE].copy(),
            "viscous": led[VISCOUS].copy(),
            "collision": led[COLLISION].copy(),
            "pressure": led[PRESSURE].copy(),
            "internal_pressure": led[PRESSURE_INTERNAL].copy(),
            "internal_viscous": led[VISCOUS] + rows[:, 1].sum(axis=0),
            "internal_collision": led[COLLISION] + rows[:, 2].sum(axis=0),
        }
        explained = (
            out["gravity"]
            + out["sponge"]
            + out["internal_pressure"]
            + out["internal_viscous"]
            + out["internal_collision"]
            - rows[:, 3].sum(axis=0)
        )
        out["residual"] = out["momentum_change"] - explained
        out["residual_external"] = (
            out["momentum_change"] - out["gravity"] - out["sponge"] + rows[:, 3].sum(axis=0)
        )
        for k, name in enumerate(self.names):
            for c, label in enumerate(("pressure", "viscous", "collision")):
                out[f"{name}/{label}"] = rows[k, c].copy()
            out[f"{name}/exchange"] = ex[k].copy()
            out[f"{name}/reported"] = rows[k, 3].copy()
        led[:] = 0.0
        led[START] = now
        return out
