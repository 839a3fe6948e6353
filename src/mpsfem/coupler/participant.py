"""The participant protocol: what the coupler asks of a fluid or a structure solver.

Modelled on preCICE's adapter API, seen from the coupler: the coupler *writes* a participant's
inputs and *reads* its outputs.

=================  ==========================  ============================================
data name          direction                   array
=================  ==========================  ============================================
``"forces"``       fluid -> structure          (n, dim) force exerted BY the fluid ON the
                                               structure at each interface point, N (N/m,
                                               i.e. per unit width, in 2D)
``"displacement"`` structure -> fluid          (n, dim) translational displacement from the
                                               reference configuration, m
``"velocity"``     structure -> fluid          (n, dim) velocity, m/s
=================  ==========================  ============================================

Contract (every participant, local or behind a transport):

* ``interface()`` returns the interface mesh in the reference configuration
  (:class:`InterfaceMesh`, or any object with the same attributes, see
  :func:`as_interface_mesh`). The structure's mesh must not change during a run; the fluid's may
  (its interface particle set), and the coupler rebuilds the mapping when it does.
* ``write(name, array)`` hands the participant an input: the value at the *end* of the next
  ``advance`` (Newmark wants F(t + dt); the fluid places its wall particles at d(t + dt)). Before
  the first ``advance`` the coupler writes the initial values (time t0). The participant must copy
  the array if it keeps it.
* ``read(name)`` returns an output at the participant's current time; valid before the first
  ``advance`` (zeros allowed). The coupler copies what it reads.
* ``advance(dt)`` integrates exactly ``dt`` and returns the time advanced; a participant that
  could only take a shorter step returns that and the coupler re-plans the rest of the window.
* ``max_dt()`` is the longest step the participant can take now (the fluid's adaptive CFL step,
  the structure's fixed dt).
* ``checkpoint()`` stores the full state at the current time, ``restore()`` puts the last
  checkpoint back; a restored participant must repeat its steps bit for bit (implicit coupling
  calls ``restore()`` once per extra iteration).
* optional ``energy()``: the structure's mechanical energy (J; J/m in 2D), a float or a tuple of
  parts (kinetic, strain) that are summed; used for the interface energy balance.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = [
    "CELL_NODES",
    "DISPLACEMENT",
    "FORCES",
    "VELOCITY",
    "InterfaceMesh",
    "Participant",
    "as_interface_mesh",
    "energy_of",
]

FORCES = "forces"
DISPLACEMENT = "displacement"
VELOCITY = "velocity"

#: nodes per cell of every cell type an interface mesh may hold
CELL_NODES = {"vertex": 1, "line": 2, "triangle": 3, "quad": 4}
_BY_NODES = {2: "line", 3: "triangle", 4: "quad"}


@dataclass(frozen=True, eq=False)
class InterfaceMesh:
    """Interface of a participant in the reference configuration.

    points: (n, dim) float64, dim 2 or 3.
    normals: (n, dim) float64 unit vectors pointing out of the structure into the fluid. The
        structure gives its mid-surface normal (one side; the fluid faces are at +-thickness/2);
        the fluid gives, for each interface particle, the normal of the face it lies on.
    cells: cell type -> (n_cells, nodes) int32 connectivity into ``points``: ``"line"`` segments
        (2D beams), ``"triangle"`` / ``"quad"`` (3D plates; quads anticlockwise about the normal).
        Empty for a point cloud (the fluid's particles).
    thickness: geometric thickness as the fluid sees it, per point (n,) in m; a scalar is
        broadcast. 0 for a fluid point cloud or a structure meshed on its wetted surface.
    """

    points: np.ndarray
    normals: np.ndarray
    cells: Mapping[str, np.ndarray] = field(default_factory=dict)
    thickness: np.ndarray | float = 0.0

    def __post_init__(self) -> None:
        pts = np.ascontiguousarray(self.points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise ValueError(f"interface points of shape {pts.shape}: expected (n, 2) or (n, 3)")
        nrm = np.ascontiguousarray(self.normals, dtype=np.float64)
        if nrm.shape != pts.shape:
            raise ValueError(f"interface normals of shape {nrm.shape}, expected {pts.shape}")
        if not (np.isfinite(pts).all() and np.isfinite(nrm).all()):
            raise ValueError("interface points or normals hold non-finite values")
        length = np.linalg.norm(nrm, axis=1)
        if pts.shape[0] and np.abs(length - 1.0).max() > 1e-6:
            bad = int(np.argmax(np.abs(length - 1.0)))
            raise ValueError(f"interface normal {bad} has length {length[bad]:.6g}; must be unit")
        cells: dict[str, np.ndarray] = {}
        for ctype, conn in dict(self.cells).items():
            if ctype not in CELL_NODES:
                raise ValueError(f"cell type {ctype!r}: allowed {sorted(CELL_NODES)}")
            c = np.ascontiguousarray(conn, dtype=np.int32)
            if c.ndim != 2 or c.shape[1] != CELL_NODES[ctype]:
                raise ValueError(
                    f"{ctype} cells of shape {c.shape}: expected (n, {CELL_NODES[ctype]})"
                )
            if c.size and (c.min() < 0 or c.max() >= pts.shape[0]):
                raise ValueError(f"{ctype} cells index points outside 0..{pts.shape[0] - 1}")
            c.setflags(write=False)
            cells[ctype] = c
        th = np.ascontiguousarray(
            np.broadcast_to(np.asarray(self.thickness, dtype=np.float64), (pts.shape[0],))
        )
        if (th < 0).any() or not np.isfinite(th).all():
            raise ValueError("interface thickness must be finite and >= 0")
        for a in (pts, nrm, th):
            a.setflags(write=False)
        object.__setattr__(self, "points", pts)
        object.__setattr__(self, "normals", nrm)
        object.__setattr__(self, "cells", cells)
        object.__setattr__(self, "thickness", th)

    @property
    def dim(self) -> int:
        return int(self.points.shape[1])

    @property
    def n_points(self) -> int:
        return int(self.points.shape[0])

    def same_points(self, other: InterfaceMesh) -> bool:
        """True if ``other`` has bit-identical points and normals (no mapping rebuild needed)."""
        return (
            self.points.shape == other.points.shape
            and np.array_equal(self.points, other.points)
            and np.array_equal(self.normals, other.normals)
        )


def as_interface_mesh(obj: Any) -> InterfaceMesh:
    """An :class:`InterfaceMesh` from ``obj``: itself, or any object with ``points``,
    ``normals``, ``cells`` and ``geometric_thickness`` (or ``thickness``) attributes, where
    ``cells`` may be a dict by cell type, or a sequence of connectivity arrays whose type is
    inferred from the number of nodes per cell (2 line, 3 triangle, 4 quad) — the form of
    :class:`mpsfem.structure_fem.participant.Interface`."""
    if isinstance(obj, InterfaceMesh):
        return obj
    cells_in = getattr(obj, "cells", {}) or {}
    if isinstance(cells_in, Mapping):
        cells = dict(cells_in)
    else:
        blocks: dict[str, list[np.ndarray]] = {}
        for conn in cells_in:
            conn = np.asarray(conn)
            if conn.size == 0:
                continue
            ctype = _BY_NODES.get(conn.shape[1])
            if ctype is None:
                raise ValueError(f"cells with {conn.shape[1]} nodes: allowed 2, 3 or 4")
            blocks.setdefault(ctype, []).append(conn)
        cells = {k: np.vstack(v) for k, v in blocks.items()}
    thickness = getattr(obj, "geometric_thickness", None)
    if thickness is None:
        thickness = getattr(obj, "thickness", 0.0)
    return InterfaceMesh(obj.points, obj.normals, cells, thickness)


def energy_of(participant: Any) -> float:
    """The participant's mechanical energy (sum of the parts it reports), NaN if it reports none."""
    fn = getattr(participant, "energy", None)
    if fn is None:
        return float("nan")
    e = fn()
    if e is None:
        return float("nan")
    if isinstance(e, tuple | list | np.ndarray):
        return float(sum(float(x) for x in e))
    return float(e)


@runtime_checkable
class Participant(Protocol):
    """A fluid or structure solver as the coupler sees it (see the module docstring)."""

    def interface(self) -> Any:
        """The interface mesh (:class:`InterfaceMesh` or an object :func:`as_interface_mesh`
        accepts), reference configuration."""
        ...

    def write(self, name: str, array: np.ndarray) -> None:
        """Set input ``name`` (value at the end of the next step; at t0 before the first)."""
        ...

    def read(self, name: str) -> np.ndarray:
        """Output ``name`` at the current time, shape (n_points, dim)."""
        ...

    def advance(self, dt: float) -> float:
        """Integrate ``dt`` seconds; return the time actually advanced (<= dt)."""
        ...

    def max_dt(self) -> float:
        """Longest step the participant can take from its current state."""
        ...

    def checkpoint(self) -> Any:
        """Store the full state at the current time (for :meth:`restore`)."""
        ...

    def restore(self) -> None:
        """Return to the last checkpoint; steps repeat bit for bit."""
        ...
