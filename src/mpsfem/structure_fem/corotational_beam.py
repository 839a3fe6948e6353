"""Co-rotational Euler-Bernoulli beam in a 2D scene: large rotations, small strains.

Crisfield's 2D co-rotational beam (Crisfield 1991, *Non-linear Finite Element Analysis of Solids
and Structures*, vol. 1, sec. 7.2-7.3; Battini 2002, ch. 2). Each element's rigid motion is taken
out by a frame that follows its chord; in that frame the element is the linear Euler-Bernoulli
beam (axial bar + cubic bending), so strains stay small while rotations are unrestricted.

Unknowns are global, node-major, per node: ``(ux, uy, theta)`` - the translation in scene
coordinates (m) and the anticlockwise rotation (rad, total, not wrapped). The element kernels
are small numba functions looping over the chain of elements (element e joins nodes e, e + 1):

* local deformations: axial stretch ``u_l = l - l0`` and end rotations
  ``theta_i,l = theta_i - (beta - beta0)``, the chord rotation ``beta - beta0`` taken on the
  branch (mod 2 pi) nearest the element's mean nodal rotation;
* local forces: ``N = EA u_l / l0``, ``[M1, M2] = EI / l0 [[4, 2], [2, 4]] [theta_1l, theta_2l]``;
* internal force ``f = B^T [N, M1, M2]`` and the consistent tangent
  ``K_t = B^T D B + N / l z z^T + (M1 + M2) / l^2 (r z^T + z r^T)`` (geometric stiffness incl.).

Mass (constant, rotation invariant, so the kinetic energy is exactly ``1/2 v.M v`` in any
configuration): the centreline translation interpolated linearly, ``rho A h / 6 [[2, 1], [1, 2]]``
per scene component, plus a rotary inertia ``rho A h^3 / 105`` at each element end (the
theta-theta diagonal of the Hermite consistent mass), which keeps M regular; it converges to the
Euler-Bernoulli mass as h -> 0 (frequency error O(h^2)). Rayleigh damping uses the reference
tangent ``K0 = K_t(0)``: ``C = a1 M + a2 K0`` (constant).

Loads are dead (fixed direction): nodal forces act on the translation dofs directly; a line
load (self-weight, a pressure along the *reference* normal) is distributed with the same linear
interpolation as the mass (no nodal moments).

Per metre of width like every 2D quantity: EI (N m^2/m), EA (N/m), rho A (kg/m^2).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from numba import njit

from .boundary_conditions import beam_constrained_dofs
from .linsolve import BandMatrix
from .model import MemberModel

__all__ = ["CorotationalBeamModel", "corotational_element_tangents"]

TWO_PI = 2.0 * np.pi


@njit(cache=True)
def _local(d0x, d0y, L0, dux, duy, th1, th2):
    """Current chord (l, c, s), axial stretch ul and local end rotations t1, t2 of one element."""
    # l^2 - l0^2 = 2 D0.du + du.du, without the cancellation of l - l0
    dl2 = 2.0 * (d0x * dux + d0y * duy) + dux * dux + duy * duy
    l = math.sqrt(L0 * L0 + dl2)
    ul = dl2 / (l + L0)  # Crisfield (1991) eq. 7.2, u_l = l - l0
    c = (d0x + dux) / l
    s = (d0y + duy) / l
    c0 = d0x / L0
    s0 = d0y / L0
    # rigid rotation of the chord, beta - beta0, on the branch (mod 2 pi) nearest the mean
    # nodal rotation: nodal rotations are unbounded (a beam rolled into a circle turns by 2 pi),
    # and a node turned by a further 2 pi is a different, strained, state
    alpha = math.atan2(c0 * s - s0 * c, c0 * c + s0 * s)
    alpha += TWO_PI * math.floor((0.5 * (th1 + th2) - alpha) / TWO_PI + 0.5)
    # Crisfield (1991) eq. 7.3, theta_il = theta_i - (beta - beta0)
    return l, c, s, ul, th1 - alpha, th2 - alpha


@njit(cache=True)
def _element(D0, L0, EA, EI, u, e, fe, ke, tangent):
    """Force fe (6,) and, if `tangent`, tangent ke (6, 6) of element e; u (n, 3) nodal dofs of
    the element's nodes e, e + 1 (rows e and e + 1)."""
    l, c, s, ul, t1, t2 = _local(
        D0[e, 0], D0[e, 1], L0[e], u[e + 1, 0] - u[e, 0], u[e + 1, 1] - u[e, 1], u[e, 2],
        u[e + 1, 2],
    )  # fmt: skip
    k = EI / L0[e]
    N = EA * ul / L0[e]  # Crisfield (1991) eq. 7.6, N = EA u_l / l0
    M1 = k * (4.0 * t1 + 2.0 * t2)  # eq. 7.6, linear Euler-Bernoulli end moments
    M2 = k * (2.0 * t1 + 4.0 * t2)
    Q = (M1 + M2) / l
    # Crisfield (1991) eq. 7.14, f = B^T [N, M1, M2] = r N - z (M1 + M2) / l + e3 M1 + e6 M2,
    # r = (-c, -s, 0, c, s, 0) = dl/dp (eq. 7.10), z = (s, -c, 0, -s, c, 0) = l dbeta/dp (7.11)
    fe[0] = -c * N - s * Q
    fe[1] = -s * N + c * Q
    fe[2] = M1
    fe[3] = c * N + s * Q
    fe[4] = s * N - c * Q
    fe[5] = M2
    if not tangent:
        return
    r = (-c, -s, 0.0, c, s, 0.0)
    z = (s, -c, 0.0, -s, c, 0.0)
    ka = EA / L0[e]
    gN = N / l
    gM = (M1 + M2) / (l * l)
    for i in range(6):
        b1i = -z[i] / l + (1.0 if i == 2 else 0.0)  # rows 2, 3 of B: e3 - z/l, e6 - z/l
        b2i = -z[i] / l + (1.0 if i == 5 else 0.0)
        for j in range(6):
            b1j = -z[j] / l + (1.0 if j == 2 else 0.0)
            b2j = -z[j] / l + (1.0 if j == 5 else 0.0)
            # Crisfield (1991) eq. 7.16: K_t = B^T D B + N/l z z^T + (M1 + M2)/l^2 (r z^T + z r^T),
            # D = diag(EA/l0, EI/l0 [[4, 2], [2, 4]])
            ke[i, j] = (
                ka * r[i] * r[j]
                + k * (4.0 * b1i * b1j + 2.0 * b1i * b2j + 2.0 * b2i * b1j + 4.0 * b2i * b2j)
                + gN * z[i] * z[j]
                + gM * (r[i] * z[j] + z[i] * r[j])
            )


