"""The semi-implicit MPS time step: state arrays sized once, stages assembled from the scenario.

One step (thesis ch. 2.1):

1. walls move to their prescribed position at t + dt;
2. explicit prediction u* = u + dt (nu lap u + g), r* = r + dt u* (lap u from the end of the
   previous step, item 8);
3. neighbour search at r* (the only one of the step); collision model (if on) on approaching
   fluid pairs;
4. particle number density n*, free-surface detection;
5. pressure Poisson equation with the mixed source term, solved by preconditioned CG;
6. negative-pressure clamp (if on); pressure gradient; correction of u and r; dynamic
   stabilisation of close fluid pairs and particle shifting (each if on;
   dynamic_stabilization.py, particle_shifting.py);
7. checks (non-finite values, escaped particles) and the next dt from the Courant number, the
   viscous limit and (if on) the antisymmetric gradients' pressure limit;
8. if nu > 0: lap u^{n+1} on this step's neighbour list (state, checkpointed), for the next
   step's prediction.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from mpsfem.fluid_mps import (
    dynamic_stabilization,
    operators,
    particle_shifting,
    probes,
    surface_pressure,
    time_integration,
    wall_boundary,
)
from mpsfem.fluid_mps.collision import collide
from mpsfem.fluid_mps.dummy_pressure import dummy_sources, extrapolate_dummy_pressure
from mpsfem.fluid_mps.geometry import (
    ExternalPatch,
    build_particles,
    compress_still_water,
    hydrostatic_pressure,
)
from mpsfem.fluid_mps.kernels import weight_code
from mpsfem.fluid_mps.lattice import lattice_constants, uniaxial_density_response
from mpsfem.fluid_mps.momentum_budget import (
    COLLISION,
    PRESSURE,
    SPONGE,
    VISCOUS,
    MomentumBudget,
)
from mpsfem.fluid_mps.neighbours import NeighbourSearch, build_neighbours
from mpsfem.fluid_mps.operators import NO_WALL_ACCELERATION
from mpsfem.fluid_mps.particle_kinds import dummy_mask
from mpsfem.fluid_mps.pressure_assembly import clamp_negative_except_at_structures
from mpsfem.fluid_mps.pressure_poisson import make_pressure_solver
from mpsfem.fluid_mps.sponge import SpongeLayer
from mpsfem.fluid_mps.surface import make_surface_detector
from mpsfem.fluid_mps.wall_motion import MotionLaw, place_moving_walls
from mpsfem.scenario.fluid import FluidSection


class FluidRunError(RuntimeError):
    """The fluid state went wrong (non-finite values, an escaped particle, dt collapse)."""


@dataclass
class StageTimes:
    """Accumulated wall time per stage, s (:meth:`FluidSolver.step` names each stage's
    counter): ``neighbours`` the searches and short lists (and the wall motion before them),
    ``explicit`` the prediction, collision, density, surface, correction and end-of-step work,
    ``assembly`` and ``solve`` the pressure solver's own split, ``other`` the pressure
    equation's boundary terms (dry flags, ghost source, surface values)."""

    neighbours: float = 0.0
    explicit: float = 0.0
    assembly: float = 0.0
    solve: float = 0.0
    other: float = 0.0
    iterations: list[int] = field(default_factory=list)

    def as_dict(self) -> dict[str, float]:
        return {
            "neighbours": self.neighbours,
            "explicit": self.explicit,
            "assembly": self.assembly,
            "solve": self.solve,
            "other": self.other,
        }

    @contextmanager
    def timed(self, name: str) -> Iterator[None]:
        """Add the wall time of the ``with`` block to the counter ``name`` (s)."""
        tic = time.perf_counter()
        try:
            yield
        finally:
            setattr(self, name, getattr(self, name) + time.perf_counter() - tic)


#: the largest particle shift of fluid.pressure.shifting, x l0
SHIFT_CAP = 0.1
#: the gravity argument of a gradient without ghosts (unread there)
_NO_GRAVITY = np.zeros(3)

#: how much wider than the small kernels' radius the search's short list is, in l0 (module
#: docstring of neighbours.py; _short_list)
SHORT_MARGIN = 0.1


