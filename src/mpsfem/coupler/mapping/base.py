"""Common machinery of the mappings: sparse operators built once, applied by mat-vec.

A mapping joins the fluid's interface points (particles, both faces of a thin member) and the
structure's interface mesh (mid-surface nodes and cells). It has two directions, in preCICE's
sense:

* :meth:`Mapping.to_fluid` — *consistent*: structure displacement / velocity -> fluid points
  (constants are reproduced: every row of the operator sums to one);
* :meth:`Mapping.to_structure` — fluid forces -> structure nodes. Conservative mappings use the
  transpose of the consistent operator, so the total force is kept and the interface does no
  spurious work (the work of the fluid forces on the fluid-side motion equals the work of the
  mapped forces on the structure motion). The thesis's KFBI is not conservative (see
  :mod:`~mpsfem.coupler.mapping.kernel`).

Both directions act on (n, dim) arrays. Operators are scipy CSR matrices, either componentwise
(n_to, n_from) applied to all columns at once, or full (n_to * dim, n_from * dim) when the mapping
mixes components (shape functions with the rigid-link offset).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np
import scipy.sparse as sp
from scipy.spatial import cKDTree

from mpsfem.coupler.participant import InterfaceMesh, as_interface_mesh
from mpsfem.scenario.base import Section

__all__ = ["Mapping", "MappingCoverageError", "point_spacing"]


class MappingCoverageError(ValueError):
    """Some fluid interface points find no structure node or cell within the mapping radius."""


def point_spacing(points: np.ndarray) -> float:
    """Typical spacing of a point cloud: median distance to the nearest other point."""
    if points.shape[0] < 2:
        raise ValueError("need at least two interface points to estimate their spacing")
    d, _ = cKDTree(points).query(points, k=2)
    return float(np.median(d[:, 1]))


def describe_points(points: np.ndarray, idx: np.ndarray, limit: int = 5) -> str:
    """'3 points, e.g. #12 at (0.1, 0.2), ...' for error messages."""
    shown = ", ".join(
        f"#{int(i)} at ({', '.join(f'{c:.6g}' for c in points[i])})" for i in idx[:limit]
    )
    more = f" and {idx.size - limit} more" if idx.size > limit else ""
    return f"{idx.size} point(s), e.g. {shown}{more}"


class Mapping(ABC):
    """Base class: subclasses implement :meth:`_build` and set the two operators."""

    kind: ClassVar[str]
    Params: ClassVar[type[Section]]
    #: True if forces go by the transpose of the consistent operator
    conservative: ClassVar[bool]

    def __init__(self, params: Section | None = None) -> None:
        self.params = params if params is not None else self.Params()
        self.fluid: InterfaceMesh | None = None
        self.structure: InterfaceMesh | None = None
        self.builds = 0
        self._to_fluid: sp.csr_matrix | None = None
        self._to_structure: sp.csr_matrix | None = None
        self._componentwise = True

    # ------------------------------------------------------------------ build
    def build(self, fluid, structure) -> None:
        """Build both operators for these meshes (reference configuration)."""
        fluid = as_interface_mesh(fluid)
        structure = as_interface_mesh(structure)
        if fluid.dim != structure.dim:
            raise ValueError(
                f"fluid interface is {fluid.dim}D but structure interface is {structure.dim}D"
            )
        if structure.n_points == 0 or fluid.n_points == 0:
            raise ValueError(
                f"empty interface: {fluid.n_points} fluid points, "
                f"{structure.n_points} structure points"
            )
        self.fluid, self.structure = fluid, structure
        a, b, componentwise = self._build(fluid, structure)
        self._to_fluid = a.tocsr()
        self._to_structure = b.tocsr()
        for m in (self._to_fluid, self._to_structure):
            m.sort_indices()
        self._componentwise = componentwise
        self.builds += 1

    def needs_rebuild(self, fluid) -> bool:
        """True if ``fluid`` differs from the mesh the operators were built for."""
        return self.fluid is None or not self.fluid.same_points(as_interface_mesh(fluid))

    @abstractmethod
    def _build(
        self, fluid: InterfaceMesh, structure: InterfaceMesh
    ) -> tuple[sp.spmatrix, sp.spmatrix, bool]:
        """(to_fluid operator, to_structure operator, componentwise?)."""

    # ------------------------------------------------------------------ apply
    @property
    def to_fluid_matrix(self) -> sp.csr_matrix:
        self._require()
        return self._to_fluid

    @property
    def to_structure_matrix(self) -> sp.csr_matrix:
        self._require()
        return self._to_structure

    def to_fluid(self, values: np.ndarray) -> np.ndarray:
        """Structure (n_s, dim) -> fluid (n_f, dim): displacement or velocity (consistent)."""
        self._require()
        return self._apply(self._to_fluid, values, self.structure, self.fluid)

    def to_structure(self, forces: np.ndarray) -> np.ndarray:
        """Fluid (n_f, dim) -> structure (n_s, dim): forces."""
        self._require()
        return self._apply(self._to_structure, forces, self.fluid, self.structure)

    # Motion-aware directions. A mapping that is linear in the structure's motion (every one but
    # the large-rotation shape-function mapping) applies its fixed operators; a geometrically
    # nonlinear one overrides these three. The coupling scheme calls them.
    def displacement_to_fluid(self, displacement: np.ndarray) -> np.ndarray:
        """Structure displacement (n_s, dim), m -> fluid interface points (n_f, dim), m."""
        return self.to_fluid(displacement)

    def velocity_to_fluid(self, velocity: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Structure velocity (n_s, dim), m/s, at ``displacement`` -> fluid points, m/s."""
        return self.to_fluid(velocity)

    def forces_to_structure(self, forces: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Fluid forces (n_f, dim), N, with the structure at ``displacement`` -> structure
        nodes (n_s, dim), N."""
        return self.to_structure(forces)

    def _apply(self, op, values, src: InterfaceMesh, dst: InterfaceMesh) -> np.ndarray:
        v = np.asarray(values, dtype=np.float64)
        if v.shape != src.points.shape:
            raise ValueError(f"array of shape {v.shape}, expected {src.points.shape}")
        if self._componentwise:
            return np.ascontiguousarray(op @ v)
        return (op @ v.reshape(-1)).reshape(dst.points.shape)

    def _require(self) -> None:
        if self._to_fluid is None:
            raise RuntimeError(f"mapping {self.kind!r} used before build()")