@njit(cache=True)
def _chain_forces(D0, L0, EA, EI, u, f):
    """Internal force f (n, 3) of a chain of elements (element e joins nodes e, e + 1)."""
    fe = np.empty(6)
    ke = np.empty((6, 6))
    f[:] = 0.0
    for e in range(L0.shape[0]):
        _element(D0, L0, EA, EI, u, e, fe, ke, False)
        for a in range(3):
            f[e, a] += fe[a]
            f[e + 1, a] += fe[3 + a]


@njit(cache=True)
def _chain_tangents(D0, L0, EA, EI, u, f, ke):
    """Internal force f (n, 3) and element tangents ke (ne, 6, 6) of a chain."""
    fe = np.empty(6)
    f[:] = 0.0
    for e in range(L0.shape[0]):
        _element(D0, L0, EA, EI, u, e, fe, ke[e], True)
        for a in range(3):
            f[e, a] += fe[a]
            f[e + 1, a] += fe[3 + a]


@njit(cache=True)
def _chain_energy(D0, L0, EA, EI, u):
    """Strain energy and largest local end rotation of a chain."""
    W = 0.0
    tmax = 0.0
    for e in range(L0.shape[0]):
        _, _, _, ul, t1, t2 = _local(
            D0[e, 0], D0[e, 1], L0[e], u[e + 1, 0] - u[e, 0], u[e + 1, 1] - u[e, 1], u[e, 2],
            u[e + 1, 2],
        )  # fmt: skip
        # 1/2 EA ul^2 / l0 + 1/2 [t1 t2] EI/l0 [[4, 2], [2, 4]] [t1 t2]^T
        W += 0.5 * EA * ul * ul / L0[e] + EI / L0[e] * (
            2.0 * t1 * t1 + 2.0 * t1 * t2 + 2.0 * t2 * t2
        )
        tmax = max(tmax, abs(t1), abs(t2))
    return W, tmax


