"""The discretised member: what every element family (beam, plate) hands to the integrators.

A :class:`MemberModel` holds the assembled consistent mass and stiffness matrices over *all* degrees
of freedom, the list of constrained ones, and the linear maps between the generalised coordinates
``q`` and the member's interface nodes (centreline / mid-surface nodes):

* ``translation`` (``n_nodes*dim x n_dof``): nodal translational displacement in scene coordinates,
  node-major (``(T @ q).reshape(n_nodes, dim)``). Its transpose maps nodal forces to generalised
  forces, so work is preserved: ``f . (T q) = (T^T f) . q``.
* ``rotation`` (``n_nodes*n_rot x n_dof``) or ``None``: beam rotation (anticlockwise), plate slopes
  ``(dw/du, dw/dv)`` in local axes (BFS only).

Load vectors and point-evaluation matrices are built on demand by the subclasses. A nonlinear
member (``nonlinear = True``, the co-rotational beam) adds its state-dependent internal force,
tangent and strain energy; its ``K`` is the tangent at the reference configuration.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

__all__ = ["MemberModel", "build_member"]


@dataclass
class MemberModel(ABC):
    """A discretised elastic member (base class of :class:`BeamModel` and :class:`PlateModel`)."""

    name: str
    dim: int
    M: sp.csr_matrix
    K: sp.csr_matrix
    fixed: np.ndarray
    nodes: np.ndarray
    normals: np.ndarray
    connectivity: np.ndarray
    translation: sp.csr_matrix
    thickness: float
    geometric_thickness: float
    rayleigh_a1: float = 0.0
    rayleigh_a2: float = 0.0
    rotation: sp.csr_matrix | None = None
    rotation_components: tuple[str, ...] = ()
    dof_kind: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int8))
    dof_kind_names: tuple[str, ...] = ("bending",)
    #: True for members whose internal force is not K q (co-rotational beams): they provide
    #: ``internal_force(q)``, ``reduced_tangent(q, free)`` and ``strain_energy(q)``
    nonlinear: ClassVar[bool] = False

    @property
    def n_dof(self) -> int:
        return self.M.shape[0]

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def free(self) -> np.ndarray:
        """Indices of the unconstrained degrees of freedom (sorted)."""
        return np.setdiff1d(np.arange(self.n_dof), self.fixed)

    @property
    def C(self) -> sp.csr_matrix:
        """Rayleigh damping matrix a1 M + a2 K."""
        return (self.rayleigh_a1 * self.M + self.rayleigh_a2 * self.K).tocsr()

    def damping_ratio(self, omega: np.ndarray) -> np.ndarray:
        """Modal damping ratio of Rayleigh damping: a1 / (2 omega) + a2 omega / 2."""
        omega = np.asarray(omega, dtype=float)
        with np.errstate(divide="ignore", invalid="ignore"):
            zeta = self.rayleigh_a1 / (2.0 * omega) + self.rayleigh_a2 * omega / 2.0
        # a rigid-body mode (omega = 0) is undamped without a1, overdamped (inf) with it
        return np.where(omega == 0.0, np.inf if self.rayleigh_a1 > 0.0 else 0.0, zeta)

    @abstractmethod
    def gravity_load(self, g: np.ndarray) -> np.ndarray:
        """Consistent load vector of the member's own weight under gravity `g` (scene vector)."""

    @abstractmethod
    def pressure_load(self, p: float) -> np.ndarray:
        """Consistent load vector of a uniform pressure `p` (Pa, positive along the normal)."""

    @abstractmethod
    def point_matrix(self, point: np.ndarray) -> sp.csr_matrix:
        """``dim x n_dof`` matrix giving the translational displacement at a scene point."""

    def point_force_load(self, point: np.ndarray, force: np.ndarray) -> np.ndarray:
        """Consistent load vector of a point force (scene vector) at a scene point."""
        return np.asarray(self.point_matrix(point).T @ np.asarray(force, dtype=float)).ravel()

    def nodal_forces_load(self, forces: np.ndarray) -> np.ndarray:
        """Generalised forces of nodal forces ``(n_nodes, dim)`` at the interface nodes."""
        return self.translation.T @ np.asarray(forces, dtype=float).reshape(-1)


def build_member(cfg) -> MemberModel:
    """Build the model of one scenario member (:class:`~mpsfem.scenario.structure.BeamMember` or
    :class:`~mpsfem.scenario.structure.PlateMember`)."""
    from .beam import BeamModel
    from .corotational_beam import CorotationalBeamModel
    from .plate import PlateModel

    if cfg.type == "beam" and getattr(cfg, "kinematics", "linear") == "corotational":
        model = CorotationalBeamModel.from_config(cfg)
    elif cfg.type == "beam":
        model = BeamModel.from_config(cfg)
    elif cfg.type == "plate" and getattr(cfg, "kinematics", "linear") == "von_karman":
        from .von_karman_plate import VonKarmanPlateModel

        model = VonKarmanPlateModel.from_config(cfg)
    elif cfg.type == "plate":
        model = PlateModel.from_config(cfg)
    else:
        raise ValueError(f"unknown member type {cfg.type!r}; allowed: 'beam', 'plate'")
    if model.free.size == 0:
        mesh = f"elements = {cfg.elements}" if cfg.type == "beam" else "its mesh"
        raise ValueError(
            f"structure member {cfg.name!r}: bc = {cfg.bc!r} fixes every one of its "
            f"{model.n_dof} degrees of freedom on {mesh}; it cannot move: refine the mesh "
            "(beam `elements`, plate `divisions` / `mesh_size`) or free a support"
        )
    return model
