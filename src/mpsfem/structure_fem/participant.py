"""The structure participant of the coupler protocol (design brief): interface, write, read,
advance, max_dt, checkpoint and restore.

The coupler sees one set of interface points: the nodes of every member, concatenated in the
order of ``[[structure.members]]`` (beam: centreline nodes from start to end; plate: mid-surface
mesh vertices). Data exchanged (SI units; in 2D per unit width):

* written: ``"forces"``, nodal forces at the interface points, shape (n_points, dim), in N (N/m in
  2D). Each is applied at its node as a point load (consistent with the nodal translation map, so
  no moment). A linear plate takes only the component along its normal (a von Karman plate all
  three), an inextensible beam (`axial = false`) only the one along its normal.
* read: ``"displacement"``, ``"velocity"``, ``"acceleration"`` (n_points, dim), translational;
  ``"rotation"`` (n_points, r): beams r = 1 (anticlockwise angle, rad), plates r = 2 (slopes
  dw/du, dw/dv along the plate axes; NaN for Morley members, which have no nodal slopes).

Co-rotational beams (``kinematics = "corotational"``) have global dofs (ux, uy, theta) per node:
"displacement" is then the true nodal translation in the scene frame however far the member
turns, "rotation" the total anticlockwise angle (not wrapped), and a written force acts on the
translation dofs of its node in the scene frame, on the deformed member (a dead load). Their
steps, and every step under ``scheme = "hht"``, are solved by Newton iterations
(:mod:`.alpha_method`); the static start by load-stepped Newton. A linear beam whose rotation
passes 0.1 rad warns once (:class:`LargeRotationWarning`, Python ``warnings``; a linear BFS plate
likewise when a slope passes tan 0.1, pointing to ``kinematics = "von_karman"``).

``advance(dt)`` integrates exactly `dt`: in ceil(dt / max_dt()) equal Newmark sub-steps, the
interface force rising linearly from the value of the previous window's end to the value just
written (one sub-step: the written value at the end of the step, as Newmark wants F(t + dt)).
The first ``"forces"`` written before any ``advance`` are the initial data (the coupler's
``initialize`` writes the fluid load at t = 0, as preCICE's initial data): the start state is
rebuilt under them (initial acceleration from equilibrium, M a0 = F0 - K u0; the static start
solves K u0 = F0 with them included), and they are the window-start value of the first window.
Self-weight acts always; the scenario's prescribed loads only when the participant is built with
``prescribed_loads=True`` (standalone runs).

Support motion (``[structure.members.motion]``, :mod:`mpsfem.scenario.motion`): a moving member
is solved in its frame, which translates rigidly by r(t): the elastic displacement u_e obeys the
member's equations with the inertial load -M a_frame(t) added (the consistent load of the body
force -rho a_frame per unit volume, exact for a translation; computed as the member's
self-weight load under "gravity" -a_frame). Everything the participant reports is absolute:
``read("displacement")`` = r(t) + u_e, ``"velocity"`` = r'(t) + u_e', ``"acceleration"`` =
a_frame + u_e'' at the interface points, and so the members' records and displacement probes;
the energies (:meth:`energy`) are those of the elastic motion relative to the frame.

The full state (u, v, a over the free dofs, the time, the step count, the interface force of the
window start and the last written forces; with Newton also the external load at t and the point
at which the kept Jacobian was formed) is what :meth:`checkpoint` copies and :meth:`restore`
puts back; a restored participant repeats its steps bit for bit.

Fictitious mass (members' ``fictitious_mass`` > 0, :mod:`.fictitious_mass`): every
:meth:`checkpoint` starts a coupling window; the steps after it solve (M + M_f) a^k + C v^k +
K u^k = F^k + M_f a^{k-1}, a^{k-1} the acceleration the same sub-step (counted from the
checkpoint) ended with in the previous iteration; :meth:`restore` keeps these accelerations
(they are not part of the state), the next checkpoint clears them. Before any checkpoint
(standalone runs) the steps are plain. With every ``fictitious_mass`` 0 nothing changes.
Members with ``fictitious_mass_nodes = "wet"`` carry M_f only on the window's wetted nodes,
decided at the window's first step (:func:`.fictitious_mass.wet_nodes`) from the interface load
at the checkpoint and the first forces written after it, and kept for the window's iterations
(``fictitious_wet_update = "grow"``: grown, never shrunk, by the nodes each later iterate's
forces wet; :meth:`fictitious_set_growths`); the fictitious factorisation is redone only when
that set changes (``fictitious_set_changes``). A window with no node in it steps plainly.
Members with ``fictitious_mass_model = "potential_flow"`` carry, on each run of consecutive
carrying nodes, ``fictitious_mass`` x the wetted patch's potential-flow added-mass operator
(a dense block, :mod:`.added_mass_potential`) for a fluid of ``fluid_density`` (kg/m^3, the
scenario's fluid.density, passed by the caller: structure_fem imports no fluid code).
:meth:`fictitious_force_error` reports the force the fictitious mass left in the member's
equation in the last iteration (the coupler's ``ForceErrorCriterion``).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from mpsfem.scenario.motion import RigidTranslation

from .alpha_method import NonlinearNewmark
from .fictitious_mass import (
    IterationHistory,
    fictitious_mass_matrix,
    tributary_measure,
    wet_nodes,
)
from .linsolve import factorize
from .newmark import Newmark, NewmarkState
from .newton import NewtonFailure
from .system import StructureSystem

__all__ = ["Interface", "LargeRotationWarning", "StructureParticipant"]

READABLE = ("displacement", "velocity", "acceleration", "rotation")
WRITABLE = ("forces",)

#: rotation (rad) beyond which a linear beam warns that it has left small-rotation theory
LINEAR_ROTATION_LIMIT = 0.1


def _rms(a: np.ndarray) -> float:
    """Root mean square of the entries (0 for none)."""
    return math.sqrt(float(a @ a) / a.size) if a.size else 0.0


class LargeRotationWarning(UserWarning):
    """A member with ``kinematics = "linear"`` rotates beyond :data:`LINEAR_ROTATION_LIMIT`
    (a beam's nodal angle, a BFS plate's slope angle atan(dw/du), atan(dw/dv))."""


@dataclass(frozen=True)
class Interface:
    """Interface mesh of the structure participant (reference configuration).

    points, normals: (n_points, dim); thickness, geometric_thickness: (n_points,) structural and
    fluid-visible thickness of the member each point belongs to; member: (n_points,) index into
    member_names; cells: per member, its elements as rows of global point indices (beam: 2-node
    segments; BFS plate: 4-node quadrilaterals, anticlockwise about the normal; Morley plate:
    3-node triangles); slices: per member name, its range of points.
    """

    dim: int
    points: np.ndarray
    normals: np.ndarray
    thickness: np.ndarray
    geometric_thickness: np.ndarray
    member: np.ndarray
    member_names: tuple[str, ...]
    cells: tuple[np.ndarray, ...]
    slices: dict[str, slice] = field(default_factory=dict)

    @property
    def n_points(self) -> int:
        return self.points.shape[0]


class StructureParticipant:
    """Structure participant for the coupler; also the engine of standalone runs.

    Parameters
    ----------
    structure:
        The ``[structure]`` section (:class:`~mpsfem.scenario.structure.StructureSection`) or a
        root scenario with a ``structure`` attribute.
    prescribed_loads:
        Apply the section's ``[[structure.loads]]`` (standalone runs); default False.
    base_dir:
        Folder against which relative CSV paths of table loads resolve (the scenario's folder).
    probes:
        Displacement probes: objects with ``name``, ``target`` (member) and ``position`` (the
        scenario's ``[[probes]]`` of kind "displacement"); each reads the displacement of the
        member point nearest ``position``. See :meth:`probe_values`.
    """

    #: errors of a step that condemn the coupling iterate (its forces), not the run: the
    #: implicit scheme retries a smaller step (coupler.coupling_scheme, RETREAT)
    iterate_errors = (NewtonFailure,)

    name = "structure"

    def __init__(
        self,
        structure,
        *,
        prescribed_loads: bool = False,
        base_dir: str | Path | None = None,
        probes=(),
        fluid_density: float | None = None,
    ) -> None:
        section = getattr(structure, "structure", structure)
        if section is None:
            raise ValueError("the scenario has no [structure] section")
        self.section = section
        self.system = StructureSystem(section, base_dir=base_dir)
        self.dim = self.system.dim
        self.use_prescribed = bool(prescribed_loads)
        t = section.time
        self.dt = float(t.dt)
        sysm = self.system
        # linear members under Newmark keep the linear integrator (one solve per step); a
        # co-rotational member or an alpha scheme (HHT, generalised-alpha) takes Newton iterations
        self.nonlinear = sysm.nonlinear or t.scheme != "newmark"
        # fictitious added mass (members' `fictitious_mass`; None: off) and the accelerations
        # of the previous coupling iteration, per sub-step of the window (:mod:`.fictitious_mass`)
        self._fm_masses = [cfg.fictitious_mass for cfg in section.members]
        self._fm_models = [cfg.fictitious_mass_model for cfg in section.members]
        self._fm_density = fluid_density
        shaped = [
            i
            for i, cfg in enumerate(section.members)
            if cfg.fictitious_mass > 0 and cfg.fictitious_mass_model == "potential_flow"
        ]
        if shaped and fluid_density is None:
            if not prescribed_loads:
                raise ValueError(
                    f"structure.members[{shaped[0]}].fictitious_mass_model = 'potential_flow' "
                    "needs the fluid density (StructureParticipant(fluid_density=...), the "
                    "scenario's fluid.density); none was given"
                )
            # standalone (prescribed loads): no coupling window, the fictitious mass never acts
            self._fm_masses = [0.0] * len(section.members)
        B = fictitious_mass_matrix(sysm, self._fm_masses, None, self._fm_models, fluid_density)
        self.fictitious = (
            None if B is None else IterationHistory(B, sysm.T, beta=t.beta, gamma=t.gamma)
        )
        # nodes that always carry M_f (members with fictitious_mass_nodes = "all") and those
        # that carry it only while wet ("wet"); the set in use; the cells that give the margin
        self._fm_always = np.zeros(sysm.n_points, dtype=bool)
        self._fm_if_wet = np.zeros(sysm.n_points, dtype=bool)
        # wet nodes whose set may grow inside a window (fictitious_wet_update = "grow")
        self._fm_grow = np.zeros(sysm.n_points, dtype=bool)
        for cfg, m in zip(section.members, sysm.models, strict=True):
            if cfg.fictitious_mass > 0:
                which = self._fm_always if cfg.fictitious_mass_nodes == "all" else self._fm_if_wet
                which[sysm.node_slices[m.name]] = True
                if cfg.fictitious_mass_nodes == "wet" and cfg.fictitious_wet_update == "grow":
                    self._fm_grow[sysm.node_slices[m.name]] = True
        self._fm_cells = [m.connectivity + sysm.node_slices[m.name].start for m in sysm.models]
        # elements by which each member's wet set is widened (fictitious_wet_margin)
        self._fm_margins = [cfg.fictitious_wet_margin for cfg in section.members]
        self._fm_measure = np.concatenate(
            [tributary_measure(m.nodes, m.connectivity) for m in sysm.models]
        )
        # members' fictitious_wet_pressure (Pa) x each node's tributary measure: the nodal load
        # (N) a node must exceed to count as wet; None: every member at 0 (any nonzero load)
        wet_p = np.concatenate(
            [
                np.full(m.n_nodes, cfg.fictitious_wet_pressure)
                for cfg, m in zip(section.members, sysm.models, strict=True)
            ]
        )
        self._fm_threshold = wet_p * self._fm_measure if wet_p.any() else None
        self._fm_nodes = self._fm_always.copy()
        self._fm_pending = False  # decide the wet set at the next step (a window started)
        self._fm_load_start = np.zeros((sysm.n_points, self.dim))  # load at the checkpoint
        self.fictitious_set_changes = 0
        self._fm_window_growths = 0  # times the set grew inside the current window
        Mf = self._install_fictitious_nodes(self._fm_nodes, build=False)
        if self.nonlinear:
            nw = section.newton
            self.integrator = NonlinearNewmark(
                sysm,
                beta=t.beta,
                gamma=t.gamma,
                alpha=t.alpha,
                alpha_m=t.alpha_m,
                tolerance=nw.tolerance,
                max_iterations=nw.max_iterations,
                reuse_ratio=nw.reuse_ratio,
                fictitious_mass=Mf,
            )
        else:
            self.integrator = Newmark(
                sysm.M,
                sysm.K,
                sysm.C,
                beta=t.newmark_beta,
                gamma=t.newmark_gamma,
                fictitious_mass=Mf,
            )
        if t.beta < (t.gamma + 0.5) ** 2 / 4.0 - 1e-12:
            self._check_conditional_stability()
        # linear members with nodal rotations (beams: the angle; BFS plates: the slopes
        # dw/du, dw/dv, an angle atan(slope)): their positions in the reduced vector, and the
        # kinematics that would take large rotations
        self._linear_rotations = []
        for m in sysm.models:
            if not m.nonlinear and m.rotation is not None:
                R = sp.csr_matrix(m.rotation)[:, m.free]
                idx = np.flatnonzero(np.asarray(abs(R).sum(axis=0)).ravel())
                remedy = "corotational" if m.dim == 2 else "von_karman"
                start = sysm.dof_slices[m.name].start
                self._linear_rotations.append((m.name, start + idx, m.dim == 3, remedy))
        self._warned: set[str] = set()
        self.probe_names: list[str] = []
        self._P_member: list[str] = []  # member of each displacement probe
        rows = []
        for pr in probes:
            if pr.target not in sysm.names:
                raise ValueError(
                    f"probe {pr.name!r}: target {pr.target!r} is not a structure member "
                    f"(members: {sysm.names})"
                )
            self.probe_names.append(pr.name)
            self._P_member.append(pr.target)
            rows.append(sysm.point_matrix(pr.target, pr.position))
        self._last_h = self.dt  # length of the last step (the table's frame acceleration)
        self._P = sp.vstack(rows, format="csr") if rows else sp.csr_matrix((0, sysm.n))
        # members with a prescribed rigid translation: (node slice, dof slice, motion law,
        # consistent load of a unit body acceleration along each scene axis over its free dofs)
        self._motions = []
        for i, (cfg, m) in enumerate(zip(section.members, sysm.models, strict=True)):
            if not cfg.motion.moves:
                continue
            law = RigidTranslation(
                cfg.motion, self.dim, base_dir, key=f"structure.members[{i}].motion"
            )
            unit = np.stack(
                [m.gravity_load(np.eye(self.dim)[k])[sysm.free_of(m.name)] for k in range(self.dim)]
            )
            self._motions.append(
                (sysm.node_slices[m.name], sysm.dof_slices[m.name], law, unit, m.name)
            )
        self._forces = np.zeros((sysm.n_points, self.dim))
        self._f_start = np.zeros(sysm.n)  # interface load at the start of the window
        self._f_new = np.zeros(sysm.n)  # interface load of the forces last written
        self._start(self._f_new)
        self._initial_data_pending = True  # the first forces written are the load at t = 0
        self._checkpoint: dict | None = None
        self._interface = self._build_interface()

    def _install_fictitious_nodes(self, nodes: np.ndarray, build: bool = True):
        """Put M_f on `nodes` (bool, (n_points,)): the IterationHistory's B, the dofs it acts on
        and (``build``) the integrator's M_f. Returns M_f over the free dofs (None: none)."""
        self._fm_nodes = nodes.copy()
        self._fm_B = None
        self._fm_rows = np.zeros(0, dtype=np.int64)
        self._fm_area = 0.0
        if self.fictitious is None:
            return None
        sysm = self.system
        B = fictitious_mass_matrix(sysm, self._fm_masses, nodes, self._fm_models, self._fm_density)
        self._fm_B = B
        Mf = None if B is None else (sysm.TT @ B @ sysm.T).tocsr()
        if Mf is not None:
            self._fm_rows = np.flatnonzero(np.asarray(abs(Mf).sum(axis=1)).ravel())
            # the node of each of those dofs (T^T's column of it), its tributary measure
            TT = sysm.TT.tocsr()[self._fm_rows]
            node = TT.indices[TT.indptr[:-1]] // self.dim
            self._fm_area = _rms(self._fm_measure[node])
        if B is not None:
            self.fictitious.set_mass(B)
        if build:
            self.integrator.set_fictitious_mass(Mf)
        return Mf

    def _decide_fictitious_nodes(self) -> None:
        """The window's wet set (members with fictitious_mass_nodes = "wet"): nodes with load at
        the checkpoint or in the forces now written, widened by each member's
        fictitious_wet_margin (elements; default one)."""
        self._fm_pending = False
        if not self._fm_if_wet.any():
            return
        wet = wet_nodes(
            [self._fm_load_start, self._forces],
            self._fm_cells,
            self.system.n_points,
            margin=self._fm_margins,
            threshold=self._fm_threshold,
        )
        nodes = self._fm_always | (wet & self._fm_if_wet)
        if not np.array_equal(nodes, self._fm_nodes):
            self._install_fictitious_nodes(nodes)
            self.fictitious_set_changes += 1

    def _grow_fictitious_nodes(self) -> None:
        """A later iterate of the window (fictitious_wet_update = "grow"): add the nodes its
        forces now wet (with the margin) to the window's set, never removing any, so the set
        and with it the fixed-point map change at most a finite number of times. The added
        nodes' a^{k-1} is the previous iterate's acceleration, as for every wet node (the
        IterationHistory keeps it over all dofs)."""
        wet = wet_nodes(
            [self._forces],
            self._fm_cells,
            self.system.n_points,
            margin=self._fm_margins,
            threshold=self._fm_threshold,
        )
        nodes = self._fm_nodes | (wet & self._fm_grow)
        if not np.array_equal(nodes, self._fm_nodes):
            self._install_fictitious_nodes(nodes)
            self.fictitious_set_changes += 1
            self._fm_window_growths += 1

    def fictitious_set_growths(self) -> int | None:
        """Optional coupler hook: how many times the wet set, and so the structure's
        fixed-point map, grew inside the current window so far (the coupler restarts its
        acceleration's window when it does and records the count); None when no member lets
        it grow (fictitious_wet_update = "window" everywhere, or no fictitious mass)."""
        if self.fictitious is None or not self._fm_grow.any():
            return None
        return self._fm_window_growths

    @property
    def fictitious_nodes(self) -> np.ndarray:
        """Interface points (bool, (n_points,)) carrying the fictitious mass in this window."""
        return self._fm_nodes.copy()

    def fictitious_force_error(self) -> tuple[float, float, float] | None:
        """Optional coupler hook (``ForceErrorCriterion``): (e, S, A) of the last iteration, e
        the largest over its sub-steps of rms(M_f (a^k - a^{k-1})) (with the iterate's shift)
        over the dofs M_f acts on, the force (N; N/m in 2D) by which the member's true equation
        M a + C v + K u = F is off, S the largest rms interface load on those dofs at the
        sub-steps' ends, A the rms tributary area (m^2; length in m in 2D) of their nodes.
        None when no fictitious mass acted (none, or no wet node)."""
        fm = self.fictitious
        if fm is None or not fm.active or self._fm_B is None or not fm.errors:
            return None
        return max(fm.errors), fm.load_scale, self._fm_area

    def _start(self, f_interface: np.ndarray) -> None:
        """Initial state at t = 0 under the prescribed loads plus the interface load
        ``f_interface`` (nodal, N): rest, or the static solution K u0 = F0; the acceleration from
        equilibrium, M a0 = F0 - K u0 (Newmark needs a0 consistent with the load at t0, else the
        first step puts a spurious free oscillation into an undamped member)."""
        F0 = self.external_load(0.0) + f_interface
        if self.section.initial_state == "static" and self.system.nonlinear:
            try:
                factorize(self.system.K.tocsc())  # supported against rigid motion at all?
                u0 = self.integrator.solve_static(
                    F0, increments=self.section.newton.static_increments
                )
            except np.linalg.LinAlgError as exc:
                raise ValueError(
                    'structure.initial_state = "static" needs every member supported against '
                    'rigid motion (give it supports in `bc`, or use "rest"): the tangent '
                    f"stiffness is singular: {exc}"
                ) from exc
            self.integrator.initialize(F0, u0=u0)
        elif self.section.initial_state == "static":
            try:
                u0 = factorize(self.system.K.tocsc()).solve(F0)
            except np.linalg.LinAlgError as exc:
                raise ValueError(
                    'structure.initial_state = "static" needs every member supported against '
                    'rigid motion (give it supports in `bc`, or use "rest"): the stiffness '
                    f"matrix is singular: {exc}"
                ) from exc
            self.integrator.initialize(F0, u0=u0)
        else:
            self.integrator.initialize(F0)
        self._f_start = f_interface.copy()

    # ------------------------------------------------------------------ protocol
    def interface(self) -> Interface:
        """Interface points, normals, thicknesses and cells (reference configuration)."""
        return self._interface

    def write(self, name: str, array: np.ndarray) -> None:
        """Hand data to the structure: ``"forces"`` (n_points, dim) nodal forces in N (N/m in 2D)."""
        if name not in WRITABLE:
            raise KeyError(f"structure participant cannot take {name!r}; it takes {WRITABLE}")
        arr = np.asarray(array, dtype=float)
        if arr.shape != self._forces.shape:
            raise ValueError(f"forces of shape {arr.shape}, expected {self._forces.shape}")
        if not np.isfinite(arr).all():
            bad = np.argwhere(~np.isfinite(arr))[0, 0]
            raise FloatingPointError(f"non-finite force written at interface point {bad}")
        self._forces = arr.copy()
        self._f_new = self.system.nodal_load(self._forces)
        if self._initial_data_pending:  # initial data (the coupler's initialize, at t = 0)
            self._initial_data_pending = False
            self._start(self._f_new)

    def read(self, name: str) -> np.ndarray:
        """Interface data at the current time: see the module docstring for names and shapes."""
        s = self.integrator.state
        if name == "displacement":
            return self._add_rigid(self.system.nodal(s.u), "displacement")
        if name == "velocity":
            return self._add_rigid(self.system.nodal(s.v), "velocity")
        if name == "acceleration":
            return self._add_rigid(self.system.nodal(s.a), "acceleration")
        if name == "rotation":
            rot = self.system.rotation(s.u)
            r = 1 if self.dim == 2 else 2
            out = np.full((self.system.n_points, r), np.nan)
            for k, sl in self.system.node_slices.items():
                if k in rot:
                    out[sl] = rot[k]
            return out
        raise KeyError(f"structure participant has no {name!r}; readable: {READABLE}")

    def _add_rigid(self, nodal: np.ndarray, what: str) -> np.ndarray:
        """Add the members' rigid translation (``what``: displacement, velocity or the frame
        acceleration of the last step) at the current time to elastic nodal values, in place."""
        t = self.integrator.state.t
        for nodes, _, law, _, _ in self._motions:
            if what == "displacement":
                nodal[nodes] += law.displacement(t)
            elif what == "velocity":
                nodal[nodes] += law.velocity(t)
            else:
                nodal[nodes] += law.acceleration(t, self._last_h)
        return nodal

    def rigid_displacement(self, member: str) -> np.ndarray:
        """Rigid translation (m, scene vector) of a member's frame at the current time (zeros
        for a member at rest)."""
        t = self.integrator.state.t
        for _, _, law, _, name in self._motions:
            if name == member:
                return law.displacement(t)
        return np.zeros(self.dim)

    def frame_load(self, t: float, h: float = 0.0) -> np.ndarray:
        """Inertial load -M a_frame over the free dofs (N; N/m in 2D) of the members' moving
        frames, for a step of length h ending at t (zeros when no member moves)."""
        f = np.zeros(self.system.n)
        for _, dofs, law, unit, _ in self._motions:
            a = law.acceleration(t, h)
            if a.any():
                f[dofs] -= a @ unit  # d'Alembert: -rho a_frame per unit volume
        return f

    def advance(self, dt: float) -> float:
        """Integrate over `dt` (sub-stepped to at most ``max_dt()``); returns the time advanced."""
        if not dt > 0 or not math.isfinite(dt):
            raise ValueError(f"advance(dt = {dt}): dt must be a positive finite number")
        self._initial_data_pending = False
        n_sub = max(1, math.ceil(dt / self.dt - 1e-9))
        h = dt / n_sub
        t0 = self.integrator.state.t
        f0, f1 = self._f_start, self._f_new
        fm = self.fictitious if self.fictitious is not None and self.fictitious.active else None
        if fm is not None and self._fm_pending:
            self._decide_fictitious_nodes()
        elif fm is not None and self._fm_grow.any():
            self._grow_fictitious_nodes()
        if fm is not None and self._fm_B is None:  # no node carries M_f in this window
            fm = None
        f_before = f0
        for j in range(1, n_sub + 1):
            frac = j / n_sub
            f_if = f1 if j == n_sub else f0 + frac * (f1 - f0)
            t = t0 + frac * dt
            if fm is None:
                self.integrator.step(h, self.external_load(t, h) + f_if)
                continue
            # fictitious mass: a^{k-1} of this sub-step from the previous iteration of the
            # window, in the first one the acceleration at the sub-step's start
            # M_f delta (f_shift): a^{k-1} shifted to the iterate the fluid answered to
            a_prev, f_shift = fm.previous(self.integrator.state.steps, h)
            new = self.integrator.step(h, self.external_load(t, h) + f_if, a_prev, f_shift)
            fm.store(h, new.u, new.a)
            # the force the scheme leaves: (M + M_f) a + ... = F + M_f a_prev + shift, so
            # M a + C v + K u - F = M_f (a_prev - a) + shift
            err = self.integrator.Mf @ (new.a - a_prev)
            if f_shift is not None:
                err -= f_shift
            rows = self._fm_rows
            fm.record_error(_rms(err[rows]), max(_rms(f_if[rows]), _rms(f_before[rows])))
            f_before = f_if
        self.integrator.state.t = t0 + dt
        self._last_h = h
        self._f_start = f1
        if self._linear_rotations:
            self._check_linear_rotation()
        return dt

    def _check_linear_rotation(self) -> None:
        """Warn once per linear member whose nodal rotation exceeds LINEAR_ROTATION_LIMIT."""
        u = self.integrator.state.u
        for name, idx, slopes, remedy in self._linear_rotations:
            if name in self._warned or not idx.size:
                continue
            rot = float(np.abs(u[idx]).max())
            if slopes:
                rot = math.atan(rot)
            if rot > LINEAR_ROTATION_LIMIT:
                self._warned.add(name)
                warnings.warn(
                    f'structure member {name!r} (kinematics = "linear") rotates {rot:.3g} rad '
                    f"at t = {self.time:.6g} s, beyond the {LINEAR_ROTATION_LIMIT} rad of "
                    f'small-rotation theory: set kinematics = "{remedy}" on this member in '
                    "[[structure.members]] for large deflections",
                    LargeRotationWarning,
                    stacklevel=3,
                )

    def set_iterate(self, displacement: np.ndarray, window: float) -> None:
        """Optional coupler hook (fictitious mass): the interface displacement (n_points, dim),
        m, at the end of the current window of length `window` (s) that the fluid's forces of
        this iteration answer to. Without it (e.g. a remote participant) a^{k-1} is the
        structure's own acceleration of the previous iteration, exact for unrelaxed iterations."""
        fm = self.fictitious
        if fm is None or not fm.active:
            return
        x = np.array(displacement, dtype=float).reshape(self.system.n_points, self.dim)
        t_end = self.integrator.state.t + float(window)
        for nodes, _, law, _, _ in self._motions:  # elastic part
            x[nodes] -= law.displacement(t_end)
        fm.set_iterate(x, window)

    def max_dt(self) -> float:
        """Longest step the structure takes in one go (the scenario's ``structure.time.dt``)."""
        return self.dt

    def checkpoint(self) -> dict:
        """Copy of the full state (also kept for :meth:`restore`); a dict of arrays and numbers."""
        s = self.integrator.state
        state = {
            "t": s.t,
            "steps": s.steps,
            "u": s.u.copy(),
            "v": s.v.copy(),
            "a": s.a.copy(),
            "f_start": self._f_start.copy(),
            "forces": self._forces.copy(),
            "last_h": self._last_h,
        }
        if self.nonlinear:
            state.update(self.integrator.checkpoint_extra())
        if self.fictitious is not None:  # a new coupling window: no previous iteration yet
            self.fictitious.reset(s.steps, s.u, s.v, s.a)
            self._fm_pending = True  # its wet set: at its first step
            self._fm_window_growths = 0
            self._fm_load_start = self._forces.copy()
        self._checkpoint = state
        return {k: (v.copy() if isinstance(v, np.ndarray) else v) for k, v in state.items()}

    def restore(self, state: dict | None = None) -> None:
        """Put back a state from :meth:`checkpoint` (default: the last one taken)."""
        state = self._checkpoint if state is None else state
        if state is None:
            raise RuntimeError("restore() before any checkpoint()")
        restored = NewmarkState(
            np.array(state["u"], dtype=float),
            np.array(state["v"], dtype=float),
            np.array(state["a"], dtype=float),
            float(state["t"]),
            int(state["steps"]),
        )
        if self.nonlinear:
            self.integrator.restore_extra(restored, state)
        else:
            self.integrator.state = restored
        if self.fictitious is not None and self.fictitious.active:
            self.fictitious.new_iteration()  # keeps this iteration's accelerations as a^{k-1}
        self._f_start = np.array(state["f_start"], dtype=float)
        self._last_h = float(state.get("last_h", self.dt))
        self._initial_data_pending = False
        self.write("forces", state["forces"])

    # ------------------------------------------------------------------ extras
    @property
    def time(self) -> float:
        return self.integrator.state.t

    def external_load(self, t: float, h: float = 0.0) -> np.ndarray:
        """Self-weight plus (standalone) prescribed loads at time t, plus the inertial load of
        moving members' frames for a step of length h ending at t, over the free dofs."""
        f = self.system.constant_load
        if self.use_prescribed and len(self.system.prescribed):
            f = f + self.system.prescribed(t)
        if self._motions:
            f = f + self.frame_load(t, h)
        return f

    def member_displacements(self) -> dict[str, np.ndarray]:
        """Translational displacement of every member's nodes, name -> (n_nodes, dim)."""
        d = self.read("displacement")
        return {k: d[sl] for k, sl in self.system.node_slices.items()}

    def member_nodes(self) -> dict[str, np.ndarray]:
        """Reference coordinates of every member's nodes, name -> (n_nodes, dim)."""
        return {m.name: m.nodes for m in self.system.models}

    def probe_values(self) -> dict[str, np.ndarray]:
        """Displacement (m) at every displacement probe, name -> (dim,)."""
        vals = (self._P @ self.integrator.state.u).reshape(-1, self.dim)
        if self._motions:
            for i, member in enumerate(self._P_member):
                vals[i] += self.rigid_displacement(member)
        return {n: vals[i] for i, n in enumerate(self.probe_names)}

    def energy(self, member: str | None = None) -> tuple[float, float]:
        """(kinetic, strain) energy of one member or of the whole structure (J; J/m in 2D)."""
        s = self.integrator.state
        names = self.system.names if member is None else [member]
        parts = [self.system.member_energy(k, s.u, s.v) for k in names]
        return sum(p[0] for p in parts), sum(p[1] for p in parts)

    def _check_conditional_stability(self) -> None:
        """For beta < (gamma + 1/2)^2 / 4: dt must satisfy omega_max dt <= Omega_crit."""
        b, g = self.integrator.beta, self.integrator.gamma
        lam = (
            sla.eigsh(
                self.system.K.tocsc(),
                k=1,
                M=self.system.M.tocsc(),
                which="LA",
                v0=np.ones(self.system.n),
                return_eigenvectors=False,
            )[0]
            if self.system.n > 1
            else float(self.system.K[0, 0] / self.system.M[0, 0])
        )
        omega_max = math.sqrt(max(lam, 0.0))
        crit = 1.0 / math.sqrt(g / 2.0 - b) if g / 2.0 > b else math.inf
        if omega_max * self.dt > crit:
            raise ValueError(
                f"structure.time.dt = {self.dt:g} s exceeds the stability limit "
                f"{crit / omega_max:.3g} s of newmark_beta = {b:g}, newmark_gamma = {g:g} "
                f"(highest natural frequency {omega_max / (2 * math.pi):.4g} Hz); reduce dt or "
                "use newmark_beta = 0.25"
            )

    def _build_interface(self) -> Interface:
        sysm = self.system
        pts, nrm, th, gth, mem, cells = [], [], [], [], [], []
        for k, m in enumerate(sysm.models):
            off = sysm.node_slices[m.name].start
            pts.append(m.nodes)
            nrm.append(m.normals)
            th.append(np.full(m.n_nodes, m.thickness))
            gth.append(np.full(m.n_nodes, m.geometric_thickness))
            mem.append(np.full(m.n_nodes, k, dtype=np.int64))
            cells.append(m.connectivity + off)
        arrays = {
            "points": np.vstack(pts),
            "normals": np.vstack(nrm),
            "thickness": np.concatenate(th),
            "geometric_thickness": np.concatenate(gth),
            "member": np.concatenate(mem),
        }
        for a in list(arrays.values()) + cells:
            a.setflags(write=False)
        return Interface(
            dim=self.dim,
            member_names=tuple(sysm.names),
            cells=tuple(cells),
            slices=dict(sysm.node_slices),
            **arrays,
        )
