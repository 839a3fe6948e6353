"""The MPS fluid as a participant of the coupler (protocol of ``mpsfem.coupler.participant``).

:class:`FluidParticipant` wraps a :class:`~mpsfem.fluid_mps.solver.FluidSolver` whose structure
members are boundary particles laid by :class:`~mpsfem.fluid_mps.structure_surface.
StructureSurface` (2D beams) or :class:`~mpsfem.fluid_mps.plate_surface.PlateSurface` (3D
plates) and kept apart across members by :class:`~mpsfem.fluid_mps.thin_member.
ThinMemberFilter` / :class:`~mpsfem.fluid_mps.thin_plate.ThinPlateFilter`.

Data (SI; 2D forces per unit width, 3D forces in N):

* interface: the structure's pressure-layer particles on both faces (and end caps) in the
  reference configuration, normals out of the structure (``cells`` empty: a point cloud);
* written: ``"displacement"`` (m) and ``"velocity"`` (m/s) at those points, the values for the
  end of the next ``advance``; dummies follow by the rigid link of their column;
* read: ``"forces"``, the force of the fluid on the structure at each interface point in the
  last step (N; N/m in 2D): with ``fluid.boundary_force = "momentum_exchange"`` the reaction
  to the step's pair interactions with the point and the dummies behind it
  (momentum_budget.py), with ``"pressure_integral"`` F_i = -p_i A_i n_i (thesis eq. 2-51;
  zero on dry particles).

``advance(dt)`` places the structure particles (``FluidSolver.set_patch_state``) and takes one
MPS step of exactly ``dt``; ``max_dt()`` is the solver's next stable step. ``checkpoint()`` /
``restore()`` copy the particle state, the time, the step count, the next dt and the written
inputs, and keep the pressure solver's preconditioner of that moment, which a restore
reinstates, so restored steps repeat bit for bit whatever happened in between. The free-surface
and dry flags of the steps after a ``checkpoint()`` are recorded and replayed after each ``restore()`` (``surface_freeze.py``;
``fluid.surface.freeze_in_coupling_window``).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.fluid_mps import wall_boundary
from mpsfem.fluid_mps.plate_surface import PlateSurface
from mpsfem.fluid_mps.solver import FluidRunError, FluidSolver
from mpsfem.fluid_mps.structure_surface import InterfaceMotionInputs, StructureSurface
from mpsfem.fluid_mps.surface_freeze import SurfaceFreeze
from mpsfem.fluid_mps.thin_member import ThinMemberFilter
from mpsfem.fluid_mps.thin_plate import ThinPlateFilter
from mpsfem.scenario.fluid import FluidSection

__all__ = ["FluidParticipant"]


class FluidParticipant(InterfaceMotionInputs):
    """The MPS fluid around structure members (2D beams or 3D plates), for the coupler.

    Parameters
    ----------
    fluid:
        The ``[fluid]`` section.
    structure_interface:
        The structure participant's ``interface()`` (reference mid-lines, geometric thickness).
    base_dir:
        Folder of the scenario (relative files of wall motions).
    member_names:
        Member names in interface order (patches ``<name>+`` / ``<name>-``, force probes).
    free_ends:
        2D: per member (free at the first node, free at the last); 3D: per plate, four flags
        (edges s1 = 0, s1 = L1, s2 = 0, s2 = L2); default: from the rigid walls.
    """

    #: errors of a fluid window that condemn the iterate it was given, not the run: the implicit
    #: scheme retries a smaller step (coupler.coupling_scheme, RETREAT)
    iterate_errors = (FluidRunError,)

    name = "fluid"

    def __init__(
        self,
        fluid: FluidSection,
        structure_interface,
        *,
        base_dir: Path | None = None,
        member_names: Sequence[str] | None = None,
        free_ends: Sequence[tuple[bool, bool]] | None = None,
    ) -> None:
        self.spec = fluid
        mesh = as_interface_mesh(structure_interface)
        if mesh.dim != fluid.dim:
            raise ValueError(
                f"the structure interface is {mesh.dim}D but fluid.dim = {fluid.dim}: beams "
                "(2D) need a 2D fluid, plates (3D) a 3D fluid"
            )
        if mesh.dim == 3:
            self.surface = PlateSurface(mesh, fluid, member_names, free_ends)
            self.filter = ThinPlateFilter(self.surface)
        else:
            self.surface = StructureSurface(mesh, fluid, member_names, free_ends)
            self.filter = ThinMemberFilter(self.surface)
        self.solver = FluidSolver(
            fluid, base_dir, external=self.surface.patches(), neighbour_filter=self.filter
        )
        self.surface.bind(self.solver)
        self.freeze = SurfaceFreeze(fluid.surface.freeze_rule)
        if fluid.surface.freeze_in_coupling_window:
            self.solver.surface_freeze = self.freeze
        self.filter.bind(self.solver)
        self._mesh = self.surface.interface_mesh()
        n = self.surface.n_interface
        self._d = np.zeros((n, self.solver.dim))
        self._v = np.zeros((n, self.solver.dim))
        self._ckpt: dict | None = None
        self._ckpt_preconditioner: dict | None = None
        #: wall time (s) of the fluid side's coupling work: placing the structure particles,
        #: the neighbour filter (inside the MPS step), the force evaluation
        self.times = {"place": 0.0, "filter": 0.0, "forces": 0.0}
        if fluid.hydrostatic_start:
            self._initial_structure_pressure()
        if self.solver.exchange:  # the load before the first step, through the filter
            self.solver.evaluate_exchange()

    # ------------------------------------------------------------------ set-up
    def _initial_structure_pressure(self) -> None:
        """Pressure of the structure particles at t0 from the hydrostatic fluid around them
        (``wall_boundary.wall_pressure`` over the filtered neighbours), so that the forces the
        coupler reads before the first step are the hydrostatic load."""
        s = self.solver
        nb = self.filter(s.search.build(s.pos), s.pos, s.kind)
        p = s.p.copy()
        dry = np.zeros(s.n, dtype=np.int8)
        wall_boundary.wall_pressure(
            s.pos,
            p,
            s.kind,
            dry,
            nb.indptr,
            nb.indices,
            s.re_n,
            s.wcode,
            s.rho,
            s.gravity,
            s.wall_acc,
            s.n_fluid,
            s.structure_floor,
        )
        idx = self.surface.index
        s.p[idx] = p[idx]

    # ------------------------------------------------------------------ protocol
    def interface(self) -> InterfaceMesh:
        """Pressure-layer particles of every member face, reference configuration."""
        return self._mesh

    def read(self, name: str) -> np.ndarray:
        """``"forces"``: fluid on structure at the interface points, N (N/m in 2D)."""
        if name != "forces":
            raise KeyError(f"the fluid has no {name!r}; readable: 'forces'")
        tic = time.perf_counter()
        s = self.solver
        rows = self.surface.interface_index - s.n_fluid
        if s.budget.model == "momentum_exchange":
            f = s.budget.exchange_force[rows].copy()
        else:
            f = self.surface.forces(s.p)
            if s.budget.model == "pressure_and_contact":
                f += s.budget.contact_force[rows]
        self.times["forces"] += time.perf_counter() - tic
        return f

    def advance(self, dt: float) -> float:
        """Move the structure particles to the written state and take one MPS step of ``dt``."""
        tic = time.perf_counter()
        self.surface.place(self.solver, self._d, self._v)
        self.times["place"] += time.perf_counter() - tic
        self.solver.step(dt)
        self.times["filter"] = self.filter.seconds
        return dt

    def max_dt(self) -> float:
        """The solver's next stable step (Courant and viscous limits, capped at dt_max), s."""
        return float(self.solver.dt_next)

    def checkpoint(self) -> None:
        """Keep a copy of the full state for :meth:`restore`."""
        self._ckpt = {
            k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in self.state().items()
        }
        self._ckpt_preconditioner = self.solver.preconditioner_state()  # by reference
        self.freeze.start()  # a new window: its first iteration decides the discrete flags

    def restore(self) -> None:
        """Return to the last :meth:`checkpoint`."""
        if self._ckpt is None:
            raise RuntimeError("restore() before any checkpoint()")
        self.load_state(self._ckpt)
        # the repeated steps reuse the window's first preconditioner too, as a run resumed from
        # a checkpoint file does: every replay and every restart then computes the same numbers
        self.solver.pressure.set_preconditioner_state(self._ckpt_preconditioner)
        self.freeze.rewind()  # the repeated steps reuse the first iteration's flags

    # ------------------------------------------------------------------ disk state
    def state(self) -> dict:
        """Arrays and numbers that restore this participant exactly (views, not copies)."""
        s = self.solver
        return {
            **s.state(),
            "d": self._d,
            "v": self._v,
            "t": s.t,
            "step": s.step_count,
            "dt_next": s.dt_next,
            "force_marks": {k: list(v) for k, v in s.force_marks.items()},
        }

    def load_state(self, state: dict) -> None:
        """Inverse of :meth:`state` (copies the arrays in; the solver's part through
        :meth:`FluidSolver.restore`, with a fresh preconditioner: a resumed run then loads the
        checkpoint's one, ``FluidSolver.load_preconditioner_arrays``)."""
        self.solver.restore(state, state)
        self._d = np.array(state["d"], dtype=np.float64)
        self._v = np.array(state["v"], dtype=np.float64)

    # ------------------------------------------------------------------ extras
    @property
    def time(self) -> float:
        return self.solver.t

    def member_force(self, member: str) -> np.ndarray:
        """Total fluid force on ``member`` in the last step, both faces, as
        ``fluid.boundary_force`` defines it (N/m in 2D)."""
        if self.solver.budget.model == "pressure_integral":
            return self.surface.member_force(self.solver.p, member)
        return self.solver.boundary_force(self._sides(member))

    def _sides(self, member: str) -> list[str]:
        """The member's patches (``<name>+``, ``<name>-``)."""
        return [n for n in self.solver.budget.names if n[:-1] == member]

    def probe_value(self, probe):
        """A fluid probe's value; ``force`` probes may target a structure member (with
        ``average`` the mean force since the probe's last sample, as for walls)."""
        if probe.kind == "force" and probe.target in self.surface.names:
            if probe.average:
                return self.solver.mean_boundary_force(probe.name, self._sides(probe.target))
            return self.member_force(probe.target)
        return self.solver.probe_value(probe)
