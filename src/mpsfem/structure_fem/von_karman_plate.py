"""Von Karman plate in a 3D scene: moderately large deflections (membrane-bending coupling).

Kirchhoff bending of the deflection w (``ElementQuadBFS``, rectangles, as :mod:`.plate`) plus
in-plane displacements (u, v) along the plate axes (``ElementVector(ElementQuad2)``), coupled by
the von Karman membrane strain (Timoshenko & Woinowsky-Krieger 1959, *Theory of Plates and
Shells*, sec. 96, eqs. 219-220)::

    eps = sym grad(u, v) + 1/2 grad w (x) grad w
    N = E h / (1 - nu^2) [(1 - nu) eps + nu tr(eps) I]     (membrane forces, N/m)

Strain energy ``1/2 int N : eps dA + 1/2 D int [(1 - nu) w_,ij w_,ij + nu (lap w)^2] dA``; its
first variation is the internal force, its second the tangent (membrane + bending + geometric
``int grad(dw) . N grad(w~)``). Internal force and tangent are scikit-fem forms evaluated with
the current state at the quadrature points (one quadrature, ``INTORDER``, for both bases).

Supports: a ``clamped`` or ``simply_supported`` edge also holds the in-plane displacements
(u = v = 0, an immovable edge: stretching carries the load); a ``free`` edge holds nothing.
Mass: ``rho h`` on w and on (u, v) (in-plane inertia). Loads are dead: a pressure along the
reference normal, self-weight (normal part on w, in-plane part on u, v), nodal forces on the
nodal translation ``w n + u e_u + v e_v``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from skfem import (
    Basis,
    BilinearForm,
    ElementQuad2,
    ElementQuadBFS,
    ElementVector,
    Functional,
    LinearForm,
)
from skfem.helpers import ddot, dot, grad, sym_grad

from .plate import PlateModel, area_mass_form, plate_bending_form

__all__ = ["VonKarmanPlateModel"]

#: polynomial degree integrated exactly by the quadrature of both bases
INTORDER = 8


@BilinearForm
def _membrane_form(u, v, w):
    """int [(1 - nu) eps(u) : eps(v) + nu div u div v] (times E h / (1 - nu^2))."""
    eu, ev = sym_grad(u), sym_grad(v)
    return (1.0 - w.nu) * ddot(eu, ev) + w.nu * (eu[0, 0] + eu[1, 1]) * (ev[0, 0] + ev[1, 1])


@BilinearForm
def _vector_mass_form(u, v, w):
    """int u . v dA (times rho h: in-plane inertia)."""
    return dot(u, v)


@LinearForm
def _force_w(v, w):
    """int grad(v) . N grad(w~) (geometric part of the force on w)."""
    return dot(w.Ngw, grad(v))


@LinearForm
def _force_m(v, w):
    """int N : eps(v) (force on u, v)."""
    return ddot(w.N, sym_grad(v))


@BilinearForm
def _tangent_ww(u, v, w):
    """int grad(v) . Q grad(u), Q = N + C (1 - nu) / 2 |g|^2 I + C (1 + nu) / 2 g (x) g.

    With g = grad w~ and S(a) = sym(g (x) a) (the variation of 1/2 g (x) g along a):
    S(a) : S(b) = 1/2 [(g.g)(a.b) + (g.a)(g.b)] and tr S(a) = g.a, so the second variation
    grad(v) . N grad(u) + C [(1 - nu) S(u) : S(v) + nu tr S(u) tr S(v)] is grad(v) . Q grad(u).
    """
    gu, gv = grad(u), grad(v)
    Q = w.Q
    return (Q[0, 0] * gu[0] + Q[0, 1] * gu[1]) * gv[0] + (Q[1, 0] * gu[0] + Q[1, 1] * gu[1]) * gv[1]


@BilinearForm
def _tangent_mw(u, v, w):
    """Trial d (w basis), test v (membrane): C [(1 - nu) S(d) : eps(v) + nu tr S(d) div v]
    = grad(d) . C [(1 - nu) eps(v) g + nu div(v) g] (S(d) : eps = (eps g) . d, eps symmetric)."""
    gd, ev, g = grad(u), sym_grad(v), w.gw
    dv = ev[0, 0] + ev[1, 1]
    a0 = (1.0 - w.nu) * (ev[0, 0] * g[0] + ev[0, 1] * g[1]) + w.nu * dv * g[0]
    a1 = (1.0 - w.nu) * (ev[1, 0] * g[0] + ev[1, 1] * g[1]) + w.nu * dv * g[1]
    return w.C * (a0 * gd[0] + a1 * gd[1])


@Functional
def _membrane_energy(w):
    """1/2 int N : eps dA."""
    return 0.5 * ddot(w.N, w.eps)


class VonKarmanPlateModel(PlateModel):
    """Von Karman plate (BFS rectangles); dofs ``[w (BFS) | u, v (vector Q2)]``."""

    nonlinear = True

    @classmethod
    def create(cls, *, element: str, **kw) -> VonKarmanPlateModel:
        if element != "bfs":
            raise ValueError(
                f'kinematics = "von_karman" needs element = "bfs" (rectangles), got {element!r}'
            )
        model = super().create(element=element, **kw)
        E, nu, h = kw["E"], kw["nu"], kw["thickness"]
        mesh = model.mesh
        bw = Basis(mesh, ElementQuadBFS(), intorder=INTORDER)
        bm = Basis(mesh, ElementVector(ElementQuad2()), intorder=INTORDER)
        Nw, Nm = bw.N, bm.N
        C = E * h / (1.0 - nu**2)
        Kb = (model.D * plate_bending_form(nu).assemble(bw)).tocsr()
        Km = (C * _membrane_form.assemble(bm, nu=nu)).tocsr()
        Mw = (model.rho_h * area_mass_form.assemble(bw)).tocsr()
        Mm = (model.rho_h * _vector_mass_form.assemble(bm)).tocsr()
        model.M = sp.block_diag((Mw, Mm), format="csr")
        model.K = sp.block_diag((Kb, Km), format="csr")
        # supports: the bending dofs as the linear plate; held edges also fix u, v
        fixed = [model.fixed]
        for facets, bc in zip(model.edge_facets, kw["bcs"], strict=True):
            if bc != "free" and len(facets):
                fixed.append(Nw + np.asarray(bm.get_dofs(facets=np.asarray(facets)).all()))
        model.fixed = np.unique(np.concatenate(fixed)).astype(np.int64)
        nn = mesh.p.shape[1]
        ud, vd = Nw + bm.nodal_dofs[0], Nw + bm.nodal_dofs[1]
        # nodal translation w n + u e_u + v e_v (node-major rows, as the linear plate)
        rows = np.concatenate([3 * np.arange(nn) + c for c in range(3) for _ in range(2)])
        cols = np.concatenate([d for _ in range(3) for d in (ud, vd)])
        vals = np.concatenate([np.full(nn, e[c]) for c in range(3) for e in (model.e_u, model.e_v)])
        Tm = sp.csr_matrix((vals, (rows, cols)), shape=(3 * nn, Nw + Nm))
        pad = sp.csr_matrix((3 * nn, Nm))
        model.translation = (sp.hstack([model.translation, pad], format="csr") + Tm).tocsr()
        R = model.rotation
        model.rotation = sp.hstack([R, sp.csr_matrix((R.shape[0], Nm))], format="csr")
        model.dof_kind = np.concatenate([np.zeros(Nw, np.int8), np.ones(Nm, np.int8)])
        model.dof_kind_names = ("bending", "membrane")
        model.bw, model.bm, model.Nw, model.Nm = bw, bm, Nw, Nm
        model.C_membrane, model.nu, model.Kb, model.Km = C, nu, Kb, Km
        return model

    # ------------------------------------------------------------------ state at quadrature points
    def _fields(self, q: np.ndarray) -> dict:
        wq, mq = q[: self.Nw], q[self.Nw :]
        gw = self.bw.interpolate(wq).grad  # (2, nel, nqp)
        gm = self.bm.interpolate(mq).grad  # (2, 2, nel, nqp)
        eps = 0.5 * (gm + gm.transpose(1, 0, 2, 3)) + 0.5 * gw[:, None] * gw[None, :]
        tr = eps[0, 0] + eps[1, 1]
        # Timoshenko & Woinowsky-Krieger (1959) eq. 219: N = C [(1 - nu) eps + nu tr(eps) I]
        N = self.C_membrane * (1.0 - self.nu) * eps
        N[0, 0] += self.C_membrane * self.nu * tr
        N[1, 1] += self.C_membrane * self.nu * tr
        Ngw = np.einsum("ij...,j...->i...", N, gw)
        return {"gw": gw, "eps": eps, "N": N, "Ngw": Ngw}

    def internal_force(self, q: np.ndarray) -> np.ndarray:
        """Internal force over all dofs (N) at the full dof vector `q`."""
        fd = self._fields(q)
        fw = self.Kb @ q[: self.Nw] + _force_w.assemble(self.bw, Ngw=fd["Ngw"])
        fm = _force_m.assemble(self.bm, N=fd["N"])
        return np.concatenate([fw, fm])

    def tangent_stiffness(self, q: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """(internal force, consistent tangent) over all dofs at `q`."""
        fd = self._fields(q)
        g, C, nu = fd["gw"], self.C_membrane, self.nu
        Q = fd["N"] + 0.5 * C * (1.0 + nu) * g[:, None] * g[None, :]
        Q[0, 0] += 0.5 * C * (1.0 - nu) * (g[0] ** 2 + g[1] ** 2)
        Q[1, 1] += 0.5 * C * (1.0 - nu) * (g[0] ** 2 + g[1] ** 2)
        Kww = self.Kb + _tangent_ww.assemble(self.bw, Q=Q)
        Kmw = _tangent_mw.assemble(self.bw, self.bm, gw=g, C=C, nu=nu)
        K = sp.bmat([[Kww, Kmw.T], [Kmw, self.Km]], format="csr")
        fw = self.Kb @ q[: self.Nw] + _force_w.assemble(self.bw, Ngw=fd["Ngw"])
        fm = _force_m.assemble(self.bm, N=fd["N"])
        return np.concatenate([fw, fm]), K

    def reduced_tangent(self, q: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        f, K = self.tangent_stiffness(q)
        return f[free], K[free][:, free].tocsr()

    def reduced_effective(
        self, q: np.ndarray, free: np.ndarray, ck: float, cm: float, cc: float
    ) -> sp.csr_matrix:
        """``ck K_t(q) + cm M + cc C`` over the `free` dofs (sparse)."""
        _, K = self.tangent_stiffness(q)
        J = ck * K + (cm + cc * self.rayleigh_a1) * self.M
        if cc * self.rayleigh_a2:
            J = J + (cc * self.rayleigh_a2) * self.K
        return J.tocsr()[free][:, free].tocsr()

    def strain_energy(self, q: np.ndarray) -> float:
        """Bending plus membrane strain energy (J)."""
        fd = self._fields(q)
        wq = q[: self.Nw]
        return 0.5 * float(wq @ (self.Kb @ wq)) + float(
            _membrane_energy.assemble(self.bm, N=fd["N"], eps=fd["eps"])
        )

    # ------------------------------------------------------------------ loads
    def gravity_load(self, g: np.ndarray) -> np.ndarray:
        g = np.asarray(g, dtype=float)
        F = np.zeros(self.n_dof)
        F[: self.Nw] = super().pressure_load(self.rho_h * float(g @ self.normal))[: self.Nw]
        gt = self.rho_h * np.array([g @ self.e_u, g @ self.e_v])

        @LinearForm
        def inplane(v, w):
            return gt[0] * v[0] + gt[1] * v[1]

        F[self.Nw :] = inplane.assemble(self.bm)
        return F

    def pressure_load(self, p: float) -> np.ndarray:
        F = np.zeros(self.n_dof)
        F[: self.Nw] = super().pressure_load(p)
        return F

    def point_matrix(self, point) -> sp.csr_matrix:
        uv = self.nearest_local(point)
        Pw = self.bw.probes(uv[:, None]).tocsr()  # 1 x Nw
        Pm = self.bm.probes(uv[:, None]).tocsr()  # 2 x Nm (u, v)
        rows = sp.kron(sp.csr_matrix(self.normal[:, None]), Pw, format="csr")
        inplane = sp.csr_matrix(np.column_stack([self.e_u, self.e_v])) @ Pm
        return sp.hstack([rows, inplane], format="csr")