def corotational_element_tangents(
    D0: np.ndarray,
    L0: np.ndarray,
    EA: float,
    EI: float,
    ue: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Internal forces (ne, 6) and consistent tangents (ne, 6, 6) of separate elements.

    D0 (ne, 2): reference chords X2 - X1 (m); L0 (ne,): their lengths; EA (N/m), EI (N m^2/m);
    ue (ne, 6): element dofs (ux1, uy1, theta1, ux2, uy2, theta2) in m and rad. Forces in N/m
    and N m/m per metre of width.
    """
    ne = len(L0)
    fe = np.empty((ne, 6))
    ke = np.empty((ne, 6, 6))
    for e in range(ne):
        u = np.ascontiguousarray(ue[e].reshape(2, 3), dtype=float)
        _element(D0[e : e + 1], L0[e : e + 1], float(EA), float(EI), u, 0, fe[e], ke[e], True)
    return fe, ke


class CorotationalBeamModel(MemberModel):
    """Co-rotational 2D beam; build with :meth:`from_config` or :meth:`create`.

    ``K`` is the tangent at the reference configuration (used by modal analysis, the Rayleigh
    matrix and the stability check); the state-dependent force and tangent come from
    :meth:`internal_force`, :meth:`tangent_stiffness` and :meth:`reduced_tangent`.
    """

    nonlinear = True
    length: float
    tangent_vector: np.ndarray
    normal: np.ndarray
    start: np.ndarray
    s: np.ndarray
    EI: float  # N m^2 / m
    EA: float  # N / m
    rhoA: float  # kg / m^2
    width: float

    @classmethod
    def from_config(cls, cfg) -> CorotationalBeamModel:
        """From a :class:`~mpsfem.scenario.structure.BeamMember` with kinematics "corotational"."""
        from .beam import beam_section

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
        width: float = 1.0,
        thickness: float = 0.0,
        geometric_thickness: float | None = None,
        rayleigh_a1: float = 0.0,
        rayleigh_a2: float = 0.0,
    ) -> CorotationalBeamModel:
        start = np.asarray(start, dtype=float)
        end = np.asarray(end, dtype=float)
        L = float(np.linalg.norm(end - start))
        t = (end - start) / L
        n = np.array([-t[1], t[0]])
        s = np.linspace(0.0, L, elements + 1)
        nn = elements + 1
        X = start[None, :] + s[:, None] * t[None, :]
        ne = elements
        ndof = 3 * nn
        # element dofs: 3 i .. 3 i + 5 (a chain)
        edofs = 3 * np.arange(ne)[:, None] + np.arange(6)[None, :]
        h = np.diff(s)
        # mass: linear translation (rho A h / 6 [[2, 1], [1, 2]] per component) + rotary
        # inertia rho A h^3 / 105 per element end (Przemieniecki 1968, Hermite mass theta-theta)
        me = np.zeros((ne, 6, 6))
        for a in range(2):
            me[:, a, a] = me[:, 3 + a, 3 + a] = rhoA * h / 3.0
            me[:, a, 3 + a] = me[:, 3 + a, a] = rhoA * h / 6.0
        me[:, 2, 2] = me[:, 5, 5] = rhoA * h**3 / 105.0
        rows = np.repeat(edofs, 6, axis=1).ravel()
        cols = np.tile(edofs, (1, 6)).ravel()
        M = sp.csr_matrix((me.ravel(), (rows, cols)), shape=(ndof, ndof))
        M.sum_duplicates()
        T = sp.csr_matrix(
            (np.ones(2 * nn), (np.arange(2 * nn), (3 * np.arange(nn)[:, None] + [0, 1]).ravel())),
            shape=(2 * nn, ndof),
        )
        R = sp.csr_matrix((np.ones(nn), (np.arange(nn), 3 * np.arange(nn) + 2)), shape=(nn, ndof))
        ux, uy, th = 3 * np.arange(nn), 3 * np.arange(nn) + 1, 3 * np.arange(nn) + 2
        fixed = beam_constrained_dofs(
            bcs, w=(uy[0], uy[-1]), slope=(th[0], th[-1]), axial=(ux[0], ux[-1])
        )
        D0 = np.diff(X, axis=0)
        L0 = np.hypot(D0[:, 0], D0[:, 1])
        _, k0 = corotational_element_tangents(D0, L0, EA, EI, np.zeros((ne, 6)))
        K0 = sp.csr_matrix((k0.ravel(), (rows, cols)), shape=(ndof, ndof))
        K0.sum_duplicates()
        model = cls(
            name=name,
            dim=2,
            M=M,
            K=K0,
            fixed=fixed,
            nodes=X,
            normals=np.tile(n, (nn, 1)),
            connectivity=np.column_stack([np.arange(nn - 1), np.arange(1, nn)]),
            translation=T,
            thickness=thickness,
            geometric_thickness=thickness if geometric_thickness is None else geometric_thickness,
            rayleigh_a1=rayleigh_a1,
            rayleigh_a2=rayleigh_a2,
            rotation=R,
            rotation_components=("theta",),
            dof_kind=np.zeros(ndof, dtype=np.int8),
            dof_kind_names=("bending", "axial"),
        )
        model.length, model.tangent_vector, model.normal, model.start, model.s = L, t, n, start, s
        model.EI, model.EA, model.rhoA, model.width = EI, EA, rhoA, width
        model._D0, model._L0 = np.ascontiguousarray(D0), np.ascontiguousarray(L0)
        model.EA, model.EI = float(EA), float(EI)
        model._rows, model._cols = rows, cols
        model._me, model._k0e = me, k0
        model._free_plan = None
        return model

    # ------------------------------------------------------------------ kernels, full dofs
    def internal_force(self, q: np.ndarray) -> np.ndarray:
        """Internal force vector over all dofs (N/m, N m/m) at the full dof vector `q`."""
        f = np.empty((self.n_nodes, 3))
        _chain_forces(self._D0, self._L0, self.EA, self.EI, q.reshape(-1, 3), f)
        return f.reshape(-1)

    def element_tangents(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(internal force over all dofs, element tangents (ne, 6, 6)) at `q`."""
        f = np.empty((self.n_nodes, 3))
        ke = np.empty((len(self._L0), 6, 6))
        _chain_tangents(self._D0, self._L0, self.EA, self.EI, q.reshape(-1, 3), f, ke)
        return f.reshape(-1), ke

    def tangent_stiffness(self, q: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """(internal force, consistent tangent stiffness) over all dofs at `q`."""
        f, ke = self.element_tangents(q)
        K = sp.csr_matrix((ke.ravel(), (self._rows, self._cols)), shape=(self.n_dof, self.n_dof))
        K.sum_duplicates()
        return f, K

    def _plans(self, free: np.ndarray) -> dict:
        """Assembly maps of element matrices onto the `free` dofs (computed once per `free`):
        CSR (indptr, indices, target, keep) and LAPACK upper band storage (bw, band, upper)."""
        if self._free_plan is None or not np.array_equal(self._free_plan[0], free):
            n = len(free)
            where = np.full(self.n_dof, -1, dtype=np.int64)
            where[free] = np.arange(n)
            r, c = where[self._rows], where[self._cols]
            keep = (r >= 0) & (c >= 0)
            key = r[keep] * n + c[keep]
            uniq, target = np.unique(key, return_inverse=True)
            indptr = np.zeros(n + 1, dtype=np.int64)
            np.add.at(indptr, uniq // n + 1, 1)
            upper = keep & (r <= c)
            bw = int((c[upper] - r[upper]).max()) if upper.any() else 0
            band = (bw + r[upper] - c[upper]) * n + c[upper]  # ab[bw + i - j, j] = A[i, j]
            plans = {
                "csr": (np.cumsum(indptr), (uniq % n).astype(np.int32), target, keep),
                "band": (bw, band, upper),
            }
            self._free_plan = (free.copy(), plans)
        return self._free_plan[1]

    def reduced_tangent(self, q: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """(internal force, tangent) restricted to the `free` dofs at the full dof vector `q`."""
        f, ke = self.element_tangents(q)
        indptr, indices, target, keep = self._plans(free)["csr"]
        data = np.bincount(target, weights=ke.ravel()[keep], minlength=len(indices))
        K = sp.csr_matrix((data, indices, indptr), shape=(len(free), len(free)))
        return f[free], K

    def reduced_effective(
        self, q: np.ndarray, free: np.ndarray, ck: float, cm: float, cc: float
    ) -> BandMatrix:
        """``ck K_t(q) + cm M + cc C`` over the `free` dofs in band storage, assembled once from
        the element matrices (C = a1 M + a2 K0, the Rayleigh matrix of :mod:`.model`)."""
        _, ke = self.element_tangents(q)
        e = ck * ke
        e += (cm + cc * self.rayleigh_a1) * self._me
        if cc * self.rayleigh_a2:
            e += (cc * self.rayleigh_a2) * self._k0e
        bw, band, upper = self._plans(free)["band"]
        n = len(free)
        ab = np.bincount(band, weights=e.ravel()[upper], minlength=(bw + 1) * n)
        return BandMatrix(ab.reshape(bw + 1, n), bw)

    def strain_energy(self, q: np.ndarray) -> float:
        """Strain energy (J/m): sum of 1/2 EA u_l^2 / l0 + EI / l0 (2 t1^2 + 2 t1 t2 + 2 t2^2)."""
        return float(_chain_energy(self._D0, self._L0, self.EA, self.EI, q.reshape(-1, 3))[0])

    def max_local_rotation(self, q: np.ndarray) -> float:
        """Largest local (chord-relative) end rotation of any element, rad."""
        return float(_chain_energy(self._D0, self._L0, self.EA, self.EI, q.reshape(-1, 3))[1])

    def classify_modes(self, shapes: np.ndarray) -> list[str]:
        """ "axial" or "bending" per mode shape (columns): kinetic energy of the translation
        along the reference tangent vs the rest (normal translation and rotation)."""
        Mphi = self.M @ shapes
        out = []
        for j in range(shapes.shape[1]):
            phi = shapes[:, j]
            q3 = phi.reshape(-1, 3)
            along = (q3[:, :2] @ self.tangent_vector)[:, None] * self.tangent_vector[None, :]
            pa = np.zeros_like(q3)
            pa[:, :2] = along
            pa = pa.reshape(-1)
            e_ax = float(pa @ (self.M @ pa))
            e_all = float(phi @ Mphi[:, j])
            out.append("axial" if e_ax > 0.5 * e_all else "bending")
        return out

    # ------------------------------------------------------------------ loads
    def _line_load(self, q: np.ndarray) -> np.ndarray:
        """Load of a uniform dead line load q (N/m, scene vector): linear interpolation."""
        h = np.diff(self.s)
        w = np.zeros(self.n_nodes)
        w[:-1] += h / 2.0
        w[1:] += h / 2.0
        F = np.zeros((self.n_nodes, 3))
        F[:, 0], F[:, 1] = w * q[0], w * q[1]
        return F.reshape(-1)

    def gravity_load(self, g: np.ndarray) -> np.ndarray:
        return self._line_load(self.rhoA * np.asarray(g, dtype=float))

    def pressure_load(self, p: float) -> np.ndarray:
        return self._line_load(p * self.normal)

    def local_coordinate(self, point) -> float:
        """Arc length s of the projection of a scene point onto the reference centreline."""
        s = float((np.asarray(point, dtype=float) - self.start) @ self.tangent_vector)
        return min(max(s, 0.0), self.length)

    def point_matrix(self, point) -> sp.csr_matrix:
        """Translation at a scene point of the reference centreline: linear in the two nodes of
        its element (the interpolation of the mass and of line loads)."""
        s = self.local_coordinate(point)
        e = int(min(np.searchsorted(self.s, s, side="right") - 1, len(self.s) - 2))
        xi = (s - self.s[e]) / (self.s[e + 1] - self.s[e])
        rows = [0, 0, 1, 1]
        cols = [3 * e, 3 * e + 3, 3 * e + 1, 3 * e + 4]
        vals = [1.0 - xi, xi, 1.0 - xi, xi]
        return sp.csr_matrix((vals, (rows, cols)), shape=(2, self.n_dof))
