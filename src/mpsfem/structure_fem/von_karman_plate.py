"""Von Karman plate in a 3D scene: moderately large deflections (membrane-bending coupling).

Kirchhoff bending of the deflection w (``ElementQuadBFS``, rectangles, as :mod:`.plate`) plus
in-plane displacements (u, v) along the plate axes (``ElementVector(ElementQuad2)``), coupled by
the von Karman membrane strain (Timoshenko & Woinowsky-Krieger 1959, *Theory of Plates and
Shells*, sec. 96, eqs. 219-220)::

    eps = sym grad(u, v) + 1/2 grad w (x) grad w
    N = E h / (1 - nu^2) [(1 - nu) eps + nu tr(eps) I]     (membrane forces, N/m)

Strain energy ``1/2 int N : eps dA + 1/2 D int [(1 - nu) w_,ij w_,ij + nu (lap w)^2] dA``; its
first variation is the internal force, its second the tangent (membrane + bending + geometric
``int grad(dw) . N grad(w~)``). The linear parts are scikit-fem forms; the nonlinear ones are
element kernels (einsum over the scikit-fem bases' gradients at the quadrature points, one
quadrature, ``INTORDER``, for both bases) scattered by the bases' element dofs; the membrane
energy is a scikit-fem Functional (an independent check of the kernels in the tests).

Speed (benchmarks/bench_structure.py, ``vk_plate_800``): the internal force and the element
tangents are numba loops over elements and quadrature points (:func:`_vk_forces`,
:func:`_vk_tangent`) on element-major copies of the basis gradients, and the tangent is refilled
into a sparsity pattern fixed at build time: each element entry knows its slot in the data array
of ``K + M + K_nl`` over all dofs, and the free-dof matrix is a fixed gather of that array, so a
Jacobian costs one kernel call and two array operations instead of a COO assembly and slicing.
The einsum path (:meth:`VonKarmanPlateModel._fields`) stays for the strain energy and as the
check of the kernels. Per Newton iteration (issue 21): the force kernel runs the quadrature
points innermost (vectorised), congruent elements share one membrane
table (:func:`_shared_tables`; the kernel then reads the BFS gradients alone, 5 of the 14 MB it
read, and keeps the cache for the solve), the internal force is memoised at its last q (a step
starts at the displacement where the previous step's last residual evaluated it), and the
time-step Jacobian is marked for a single-precision factor
(:class:`.linsolve.SinglePrecisionJacobian`; :attr:`VonKarmanPlateModel.single_precision_factor`).

Supports: a ``clamped`` or ``simply_supported`` edge also holds the in-plane displacements
(u = v = 0, an immovable edge: stretching carries the load); a ``free`` edge holds nothing.
Mass: ``rho h`` on w and on (u, v) (in-plane inertia). Loads are dead: a pressure along the
reference normal, self-weight (normal part on w, in-plane part on u, v), nodal forces on the
nodal translation ``w n + u e_u + v e_v``.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from numba import njit
from skfem import (
    Basis,
    BilinearForm,
    ElementQuad2,
    ElementQuadBFS,
    ElementVector,
    Functional,
    LinearForm,
)
from skfem.helpers import ddot, dot, sym_grad

from .linsolve import SinglePrecisionJacobian
from .plate import PlateModel, area_mass_form, plate_bending_form

__all__ = ["VonKarmanPlateModel"]

#: polynomial degree integrated exactly by the quadrature of both bases
INTORDER = 8
#: elements whose membrane tables (symmetric gradients of the Q2 functions and quadrature
#: weights) agree to this fraction of the tables' largest entry share one table in the kernels
#: (congruent elements differ at round-off, ~1e-14; the BFS gradients are kept per element:
#: scikit-fem's BFS basis differs by up to 6e-6 between congruent elements)
TABLE_RTOL = 1e-12


def _shared_tables(es: np.ndarray, dx: np.ndarray, rtol: float = TABLE_RTOL) -> tuple:
    """(es_t, dx_t, tid): the distinct membrane tables of the elements, es (el, ...) and
    dx (el, qp), and the table of each element (element e uses es_t[tid[e]], dx_t[tid[e]]).
    Elements whose tables round to the same multiples of `rtol` x (largest entry) share the
    first one's: a uniform mesh has one table (fewer bytes per force evaluation, 8.6 MB -> 11
    kB for 800 elements), so the kernels run from the cache."""
    nel = es.shape[0]
    scaled = [a.reshape(nel, -1) / max(float(np.abs(a).max()), 1e-300) for a in (es, dx)]
    key = np.round(np.hstack(scaled) / rtol)
    _, first, tid = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return (
        np.ascontiguousarray(es[first]),
        np.ascontiguousarray(dx[first]),
        np.ascontiguousarray(tid.ravel(), dtype=np.int64),
    )


@BilinearForm
def _membrane_form(u, v, w):
    """int [(1 - nu) eps(u) : eps(v) + nu div u div v] (times E h / (1 - nu^2))."""
    eu, ev = sym_grad(u), sym_grad(v)
    return (1.0 - w.nu) * ddot(eu, ev) + w.nu * (eu[0, 0] + eu[1, 1]) * (ev[0, 0] + ev[1, 1])


@BilinearForm
def _vector_mass_form(u, v, w):
    """int u . v dA (times rho h: in-plane inertia)."""
    return dot(u, v)


@Functional
def _membrane_energy(w):
    """1/2 int N : eps dA."""
    return 0.5 * ddot(w.N, w.eps)


@njit(cache=True)
def _vk_strain(qw, qm, gl, el, p):
    """(grad w, membrane strain [e11, e12, e22]) at quadrature point p of an element from its
    local dofs qw (w), qm (u, v) and its tables gl (qp, 2, i), el (qp, 3, i)."""
    g0 = 0.0
    g1 = 0.0
    for i in range(qw.shape[0]):
        g0 += qw[i] * gl[p, 0, i]
        g1 += qw[i] * gl[p, 1, i]
    e00 = 0.5 * g0 * g0
    e01 = 0.5 * g0 * g1
    e11 = 0.5 * g1 * g1
    for i in range(qm.shape[0]):
        e00 += qm[i] * el[p, 0, i]
        e01 += qm[i] * el[p, 1, i]
        e11 += qm[i] * el[p, 2, i]
    return g0, g1, e00, e01, e11


@njit(cache=True, fastmath={"reassoc", "contract"})
def _vk_forces(q, ew, em, gw, es, dx, tid, C, nu, f):
    """Add the nonlinear internal force (N) to f: int grad(dw) . N grad w on the w dofs,
    int N : eps(du) on (u, v), N = C [(1 - nu) eps + nu tr(eps) I] (T & W-K 1959, eq. 219).
    gw (el, 2, i, qp): per element; es (table, 3, i, qp), dx (table, qp): element e uses table
    tid[e]. The quadrature points are the inner loop (vectorised; sums reassociated: round-off
    only, IEEE NaN / inf semantics kept)."""
    nw = ew.shape[0]
    nm = em.shape[0]
    nq = gw.shape[3]
    qw = np.empty(nw)
    qm = np.empty(nm)
    g0 = np.empty(nq)
    g1 = np.empty(nq)
    e00 = np.empty(nq)
    e01 = np.empty(nq)
    e11 = np.empty(nq)
    for e in range(gw.shape[0]):
        t = tid[e]
        for i in range(nw):
            qw[i] = q[ew[i, e]]
        for i in range(nm):
            qm[i] = q[em[i, e]]
        g0[:] = 0.0
        g1[:] = 0.0
        for i in range(nw):  # grad w at the quadrature points
            c = qw[i]
            for p in range(nq):
                g0[p] += c * gw[e, 0, i, p]
                g1[p] += c * gw[e, 1, i, p]
        for p in range(nq):  # eps = sym grad (u, v) + 1/2 grad w (x) grad w (T & W-K eq. 220)
            e00[p] = 0.5 * g0[p] * g0[p]
            e01[p] = 0.5 * g0[p] * g1[p]
            e11[p] = 0.5 * g1[p] * g1[p]
        for i in range(nm):
            c = qm[i]
            for p in range(nq):
                e00[p] += c * es[t, 0, i, p]
                e01[p] += c * es[t, 1, i, p]
                e11[p] += c * es[t, 2, i, p]
        for p in range(nq):  # weighted N, then N grad w (in g) and N with 2 N12 (in e)
            tr = nu * (e00[p] + e11[p])
            w = dx[t, p]
            n00 = w * C * ((1.0 - nu) * e00[p] + tr)
            n01 = w * C * (1.0 - nu) * e01[p]
            n11 = w * C * ((1.0 - nu) * e11[p] + tr)
            a0 = n00 * g0[p] + n01 * g1[p]
            a1 = n01 * g0[p] + n11 * g1[p]
            g0[p] = a0
            g1[p] = a1
            e00[p] = n00
            e01[p] = 2.0 * n01
            e11[p] = n11
        for i in range(nw):
            s = 0.0
            for p in range(nq):
                s += g0[p] * gw[e, 0, i, p] + g1[p] * gw[e, 1, i, p]
            f[ew[i, e]] += s
        for i in range(nm):
            s = 0.0
            for p in range(nq):
                s += e00[p] * es[t, 0, i, p] + e01[p] * es[t, 1, i, p] + e11[p] * es[t, 2, i, p]
            f[em[i, e]] += s


@njit(cache=True)
def _vk_tangent(q, ew, em, gw, es, dx, tid, C, nu, ck, slot_ww, slot_mw, slot_wm, data):
    """Add ck x the nonlinear element tangents into data (the fixed pattern's slots): ww block
    int grad(v) . Q grad(u), Q = N + C (1 - nu) / 2 |g|^2 I + C (1 + nu) / 2 g (x) g, and the
    membrane-bending block int grad(d) . C [(1 - nu) eps(v) g + nu div(v) g] and its transpose
    (derivation in :meth:`VonKarmanPlateModel.tangent_stiffness`); tables as :func:`_vk_forces`."""
    nw = ew.shape[0]
    nm = em.shape[0]
    kww = np.empty((nw, nw))
    kmw = np.empty((nm, nw))
    ag = np.empty((nm, 2))
    qw = np.empty(nw)
    qm = np.empty(nm)
    nq = gw.shape[3]
    gl = np.empty((nq, 2, nw))  # the element's tables, point-major (unit stride below)
    el = np.empty((nq, 3, nm))
    t_el = -1
    for e in range(gw.shape[0]):
        t = tid[e]
        for c in range(2):
            for i in range(nw):
                for p in range(nq):
                    gl[p, c, i] = gw[e, c, i, p]
        if t != t_el:
            for c in range(3):
                for i in range(nm):
                    for p in range(nq):
                        el[p, c, i] = es[t, c, i, p]
            t_el = t
        for i in range(nw):
            qw[i] = q[ew[i, e]]
        for i in range(nm):
            qm[i] = q[em[i, e]]
        kww[:] = 0.0
        kmw[:] = 0.0
        for p in range(nq):
            g0, g1, e00, e01, e11 = _vk_strain(qw, qm, gl, el, p)
            tr = nu * (e00 + e11)
            w = ck * dx[t, p]
            gg = 0.5 * C * (1.0 - nu) * (g0 * g0 + g1 * g1)
            q00 = w * (C * ((1.0 - nu) * e00 + tr) + 0.5 * C * (1.0 + nu) * g0 * g0 + gg)
            q01 = w * (C * (1.0 - nu) * e01 + 0.5 * C * (1.0 + nu) * g0 * g1)
            q11 = w * (C * ((1.0 - nu) * e11 + tr) + 0.5 * C * (1.0 + nu) * g1 * g1 + gg)
            for j in range(nw):
                b0 = q00 * gl[p, 0, j] + q01 * gl[p, 1, j]
                b1 = q01 * gl[p, 0, j] + q11 * gl[p, 1, j]
                for i in range(nw):
                    kww[i, j] += gl[p, 0, i] * b0 + gl[p, 1, i] * b1
            for i in range(nm):
                d = nu * (el[p, 0, i] + el[p, 2, i])
                ag[i, 0] = w * C * ((1.0 - nu) * (el[p, 0, i] * g0 + el[p, 1, i] * g1) + d * g0)
                ag[i, 1] = w * C * ((1.0 - nu) * (el[p, 1, i] * g0 + el[p, 2, i] * g1) + d * g1)
            for i in range(nm):
                for j in range(nw):
                    kmw[i, j] += ag[i, 0] * gl[p, 0, j] + ag[i, 1] * gl[p, 1, j]
        for i in range(nw):
            for j in range(nw):
                data[slot_ww[e, i, j]] += kww[i, j]
        for i in range(nm):
            for j in range(nw):
                data[slot_mw[e, i, j]] += kmw[i, j]
                data[slot_wm[e, j, i]] += kmw[i, j]


class VonKarmanPlateModel(PlateModel):
    """Von Karman plate (BFS rectangles); dofs ``[w (BFS) | u, v (vector Q2)]``."""

    nonlinear = True
    #: mark the time-step Jacobian for a single-precision factor (:mod:`.linsolve`); False
    #: restores the double-precision factor (results differ at the Newton tolerance level)
    single_precision_factor: bool = True

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
        # element kernels: basis gradients at the quadrature points, (local dof, ..., el, qp)
        model._Gw = np.stack([bw.basis[i][0].grad for i in range(len(bw.basis))])
        Gm = np.stack([bm.basis[i][0].grad for i in range(len(bm.basis))])
        model._Em = 0.5 * (Gm + Gm.transpose(0, 2, 1, 3, 4))  # eps of each membrane function
        model._dx = bw.dx
        model._ew, model._em = bw.element_dofs, Nw + bm.element_dofs
        ew, em = model._ew, bm.element_dofs
        nw_, nm_ = ew.shape[0], em.shape[0]
        # COO pattern of the element blocks (e, i, j): ww over the w dofs, mw (membrane rows,
        # w columns) over the local membrane / w numbering
        model._pattern = (
            (np.broadcast_to(ew.T[:, :, None], (ew.shape[1], nw_, nw_)).ravel(),
             np.broadcast_to(em.T[:, :, None], (em.shape[1], nm_, nw_)).ravel()),
            (np.broadcast_to(ew.T[:, None, :], (ew.shape[1], nw_, nw_)).ravel(),
             np.broadcast_to(ew.T[:, None, :], (em.shape[1], nm_, nw_)).ravel()),
        )  # fmt: skip
        model._build_kernels()
        return model

    def _build_kernels(self) -> None:
        """Element-major basis gradients for the numba kernels, and the fixed sparsity pattern
        of ``K + M + K_nl`` (all dofs) with each element entry's slot in its data array."""
        Gw, Em = self._Gw, self._Em
        self._gw = np.ascontiguousarray(Gw.transpose(2, 1, 0, 3))  # (el, 2, i, qp)
        es = np.stack([Em[:, 0, 0], Em[:, 0, 1], Em[:, 1, 1]], axis=-1)  # (i, el, qp, 3)
        self._es, self._dxc, self._tid = _shared_tables(
            np.ascontiguousarray(es.transpose(1, 3, 0, 2)),  # (el, 3, i, qp)
            np.ascontiguousarray(self._dx),
        )
        self._force_memo: tuple[np.ndarray, np.ndarray] | None = None
        self._ewi = np.ascontiguousarray(self._ew, dtype=np.int64)
        self._emi = np.ascontiguousarray(self._em, dtype=np.int64)
        n = self.n_dof
        (rww, rmw), (cww, cmw) = self._pattern
        rmw = rmw + self.Nw
        rows = np.concatenate([rww, rmw, cmw])
        cols = np.concatenate([cww, cmw, rmw])
        nl = sp.csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(n, n))
        K1, M1 = self.K.tocsr(copy=True), self.M.tocsr(copy=True)
        K1.data[:] = 1.0  # the stored entries, explicit zeros included
        M1.data[:] = 1.0
        S = (K1 + M1 + nl).tocsr()
        S.sum_duplicates()
        S.sort_indices()
        indptr, indices = S.indptr.astype(np.int64), S.indices.astype(np.int64)
        keys = np.repeat(np.arange(n, dtype=np.int64), np.diff(indptr)) * n + indices

        def slots(r: np.ndarray, c: np.ndarray) -> np.ndarray:
            k = np.searchsorted(keys, r.astype(np.int64) * n + c)
            if not np.array_equal(keys[np.minimum(k, len(keys) - 1)], r.astype(np.int64) * n + c):
                raise RuntimeError("von Karman plate: an element entry lies outside the pattern")
            return k

        def on_pattern(A: sp.csr_matrix) -> np.ndarray:
            A = A.tocoo()
            return np.bincount(slots(A.row, A.col), weights=A.data, minlength=len(keys))

        nel, nw_, nm_ = self._ew.shape[1], self._ew.shape[0], self._em.shape[0]
        self._slot_ww = slots(rww, cww).reshape(nel, nw_, nw_)
        self._slot_mw = slots(rmw, cmw).reshape(nel, nm_, nw_)
        self._slot_wm = np.ascontiguousarray(
            slots(cmw, rmw).reshape(nel, nm_, nw_).transpose(0, 2, 1)
        )
        self._S = (S.indptr, S.indices)
        self._K_on_S, self._M_on_S = on_pattern(self.K), on_pattern(self.M)
        self._free_plan: tuple[np.ndarray, tuple] | None = None

    def _reduction(self, free: np.ndarray, layout: str = "csr") -> tuple:
        """(indptr, indices, gather) of the pattern restricted to the `free` dofs, compressed by
        rows (``layout = "csr"``) or columns (``"csc"``): the reduced matrix's data is the full
        data array at `gather` (computed once per `free`)."""
        if self._free_plan is None or not np.array_equal(self._free_plan[0], free):
            indptr, indices = self._S
            n = self.n_dof
            ids = sp.csr_matrix((np.arange(1.0, len(indices) + 1.0), indices, indptr), shape=(n, n))
            R = ids[free][:, free]
            plans = {}
            for name, Rl in (("csr", R.tocsr()), ("csc", R.tocsc())):
                Rl.sort_indices()
                gather = np.rint(Rl.data).astype(np.int64) - 1
                plans[name] = (Rl.indptr.copy(), Rl.indices.copy(), gather)
            self._free_plan = (free.copy(), plans)
        return self._free_plan[1][layout]

    def _tangent_data(self, q: np.ndarray, ck: float, cm: float) -> np.ndarray:
        """Data of ``ck K_t(q) + cm M`` on the fixed pattern (all dofs)."""
        data = ck * self._K_on_S
        if cm:
            data += cm * self._M_on_S
        _vk_tangent(
            np.ascontiguousarray(q, dtype=np.float64), self._ewi, self._emi, self._gw, self._es,
            self._dxc, self._tid, self.C_membrane, self.nu, ck, self._slot_ww, self._slot_mw,
            self._slot_wm, data,
        )  # fmt: skip
        return data

    # ------------------------------------------------------------------ state at quadrature points
    def _fields(self, q: np.ndarray) -> dict:
        gw = np.einsum("ie,iaeq->aeq", q[self._ew], self._Gw, optimize=True)  # (2, nel, nqp)
        em = np.einsum("ie,iabeq->abeq", q[self._em], self._Em, optimize=True)  # sym grad (u, v)
        eps = em + 0.5 * gw[:, None] * gw[None, :]
        tr = eps[0, 0] + eps[1, 1]
        # Timoshenko & Woinowsky-Krieger (1959) eq. 219: N = C [(1 - nu) eps + nu tr(eps) I]
        N = self.C_membrane * (1.0 - self.nu) * eps
        N[0, 0] += self.C_membrane * self.nu * tr
        N[1, 1] += self.C_membrane * self.nu * tr
        Ngw = np.einsum("ij...,j...->i...", N, gw)
        return {"gw": gw, "eps": eps, "N": N, "Ngw": Ngw}

    def _element_forces(self, fd: dict) -> np.ndarray:
        """Nonlinear internal force (all dofs): int grad(dw) . N grad(w~) on w, int N : eps(du)
        on (u, v) (the first variation of the membrane energy), by element kernels."""
        dx = self._dx
        fw = np.einsum("aeq,iaeq,eq->ie", fd["Ngw"], self._Gw, dx, optimize=True)
        fm = np.einsum("abeq,iabeq,eq->ie", fd["N"], self._Em, dx, optimize=True)
        f = np.bincount(self._ew.ravel(), weights=fw.ravel(), minlength=self.n_dof)
        f += np.bincount(self._em.ravel(), weights=fm.ravel(), minlength=self.n_dof)
        return f

    def internal_force(self, q: np.ndarray) -> np.ndarray:
        """Internal force over all dofs (N) at the full dof vector `q` (numba kernel).

        The last result is kept with its `q`: a call at the same `q` (bit for bit) returns a copy
        of it. A Newton step starts from the last converged displacement, where the previous
        step's final residual already evaluated the force: one kernel call saved per step."""
        q = np.ascontiguousarray(q, dtype=np.float64)
        memo = self._force_memo
        if memo is not None and np.array_equal(memo[0], q):
            return memo[1].copy()
        f = self.compute_internal_force(q)
        self._force_memo = (q.copy(), f.copy())
        return f

    def compute_internal_force(self, q: np.ndarray) -> np.ndarray:
        """:meth:`internal_force` evaluated afresh (N)."""
        q = np.ascontiguousarray(q, dtype=np.float64)
        f = np.zeros(self.n_dof)
        f[: self.Nw] = self.Kb @ q[: self.Nw]
        _vk_forces(
            q, self._ewi, self._emi, self._gw, self._es, self._dxc, self._tid, self.C_membrane,
            self.nu, f,
        )  # fmt: skip
        return f

    def internal_force_einsum(self, q: np.ndarray) -> np.ndarray:
        """:meth:`internal_force` by the einsum kernels (the reference the numba one is tested
        against)."""
        f = self._element_forces(self._fields(q))
        f[: self.Nw] += self.Kb @ q[: self.Nw]
        return f

    def tangent_stiffness(self, q: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """(internal force, consistent tangent) over all dofs at `q`, by the numba kernels on
        the fixed pattern (formulas in :meth:`tangent_stiffness_einsum`)."""
        indptr, indices = self._S
        n = self.n_dof
        K = sp.csr_matrix((self._tangent_data(q, 1.0, 0.0), indices, indptr), shape=(n, n))
        return self.internal_force(q), K

    def tangent_stiffness_einsum(self, q: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        """(internal force, consistent tangent) over all dofs at `q` (einsum reference).

        With g = grad w~ and S(a) = sym(g (x) a) (the variation of 1/2 g (x) g along a):
        S(a) : S(b) = 1/2 [(g.g)(a.b) + (g.a)(g.b)] and tr S(a) = g.a, so the ww block
        int grad(v) . N grad(u) + C [(1 - nu) S(u) : S(v) + nu tr S(u) tr S(v)] is
        int grad(v) . Q grad(u), Q = N + C (1 - nu) / 2 |g|^2 I + C (1 + nu) / 2 g (x) g; the
        membrane-bending block int C [(1 - nu) S(d) : eps(v) + nu tr S(d) div v] is
        int grad(d) . C [(1 - nu) eps(v) g + nu div(v) g] (eps symmetric).
        """
        fd = self._fields(q)
        g, C, nu, dx = fd["gw"], self.C_membrane, self.nu, self._dx
        Q = fd["N"] + 0.5 * C * (1.0 + nu) * g[:, None] * g[None, :]
        Q[0, 0] += 0.5 * C * (1.0 - nu) * (g[0] ** 2 + g[1] ** 2)
        Q[1, 1] += 0.5 * C * (1.0 - nu) * (g[0] ** 2 + g[1] ** 2)
        Gw, Em = self._Gw, self._Em
        kww = np.einsum("iaeq,abeq,jbeq,eq->eij", Gw, Q, Gw, dx, optimize=True)
        div = Em[:, 0, 0] + Em[:, 1, 1]
        Ag = (1.0 - nu) * np.einsum("iabeq,beq->iaeq", Em, g) + nu * div[:, None] * g[None]
        kmw = C * np.einsum("iaeq,jaeq,eq->eij", Ag, Gw, dx, optimize=True)
        r, c = self._pattern
        Kww = sp.csr_matrix((kww.ravel(), (r[0], c[0])), shape=(self.Nw, self.Nw))
        Kmw = sp.csr_matrix((kmw.ravel(), (r[1], c[1])), shape=(self.Nm, self.Nw))
        K = self.K + sp.bmat([[Kww, Kmw.T], [Kmw, None]], format="csr")
        f = self._element_forces(fd)
        f[: self.Nw] += self.Kb @ q[: self.Nw]
        return f, K

    def reduced_tangent(self, q: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, sp.csr_matrix]:
        indptr, indices, gather = self._reduction(free)
        data = self._tangent_data(q, 1.0, 0.0)[gather]
        K = sp.csr_matrix((data, indices, indptr), shape=(len(free), len(free)))
        return self.internal_force(q)[free], K

    def reduced_effective(
        self, q: np.ndarray, free: np.ndarray, ck: float, cm: float, cc: float
    ) -> sp.csr_matrix | SinglePrecisionJacobian:
        """``ck K_t(q) + cm M + cc C`` over the `free` dofs (sparse), C = a1 M + a2 K (the
        linear K), refilled into the fixed pattern: the Jacobian of a time step. With
        :attr:`single_precision_factor` (default) it is a
        :class:`.linsolve.SinglePrecisionJacobian` (CSC, same values), else CSR."""
        single = self.single_precision_factor
        indptr, indices, gather = self._reduction(free, "csc" if single else "csr")
        data = self._tangent_data(q, ck, cm + cc * self.rayleigh_a1)
        if cc * self.rayleigh_a2:
            data += (cc * self.rayleigh_a2) * self._K_on_S
        n = len(free)
        kind = SinglePrecisionJacobian if single else sp.csr_matrix
        return kind((data[gather], indices, indptr), shape=(n, n))

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
