"""The δ-SPH / δ-SPHC fluid (``fluid.method = "delta-sph"``): state arrays sized once, explicit
steps of the right-hand side in ``delta_sph.py``, the :class:`~mpsfem.fluid_methods.FluidMethod`
protocol for the run loop, the probes, the results file and the checkpoints.

Shared with MPS (``fluid_mps``): the particle layout of blocks and walls (``geometry.py``; the
wall's first layer and its dummies all become dummy particles with extrapolated pressure, the wall
surface lies half a spacing in front of them as in MPS), the neighbour search
(``neighbours.py``; its Verlet candidates go to the δ-SPH kernels unfiltered, see
``candidate_pairs.py``), prescribed wall motion (``wall_motion.py``), the probe kernels
(``probes.py``) and the state checks (``time_integration.first_bad_particle``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mpsfem.fluid_mps import probes
from mpsfem.fluid_mps.geometry import ParticleSet, build_particles, default_dummy_layers
from mpsfem.fluid_mps.geometry import hydrostatic_pressure as hydrostatic_column_pressure
from mpsfem.fluid_mps.neighbours import NeighbourList, NeighbourSearch, build_neighbours
from mpsfem.fluid_mps.particle_kinds import STRUCTURE, WALL
from mpsfem.fluid_mps.sponge import SpongeLayer
from mpsfem.fluid_mps.time_integration import first_bad_particle, split_window, step_towards
from mpsfem.fluid_mps.wall_motion import MotionLaw, place_moving_walls
from mpsfem.fluid_sph import delta_sph, particle_shifting, time_stepping
from mpsfem.fluid_sph.candidate_pairs import CandidatePairs
from mpsfem.fluid_sph.momentum_budget import SPHMomentumBudget
from mpsfem.fluid_sph.wendland import gradient_coefficient, wendland_norm
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.fluid_sph import DeltaSPHSection

#: default acoustic Courant numbers (dt <= cfl h / (c0 + u_max)) per integrator. The leapfrog
#: has no damping of its own: at 0.2 the δ-SPHC free surface of still water grew unstable within
#: 0.1 s (0.2 m deep, 10 particles per depth), at 0.1 it stayed still for 0.6 s
#: (docs/fluid_sph.md); RK4 was stable at 0.8 and 1.2
DEFAULT_CFL = {"symplectic": 0.1, "rk4": 0.8}
#: viscous limit dt <= C h / (alpha_max c0) of the artificial viscosity, per integrator. Measured
#: on the regular-wave tank (damping zone alpha = 0.6, RK4): stable at 0.25 h / c0, growing at
#: 0.35, blown up at 0.5 within 15 steps; so C = 0.15 for RK4. The leapfrog's real-axis
#: stability interval is shorter (2 against RK4's 2.8): 0.1 (not measured)
VISCOUS_LIMIT = {"symplectic": 0.1, "rk4": 0.15}


class SPHRunError(RuntimeError):
    """The δ-SPH state went wrong (non-finite values, an escaped particle, Mach number too high)."""


@dataclass
class SPHStageTimes:
    """Accumulated wall time per stage, s; ``rhs_calls`` right-hand-side evaluations."""

    neighbours: float = 0.0
    rhs: float = 0.0
    integrate: float = 0.0
    other: float = 0.0
    rhs_calls: int = 0

    def as_dict(self) -> dict[str, float]:
        return {
            "neighbours": self.neighbours,
            "rhs": self.rhs,
            "integrate": self.integrate,
            "other": self.other,
            "rhs_calls": float(self.rhs_calls),
        }


@dataclass
class NoBudget:
    """No momentum budget (``fluid.momentum_budget = false``); the run loop reads ``full`` and
    the force model's name."""

    names: list[str]
    model: str
    full: bool = False


