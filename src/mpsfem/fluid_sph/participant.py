"""The δ-SPH fluid as a participant of the coupler (protocol of ``mpsfem.coupler.participant``).

:class:`SPHParticipant` wraps a :class:`~mpsfem.fluid_sph.solver.DeltaSPHSolver` whose structure
members (2D beams) are moving dummy walls of the δ-SPH scheme. The layout is MPS's, which is
method-neutral: :class:`~mpsfem.fluid_mps.structure_surface.StructureSurface` lays each face's
virtual solid (as many layers as the Wendland support 2h needs) and moves it with the coupler's
displacement (rigid cross-sections), :class:`~mpsfem.fluid_mps.thin_member.ThinMemberFilter`
keeps the fluid on each face from seeing the other face's layers.

Structure particles are walls like the rigid ones: their pressure is Adami's extrapolation from
the fluid around them with the wall's own acceleration (Adami, Hu & Adams 2012, eq. 27; the
acceleration is (v_end - v_start) / dt of the written velocities), free slip (no viscous pair
force), no density diffusion into them.

Data (SI; 2D forces per unit width):

* interface: the structure's pressure-layer particles on both faces (and end caps) in the
  reference configuration, normals out of the structure (a point cloud), as for MPS;
* written: ``"displacement"`` (m) and ``"velocity"`` (m/s) at those points for the end of the
  next ``advance``; over the step the particles move linearly from where they were;
* read: ``"forces"``, the force of the fluid on the structure at each interface point over the
  last step (N/m in 2D): minus the pressure pair forces the fluid received from the point and
  from the dummies of its column (``delta_sph.wall_reaction``), averaged over the step with the
  integrator's weights, so that dt times their sum is exactly the momentum the fluid lost to the
  member in the step. Before the first step: the reaction of the initial right-hand side.
  With ``fluid.sph.structure_load = "normal"`` (default) each point's force is that exchange
  projected on the point's current normal (face points on the face normal, end-cap points on
  the cap's): the members are free-slip walls of an
  inviscid fluid, which push normal to their faces, and the exchange's tangential part is the
  discretisation's (the one-sided kernel support along a face where the pressure varies along
  it, worst in the floor corner of a member standing on the floor; it put a net upward load on
  the elastic obstacle during its impact, docs/validation_delta_sph_coupled.md "Axial load").
  Corner points (face and cap) split it into the face-normal part and the cap-normal part, and
  the cap-normal part of corners and end-cap points may only push: water leaving a free end
  pulled it with δ-SPH's negative pressures (-5 to -18 kPa at the elastic obstacle's tip as the
  surge passed over it; the fluid has no cavitation or ventilation there, MPS clamps negative
  pressures). The dropped parts are then not booked to the member (the fluid's momentum still
  lost them): ``"exchange"`` hands over the whole exchange (the behaviour before the key).

``checkpoint()`` / ``restore()`` copy the solver's state (an explicit method: nothing else is
reused), the written inputs and the member impulses of the force probes; restored steps repeat
bit for bit.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.fluid_mps.geometry import default_dummy_layers
from mpsfem.fluid_mps.structure_surface import InterfaceMotionInputs, StructureSurface
from mpsfem.fluid_mps.thin_member import ThinMemberFilter
from mpsfem.fluid_sph.solver import DeltaSPHSolver, SPHRunError
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.fluid_sph import DeltaSPHSection

__all__ = ["SPHParticipant"]


class SPHParticipant(InterfaceMotionInputs):
    """The δ-SPH fluid around 2D beam members, for the coupler.

    Parameters as :class:`mpsfem.fluid_mps.participant.FluidParticipant`: ``fluid`` the
    ``[fluid]`` section (``method = "delta-sph"``), ``structure_interface`` the structure's
    ``interface()``, ``base_dir`` the scenario's folder, ``member_names`` in interface order,
    ``free_ends`` per member (default: from the rigid walls).
    """

    #: a broken δ-SPH state condemns the iterate, not the run (the scheme retries a smaller step)
    iterate_errors = (SPHRunError,)

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
        mesh = as_interface_mesh(structure_interface)
        if mesh.dim != 2 or fluid.dim != 2:
            raise ValueError(
                f"fluid.method = 'delta-sph' couples to 2D beam members only (structure "
                f"interface {mesh.dim}D, fluid.dim = {fluid.dim}); 3D plates need "
                "fluid.method = 'mps'"
            )
        if fluid.dummy_layers is None:  # the structure's layers fill the Wendland support 2h
            sph = fluid.sph if fluid.sph is not None else DeltaSPHSection()
            layers = default_dummy_layers(2.0 * sph.smoothing_ratio)
            fluid = fluid.model_copy(update={"dummy_layers": layers - 1})
        self.spec = fluid
        self.surface = StructureSurface(mesh, fluid, member_names, free_ends)
        self.filter = ThinMemberFilter(self.surface)  # the solver binds it to its particles
        self.solver = DeltaSPHSolver(
            fluid, base_dir, external=self.surface.patches(), neighbour_filter=self.filter
        )
        s = self.solver
        self._mesh = self.surface.interface_mesh()
        n = self.surface.n_interface
        self._d = np.zeros((n, 2))
        self._v = np.zeros((n, 2))
        # each structure particle's slot in the solver's reaction rows, and the interface
        # point whose force it adds to (itself, or the face particle of its column)
        slot = s.ext_slot[self.surface.index]
        if (slot < 0).any():
            raise RuntimeError("a structure particle is not an external row of the δ-SPH fluid")
        loc_of_if = np.full(len(self.surface.index), -1, dtype=np.int64)
        loc_of_if[self.surface.interface_local] = np.arange(n)
        target = np.where(
            self.surface.is_interface, loc_of_if, loc_of_if[self.surface.follow]
        ).astype(np.int64)
        if (target < 0).any():
            raise RuntimeError("a structure dummy follows no interface point")
        self._slot = slot
        self._target = target
        sph = fluid.sph if fluid.sph is not None else DeltaSPHSection()
        #: solver rows of the interface points (their current normals), and which of them are
        #: projected on it: face-only or cap-only points, not corners (structure_load "normal")
        self._if_rows = self.surface.interface_index
        n_ref = self.surface.interface_normals
        frame_n = np.array([self.surface.frames[m].normal for m in self.surface.interface_member])
        frame_t = np.array([self.surface.frames[m].tangent for m in self.surface.interface_member])
        along = np.maximum(
            np.abs(np.einsum("ka,ka->k", n_ref, frame_n)),
            np.abs(np.einsum("ka,ka->k", n_ref, frame_t)),
        )
        normal_load = sph.structure_load in ("normal", "normal_pairs")
        #: "normal_pairs": the projection lives in the solver's pair kernels (fluid and member
        #: alike); "normal": in :meth:`_forces`, on the step's whole exchange (member only)
        self._in_kernel = sph.structure_load == "normal_pairs"
        self._project = along > 1.0 - 1e-9 if normal_load else np.zeros(n, dtype=bool)
        #: end-cap points (cap only) and corners (face and cap) of free ends: their cap
        #: component may only push (structure_load "normal"); a corner's face and cap unit
        #: vectors in the reference configuration
        self._cap_only = self._project & (np.abs(np.einsum("ka,ka->k", n_ref, frame_t)) > 0.5)
        self._corner = ~(along > 1.0 - 1e-9) if normal_load else np.zeros(n, dtype=bool)
        c = self._corner
        self._n_ref = n_ref[c]
        self._face_ref = np.sign(np.einsum("ka,ka->k", n_ref[c], frame_n[c]))[:, None] * frame_n[c]
        self._cap_ref = np.sign(np.einsum("ka,ka->k", n_ref[c], frame_t[c]))[:, None] * frame_t[c]
        names = self.surface.names
        self._member_of_if = self.surface.interface_member
        #: impulse (N s; N s/m in 2D) of each member's fluid force since t = 0, for the probes'
        #: interval means, and the probes' marks (time, impulse at the last sample)
        self.impulse = np.zeros((len(names), 2))
        self.force_marks: dict[str, list[float]] = {}
        self._ckpt: dict | None = None
        self.times = {"place": 0.0, "filter": 0.0, "forces": 0.0}
        self.surface.place(s, self._d, self._v)  # the normals' rows; positions unchanged
        if self._in_kernel:  # each structure particle's group is its interface point
            slot_group = np.full(s.ext_rows.size, -1, dtype=np.int64)
            slot_group[slot] = target
            s.project_external(slot_group, n)
            s.ext_push[self._cap_only, 1] = True  # an end cap is pushed, never pulled
            s.ext_push[self._corner, 1] = True
            self._set_directions()
            s.rhs()  # the initial right-hand side again, projected
            s.reaction_step[...] = s.reaction

    # ------------------------------------------------------------------ protocol
    def interface(self) -> InterfaceMesh:
        """Pressure-layer particles of every member face, reference configuration."""
        return self._mesh

    def read(self, name: str) -> np.ndarray:
        """``"forces"``: fluid on structure at the interface points over the last step, N/m."""
        if name != "forces":
            raise KeyError(f"the fluid has no {name!r}; readable: 'forces'")
        tic = time.perf_counter()
        f = self._forces()
        self.times["forces"] += time.perf_counter() - tic
        return f

    def _corner_axes(self) -> tuple[np.ndarray, np.ndarray]:
        """The corner points' current face and cap unit vectors: their reference ones turned by
        the angle from the reference normal to the current one."""
        k = self._corner
        cur = self.solver.normal[self._if_rows[k]]  # the reference normal turned by theta
        cos = np.einsum("ka,ka->k", self._n_ref, cur)
        sin = self._n_ref[:, 0] * cur[:, 1] - self._n_ref[:, 1] * cur[:, 0]
        face, cap = (
            np.c_[cos * u[:, 0] - sin * u[:, 1], sin * u[:, 0] + cos * u[:, 1]]
            for u in (self._face_ref, self._cap_ref)
        )
        return face, cap

    def _axes(self) -> np.ndarray:
        """Per interface point (n_interface, 2, 2) the unit vectors its force is projected on,
        from the current normals: a face point its normal and zero, an end-cap point zero and its
        cap normal, a corner its face and cap normals; zero for a point not projected. The
        second one's component may only push (structure_load "normal" and "normal_pairs")."""
        e = np.zeros((self.surface.n_interface, 2, 2))
        cur = self.solver.normal[self._if_rows]
        face_only = self._project & ~self._cap_only
        e[face_only, 0] = cur[face_only]
        e[self._cap_only, 1] = cur[self._cap_only]
        if self._corner.any():
            e[self._corner, 0], e[self._corner, 1] = self._corner_axes()
        return e

    def _set_directions(self) -> None:
        """structure_load = "normal_pairs": the solver's projection vectors of every interface
        point for the next step (:meth:`_axes`, at the end of the step, as the placed
        particles)."""
        self.solver.ext_dir[...] = self._axes()

    def _forces(self) -> np.ndarray:
        """Per interface point, the step-mean reaction of its own particle and its dummies."""
        r = self.solver.reaction_step[self._slot]
        n = self.surface.n_interface
        f = np.stack(
            [np.bincount(self._target, weights=r[:, a], minlength=n) for a in range(2)], axis=1
        )
        if self._in_kernel:  # "normal_pairs": the reactions are projected and gated already
            return f
        k = self._project | self._corner
        if k.any():  # "normal": free slip, f = sum_e (f . e) e over the point's axes
            e = self._axes()[k]
            c = np.einsum("kea,ka->ke", e, f[k])
            c[:, 1] = np.minimum(c[:, 1], 0.0)  # an end cap is pushed, never pulled
            f[k] = np.einsum("ke,kea->ka", c, e)
        return f

    def advance(self, dt: float) -> float:
        """Move the structure particles to the written state over one δ-SPH step of ``dt``."""
        tic = time.perf_counter()
        self.surface.place(self.solver, self._d, self._v)
        if self._in_kernel:
            self._set_directions()
        self.times["place"] += time.perf_counter() - tic
        self.solver.step(dt)
        self.times["filter"] = self.filter.seconds
        f = self._forces()
        for m in range(len(self.impulse)):
            self.impulse[m] += dt * f[self._member_of_if == m].sum(axis=0)
        return dt

    def max_dt(self) -> float:
        """The solver's next stable step (acoustic, force and viscous limits, dt_max), s."""
        return float(self.solver.dt_next)

    def checkpoint(self) -> None:
        """Keep a copy of the full state for :meth:`restore`."""
        self._ckpt = {
            k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in self.state().items()
        }

    def restore(self) -> None:
        """Return to the last :meth:`checkpoint`."""
        if self._ckpt is None:
            raise RuntimeError("restore() before any checkpoint()")
        self.load_state(self._ckpt)

    # ------------------------------------------------------------------ disk state
    def state(self) -> dict:
        """Arrays and numbers that restore this participant exactly (views, not copies)."""
        s = self.solver
        meta = s.meta()
        return {
            **s.state(),
            "d": self._d,
            "v": self._v,
            "member_impulse": self.impulse,
            "t": meta["t"],
            "step": meta["step"],
            "dt_next": meta["dt_next"],
            "max_speed": meta["max_speed"],
            "force_marks": {k: list(v) for k, v in s.force_marks.items()},
            "member_force_marks": {k: list(v) for k, v in self.force_marks.items()},
        }

    def load_state(self, state: dict) -> None:
        """Inverse of :meth:`state` (copies the arrays in)."""
        self.solver.restore(state, state)
        self._d = np.array(state["d"], dtype=np.float64)
        self._v = np.array(state["v"], dtype=np.float64)
        self.impulse[...] = state["member_impulse"]
        self.force_marks = {k: list(v) for k, v in state.get("member_force_marks", {}).items()}

    # ------------------------------------------------------------------ extras
    @property
    def time(self) -> float:
        return self.solver.t

    def member_force(self, member: str) -> np.ndarray:
        """Total fluid force on ``member`` over the last step, both faces (N/m in 2D)."""
        m = self.surface.names.index(member)
        return self._forces()[self._member_of_if == m].sum(axis=0)

    def mean_member_force(self, key: str, member: str) -> np.ndarray:
        """:meth:`member_force` averaged since the last call with ``key`` (a probe's name): the
        impulse over that interval divided by its length; the current force at a first call."""
        m = self.surface.names.index(member)
        mark = self.force_marks.get(key)
        t = self.solver.t
        self.force_marks[key] = [t, *self.impulse[m].tolist()]
        if mark is None or not t > mark[0]:
            return self.member_force(member)
        return (self.impulse[m] - np.array(mark[1:])) / (t - mark[0])

    def probe_value(self, probe):
        """A fluid probe's value; ``force`` probes may target a structure member."""
        if probe.kind == "force" and probe.target in self.surface.names:
            if probe.average:
                return self.mean_member_force(probe.name, probe.target)
            return self.member_force(probe.target)
        return self.solver.probe_value(probe)