class FluidSolver:
    """MPS fluid state and its time step. Units SI; arrays (N, dim) float64, kinds int8."""

    def __init__(
        self,
        spec: FluidSection,
        base_dir: Path | None = None,
        external: Sequence[ExternalPatch] = (),
        neighbour_filter: Callable | None = None,
    ) -> None:
        """``external``: boundary patches driven by another participant (structure surfaces,
        moved with :meth:`set_patch_state`); ``neighbour_filter(nb, pos, kind)``: called after
        every neighbour search, may drop pairs in place (e.g. across a thin member) and returns
        the list to use."""
        self.spec = spec
        self.dim = spec.dim
        l0 = spec.spacing
        self.l0 = l0
        self.rho = spec.density
        self.nu = spec.viscosity
        self.gravity = np.asarray(spec.gravity, dtype=np.float64)

        ps = build_particles(spec, external)
        self.neighbour_filter = neighbour_filter
        #: set by a coupled participant: freezes the surface/dry flags across the iterations of
        #: an implicit coupling window (``surface_freeze.SurfaceFreeze``)
        self.surface_freeze = None
        self.pos, self.vel, self.kind, self.normal = ps.pos, ps.vel, ps.kind, ps.normal
        self.n_fluid = ps.n_fluid
        self.contact_wet = ps.contact_wet  # polygon walls' pressure layers (wall_boundary.py)
        #: fluid.pressure.buried_walls = "ghost": buried boundary particles stay ghosts
        self.buried_wet = spec.pressure.buried_walls == "ghost"
        self.patches = ps.patches
        self._patch = {pt.name: pt for pt in self.patches}
        n = len(self.pos)
        self.n = n
        self.p = np.zeros(n)
        #: m: how far the compressed start lowered the deepest column's top (0 = off)
        self.compressed_drop = 0.0
        if spec.hydrostatic_start:
            strain_per_pa = 0.0  # the lattice's strain under p: kappa p / s
            if spec.pressure.compressed_start:
                strain_per_pa = spec.pressure.compressibility / uniaxial_density_response(
                    self.dim, l0, spec.kernel.re_density * l0, spec.kernel.weight
                )
            self.compressed_drop = compress_still_water(
                self.pos, self.kind, self.gravity, self.rho, l0, strain_per_pa
            )
            self.p[:] = hydrostatic_pressure(self.pos, self.kind, self.gravity, self.rho, l0)

        k = spec.kernel
        self.wcode = weight_code(k.weight)
        self.re_n = k.re_density * l0
        self.re_grad = k.re_gradient * l0
        self.re_lap = k.re_laplacian * l0
        self.re_ppe = k.re_pressure * l0
        self.n0_n, _ = lattice_constants(self.dim, l0, self.re_n, k.weight)
        self.n0_grad, _ = lattice_constants(self.dim, l0, self.re_grad, k.weight)
        n0_lap, lam_lap = lattice_constants(self.dim, l0, self.re_lap, k.weight)
        self.lap_coef = operators.laplacian_coefficient(self.dim, n0_lap, lam_lap)
        self.grad_form = operators.gradient_code(spec.pressure.gradient)
        #: every fluid particle's reference pressure, read by the ``cmps`` gradient (Pa)
        self.pref_all = np.zeros(len(ps.pos) if self.grad_form == operators.CMPS else 0)

        radii = [self.re_n, self.re_grad, self.re_ppe]
        if self.nu > 0.0:
            radii.append(self.re_lap)
        if spec.collision.enabled:
            radii.append(spec.collision.distance * l0)
        self.search_radius = max(radii)
        # the small-kernel operators (collision, number density, free surface, divergence,
        # pressure gradient, wall pressure) read a shorter list of their own where it pays: at
        # 2.1 against 4.01 l0 they scan 3.5x (2D) or 7.8x (3D) fewer pairs. The search writes
        # it with the shared list, short_margin wider, so that the collision model's shift
        # (after the search) cannot bring an unlisted pair within the operators' radius. A
        # neighbour filter drops pairs from the shared list after the search, so with one the
        # search writes no short list and each step filters the filtered list instead
        short = max(self.re_n, self.re_grad)
        self.short_radius = short if (self.search_radius / short) ** self.dim >= 2.0 else None
        self.short_margin = SHORT_MARGIN * l0 if spec.collision.enabled else 0.0
        if self.short_radius is not None:
            self.short_margin = min(self.short_margin, self.search_radius - short)
        #: steps that filtered the shared list anew for the short one (a collision shift over
        #: short_margin / 2, or a neighbour filter that dropped pairs)
        self.short_refilters = 0
        self.lower, self.upper = self._domain(spec)
        self._check_grid_size(spec)
        self.search = NeighbourSearch(
            self.dim,
            self.search_radius,
            domain=(self.lower, self.upper),
            escape="clip",
            skin=spec.neighbours.skin * l0,
            short_radius=0.0
            if self.short_radius is None or neighbour_filter is not None
            else self.short_radius + self.short_margin,
        )
        self.surface = make_surface_detector(
            spec.surface.detector,
            dim=self.dim,
            l0=l0,
            re=self.re_n,
            weight=k.weight,
            beta=spec.surface.beta,
            beta_low=spec.surface.beta_low,
            asymmetry=spec.surface.asymmetry,
        )
        self.pressure = make_pressure_solver(
            spec.pressure.solver,
            dim=self.dim,
            l0=l0,
            re=self.re_ppe,
            re_density=self.re_n,
            weight=k.weight,
            rho=self.rho,
            gamma=spec.pressure.gamma,
            tol=spec.pressure.tol,
            max_iter=spec.pressure.max_iter,
            rebuild_factor=spec.pressure.amg_rebuild_factor,
            compressibility=spec.pressure.compressibility,
            wall_model=spec.pressure.wall_model,
            source_term=spec.pressure.source_term,
            error_compensation=spec.pressure.error_compensation,
            laplacian=spec.pressure.laplacian,
            gravity=self.gravity,
            source_filter=spec.pressure.source_filter,
        )
        self.neumann = spec.pressure.wall_model == "neumann"
        # the structure particles' lowest pressure, Pa (fluid.pressure.structure_suction)
        self.structure_floor = (
            spec.pressure.suction_floor if spec.pressure.structure_suction else 0.0
        )
        n0_ppe, lam_ppe = lattice_constants(self.dim, l0, self.re_ppe, k.weight)
        self.ppe_coef = operators.laplacian_coefficient(self.dim, n0_ppe, lam_ppe)
        self.ghost_rhs = np.zeros(n)

        # work arrays, sized once
        self.number_density = np.zeros(n)
        self.free_surface = np.zeros(n, dtype=np.int8)
        self.lap_u = np.zeros((n, self.dim))
        self.grad_p = np.zeros((n, self.dim))
        if spec.hydrostatic_start:  # the previous-step gradient the surface values start from
            self.grad_p[self.kind == 0] = self.rho * self.gravity
        self.surface_offset = self.neumann and spec.surface.pressure == "half_spacing"
        self.p_surface = np.zeros(n)
        self.vel_before = np.zeros((n, self.dim))
        #: fluid.pressure.dynamic_stabilization: its distance (m, 0 = off) and work array
        self.ds_distance = spec.pressure.dynamic_stabilization * l0
        self.ds_work = np.zeros((n, self.dim)) if self.ds_distance > 0.0 else None
        self.shift_work = np.zeros((n, self.dim)) if spec.pressure.shifting > 0.0 else None
        #: fluid.pressure.pressure_courant: the decaying peak fluid pressure it reads (Pa)
        self.p_peak = 0.0

        # dummy particles need no neighbour rows of their own (neighbours.py): skipping them
        # saves three quarters of the search in a 3D tank
        self.neighbour_rows = np.where(dummy_mask(self.kind), 0, 1).astype(np.int8)
        self.dummy_src = dummy_sources(
            self.pos, self.kind, [(pt.start, pt.stop) for pt in self.patches]
        )
        g_abs = float(np.linalg.norm(self.gravity))
        # the patches with a spec are the scenario's walls, in scenario order (build_particles)
        self.motions = [
            MotionLaw(
                w.motion, base_dir, gravity=g_abs, dim=self.dim, key=f"fluid.walls[{i}].motion"
            )
            for i, w in enumerate(pt.spec for pt in self.patches if pt.spec is not None)
        ]
        self.sponge = SpongeLayer(spec.sponges, self.dim)
        self.exchange = spec.boundary_force == "momentum_exchange"
        self.budget = MomentumBudget(
            self.kind,
            self.dummy_src,
            self.n_fluid,
            [(pt.name, pt.start, pt.stop) for pt in self.patches],
            self.dim,
            self.mass,
            self.rho,
            self.nu,
            self.gravity,
            full=spec.momentum_budget,
            model=spec.boundary_force,
        )
        self.budget.reset((self.vel, self.kind))
        self._patch_starts = np.array([pt.start for pt in self.patches], dtype=np.int64)
        self._patch_stops = np.array([pt.stop for pt in self.patches], dtype=np.int64)
        self._integrals = np.zeros((len(self.patches), self.dim))
        #: per force probe, [time, impulse...] at its last sample (interval means, state)
        self.force_marks: dict[str, list[float]] = {}
        #: attached pressure probes' running impulses (:meth:`attach_pressure_ledger`; state)
        self.pressure_ledger: probes.AttachedPressureLedger | None = None
        #: fluid.pressure.wall_acceleration: each boundary particle's acceleration over the step
        #: (m/s^2) in its ghosts, from its velocity at the end of the previous step (state)
        self.wall_acceleration = spec.pressure.wall_acceleration
        nb_rows = n - self.n_fluid if self.wall_acceleration else 0
        self.wall_acc = np.zeros((nb_rows, self.dim))
        self.wall_vel_prev = self.vel[self.n_fluid :].copy() if nb_rows else self.wall_acc
        rigid = [pt for pt in self.patches if pt.spec is not None]
        self.moving = [(pt, m) for pt, m in zip(rigid, self.motions, strict=True) if m.moves]
        self.wall_origin = {pt.name: self.pos[pt.start : pt.stop].copy() for pt, _ in self.moving}

        self.t = 0.0
        self.step_count = 0
        ts = spec.time_step
        self.times = StageTimes()
        self.last_iterations = 0
        self._last_neighbours = None
        self._lap_u_ready = False  # lap_u holds the viscous Laplacian of the current state
        self._uf_parent: np.ndarray | None = None
        self._gauge_work: np.ndarray | None = None
        self._uf_size: np.ndarray | None = None
        # the first step obeys the Courant and viscous limits too (a block that starts moving)
        self.dt_next = min(ts.dt_initial or ts.dt_max, self.stable_dt())
        if self.exchange and neighbour_filter is None:  # a participant evaluates it once bound
            self.evaluate_exchange()

    # ------------------------------------------------------------------ set-up helpers
    #: neighbour-grid cells allowed per particle (8 B each in the cell index), plus a base
    MAX_CELLS_PER_PARTICLE = 64
    MAX_CELLS_BASE = 2**20

    def _check_grid_size(self, spec: FluidSection) -> None:
        """Refuse a domain whose neighbour grid would dwarf the particles (a 100 m box at 1 mm:
        2.5e9 cells, 20 GB) before anything is allocated for it."""
        cells = np.maximum(1.0, np.ceil((self.upper - self.lower) / self.search_radius))
        ncell = float(np.prod(cells))
        limit = self.MAX_CELLS_PER_PARTICLE * self.n + self.MAX_CELLS_BASE
        if ncell > limit:
            given = spec.domain_lower is not None or spec.domain_upper is not None
            where = (
                f"fluid.domain_lower .. fluid.domain_upper = {self.lower.tolist()} .. "
                f"{self.upper.tolist()}"
                if given
                else f"the default domain {self.lower.tolist()} .. {self.upper.tolist()} (the "
                "scene's bounding box grown by 10 l0, and 1 m upwards)"
            )
            raise ValueError(
                f"{where}: its neighbour grid of cells {self.search_radius:.3g} m wide would hold "
                f"{ncell:.3g} cells for {self.n} particles; allowed at most "
                f"{self.MAX_CELLS_PER_PARTICLE} per particle + {self.MAX_CELLS_BASE} ({limit}): "
                "give a domain closer to where the fluid can go (fluid.domain_lower, "
                "fluid.domain_upper)"
            )

    def _domain(self, spec: FluidSection) -> tuple[np.ndarray, np.ndarray]:
        if spec.domain_lower is not None and spec.domain_upper is not None:
            return (np.asarray(spec.domain_lower, float), np.asarray(spec.domain_upper, float))
        lo = self.pos.min(axis=0) - 10.0 * self.l0
        hi = self.pos.max(axis=0) + 10.0 * self.l0
        up = int(np.argmax(np.abs(self.gravity))) if np.any(self.gravity) else self.dim - 1
        hi[up] += 1.0
        if spec.domain_lower is not None:
            lo = np.asarray(spec.domain_lower, float)
        if spec.domain_upper is not None:
            hi = np.asarray(spec.domain_upper, float)
        return lo, hi

    @property
    def mass(self) -> float:
        """Mass of one particle, kg (kg/m in 2D)."""
        return self.rho * self.l0**self.dim

    # ------------------------------------------------------------------ time step
    def stable_dt(self) -> float:
        """Largest dt allowed by the Courant number, the viscous limit and, with
        ``fluid.pressure.pressure_courant`` = C, dt <= C l0 / sqrt(2 p_peak / rho) (the
        stiffness of Tanaka's p_i + p_j repulsion, docs/fluid.md), capped at dt_max (s)."""
        ts = self.spec.time_step
        umax = time_integration.max_speed(self.vel, self.kind)
        dt = ts.dt_max
        if umax > 0.0:
            dt = min(dt, ts.courant * self.l0 / umax)
        if self.nu > 0.0:
            dt = min(dt, ts.viscous_number * self.l0**2 / self.nu)
        c_p = self.spec.pressure.pressure_courant
        if c_p > 0.0:  # the repulsion p_i + p_j as a spring: omega ~ sqrt(2 p / rho) / l0
            p_max = float(self.p[: self.n_fluid].max()) if self.n_fluid else 0.0
            # a decaying peak (half in ~10 steps): one step whose pressures collapse (many
            # surface flags) must not hand the next step a dt far beyond the stiffness limit
            self.p_peak = max(p_max, 0.93 * self.p_peak)
            if self.p_peak > 0.0:
                dt = min(dt, c_p * self.l0 / math.sqrt(2.0 * self.p_peak / self.rho))
        return dt

    def move_walls(self, t: float) -> None:
        """Put the moving wall patches at their prescribed position and velocity for time t."""
        place_moving_walls(self.moving, self.wall_origin, t, self.pos, self.vel)

    def set_patch_state(self, name: str, pos: np.ndarray, vel: np.ndarray) -> None:
        """Position (m) and velocity (m/s) of an external patch's particles at the end of the next
        step (the driving participant calls this before :meth:`step`)."""
        pt = self._patch[name]
        self.pos[pt.start : pt.stop] = pos
        self.vel[pt.start : pt.stop] = vel

    def patch(self, name: str):
        """The index range of the patch ``name`` (a WallPatch)."""
        return self._patch[name]

    def _neighbours(self):
        nb = self.search.update(self.pos, rows=self.neighbour_rows)
        if self.neighbour_filter is not None:
            nb = self.neighbour_filter(nb, self.pos, self.kind)
        return nb

    def _collision_list(self, nb, distance: float):
        """The search's short list where it holds every pair of ``nb`` closer than ``distance``
        (m) at the search's positions, else ``nb``. The collision model skips farther pairs:
        the same result on either list."""
        short = self.search.short
        return short if short is not None and distance <= short.radius else nb

    def _short_list(self, nb, moved: float):
        """A list holding every pair of ``nb`` within ``short_radius`` at the current positions
        (``nb`` itself where no short list pays); ``moved``: the largest displacement since the
        search, m. The small-kernel operators skip pairs beyond their radius, so they give the
        same result on either list, bit for bit.

        The search's short list (``short_radius + short_margin`` at the search's positions) holds
        them while no particle has moved more than half the margin; otherwise, or where the
        search writes none (a neighbour filter), ``nb`` is filtered anew."""
        if self.short_radius is None:
            return nb
        short = self.search.short
        if short is not None and 2.0 * moved <= self.short_margin * (1 - 1e-9):
            return short
        self.short_refilters += 1
        return self.search.within(self.pos, self.short_radius, nb)

    def _viscous_laplacian(self, nb) -> None:
        """lap_u = Laplacian of the velocity (thesis eq. 2-16, re_lap) at the current positions.

        The pair list may be the one built at this step's r* (the end-of-step call): the
        distances are recomputed from the current positions, and a pair missing from it is one
        that has come within re_lap during the pressure correction (a displacement of
        dt^2 |grad p| / rho, a few hundredths of l0), where the kernel weight is ~0.85 delta / re.
        This saves the second neighbour search of every viscous step.
        """
        operators.laplacian(
            self.pos,
            self.vel,
            self.kind,
            nb.indptr,
            nb.indices,
            self.re_lap,
            self.wcode,
            self.lap_coef,
            self.lap_u,
        )
        self.budget.viscous(
            self.pos, self.vel, self.kind, nb, self.re_lap, self.wcode, self.lap_coef
        )
        self._lap_u_ready = True

    def _ensure_lap_u(self) -> None:
        """Compute lap_u at the current state where no step has left it (the first step, a
        checkpoint without it); after bind-time set-up such as neighbour filters."""
        if self.nu > 0.0 and not self._lap_u_ready:
            self._viscous_laplacian(self._neighbours())

    def step(self, dt: float) -> None:
        """Advance the fluid by dt (s): the stages of the module docstring, in order, each timed
        on the :class:`StageTimes` counter named beside it."""
        self._refuse_dt(dt)
        tm = self.times
        with tm.timed("neighbours"):  # (counted here since the first benchmarks)
            self._stage_walls(dt)
        with tm.timed("explicit"):
            self._stage_prediction(dt)
        with tm.timed("neighbours"):
            nb = self._stage_search()
        with tm.timed("explicit"):
            moved = self._stage_collision(nb, dt)
        with tm.timed("neighbours"):
            near = self._short_list(nb, moved)
        with tm.timed("explicit"):
            self._stage_density_and_surface(near)
        with tm.timed("other"):
            self._stage_pressure_boundary(nb, near, dt)
        self._stage_pressure_solve(nb, near, dt)  # books its own assembly and solve times
        with tm.timed("explicit"):
            self._stage_correction(nb, near, dt)
        with tm.timed("explicit"):
            self._stage_close(nb, dt)

    # ------------------------------------------------------------------ stages of a step
    def _refuse_dt(self, dt: float) -> None:
        """Stop a run whose step has fallen below fluid.time_step.dt_min (s)."""
        if not dt >= self.spec.time_step.dt_min:
            raise FluidRunError(
                f"time step {dt:.3e} s at t = {self.t:.6g} s is below fluid.time_step.dt_min = "
                f"{self.spec.time_step.dt_min:.3e} s (the flow has become too fast; check the "
                "scenario or lower the Courant number)"
            )

    def _stage_walls(self, dt: float) -> None:
        """1. Walls to their position at t + dt; their acceleration over the step (if read);
        lap u of the start state on the first step (a neighbour search)."""
        self.move_walls(self.t + dt)
        if self.wall_acceleration:  # over the step: the walls' new velocity against the last
            np.subtract(self.vel[self.n_fluid :], self.wall_vel_prev, out=self.wall_acc)
            self.wall_acc /= dt
        if self.nu > 0.0:
            self._ensure_lap_u()  # the first step only: later steps leave it at their end

    def _stage_prediction(self, dt: float) -> None:
        """2. Sponge (if any) and the explicit prediction u*, r* (gravity, viscosity)."""
        budget = self.budget
        budget.begin(self.vel, self.kind)
        if self.sponge.active:  # thesis eq. 3-9, explicit with u^n
            self.sponge.apply(self.pos, self.vel, self.n_fluid, dt)
            budget.stage(SPONGE, self.vel, self.kind)
        if self.nu > 0.0:
            time_integration.predict(
                self.pos, self.vel, self.kind, self.lap_u, self.nu, self.gravity, dt
            )
        else:
            time_integration.predict_inviscid(self.pos, self.vel, self.kind, self.gravity, dt)
        budget.stage(VISCOUS, self.vel, self.kind)

    def _stage_search(self):
        """3. The step's neighbour search at r* (filtered where a filter is set)."""
        nb = self._neighbours()
        self._last_neighbours = nb
        return nb

    def _stage_collision(self, nb, dt: float) -> float:
        """3. The collision model on approaching fluid pairs (if on); returns the largest shift
        it made, m (0 when off)."""
        col = self.spec.collision
        moved = 0.0
        if col.enabled:
            budget = self.budget
            self.vel_before[:] = self.vel
            pairs = self._collision_list(nb, col.distance * self.l0)
            dv = collide(
                self.pos,
                self.vel,
                self.kind,
                pairs.indptr,
                pairs.indices,
                col.distance * self.l0,
                col.restitution,
                ramp=col.ramp,
            )
            budget.collision(
                self.pos, self.vel_before, self.kind, pairs, col.distance * self.l0,
                col.restitution, col.ramp,
            )  # fmt: skip
            budget.stage(COLLISION, self.vel, self.kind)
            time_integration.shift_by_velocity_change(
                self.pos, self.vel, self.vel_before, self.kind, dt
            )
            moved = dt * time_integration.max_speed(dv, self.kind)  # the largest shift, m
        return moved

    def _stage_density_and_surface(self, near) -> None:
        """4. Particle number density n* and the free-surface flags."""
        operators.number_density(
            self.pos, near.indptr, near.indices, self.re_n, self.wcode, self.number_density
        )
        self.surface.detect(self.pos, self.kind, self.number_density, near, self.free_surface)

    def _stage_pressure_boundary(self, nb, near, dt: float) -> None:
        """5. The pressure equation's boundary terms: dry flags and ghost source (Neumann
        walls), frozen flags (implicit coupling), surface values half a spacing out."""
        if self.neumann:
            wall_boundary.mark_dry(
                self.pos,
                self.kind,
                self.free_surface,
                self.dummy_src,
                near.indptr,
                near.indices,
                self.re_n,
                self.contact_wet,
                self.buried_wet,
            )
        if self.surface_freeze is not None:  # implicit coupling: one set of flags per window
            self.surface_freeze.apply(self.free_surface)
        if self.neumann:
            wall_boundary.ghost_rhs(
                self.pos,
                self.vel,
                self.kind,
                self.free_surface,
                nb.indptr,
                nb.indices,
                self.re_ppe,
                self.wcode,
                self.ppe_coef,
                self.re_n,
                self.n0_n,
                self.spec.pressure.gamma,
                self.rho,
                dt,
                self.gravity,
                self.wall_acc,
                self.n_fluid,
                self.ghost_rhs,
            )
        if self.surface_offset:  # p = 0 half a spacing beyond the surface particles
            surface_pressure.surface_values(
                self.kind, self.free_surface, self.grad_p, self.l0, self.p_surface
            )
            surface_pressure.add_dirichlet_rhs(
                self.pos,
                self.kind,
                self.free_surface,
                self.p_surface,
                nb.indptr,
                nb.indices,
                self.re_ppe,
                self.wcode,
                self.ppe_coef,
                self.ghost_rhs,
            )

    def _stage_pressure_solve(self, nb, near, dt: float) -> None:
        """5. The pressure Poisson equation; books the solver's assembly and solve times and
        its iterations."""
        info = self.pressure.solve(
            self.pos,
            self.vel,
            self.kind,
            self.number_density,
            self.free_surface,
            nb,
            dt,
            self.p,
            self.ghost_rhs if self.neumann else None,
            density_nb=near,
            surface_values=self.p_surface if self.surface_offset else None,
        )
        tm = self.times
        tm.assembly += info.assembly_time
        tm.solve += info.solve_time
        tm.iterations.append(info.iterations)
        self.last_iterations = info.iterations

    def _stage_correction(self, nb, near, dt: float) -> None:
        """6. Surface values and clamp, the pressure gradient (and wall pressures), the
        correction of u and r, dynamic stabilisation and shifting (each if on)."""
        budget = self.budget
        if self.surface_offset:
            surface_pressure.write_surface_values(
                self.kind, self.free_surface, self.p_surface, self.p
            )
        pr = self.spec.pressure
        if pr.clamp_negative and pr.structure_suction:
            clamp_negative_except_at_structures(
                self.pos, self.p, self.kind, self.free_surface, near.indptr, near.indices,
                self.re_grad, self.structure_floor,
            )  # fmt: skip
        elif pr.clamp_negative:
            np.maximum(self.p, 0.0, out=self.p)
        if self.neumann:
            wall_boundary.pressure_gradient_ghost(
                self.pos,
                self.p,
                self.kind,
                self.free_surface,
                near.indptr,
                near.indices,
                self.re_grad,
                self.wcode,
                self.n0_grad,
                self.grad_form,
                self.rho,
                self.gravity,
                self.grad_p,
                self.pref_all,
                self.wall_acc,
                self.n_fluid,
            )
            wall_boundary.wall_pressure(
                self.pos,
                self.p,
                self.kind,
                self.free_surface,
                near.indptr,
                near.indices,
                self.re_n,
                self.wcode,
                self.rho,
                self.gravity,
                self.wall_acc,
                self.n_fluid,
                self.structure_floor,
            )
        else:
            extrapolate_dummy_pressure(self.pos, self.p, self.dummy_src, self.rho, self.gravity)
            operators.pressure_gradient(
                self.pos,
                self.p,
                self.kind,
                near.indptr,
                near.indices,
                self.re_grad,
                self.wcode,
                self.n0_grad,
                self.grad_form,
                False,
                self.grad_p,
                self.pref_all,
            )
        budget.pressure(self._gradient_args(), near, self.vel_before, self.kind)
        time_integration.correct(self.pos, self.vel, self.kind, self.grad_p, self.rho, dt)
        if self.ds_distance > 0.0:  # fluid-fluid only: nets to zero in the pressure stage
            dynamic_stabilization.stabilise(
                self.pos, self.vel, self.kind, near.indptr, near.indices, self.ds_distance, dt,
                self.ds_work,
            )  # fmt: skip
        if self.spec.pressure.shifting > 0.0:  # positions only: momentum untouched
            particle_shifting.shift_particles(
                self.pos, self.kind, self.free_surface, near.indptr, near.indices,
                self.re_grad, self.wcode, self.n0_grad, self.spec.pressure.shifting, self.l0,
                SHIFT_CAP * self.l0, self.shift_work,
            )  # fmt: skip
        budget.stage(PRESSURE, self.vel, self.kind)

    def _stage_close(self, nb, dt: float) -> None:
        """7-8. The step's momentum ledger, time and checks; lap u^{n+1} for the next step
        (if nu > 0) and the next stable dt."""
        self.budget.finish(dt, None if self.exchange else self._pressure_integrals())
        if self.wall_acceleration:
            self.wall_vel_prev[:] = self.vel[self.n_fluid :]
        if self.pressure_ledger is not None:  # I += dt p^{n+1}, as patch_impulse
            self.pressure_ledger.accumulate(self.p, dt)
        self.t += dt
        self.step_count += 1
        self._check()
        if self.nu > 0.0:  # nu lap u^{n+1} for the next step's prediction, on this step's list
            self._viscous_laplacian(nb)
        self.dt_next = self.stable_dt()

    def _gradient_args(self) -> tuple:
        """The pressure gradient's arguments of this wall model, as
        ``MomentumBudget.pressure`` takes them (same pairs, same pressures as the step)."""
        if self.neumann:
            return (self.pos, self.p, self.kind, self.re_grad, self.wcode, self.n0_grad,
                    self.grad_form, False, True, self.free_surface, self.rho,
                    self.gravity, self.pref_all, self.wall_acc, self.n_fluid)  # fmt: skip
        return (self.pos, self.p, self.kind, self.re_grad, self.wcode, self.n0_grad,
                self.grad_form, False, False, self.kind, 0.0, _NO_GRAVITY,
                self.pref_all, NO_WALL_ACCELERATION, 0)  # fmt: skip

    def _pressure_integrals(self) -> np.ndarray:
        """Per patch, the pressure integral force of thesis eq. 2-51 (N; N/m in 2D), into an
        array sized once (read before the next step)."""
        probes.patch_forces(
            self.p, self.normal, self._patch_starts, self._patch_stops, self.kind,
            self.l0 ** (self.dim - 1), self._integrals,
        )  # fmt: skip
        return self._integrals

    def boundary_force(self, names: Sequence[str]) -> np.ndarray:
        """The force of the last step on the patches ``names`` as ``fluid.boundary_force``
        defines it (momentum_budget.py), N (N/m in 2D); before any step, that of the state."""
        b = self.budget
        o = self.n_fluid
        total = np.zeros(self.dim)
        for name in names:
            pt = self._patch[name]
            if b.model != "momentum_exchange":
                total += probes.patch_force(
                    self.p, self.normal, pt.start, pt.stop, self.kind, self.l0 ** (self.dim - 1)
                )
            if b.model == "momentum_exchange":
                total += b.exchange_force[pt.start - o : pt.stop - o].sum(axis=0)
            elif b.model == "pressure_and_contact":
                total += b.contact_force[pt.start - o : pt.stop - o].sum(axis=0)
        return total

    def mean_boundary_force(self, key: str, names: Sequence[str]) -> np.ndarray:
        """The :meth:`boundary_force` on the patches ``names`` averaged since the last call
        with ``key`` (a probe's name), N (N/m in 2D): their impulse over that interval divided
        by its length, so that samples integrate to the impulse however coarse they are; the
        last step's force at a first call or at the same time."""
        ids = [self.budget.names.index(n) for n in names]
        impulse = self.budget.patch_impulse[ids].sum(axis=0)
        mark = self.force_marks.get(key)
        self.force_marks[key] = [self.t, *impulse.tolist()]
        if mark is None or not self.t > mark[0]:
            return self.boundary_force(names)
        return (impulse - np.array(mark[1:])) / (self.t - mark[0])

    def evaluate_exchange(self, nb=None) -> None:
        """The momentum-exchange force of the current state without a step (the load before
        the first step, e.g. hydrostatic): number density, free surface and dry flags, then
        the pressure gradient's exchange, plus the viscous share. ``nb``: a neighbour list at
        the current positions (default: a fresh search, filtered)."""
        if nb is None:
            nb = self._neighbours()
        operators.number_density(
            self.pos, nb.indptr, nb.indices, self.re_n, self.wcode, self.number_density
        )
        self.surface.detect(self.pos, self.kind, self.number_density, nb, self.free_surface)
        if self.neumann:
            wall_boundary.mark_dry(
                self.pos, self.kind, self.free_surface, self.dummy_src, nb.indptr, nb.indices,
                self.re_n, self.contact_wet, self.buried_wet,
            )  # fmt: skip
        operators.fill_reference_pressures(  # cmps reads them; the step's gradient fills them
            self.pos, self.p, self.kind, nb.indptr, nb.indices, self.re_grad, self.grad_form,
            False, self.neumann, self.pref_all,
        )  # fmt: skip
        self.budget.pressure(self._gradient_args(), nb, self.vel_before, self.kind)
        np.copyto(self.budget.contact_force, self.budget.viscous_force)
        np.add(self.budget.pressure_force, self.budget.contact_force,
               out=self.budget.exchange_force)  # fmt: skip

    def _check(self) -> None:
        i, code = time_integration.first_bad_particle(
            self.pos, self.vel, self.p, self.kind, self.lower, self.upper
        )
        if i < 0:
            return
        what = {
            1: "a non-finite position or velocity",
            2: "a non-finite pressure",
            3: "left the domain",
        }
        raise FluidRunError(
            f"particle {i} (kind {int(self.kind[i])}) has {what[code]} at t = {self.t:.6g} s, "
            f"step {self.step_count}: position {self.pos[i].tolist()}, velocity "
            f"{self.vel[i].tolist()}, pressure {self.p[i]:.6g} (domain {self.lower.tolist()} .. "
            f"{self.upper.tolist()})"
            if code != 3
            else f"fluid particle {i} left the domain {self.lower.tolist()} .. "
            f"{self.upper.tolist()} at t = {self.t:.6g} s (step {self.step_count}): position "
            f"{self.pos[i].tolist()}, velocity {self.vel[i].tolist()}"
        )

    def dt_towards(self, t_end: float) -> float:
        """The next step (s) on the way to ``t_end``: the stable dt, except that the last one or
        two steps split the remainder equally (never a tiny last step: the pressure equation's
        source term scales with 1/dt^2)."""
        return time_integration.step_towards(self.t, t_end, self.dt_next)

    def substeps(self, window: float) -> tuple[int, float]:
        """Split ``window`` (s) into n equal steps no longer than the stable dt."""
        return time_integration.split_window(window, self.dt_next)

    # ------------------------------------------------------------------ state for checkpoints
    def state(self) -> dict[str, np.ndarray]:
        """Arrays that, with ``meta()``, restore the solver exactly."""
        self._ensure_lap_u()
        return {
            "pos": self.pos,
            "vel": self.vel,
            "p": self.p,
            "grad_p": self.grad_p,
            "lap_u": self.lap_u,
            "viscous_exchange": self.budget.viscous_force,
            "exchange_force": self.budget.exchange_force,
            "momentum_ledger": self.budget.ledger,
            "patch_impulse": self.budget.patch_impulse,
            **({"wall_velocity": self.wall_vel_prev} if self.wall_acceleration else {}),
            **self._ledger_state(),
        }

    def attach_pressure_ledger(self, ledger: probes.AttachedPressureLedger) -> None:
        """Accumulate the attached pressure probes' impulses every step from now on; call
        before :meth:`restore` (its ``ledger`` array is then part of :meth:`state`)."""
        self.pressure_ledger = ledger if ledger.probes else None

    def _ledger_state(self) -> dict[str, np.ndarray]:
        led = self.pressure_ledger
        return {"attached_pressure": led.ledger} if led is not None else {}

    def meta(self) -> dict:
        return {
            "t": self.t,
            "step": self.step_count,
            "dt_next": self.dt_next,
            "p_peak": self.p_peak,
            "force_marks": {k: list(v) for k, v in self.force_marks.items()},
        }

    def restore(
        self, arrays: dict[str, np.ndarray], meta: dict, preconditioner: dict | None = None
    ) -> None:
        """Set the state from :meth:`state` and :meth:`meta` (copied in). ``preconditioner``:
        the pressure solver's reused preconditioner at that state
        (:meth:`preconditioner_state`); None starts a fresh one, which a run that was not
        restored has not done, so only the first gives bit-identical continuations."""
        self._lap_u_ready = "lap_u" in arrays  # else the next step recomputes it
        budget = {
            "viscous_exchange": self.budget.viscous_force,
            "exchange_force": self.budget.exchange_force,
            "momentum_ledger": self.budget.ledger,
            "patch_impulse": self.budget.patch_impulse,
            **({"wall_velocity": self.wall_vel_prev} if self.wall_acceleration else {}),
            **self._ledger_state(),
        }
        for name in ("pos", "vel", "p", "grad_p", "lap_u", *budget):
            if name not in ("pos", "vel", "p") and name not in arrays:
                continue  # checkpoints written before these were state
            src = arrays[name]
            dst = budget[name] if name in budget else getattr(self, name)
            if src.shape != dst.shape:
                raise ValueError(
                    f"checkpoint array {name} has shape {src.shape}, the scenario gives "
                    f"{dst.shape}: the checkpoint belongs to another scenario"
                )
            dst[...] = src
        if "viscous_exchange" not in arrays:  # an older checkpoint: rebuilt from this state
            self._lap_u_ready = False
            self.budget.reset((self.vel, self.kind))
        self.t = float(meta["t"])
        self.step_count = int(meta["step"])
        self.dt_next = float(meta["dt_next"])
        self.p_peak = float(meta.get("p_peak", 0.0))  # pressure_courant's decaying peak
        self.force_marks = {k: list(v) for k, v in meta.get("force_marks", {}).items()}
        self.pressure.set_preconditioner_state(preconditioner)

    def preconditioner_state(self) -> dict | None:
        """The pressure solver's reused preconditioner, by reference (cheap; see
        ``PressureSolver.preconditioner_state``)."""
        return self.pressure.preconditioner_state()

    def preconditioner_arrays(self) -> tuple[dict[str, np.ndarray], dict]:
        """The current preconditioner as arrays and JSON-able numbers, for checkpoint files."""
        return self.pressure.preconditioner_arrays(self.pressure.preconditioner_state())

    def load_preconditioner_arrays(self, arrays: dict[str, np.ndarray], meta: dict | None) -> None:
        """Continue with the preconditioner of a checkpoint file (:meth:`preconditioner_arrays`);
        ``meta`` None (a checkpoint written before checkpoints carried it): a fresh one."""
        state = None if meta is None else self.pressure.preconditioner_from_arrays(arrays, meta)
        self.pressure.set_preconditioner_state(state)

    # ------------------------------------------------------------------ probes
    def probe_value(self, probe) -> float | np.ndarray:
        """Current value of a fluid-side probe (see mpsfem.fluid_mps.probes for definitions)."""
        l0 = self.l0
        if probe.kind == "pressure":
            r = probe.radius or l0
            return probes.pressure_at(
                self.pos, self.p, self.kind, np.asarray(probe.position, float), r
            )
        if probe.kind == "wave_gauge":
            up = self._up_axis()
            where = np.asarray(probe.position, float)
            if probe.method == "top_particle":
                hw = probe.half_width or 0.5 * l0
                h = probes.surface_height(self.pos, self.kind, where, hw, up, l0)
            else:
                if self._gauge_work is None:
                    self._gauge_work = np.empty(self.n, np.int64)
                h = probes.surface_height_kernel(
                    self.pos, self.kind, where, up, l0, self._gauge_work
                )
            return h - probe.reference_level
        if probe.kind == "front":
            link = probe.link_distance * l0
            nb = self._last_neighbours
            if nb is None:
                nb = self._last_neighbours = self._neighbours()
            if link > self.search_radius:  # longer than the step's list holds: a list of its own
                nb = build_neighbours(self.pos, link, domain=(self.lower, self.upper))
            if self._uf_parent is None:
                self._uf_parent = np.empty(self.n, np.int64)
                self._uf_size = np.empty(self.n, np.int64)
            return probes.front_position(
                self.pos,
                self.kind,
                nb.indptr,
                nb.indices,
                link,
                probe.axis,
                probe.min_cluster_fraction,
                l0,
                self._uf_parent,
                self._uf_size,
            )
        if probe.kind == "force":
            pt = next(pt for pt in self.patches if pt.name == probe.target)
            if probe.average:
                return self.mean_boundary_force(probe.name, [pt.name])
            if self.budget.model != "pressure_integral":
                return self.boundary_force([pt.name])
            return probes.patch_force(
                self.p, self.normal, pt.start, pt.stop, self.kind, l0 ** (self.dim - 1)
            )
        if probe.kind == "energy":
            return np.array(
                probes.fluid_energy(self.pos, self.vel, self.kind, self.mass, self.gravity)
            )
        raise ValueError(f"probe kind {probe.kind!r} is not a fluid probe")

    def _up_axis(self) -> int:
        if np.any(self.gravity):
            return int(np.argmax(np.abs(self.gravity)))
        return self.dim - 1
