"""All members of a ``[structure]`` section as one block-diagonal system over their free dofs.

Members do not interact, so the global matrices are block diagonal; one factorisation and one
solve per step serve every member. The reduced vector of generalised coordinates is the
concatenation of each member's free dofs (``dof_slices``); the interface points are the
concatenation of each member's nodes (``node_slices``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.sparse as sp

from .loads import PrescribedLoads, time_function
from .model import MemberModel, build_member

__all__ = ["StructureSystem"]


def _reduce(A: sp.spmatrix, free: np.ndarray) -> sp.csr_matrix:
    return sp.csr_matrix(A)[free][:, free].tocsr()


class StructureSystem:
    """Assembled, constrained system of a :class:`~mpsfem.scenario.structure.StructureSection`."""

    def __init__(self, section, *, base_dir: str | Path | None = None) -> None:
        self.section = section
        self.dim = section.dim
        self.models: list[MemberModel] = [build_member(cfg) for cfg in section.members]
        self.names = [m.name for m in self.models]
        self.frees = [m.free for m in self.models]
        nd = np.cumsum([0] + [len(f) for f in self.frees])
        nn = np.cumsum([0] + [m.n_nodes for m in self.models])
        self.dof_slices = {
            m.name: slice(int(nd[k]), int(nd[k + 1])) for k, m in enumerate(self.models)
        }
        self.node_slices = {
            m.name: slice(int(nn[k]), int(nn[k + 1])) for k, m in enumerate(self.models)
        }
        self.n = int(nd[-1])
        self.n_points = int(nn[-1])
        self.M = sp.block_diag(
            [_reduce(m.M, f) for m, f in zip(self.models, self.frees, strict=True)], format="csr"
        )
        self.K = sp.block_diag(
            [_reduce(m.K, f) for m, f in zip(self.models, self.frees, strict=True)], format="csr"
        )
        self.C = sp.block_diag(
            [_reduce(m.C, f) for m, f in zip(self.models, self.frees, strict=True)], format="csr"
        )
        self.T = sp.block_diag(
            [
                sp.csr_matrix(m.translation)[:, f]
                for m, f in zip(self.models, self.frees, strict=True)
            ],
            format="csr",
        )
        self.TT = self.T.T.tocsr()
        self._blocks: dict[str, tuple[sp.csr_matrix, sp.csr_matrix]] = {}
        # nonlinear (co-rotational) members: internal force and tangent from their kernels
        self.nonlinear_members = [m.name for m in self.models if m.nonlinear]
        self.nonlinear = bool(self.nonlinear_members)
        if self.nonlinear:
            self._K_linear = sp.block_diag(
                [
                    sp.csr_matrix((len(f), len(f))) if m.nonlinear else _reduce(m.K, f)
                    for m, f in zip(self.models, self.frees, strict=True)
                ],
                format="csr",
            )
        # constant loads: self-weight
        g = np.asarray(section.gravity_vector, dtype=float)
        self.constant_load = np.zeros(self.n)
        for cfg, m in zip(section.members, self.models, strict=True):
            if cfg.self_weight:
                self.constant_load[self.dof_slices[m.name]] += m.gravity_load(g)[
                    self.free_of(m.name)
                ]
        # prescribed loads (standalone runs)
        self.prescribed = PrescribedLoads(self.n)
        for load in section.loads:
            m = self.model(load.member)
            if load.kind == "pressure":
                vec = m.pressure_load(load.value)
            else:
                vec = m.point_force_load(np.asarray(load.position), np.asarray(load.force))
            full = np.zeros(self.n)
            full[self.dof_slices[m.name]] = vec[self.free_of(m.name)]
            self.prescribed.add(full, time_function(load.time, base_dir))

    # ------------------------------------------------------------------ lookup
    def model(self, name: str) -> MemberModel:
        for m in self.models:
            if m.name == name:
                return m
        raise KeyError(f"no structure member named {name!r}; members: {self.names}")

    def free_of(self, name: str) -> np.ndarray:
        return self.frees[self.names.index(name)]

    # ------------------------------------------------------------------ maps
    def expand(self, q: np.ndarray, name: str) -> np.ndarray:
        """Full dof vector of member `name` (zeros at constrained dofs) from the reduced vector."""
        m = self.model(name)
        full = np.zeros(m.n_dof)
        full[self.free_of(name)] = q[self.dof_slices[name]]
        return full

    def nodal(self, q: np.ndarray) -> np.ndarray:
        """Translational displacement (or velocity, ...) of every interface point, (n_points, dim)."""
        return (self.T @ q).reshape(self.n_points, self.dim)

    def nodal_load(self, forces: np.ndarray) -> np.ndarray:
        """Generalised forces of nodal forces (n_points, dim) at the interface points."""
        return self.TT @ forces.reshape(-1)

    def rotation(self, q: np.ndarray) -> dict[str, np.ndarray]:
        """Rotations per member: beams (n, 1) anticlockwise angle, BFS plates (n, 2) slopes."""
        out = {}
        for m in self.models:
            if m.rotation is None:
                continue
            r = sp.csr_matrix(m.rotation)[:, self.free_of(m.name)] @ q[self.dof_slices[m.name]]
            out[m.name] = r.reshape(m.n_nodes, len(m.rotation_components))
        return out

    def point_matrix(self, name: str, position) -> sp.csr_matrix:
        """``dim x n`` matrix: displacement of member `name` at the point nearest `position`."""
        m = self.model(name)
        P = sp.csr_matrix(m.point_matrix(np.asarray(position, dtype=float)))[:, self.free_of(name)]
        blocks = [
            P if k == name else sp.csr_matrix((self.dim, len(f)))
            for k, f in zip(self.names, self.frees, strict=True)
        ]
        return sp.hstack(blocks, format="csr")

    def member_energy(self, name: str, u: np.ndarray, v: np.ndarray) -> tuple[float, float]:
        """(kinetic, strain) energy of member `name` (J; J/m in 2D): 1/2 v.M v, and 1/2 u.K u or,
        for a co-rotational member, the sum of its elements' local strain energies."""
        sl = self.dof_slices[name]
        if name not in self._blocks:
            self._blocks[name] = (self.M[sl, sl].tocsr(), self.K[sl, sl].tocsr())
        Mk, Kk = self._blocks[name]
        m = self.model(name)
        if m.nonlinear:
            return 0.5 * float(v[sl] @ (Mk @ v[sl])), m.strain_energy(self.expand(u, name))
        return 0.5 * float(v[sl] @ (Mk @ v[sl])), 0.5 * float(u[sl] @ (Kk @ u[sl]))

    # ------------------------------------------------------------------ nonlinear members
    def internal_force(self, u: np.ndarray) -> np.ndarray:
        """Internal force over the free dofs: K u for linear members, the co-rotational kernels
        for the others (N; N/m in 2D)."""
        if not self.nonlinear:
            return self.K @ u
        f = self._K_linear @ u if self._K_linear.nnz else np.zeros(self.n)
        for name in self.nonlinear_members:
            m, sl = self.model(name), self.dof_slices[name]
            f[sl] = m.internal_force(self.expand(u, name))[self.free_of(name)]
        return f

    def effective_tangent(self, u: np.ndarray, ck: float, cm: float, cc: float) -> sp.csr_matrix:
        """``ck K_t(u) + cm M + cc C`` over the free dofs (the Jacobian of a time step)."""
        if self.nonlinear and len(self.models) == 1:
            m = self.models[0]
            return m.reduced_effective(self.expand(u, m.name), self.frees[0], ck, cm, cc)
        J = ck * self.tangent(u) + cm * self.M
        return J + cc * self.C if cc else J

    def tangent(self, u: np.ndarray) -> sp.csr_matrix:
        """Tangent stiffness d(internal_force)/du over the free dofs (K for linear members)."""
        if not self.nonlinear:
            return self.K
        if len(self.models) == 1:
            return self.models[0].reduced_tangent(self.expand(u, self.names[0]), self.frees[0])[1]
        blocks = []
        for m, f in zip(self.models, self.frees, strict=True):
            if m.nonlinear:
                blocks.append(m.reduced_tangent(self.expand(u, m.name), f)[1])
            else:
                blocks.append(self.K[self.dof_slices[m.name], self.dof_slices[m.name]])
        return sp.block_diag(blocks, format="csr")