class DeltaSPHSolver:
    """Weakly compressible δ-SPH fluid. Units SI; arrays (N, dim) float64, kinds int8.

    ``particles``: a ready particle set (fluid first, then walls), e.g. a circular drop; default
    the scenario's blocks and walls. ``external``: patches driven by another participant (coupled
    structure surfaces, ``fluid_sph.participant``): moving dummy walls whose end-of-step position
    and velocity :meth:`set_patch_state` sets, and whose pair forces with the fluid are booked
    (:attr:`reaction_step`). ``neighbour_filter(nb, pos, kind) -> nb``: applied after every
    neighbour search (``fluid_mps.thin_member``: nothing interacts through a member).
    """

    def __init__(
        self,
        spec: FluidSection,
        base_dir: Path | None = None,
        external: Sequence = (),
        neighbour_filter=None,
        particles: ParticleSet | None = None,
    ) -> None:
        self.spec = spec
        self.sph = sph = spec.sph if spec.sph is not None else DeltaSPHSection()
        self.dim = dim = spec.dim
        self.l0 = dx = spec.spacing
        self.rho0 = spec.density
        self.gravity = np.asarray(spec.gravity, dtype=np.float64)
        self.h = sph.smoothing_ratio * dx
        self.norm = wendland_norm(dim, self.h)
        self.inv_h = 1.0 / self.h
        self.grad_coef = gradient_coefficient(dim, self.h)
        self.radius = 2.0 * self.h  # Wendland C2 support
        self.corrected = sph.gradient == "corrected"
        self.omega2 = sph.central_field_omega**2
        self.center = np.zeros(dim)
        if sph.central_field_center is not None:
            self.center[:] = sph.central_field_center

        if particles is None:
            layered = spec
            if spec.dummy_layers is None:  # enough layers to fill the kernel's support 2h
                layers = default_dummy_layers(2.0 * sph.smoothing_ratio)
                layered = spec.model_copy(update={"dummy_layers": layers - 1})
            particles = build_particles(layered, external)
        elif len(external):
            raise ValueError("external patches come with the scenario's particles, not a given set")
        ps = particles
        self.pos = np.ascontiguousarray(ps.pos, dtype=np.float64)
        self.vel = np.ascontiguousarray(ps.vel, dtype=np.float64)
        self.kind = np.asarray(ps.kind, dtype=np.int8)
        self.normal = np.ascontiguousarray(ps.normal, dtype=np.float64)
        self.n_fluid = nf = ps.n_fluid
        self.n = n = len(self.pos)
        self.patches = ps.patches
        self._patch = {pt.name: pt for pt in self.patches}
        self.neighbour_filter = neighbour_filter
        if neighbour_filter is not None and hasattr(neighbour_filter, "bind"):
            neighbour_filter.bind(self)  # needs n and patch(); before the first search
        # externally driven rows (patch order): state at the step's start and its end
        ext = [np.arange(pt.start, pt.stop) for pt in self.patches if pt.spec is None]
        self.ext_rows = np.concatenate(ext) if ext else np.zeros(0, dtype=np.int64)
        self._ext_pos0 = self.pos[self.ext_rows].copy()
        self._ext_vel0 = self.vel[self.ext_rows].copy()
        self._ext_pos1 = self.pos[self.ext_rows].copy()
        self._ext_vel1 = self.vel[self.ext_rows].copy()
        #: slot of every particle in ext_rows (-1: not external), for the reaction kernel
        self.ext_slot = np.full(self.n, -1, dtype=np.int64)
        self.ext_slot[self.ext_rows] = np.arange(self.ext_rows.size)
        #: force of the fluid on each external particle at the last right-hand side, and its
        #: mean over the last step with the integrator's weights (exactly the momentum the
        #: fluid lost to it over the step, divided by dt), N (N/m in 2D)
        self.reaction = np.zeros((self.ext_rows.size, self.dim))
        self.reaction_step = np.zeros((self.ext_rows.size, self.dim))
        #: the free-slip projection of the structure's pair forces (fluid.sph.structure_load =
        #: "normal_pairs", :meth:`project_external`): per wall row its group (-1: whole pairs), per
        #: external slot its group, per group two unit vectors (or zero), which of them may only
        #: push, and their gates of the last right-hand side (delta_sph.wall_reaction_projected)
        self.project_load = False
        self.wall_group = np.full(n - nf, -1, dtype=np.int64)
        self.slot_group = np.full(self.ext_rows.size, -1, dtype=np.int64)
        self.ext_dir = np.zeros((0, 2, dim))
        self.ext_push = np.zeros((0, 2), dtype=np.bool_)
        self.ext_keep = np.ones((0, 2))
        self._ext_comp = np.zeros((self.ext_rows.size, 2))
        self._ext_gsum = np.zeros((0, 2))
        #: fluid.boundary_force = "momentum_exchange": each rigid wall patch's force is the pair
        #: exchange (delta_sph.patch_exchange) at the last right-hand side, and its mean over the
        #: last step with the integrator's weights (the momentum the fluid lost at it / dt), N
        self.exchange_walls = spec.boundary_force == "momentum_exchange"
        self.wall_patch = np.full(n - nf, -1, dtype=np.int64)
        for k, pt in enumerate(self.patches):
            if pt.spec is not None:
                self.wall_patch[pt.start - nf : pt.stop - nf] = k
        self.wall_exchange = np.zeros((len(self.patches), dim))
        #: fluid.sph.wall_pressure = "wetted" (delta_sph.dry_walls): each wall particle's patch
        #: (all patches), which are pressure-layer particles (WALL, STRUCTURE), the thresholds
        #: on the fluid's kernel sum for a gap of DRY_GAP / WET_GAP spacings, and each wall
        #: particle's wetness at the last right-hand side (1: Adami's pressure, 0: p_w = 0)
        self.wetted_walls = sph.wall_pressure == "wetted"
        self.clamped_walls = sph.wall_pressure == "clamped"
        self.wall_patch_all = np.full(n - nf, -1, dtype=np.int64)
        for k, pt in enumerate(self.patches):
            self.wall_patch_all[pt.start - nf : pt.stop - nf] = k
        self.pressure_layer = np.isin(self.kind[nf:], (WALL, STRUCTURE))
        ratio = sph.smoothing_ratio
        self.wet_support = (
            delta_sph.half_space_support(dim, ratio, 1.0 + delta_sph.DRY_GAP),
            delta_sph.half_space_support(dim, ratio, 1.0 + delta_sph.WET_GAP),
        )
        self.wall_wet = np.ones(n - nf)
        self._wet_own = np.ones(n - nf)  # work array of dry_walls
        self.wall_exchange_step = np.zeros((len(self.patches), dim))
        self.mass = self.rho0 * dx**dim  # kg (kg/m in 2D)

        self.c0 = self._sound_speed()
        self.p = np.zeros(n)
        self.rho = np.full(n, self.rho0)
        if spec.hydrostatic_start and np.any(self.gravity):
            self.p[:nf] = hydrostatic_column_pressure(
                self.pos, self.kind, self.gravity, self.rho0, dx
            )[:nf]
            self.rho[:nf] = self.rho0 + self.p[:nf] / self.c0**2  # inverse of seed eq. 1

        self.lower, self.upper = self._domain()
        # work arrays, sized once
        self.M = np.zeros((nf, dim, dim))
        self.pM = np.zeros((nf, dim, dim))  # p_i M_i (Pa), for the pair pass
        #: the pairs closer than the radius, row i in slots indptr[i] .. row_end[i] - 1 of the
        #: candidate rows: j and F(r_ij) V_j (delta_sph.correction writes them, pair_terms reads
        #: them); grown with the candidates, with 10 % spare
        self.pair_j = np.zeros(0, np.int32)
        self.fv_pair = np.zeros(0)
        self.row_end = np.zeros(n, np.int64)
        self.grad_rho = np.zeros((nf, dim))
        # fluid.sph.viscosity_form: 'antuono' divides alpha by 2 (n + 2), the factor seed eq. 3
        # puts inside phi_ij (nu = alpha h c0 / (2 (n + 2)), Antuono et al. 2010)
        scale = 1.0 if sph.viscosity_form == "seed" else 1.0 / (2.0 * (dim + 2))
        self.visc_alpha = sph.viscosity_alpha * scale  # alpha as the kernels read it
        self.damp_alpha = sph.damping_alpha * scale
        self.alpha = np.full(nf, self.visc_alpha)
        self.acc = np.zeros((n, dim))
        self.vol = np.zeros(n)
        #: each wall particle's acceleration over the current step, m/s^2 (moving walls)
        self.wall_acc = np.zeros((n - nf, dim))
        self.drho = np.zeros(n)
        # fluid.sph.damping: 'viscosity' ramps alpha inside the zones (seed eq. 4, in rhs());
        # 'sponge' damps the velocity once per step at its end (thesis eq. 3-9, SpongeLayer)
        # and leaves the viscosity ramp without zones
        self.sponge = SpongeLayer(spec.sponges if sph.damping == "sponge" else [], dim)
        zones = spec.sponges if sph.damping == "viscosity" else []
        self.zone_axis = np.array([z.axis for z in zones], dtype=np.int32)
        self.zone_start = np.array([z.start for z in zones], dtype=np.float64)
        self.zone_inv = np.array([1.0 / (z.end - z.start) for z in zones], dtype=np.float64)
        self.integrator = sph.integrator
        self.alpha_max = max(self.visc_alpha, self.damp_alpha if len(zones) else 0.0)
        self.cfl = sph.cfl if sph.cfl is not None else DEFAULT_CFL[sph.integrator]
        if self.integrator == "rk4":
            self._y0 = (np.empty_like(self.pos), np.empty_like(self.vel), np.empty_like(self.rho))
            self._sum = (np.empty_like(self.pos), np.empty_like(self.vel), np.empty_like(self.rho))

        g_abs = float(np.linalg.norm(self.gravity))
        self.motions = [
            MotionLaw(w.motion, base_dir, gravity=g_abs, dim=dim, key=f"fluid.walls[{i}].motion")
            for i, w in enumerate(pt.spec for pt in self.patches if pt.spec is not None)
        ]
        rigid = [pt for pt in self.patches if pt.spec is not None]
        self.moving = [(pt, m) for pt, m in zip(rigid, self.motions, strict=True) if m.moves]
        self.wall_origin = {pt.name: self.pos[pt.start : pt.stop].copy() for pt, _ in self.moving}
        names = [pt.name for pt in self.patches]
        # fluid_sph.momentum_budget, /momentum_budget: only when the scenario asks for it (the
        # key's default true is MPS's; the δ-SPH split costs a serial pair pass per rhs)
        if spec.momentum_budget and "momentum_budget" in spec.model_fields_set:
            self.budget = SPHMomentumBudget(
                names, [pt.start - nf for pt in self.patches],
                [pt.stop - nf for pt in self.patches],
                [pt.spec is None for pt in self.patches], dim, n - nf, self.mass,
                spec.boundary_force, sponge=self.sponge.active,
            )  # fmt: skip
            self._patch_forces = np.zeros((len(self.patches), dim))
        else:
            self.budget = NoBudget(names, spec.boundary_force)
        # the pair rows of the kernels: Verlet candidates filtered inside the kernels
        # (candidate_pairs.py), in every run; a neighbour filter works on a copy of them
        # (neighbour_rows). Until 2026-11-27 a run with a neighbour filter, a wall reaction, the
        # budget or exchange walls took the exact list of a shared search instead (1 ms a
        # right-hand side at 18 k particles, a fifth of a coupled obstacle run); the kernels
        # those runs add skip pairs beyond the support as the others do, so the results are the
        # same bit for bit. ``exact_neighbours = True`` with a NeighbourSearch as ``search``
        # keeps that path reachable (tests/fluid_sph/test_delta_sph.py compares the two).
        self.exact_neighbours = False
        self._copy_ptr = np.empty(0, np.int64)  # neighbour_rows' copy for the filter
        self._copy_idx = np.empty(0, np.int32)
        skin = spec.neighbours.skin * dx
        domain = (self.lower, self.upper)
        if self.exact_neighbours:
            self.search = NeighbourSearch(dim, self.radius, domain=domain, escape="clip",
                                          skin=skin)  # fmt: skip
        else:
            self.search = CandidatePairs(dim, self.radius, skin, domain=domain, escape="clip")
        self._last_neighbours = None
        #: fluid.sph.shifting: the δ+-SPH shift at each step's end (None: off)
        self.shifting = particle_shifting.build(self)
        self.force_marks: dict[str, list[float]] = {}
        #: attached pressure probes' running impulses (:meth:`attach_pressure_ledger`; state)
        self.pressure_ledger: probes.AttachedPressureLedger | None = None
        #: per patch, the impulse of boundary_force since t = 0 (step-end force x dt), N s
        self.patch_impulse = np.zeros((len(self.patches), dim))
        self._patch_index = {pt.name: k for k, pt in enumerate(self.patches)}
        self.times = SPHStageTimes()
        self.t = 0.0
        self.step_count = 0
        self.max_speed = 0.0
        self._uf_parent: np.ndarray | None = None
        self._uf_size: np.ndarray | None = None
        self._gauge_work: np.ndarray | None = None
        self.move_walls(0.0)
        self.rhs()  # the first kick's right-hand side (state from here on)
        self.reaction_step[...] = self.reaction  # the load before the first step
        self.wall_exchange_step[...] = self.wall_exchange
        if self.budget.full:
            self.budget.start(self.vel, nf)
        ts = spec.time_step
        self.dt_next = min(ts.dt_initial or ts.dt_max, self.stable_dt())

    # ------------------------------------------------------------------ set-up helpers
    def _sound_speed(self) -> float:
        """c0 (m/s): fluid.sph.sound_speed, or 10 max(U, sqrt(g H)) (seed eq. 1) with H the
        tallest block and U fluid.sph.reference_speed (default 2 sqrt(g H), Ritter's front);
        :meth:`FluidSection.sph_sound_speed`, which ``mpsfem validate`` and the scenario's
        light-member advice read too."""
        c0 = self.spec.sph_sound_speed()
        if not c0 > 0.0:
            raise ValueError(
                "fluid.sph.sound_speed: without gravity and a reference speed the default c0 = "
                "10 max(U, sqrt(g H)) is 0; give fluid.sph.sound_speed (or reference_speed)"
            )
        return c0

    def _domain(self) -> tuple[np.ndarray, np.ndarray]:
        """The box a fluid particle may not leave (fluid.domain_lower/upper, else the particles'
        bounding box grown by 10 l0 and 1 m against gravity, as MPS)."""
        spec = self.spec
        lo = self.pos.min(axis=0) - 10.0 * self.l0
        hi = self.pos.max(axis=0) + 10.0 * self.l0
        if np.any(self.gravity):
            hi[int(np.argmax(np.abs(self.gravity)))] += 1.0
        if spec.domain_lower is not None:
            lo = np.asarray(spec.domain_lower, float)
        if spec.domain_upper is not None:
            hi = np.asarray(spec.domain_upper, float)
        return lo, hi

    def set_initial_state(self, vel: np.ndarray | None = None, p: np.ndarray | None = None) -> None:
        """Fluid velocities (m/s) and pressures (Pa) of the initial state, before the first step
        (densities from the inverse linear EOS); the right-hand side is re-evaluated."""
        nf = self.n_fluid
        if vel is not None:
            self.vel[:nf] = vel
        if p is not None:
            self.p[:nf] = p
            self.rho[:nf] = self.rho0 + self.p[:nf] / self.c0**2
        self.rhs()
        if self.budget.full:
            self.budget.start(self.vel, nf)
        self.dt_next = min(self.spec.time_step.dt_initial or self.spec.time_step.dt_max,
                           self.stable_dt())  # fmt: skip

    # ------------------------------------------------------------------ right-hand side
    def neighbour_rows(self) -> NeighbourList:
        """The pair rows of the kernels at the current positions: the search's Verlet
        candidates (a superset of the pairs within :attr:`radius`, rows ascending; the kernels
        skip the pairs beyond it), through the neighbour filter when there is one. The filter
        drops pairs in place, so it gets a copy (the candidates are kept for the next calls),
        labelled with the true radius (its reach: which particles it classifies)."""
        nb = self.search.update(self.pos)
        if self.neighbour_filter is None:
            return nb
        n, nnz = nb.n, nb.nnz
        if self._copy_ptr.shape[0] < n + 1:
            self._copy_ptr = np.empty(n + 1, np.int64)
        if self._copy_idx.shape[0] < nnz:
            self._copy_idx = np.empty(int(1.1 * nnz) + 16, np.int32)
        ptr, idx = self._copy_ptr[: n + 1], self._copy_idx[:nnz]
        ptr[:] = nb.indptr
        idx[:] = nb.indices
        return self.neighbour_filter(NeighbourList(ptr, idx, self.radius), self.pos, self.kind)

    def rhs(self) -> None:
        """acc and drho/dt of the fluid at the current (pos, vel, rho); walls where they are.

        The kernels read the rows of :meth:`neighbour_rows` (Verlet candidates, through the
        neighbour filter when there is one) and skip the pairs beyond the radius; on the exact
        list (:attr:`exact_neighbours` with a NeighbourSearch) they give the same results, bit
        for bit."""
        tic = time.perf_counter()
        nb = self.neighbour_rows()
        if self.pair_j.shape[0] < nb.nnz:
            self.pair_j = np.empty(int(1.1 * nb.nnz) + 16, np.int32)
            self.fv_pair = np.empty(self.pair_j.shape[0])
        r2max = self.radius * self.radius  # the neighbour search's test, r^2 < radius^2
        toc = time.perf_counter()
        self.times.neighbours += toc - tic
        nf = self.n_fluid
        delta_sph.equation_of_state(self.rho, self.p, nf, self.rho0, self.c0)
        delta_sph.wall_pressure(
            self.pos, self.rho, self.p, self.kind, nb.indptr, nb.indices, r2max, nf,
            self.gravity, self.omega2, self.center, self.wall_acc, self.h, self.norm, self.rho0,
            self.c0,
        )  # fmt: skip
        if self.clamped_walls:  # fluid.sph.wall_pressure = "clamped": no wall pulls
            delta_sph.clamp_wall_pressure(self.p, self.rho, nf, self.rho0)
        if self.wetted_walls:  # fluid.sph.wall_pressure = "wetted": no pull across an air gap
            delta_sph.dry_walls(
                self.pos, self.rho, self.p, nb.indptr, nb.indices, r2max, nf, self.mass,
                self.h, self.norm, self.rho0, self.c0, self.pressure_layer,
                self.wall_patch_all, *self.wet_support, (1.5 * self.l0) ** 2, self._wet_own,
                self.wall_wet,
            )  # fmt: skip
        delta_sph.particle_volume(self.rho, self.mass, self.vol)
        delta_sph.correction(
            self.pos, self.rho, self.vol, self.p, nb.indptr, nb.indices, r2max, nf, self.inv_h,
            self.grad_coef, self.M, self.pM, self.grad_rho, self.pair_j, self.fv_pair,
            self.row_end,
        )  # fmt: skip
        if len(self.zone_axis):
            delta_sph.viscosity_ramp(
                self.pos, nf, self.visc_alpha, self.damp_alpha, self.zone_axis,
                self.zone_start, self.zone_inv, self.alpha,
            )  # fmt: skip
        project = self.project_load and self.ext_rows.size > 0
        wet = self.wall_wet if self.wetted_walls else None  # weighs p_i in the wall pairs
        if project:  # the projected reactions and their gates, which pair_terms then applies
            delta_sph.wall_reaction_projected(
                self.pos, self.vol, self.p, nb.indptr, nb.indices, nf, self.inv_h,
                self.grad_coef, self.corrected, self.M, self.ext_slot, self.wall_group,
                self.slot_group, self.ext_dir, self.ext_push, self._ext_comp, self._ext_gsum,
                self.ext_keep, self.reaction, wet,
            )  # fmt: skip
        delta_sph.pair_terms(
            self.pos, self.vel, self.rho, self.p, nb.indptr, self.row_end, self.pair_j,
            self.fv_pair, nf, self.h, self.rho0, self.c0, self.sph.density_diffusion,
            self.corrected, self.M, self.pM, self.grad_rho, self.alpha, self.gravity, self.omega2,
            self.center, self.acc, self.drho,
            *((self.wall_group, self.ext_dir, self.ext_keep) if project else (None, None, None)),
            wet,
        )  # fmt: skip
        if self.exchange_walls:
            delta_sph.patch_exchange(
                self.pos, self.vol, self.p, nb.indptr, nb.indices, nf, self.inv_h,
                self.grad_coef, self.corrected, self.M, self.wall_patch, self.wall_exchange, wet,
            )  # fmt: skip
        if self.ext_rows.size and not project:
            delta_sph.wall_reaction(
                self.pos, self.rho, self.vol, self.p, nb.indptr, nb.indices, nf, self.inv_h,
                self.grad_coef, self.corrected, self.M, self.ext_slot, self.reaction, wet,
            )  # fmt: skip
        if self.budget.full:
            self.budget.evaluate(self, nb)
        self._last_neighbours = nb  # the rows this right-hand side used (tests, diagnostics)
        self.times.rhs += time.perf_counter() - toc
        self.times.rhs_calls += 1

    # ------------------------------------------------------------------ time step
    def stable_dt(self) -> float:
        """dt (s) <= cfl h / (c0 + u_max), 0.25 sqrt(h / a_max) (Monaghan 1992), the viscous
        limit C h / (alpha_max c0) (:data:`VISCOUS_LIMIT`) and dt_max."""
        umax = time_stepping.max_norm(self.vel, self.n_fluid)
        amax = time_stepping.max_norm(self.acc, self.n_fluid)
        dt = min(self.spec.time_step.dt_max, self.cfl * self.h / (self.c0 + umax))
        if amax > 0.0:
            dt = min(dt, 0.25 * math.sqrt(self.h / amax))  # force condition
        if self.alpha_max > 0.0:  # the artificial viscosity's own limit (VISCOUS_LIMIT)
            dt = min(dt, VISCOUS_LIMIT[self.integrator] * self.h / (self.alpha_max * self.c0))
        return dt

    def move_walls(self, t: float) -> None:
        """Put the moving wall patches at their prescribed position and velocity for time t."""
        place_moving_walls(self.moving, self.wall_origin, t, self.pos, self.vel)

    def set_patch_state(self, name: str, pos: np.ndarray, vel: np.ndarray) -> None:
        """Position (m) and velocity (m/s) of an external patch's particles at the end of the next
        step (the driving participant calls this before :meth:`step`); over the step they move
        linearly from where they are, and their acceleration (v_end - v_start) / dt enters the
        Adami wall pressure."""
        pt = self._patch.get(name)
        if pt is None or pt.spec is not None:
            raise ValueError(f"{name!r} is not an external patch of this δ-SPH fluid")
        rows = self.ext_slot[pt.start : pt.stop]
        self._ext_pos1[rows] = pos
        self._ext_vel1[rows] = vel

    def project_external(self, slot_group: np.ndarray, n_group: int) -> None:
        """Give the external particles the free-slip projection (fluid.sph.structure_load =
        "normal_pairs"): ``slot_group`` (one per external slot, -1: whole pairs) names each particle's
        group (a member's interface point with its column), ``n_group`` their number. The
        driving participant fills :attr:`ext_dir` (groups, 2, dim: unit vectors or zero) and
        :attr:`ext_push` (groups, 2: may only push) before each step; from the next
        right-hand side the fluid and the reactions keep only those components (both sides
        alike: delta_sph.wall_reaction_projected, pair_terms)."""
        self.slot_group[:] = slot_group
        self.wall_group[:] = -1
        self.wall_group[self.ext_rows - self.n_fluid] = self.slot_group
        self.ext_dir = np.zeros((n_group, 2, self.dim))
        self.ext_push = np.zeros((n_group, 2), dtype=np.bool_)
        self.ext_keep = np.ones((n_group, 2))
        self._ext_gsum = np.zeros((n_group, 2))
        self.project_load = True

    def patch(self, name: str):
        """The index range of the patch ``name`` (a WallPatch)."""
        return self._patch[name]

    def _begin_external(self, dt: float) -> None:
        """Start a step of the external patches: their start state and constant acceleration."""
        r = self.ext_rows
        np.copyto(self._ext_pos0, self.pos[r])
        np.copyto(self._ext_vel0, self.vel[r])
        self.wall_acc[r - self.n_fluid] = (self._ext_vel1 - self._ext_vel0) / dt

    def _place_external(self, frac: float) -> None:
        """External patches at the fraction ``frac`` of the step (linear in time)."""
        r = self.ext_rows
        if frac == 1.0:
            self.pos[r] = self._ext_pos1
            self.vel[r] = self._ext_vel1
        else:
            self.pos[r] = self._ext_pos0 + frac * (self._ext_pos1 - self._ext_pos0)
            self.vel[r] = self._ext_vel0 + frac * (self._ext_vel1 - self._ext_vel0)

    def _wall_acceleration(self, dt: float) -> None:
        """a_w = (v(t + dt) - v(t)) / dt of every moving wall particle, constant over the step
        (the prescribed velocities' difference; zero for walls at rest)."""
        for pt, law in self.moving:
            _, v0 = law(self.t)
            _, v1 = law(self.t + dt)
            rows = slice(pt.start - self.n_fluid, pt.stop - self.n_fluid)
            self.wall_acc[rows] = (v1 - v0) / dt * law.direction

    def step(self, dt: float) -> None:
        """Advance by exactly ``dt`` (s) with fluid.sph.integrator; raises :class:`SPHRunError`
        on a non-finite or escaped particle or a Mach number above fluid.sph.max_mach."""
        nf = self.n_fluid
        if self.moving:
            self._wall_acceleration(dt)
        ext = self.ext_rows.size > 0
        if ext:
            self._begin_external(dt)
        if self.integrator == "symplectic":
            tic = time.perf_counter()
            # leapfrog: the fluid's momentum changes by dt (F_start + F_end) / 2
            self._weigh_step_forces(0.5, first=True)
            if self.budget.full:  # the first kick's right-hand side, the last step's end
                self.budget.book(0.5 * dt)
            time_stepping.kick(self.vel, self.rho, self.acc, self.drho, nf, 0.5 * dt)
            time_stepping.drift(self.pos, self.vel, nf, dt)
            self.move_walls(self.t + dt)
            if ext:
                self._place_external(1.0)
            if self.shifting is not None:  # the step's end positions, before its rhs
                self.shifting.apply(self, dt)
            self.times.integrate += time.perf_counter() - tic
            self.rhs()
            tic = time.perf_counter()
            self._weigh_step_forces(0.5, first=False)
            if self.budget.full:
                self.budget.book(0.5 * dt)
            time_stepping.kick(self.vel, self.rho, self.acc, self.drho, nf, 0.5 * dt)
        else:
            self._rk4(dt)
            tic = time.perf_counter()
            if self.shifting is not None:  # the step's end positions (the next rhs reads them)
                self.shifting.apply(self, dt)
        delta_sph.equation_of_state(self.rho, self.p, nf, self.rho0, self.c0)
        if self.sponge.active:  # thesis eq. 3-9, u <- u (1 - dt alpha_s r) at the step's end
            if self.budget.full:
                self.budget.sponge_begin(self.vel, nf)
            self.sponge.apply(self.pos, self.vel, nf, dt)
            if self.budget.full:
                self.budget.sponge_end(self.vel, nf)
        self.times.integrate += time.perf_counter() - tic
        tic = time.perf_counter()
        self.t += dt
        self.step_count += 1
        self._check()
        if self.budget.full:
            self._book_reported(dt)
        if self.force_marks:  # some probe averages: book each patch's impulse of this step
            for k, pt in enumerate(self.patches):
                self.patch_impulse[k] += dt * self.boundary_force([pt.name])
        if self.pressure_ledger is not None:  # I += dt p^{n+1}, as MPS books it
            self.pressure_ledger.accumulate(self.p, dt)
        self.dt_next = self.stable_dt()
        self.times.other += time.perf_counter() - tic

    def _book_reported(self, dt: float) -> None:
        """The budget's reported impulse of this step: the pressure integral at the step's end
        on a wall patch, the step-mean reaction on an externally driven patch."""
        f = self._patch_forces
        for k, pt in enumerate(self.patches):
            if pt.spec is None:
                f[k] = self.reaction_step[self.ext_slot[pt.start : pt.stop]].sum(axis=0)
            else:
                f[k] = self.boundary_force([pt.name])
        self.budget.report(dt, f)

    def _rk4(self, dt: float) -> None:
        """Classical RK4 (weights 1, 2, 2, 1; stages at t, t + dt/2, t + dt/2, t + dt)."""
        nf = self.n_fluid
        p0, v0, r0 = self._y0
        sp, sv, sr = self._sum
        np.copyto(p0, self.pos)
        np.copyto(v0, self.vel)
        np.copyto(r0, self.rho)
        t = self.t
        ext = self.ext_rows.size > 0
        for stage, (w, c) in enumerate(((1.0, 0.5), (2.0, 0.5), (2.0, 1.0), (1.0, 0.0))):
            if stage > 0:
                frac = 0.5 if stage < 3 else 1.0
                self.move_walls(t + frac * dt)
                if ext:
                    self._place_external(frac)
            self.rhs()
            # RK4: the fluid's momentum changes by dt (F1 + 2 F2 + 2 F3 + F4) / 6
            self._weigh_step_forces(w / 6.0, first=stage == 0)
            if self.budget.full:  # the stage's weight in the velocity update
                self.budget.book(w / 6.0 * dt)
            tic = time.perf_counter()
            time_stepping.rk_accumulate(sp, sv, sr, self.vel, self.acc, self.drho, nf, w,
                                        stage == 0)  # fmt: skip
            if stage < 3:
                time_stepping.rk_stage(p0, v0, r0, self.vel, self.acc, self.drho, nf, c * dt,
                                       self.pos, self.vel, self.rho)  # fmt: skip
            else:
                time_stepping.rk_finish(p0, v0, r0, sp, sv, sr, nf, dt / 6.0, self.pos,
                                        self.vel, self.rho)  # fmt: skip
            self.times.integrate += time.perf_counter() - tic

    def _check(self) -> None:
        i, code = first_bad_particle(self.pos, self.vel, self.p, self.kind, self.lower, self.upper)
        where = f"at t = {self.t:.6g} s (step {self.step_count})"
        if i >= 0:
            what = {1: "a non-finite position or velocity", 2: "a non-finite pressure",
                    3: f"left the domain {self.lower.tolist()} .. {self.upper.tolist()}"}[code]  # fmt: skip
            raise SPHRunError(
                f"δ-SPH particle {i} has {what} {where}: position {self.pos[i].tolist()}, "
                f"velocity {self.vel[i].tolist()}"
                if code != 3
                else f"δ-SPH fluid particle {i} {what} {where}: position {self.pos[i].tolist()}"
            )
        umax = time_stepping.max_norm(self.vel, self.n_fluid)
        self.max_speed = max(self.max_speed, umax)
        if umax > self.sph.max_mach * self.c0:
            raise SPHRunError(
                f"δ-SPH: the fastest fluid particle moves at {umax:.3g} m/s {where}, above "
                f"fluid.sph.max_mach = {self.sph.max_mach} times c0 = {self.c0:.3g} m/s: weak "
                "compressibility is lost; raise fluid.sph.sound_speed"
            )

    def _weigh_step_forces(self, weight: float, first: bool) -> None:
        """Add `weight` x the last right-hand side's forces on the external particles
        (:attr:`reaction`) and, under ``boundary_force = "momentum_exchange"``, on the wall
        patches (:attr:`wall_exchange`) to their step means (``*_step``; `first`: start them):
        the integrator's weights of its right-hand sides in the velocity update."""
        pairs = []
        if self.ext_rows.size:
            pairs.append((self.reaction, self.reaction_step))
        if self.exchange_walls:
            pairs.append((self.wall_exchange, self.wall_exchange_step))
        for now, step in pairs:
            if first:
                np.multiply(now, weight, out=step)
            else:
                step += weight * now

    def dt_towards(self, t_end: float) -> float:
        """The next step (s) on the way to ``t_end``; the last one or two split the rest."""
        return step_towards(self.t, t_end, self.dt_next)

    def substeps(self, window: float) -> tuple[int, float]:
        """Split ``window`` (s) into n equal steps no longer than the stable dt."""
        return split_window(window, self.dt_next)

    # ------------------------------------------------------------------ state
    def state(self) -> dict[str, np.ndarray]:
        """Arrays that, with :meth:`meta`, restore the solver bit for bit (views)."""
        arrays = {
            "pos": self.pos,
            "vel": self.vel,
            "p": self.p,
            "rho": self.rho,
            "acc": self.acc,
            "drho": self.drho,
            "patch_impulse": self.patch_impulse,
        }
        if self.ext_rows.size:  # coupled: the forces read after a restore
            arrays["reaction"] = self.reaction
            arrays["reaction_step"] = self.reaction_step
        if self.exchange_walls:  # the walls' forces read after a restore, the leapfrog's start
            arrays["wall_exchange"] = self.wall_exchange
            arrays["wall_exchange_step"] = self.wall_exchange_step
        if self.budget.full:  # the ledger, and the split the next first kick reuses
            arrays["budget_ledger"] = self.budget.ledger
            arrays["budget_split"] = self.budget.split
            arrays["budget_wall_force"] = self.budget.wall_force
        if self.pressure_ledger is not None:
            arrays["attached_pressure"] = self.pressure_ledger.ledger
        return arrays

    def attach_pressure_ledger(self, ledger: probes.AttachedPressureLedger) -> None:
        """Accumulate the attached pressure probes' impulses every step from now on; call
        before :meth:`restore` (its ``ledger`` array is then part of :meth:`state`)."""
        self.pressure_ledger = ledger if ledger.probes else None

    def meta(self) -> dict:
        return {
            "t": self.t,
            "step": self.step_count,
            "dt_next": self.dt_next,
            "force_marks": {k: list(v) for k, v in self.force_marks.items()},
            "max_speed": self.max_speed,
        }

    def restore(self, arrays: dict[str, np.ndarray], meta: dict, preconditioner=None) -> None:
        """Set the state from :meth:`state` and :meth:`meta` (copied in)."""
        for name, dst in self.state().items():
            if name not in arrays:
                raise ValueError(f"checkpoint lacks the δ-SPH array {name!r}")
            src = arrays[name]
            if src.shape != dst.shape:
                raise ValueError(
                    f"checkpoint array {name} has shape {src.shape}, the scenario gives "
                    f"{dst.shape}: the checkpoint belongs to another scenario"
                )
            dst[...] = src
        self.t = float(meta["t"])
        self.step_count = int(meta["step"])
        self.dt_next = float(meta["dt_next"])
        self.max_speed = float(meta.get("max_speed", 0.0))
        self.force_marks = {k: list(v) for k, v in meta.get("force_marks", {}).items()}
        # undriven external patches stay where the state put them
        self._ext_pos1[...] = self.pos[self.ext_rows]
        self._ext_vel1[...] = self.vel[self.ext_rows]

    def preconditioner_state(self) -> None:
        """δ-SPH is explicit: no reused solver data."""
        return None

    def preconditioner_arrays(self) -> tuple[dict[str, np.ndarray], dict]:
        return {}, {}

    def load_preconditioner_arrays(self, arrays: dict[str, np.ndarray], meta: dict | None) -> None:
        """Nothing to load (explicit method)."""

    # ------------------------------------------------------------------ forces and probes
    def boundary_force(self, names: Sequence[str]) -> np.ndarray:
        """Force of the fluid on the named wall patches, N (N/m in 2D): the pressure integral
        -sum p_i l0^(d-1) n_i over each wall's first layer (thesis eq. 2-51, extrapolated
        dummy pressures); with fluid.boundary_force = "momentum_exchange" the pair exchange
        with the patch's particles over the last step (:attr:`wall_exchange_step`; an external
        patch's :attr:`reaction_step`), exactly the momentum the fluid lost at it / dt."""
        f = np.zeros(self.dim)
        for name in names:
            pt = next(pt for pt in self.patches if pt.name == name)
            if self.exchange_walls:
                if pt.spec is None:
                    f += self.reaction_step[self.ext_slot[pt.start : pt.stop]].sum(axis=0)
                else:
                    f += self.wall_exchange_step[self._patch_index[name]]
                continue
            f += probes.patch_force(
                self.p, self.normal, pt.start, pt.stop, self.kind, self.l0 ** (self.dim - 1)
            )
        return f

    def mean_boundary_force(self, key: str, names: Sequence[str]) -> np.ndarray:
        """:meth:`boundary_force` on ``names`` averaged since the last call with ``key`` (a
        probe's name), N (N/m in 2D): the impulse booked step by step (step-end force x dt)
        over that interval divided by its length; the current force at a first call or at the
        same time (as MPS's ``mean_boundary_force``). Impulses are booked from the first call
        on."""
        impulse = sum(self.patch_impulse[self._patch_index[n]] for n in names)
        mark = self.force_marks.get(key)
        self.force_marks[key] = [self.t, *np.asarray(impulse).tolist()]
        if mark is None or not self.t > mark[0]:
            return self.boundary_force(names)
        return (impulse - np.array(mark[1:])) / (self.t - mark[0])

    def probe_value(self, probe) -> float | np.ndarray:
        """Current value of a fluid probe (definitions in ``fluid_mps.probes``)."""
        l0 = self.l0
        if probe.kind == "pressure":
            return probes.pressure_at(
                self.pos, self.p, self.kind, np.asarray(probe.position, float), probe.radius or l0
            )
        if probe.kind == "wave_gauge":
            up = self.spec.vertical_axis
            where = np.asarray(probe.position, float)
            if probe.method == "top_particle":
                hw = probe.half_width or 0.5 * l0
                h = probes.surface_height(self.pos, self.kind, where, hw, up, l0)
            else:
                if self._gauge_work is None:
                    self._gauge_work = np.empty(self.n, np.int64)
                h = probes.surface_height_kernel(self.pos, self.kind, where, up, l0,
                                                 self._gauge_work)  # fmt: skip
            return h - probe.reference_level
        if probe.kind == "front":
            link = probe.link_distance * l0
            nb = build_neighbours(self.pos, link, domain=(self.lower, self.upper))
            if self._uf_parent is None:
                self._uf_parent = np.empty(self.n, np.int64)
                self._uf_size = np.empty(self.n, np.int64)
            return probes.front_position(
                self.pos, self.kind, nb.indptr, nb.indices, link, probe.axis,
                probe.min_cluster_fraction, l0, self._uf_parent, self._uf_size,
            )  # fmt: skip
        if probe.kind == "force":
            if probe.average:
                return self.mean_boundary_force(probe.name, [probe.target])
            return self.boundary_force([probe.target])
        if probe.kind == "energy":
            return np.array(probes.fluid_energy(self.pos, self.vel, self.kind, self.mass,
                                                self.gravity))  # fmt: skip
        raise ValueError(f"probe kind {probe.kind!r} is not a fluid probe")
