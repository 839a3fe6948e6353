"""Euler-Bernoulli beam in a 2D scene: bending on ElementLineHermite, axial on ElementLineP1.

The member runs from ``start`` to ``end`` (length L, unit tangent t, normal n = t turned 90 degrees
anticlockwise). Its local coordinate is the arc length s in [0, L]. Unknowns:

* transverse deflection w(s) along n and its slope w'(s) (Hermite cubic, C1): bending,
  stiffness ``EI int w'' v''``, consistent mass ``rho A int w v``;
* axial displacement u(s) along t (linear, optional): ``EA int u' v'`` and ``rho A int u v``.

The two fields are uncoupled (small deflections), so M and K are block diagonal
``[bending | axial]``. Rotary inertia and shear deformation are neglected (Euler-Bernoulli).

Like every 2D quantity the model is per metre of width: EI (N m^2/m), EA (N/m), rho A (kg/m^2),
loads in N/m per metre of width, energies in J/m. A member ``width`` b only divides the section
given for the whole width (A = b t, I = b t^3 / 12 or ``area`` / ``second_moment``) by b.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementLineHermite, ElementLineP1, LinearForm, MeshLine1
from skfem.helpers import dd, grad

from .boundary_conditions import beam_constrained_dofs
from .model import MemberModel

__all__ = [
    "BeamModel",
    "beam_section",
    "beam_bending_form",
    "line_mass_form",
    "bar_stiffness_form",
    "unit_load_form",
]


def beam_section(cfg) -> tuple[float, float, float]:
    """(EI in N m^2/m, EA in N/m, rho A in kg/m^2) per metre of width of a
    :class:`~mpsfem.scenario.structure.BeamMember`."""
    mat = cfg.material
    E = mat.youngs_modulus
    if cfg.plate_strip:
        E = E / (1.0 - mat.poisson_ratio**2)
    # the section (A, I) describes the member's whole width b; the 2D model, like every 2D
    # force and energy it exchanges, is per metre of width: A / b, I / b
    b = cfg.width
    area = cfg.area_per_width
    inertia = (
        cfg.second_moment if cfg.second_moment is not None else b * cfg.thickness**3 / 12.0
    ) / b
    return E * inertia, E * area, mat.density * area


@BilinearForm
def beam_bending_form(u, v, w):
    """int w'' v'' ds (times EI gives the bending stiffness)."""
    return dd(u)[0, 0] * dd(v)[0, 0]


@BilinearForm
def line_mass_form(u, v, w):
    """int u v ds (times rho A gives the consistent mass)."""
    return u * v


@BilinearForm
def bar_stiffness_form(u, v, w):
    """int u' v' ds (times EA gives the axial stiffness)."""
    return grad(u)[0] * grad(v)[0]


@LinearForm
def unit_load_form(v, w):
    """int v ds (times a line load q gives the consistent load vector)."""
    return v


class BeamModel(MemberModel):
    """Discretised beam; build with :meth:`from_config` or :meth:`create`."""

    length: float
    tangent: np.ndarray
    normal: np.ndarray
    start: np.ndarray
    s: np.ndarray
    EI: float  # per metre of width, N m^2 / m
    EA: float  # N / m
    rhoA: float  # kg / m^2
    width: float  # m, informative: the properties above are already per metre of width
    w_dofs: np.ndarray
    slope_dofs: np.ndarray
    u_dofs: np.ndarray | None
    n_bending: int

    @classmethod
    def from_config(cls, cfg) -> BeamModel:
        """From a :class:`~mpsfem.scenario.structure.BeamMember`."""
        EI, EA, rhoA = beam_section(cfg)
        return cls.create(
            name=cfg.name,
            start=cfg.start,
            end=cfg.end,
            elements=cfg.elements,
            EI=EI,
            EA=EA,
            rhoA=rhoA,
            bcs=cfg.edge_bcs,
            axial=cfg.axial,
            width=cfg.width,
            thickness=cfg.thickness,
            geometric_thickness=cfg.fluid_thickness,
            rayleigh_a1=cfg.rayleigh_a1,
            rayleigh_a2=cfg.rayleigh_a2,
        )

    @classmethod
    def create(
        cls,
        *,
        name: str,
        start,
        end,
        elements: int,
        EI: float,
        EA: float,
        rhoA: float,
        bcs: list[str],
        axial: bool = True,
        width: float = 1.0,
        thickness: float = 0.0,
        geometric_thickness: float | None = None,
        rayleigh_a1: float = 0.0,
        rayleigh_a2: float = 0.0,
    ) -> BeamModel:
        start = np.asarray(start, dtype=float)
        end = np.asarray(end, dtype=float)
        L = float(np.linalg.norm(end - start))
        t = (end - start) / L
        n = np.array([-t[1], t[0]])
        s = np.linspace(0.0, L, elements + 1)
        mesh = MeshLine1.init_tensor(s)
        bw = Basis(mesh, ElementLineHermite())
        Kb = EI * beam_bending_form.assemble(bw)
        Mb = rhoA * line_mass_form.assemble(bw)
        nn = elements + 1
        w_dofs = bw.nodal_dofs[0].astype(np.int64)
        r_dofs = bw.nodal_dofs[1].astype(np.int64)
        nb = bw.N
        if axial:
            bu = Basis(mesh, ElementLineP1())
            Ka = EA * bar_stiffness_form.assemble(bu)
            Ma = rhoA * line_mass_form.assemble(bu)
            u_dofs = nb + bu.nodal_dofs[0].astype(np.int64)
            K = sp.block_diag((Kb, Ka), format="csr")
            M = sp.block_diag((Mb, Ma), format="csr")
        else:
            bu = None
            u_dofs = None
            K, M = Kb.tocsr(), Mb.tocsr()
        ndof = M.shape[0]

        # nodal translation T: (w n + u t) at each node, node-major rows
        rows, cols, vals = [], [], []
        for c in range(2):
            rows.append(2 * np.arange(nn) + c)
            cols.append(w_dofs)
            vals.append(np.full(nn, n[c]))
            if axial:
                rows.append(2 * np.arange(nn) + c)
                cols.append(u_dofs)
                vals.append(np.full(nn, t[c]))
        T = sp.csr_matrix(
            (np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
            shape=(2 * nn, ndof),
        )
        R = sp.csr_matrix((np.ones(nn), (np.arange(nn), r_dofs)), shape=(nn, ndof))
        fixed = beam_constrained_dofs(
            bcs,
            w=(w_dofs[0], w_dofs[-1]),
            slope=(r_dofs[0], r_dofs[-1]),
            axial=None if u_dofs is None else (u_dofs[0], u_dofs[-1]),
        )
        dof_kind = np.zeros(ndof, dtype=np.int8)
        if axial:
            dof_kind[nb:] = 1
        model = cls(
            name=name,
            dim=2,
            M=M,
            K=K,
            fixed=fixed,
            nodes=start[None, :] + s[:, None] * t[None, :],
            normals=np.tile(n, (nn, 1)),
            connectivity=np.column_stack([np.arange(nn - 1), np.arange(1, nn)]),
            translation=T,
            thickness=thickness,
            geometric_thickness=thickness if geometric_thickness is None else geometric_thickness,
            rayleigh_a1=rayleigh_a1,
            rayleigh_a2=rayleigh_a2,
            rotation=R,
            rotation_components=("theta",),
            dof_kind=dof_kind,
            dof_kind_names=("bending", "axial"),
        )
        model.length = L
        model.tangent = t
        model.normal = n
        model.start = start
        model.s = s
        model.EI, model.EA, model.rhoA, model.width = EI, EA, rhoA, width
        model.basis_w, model.basis_u = bw, bu
        model.w_dofs, model.slope_dofs, model.u_dofs = w_dofs, r_dofs, u_dofs
        model.n_bending = nb
        return model

    # ------------------------------------------------------------------ loads
    def _line_load(self, q: np.ndarray) -> np.ndarray:
        """Consistent load of a uniform line load vector q (N/m, scene components)."""
        F = np.zeros(self.n_dof)
        F[: self.n_bending] = float(q @ self.normal) * unit_load_form.assemble(self.basis_w)
        if self.basis_u is not None:
            F[self.n_bending :] = float(q @ self.tangent) * unit_load_form.assemble(self.basis_u)
        return F

    def gravity_load(self, g: np.ndarray) -> np.ndarray:
        return self._line_load(self.rhoA * np.asarray(g, dtype=float))

    def pressure_load(self, p: float) -> np.ndarray:
        return self._line_load(p * self.normal)

    def local_coordinate(self, point) -> float:
        """Arc length s of the projection of a scene point onto the centreline, clipped to [0, L]."""
        s = float((np.asarray(point, dtype=float) - self.start) @ self.tangent)
        return min(max(s, 0.0), self.length)

    def point_matrix(self, point) -> sp.csr_matrix:
        s = self.local_coordinate(point)
        # keep the probe strictly inside the mesh so the element finder never misses an end
        s = min(max(s, 0.0), self.length * (1.0 - 1e-14))
        Pw = self.basis_w.probes(np.array([[s]])).tocsr()  # 1 x n_bending
        Pw_full = sp.hstack([Pw, sp.csr_matrix((1, self.n_dof - self.n_bending))], format="csr")
        out = sp.kron(sp.csr_matrix(self.normal[:, None]), Pw_full, format="csr")
        if self.basis_u is not None:
            Pu = self.basis_u.probes(np.array([[s]])).tocsr()
            Pu_full = sp.hstack([sp.csr_matrix((1, self.n_bending)), Pu], format="csr")
            out = out + sp.kron(sp.csr_matrix(self.tangent[:, None]), Pu_full, format="csr")
        return out.tocsr()
