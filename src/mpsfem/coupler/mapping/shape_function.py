"""Shape-function mapping: project each fluid point onto the structure's mid-surface cells.

Every fluid interface point p is projected onto the nearest cell of the structure's interface mesh
(closest point x* on a 2D segment, a 3D triangle or a planar quadrilateral). Its displacement is

    u(p) = sum_a N_a(x*) u_a  +  theta(x*) x (p - x*)

— the element's own (linear / bilinear) shape functions N_a at the projection, plus, with
``rotation = true``, the rigid-link offset of a point off the mid-surface: theta is the element's
rotation from its shape-function gradients (2D: the beam slope d(u.n)/ds about the out-of-plane
axis; 3D: the plate slopes grad_s(u.n) and the in-plane spin (n . curl_s u)/2), so a face particle
of a thick member follows the rotating face. Linear fields along the mid-surface are reproduced
exactly at the projections, rigid-body motion (translation plus small rotation) exactly at any
offset. This linear operator H is :meth:`Mapping.to_fluid` / :meth:`Mapping.to_structure`.

Large rotations (2D line cells, ``rotation = true``, ``large_rotation = true``; the default
``false`` keeps the linear operator, the consistent partner of geometrically linear members: on
the mock added-mass problem the exact link moves the coupled result by 6e-4 relative to its
linear monolithic reference, tests/coupler/test_schemes.py): the coupler
maps the motion through :meth:`ShapeFunctionMapping.displacement_to_fluid` and friends, which use
the exact rigid link of the segment's chord (Crisfield 1991, vol. 1, sec. 7.2: the co-rotational
frame of a 2D element is its current chord):

    u(p) = sum_a N_a u_a + (R(theta) - I) r,   theta = atan2(e0 x e, e0 . e),   r = p - x*

with e0, e = X_b - X_a, x_b - x_a the reference and current chords. R(theta) depends on theta
only modulo 2 pi, so the wrapped atan2 gives the same motion as the structure's unwrapped angle.
Velocity (the time derivative): v(p) = sum_a N_a v_a + omega z x (R r), omega = (e x (v_b - v_a))
/ |e|^2. For small rotations R(theta) - I = theta [z]_x + O(theta^2), and theta agrees with the
linear slope to O(theta eps, theta^2) (eps the chord's strain), so the two formulas differ at
second order only.

Forces go by the transpose: F_s = H^T F_f (large rotations: the transpose of the velocity
operator at the current configuration, H_t(d)^T). Because H reproduces translations, the total
force is kept; because it reproduces rigid rotations, so is the total moment (about any point; at
large rotation about any point of the current configuration); and the interface does no spurious
work. Particles on both faces of a thin member project onto the same mid-surface cell and their
forces add up as vectors at its nodes.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
import scipy.sparse as sp
from pydantic import Field
from scipy.spatial import cKDTree

from mpsfem.coupler.mapping.base import (
    Mapping,
    MappingCoverageError,
    describe_points,
    point_spacing,
)
from mpsfem.coupler.participant import InterfaceMesh
from mpsfem.scenario.base import Section

__all__ = ["ShapeFunctionMapping", "ShapeFunctionParams", "project"]

#: default search distance beyond half the thickness, in fluid interface spacings
SEARCH_SPACINGS = 5.0
_QUAD_XI = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])


class ShapeFunctionParams(Section):
    """Projection onto the mid-surface cells; element shape functions; forces by the transpose."""

    kind: Literal["shape-function"] = Field(description='"shape-function".')
    radius: float | None = Field(
        None,
        gt=0,
        description=(
            "Search distance in m (> 0): every fluid interface point must lie within this "
            "distance of a structure cell. Default: half the largest geometric thickness plus "
            "5 spacings of the fluid interface points."
        ),
    )
    rotation: bool = Field(
        True,
        description=(
            "Rigid-link offset: a point off the mid-surface moves with the element rotation "
            "(rigid motion exact at the faces, moments kept for any force direction). false: "
            "every point takes the displacement of its projection."
        ),
    )
    large_rotation: bool = Field(
        False,
        description=(
            "2D beams with rotation = true: the rigid link of each segment turns by the exact "
            "rotation R(theta) of its current chord (large rotations exact, forces by the "
            "transpose at the current configuration); on by default when a member has "
            'kinematics = "corotational" (unless set here). false (default otherwise): the '
            "linear offset theta z x r, the operator built once, consistent with geometrically "
            "linear members. The two agree to O(theta^2)."
        ),
    )


# ---------------------------------------------------------------------- projections
def _segment(P, A, B):
    """Closest points of P on segments AB: (parameter s in [0, 1], point)."""
    e = B - A
    s = np.clip(np.einsum("kd,kd->k", P - A, e) / np.einsum("kd,kd->k", e, e), 0.0, 1.0)
    return s, A + s[:, None] * e


def _surface_gradient(J, dN):
    """Global surface gradients (m, k, dim) from Jacobians J (m, dim, q) and dN/dxi (m, k, q)."""
    G = np.einsum("mdi,mdj->mij", J, J)
    return np.einsum("mdi,mij,maj->mad", J, np.linalg.inv(G), dN)


def _project_line(P, X):
    if P.shape[1] != 2:
        raise ValueError("line cells are 2D beam mid-lines; a 3D interface needs triangles/quads")
    s, x = _segment(P, X[:, 0], X[:, 1])
    N = np.stack([1.0 - s, s], axis=1)
    dN = np.broadcast_to(np.array([[-1.0], [1.0]]), (P.shape[0], 2, 1))
    J = (X[:, 1] - X[:, 0])[:, :, None]
    return x, N, _surface_gradient(J, dN)


def _project_triangle(P, X):
    if P.shape[1] != 3:
        raise ValueError("triangle cells need a 3D interface")
    A, e1, e2 = X[:, 0], X[:, 1] - X[:, 0], X[:, 2] - X[:, 0]
    J = np.stack([e1, e2], axis=2)
    G = np.einsum("mdi,mdj->mij", J, J)
    lam = np.linalg.solve(G, np.einsum("mdi,md->mi", J, P - A)[:, :, None])[:, :, 0]
    inside = (lam[:, 0] >= 0) & (lam[:, 1] >= 0) & (lam.sum(axis=1) <= 1)
    if not inside.all():
        o = ~inside
        best = None
        for a, b, conv in ((0, 1, 0), (1, 2, 1), (2, 0, 2)):
            s, x = _segment(P[o], X[o, a], X[o, b])
            d = np.linalg.norm(P[o] - x, axis=1)
            if conv == 0:
                lm = np.stack([s, 0 * s], axis=1)
            elif conv == 1:
                lm = np.stack([1 - s, s], axis=1)
            else:
                lm = np.stack([0 * s, 1 - s], axis=1)
            if best is None:
                best, bestd = lm, d
            else:
                take = d < bestd
                best[take], bestd[take] = lm[take], d[take]
        lam[o] = best
    N = np.stack([1.0 - lam[:, 0] - lam[:, 1], lam[:, 0], lam[:, 1]], axis=1)
    x = np.einsum("ma,mad->md", N, X)
    dN = np.broadcast_to(np.array([[-1.0, -1.0], [1.0, 0.0], [0.0, 1.0]]), (P.shape[0], 3, 2))
    return x, N, _surface_gradient(J, dN)


def _quad_shape(xi):
    """Bilinear N (m, 4) and dN/dxi (m, 4, 2) at xi (m, 2)."""
    a = 1.0 + xi[:, None, 0] * _QUAD_XI[None, :, 0]
    b = 1.0 + xi[:, None, 1] * _QUAD_XI[None, :, 1]
    N = 0.25 * a * b
    dN = 0.25 * np.stack([_QUAD_XI[None, :, 0] * b, a * _QUAD_XI[None, :, 1]], axis=2)
    return N, dN


def _project_quad(P, X):
    if P.shape[1] != 3:
        raise ValueError("quad cells need a 3D interface")
    m = P.shape[0]
    xi = np.zeros((m, 2))
    for _ in range(8):  # Gauss-Newton on |x(xi) - p|^2; one step for parallelograms
        N, dN = _quad_shape(xi)
        J = np.einsum("mad,mai->mdi", X, dN)
        R = np.einsum("ma,mad->md", N, X) - P
        G = np.einsum("mdi,mdj->mij", J, J)
        step = np.linalg.solve(G, np.einsum("mdi,md->mi", J, R)[:, :, None])[:, :, 0]
        xi -= step
        if np.abs(step).max() < 1e-13:
            break
    outside = (np.abs(xi) > 1.0 + 1e-12).any(axis=1)
    if outside.any():
        o = np.flatnonzero(outside)
        best, bestd = None, None
        for a in range(4):
            b = (a + 1) % 4
            s, x = _segment(P[o], X[o, a], X[o, b])
            d = np.linalg.norm(P[o] - x, axis=1)
            e = _QUAD_XI[a][None, :] + s[:, None] * (_QUAD_XI[b] - _QUAD_XI[a])[None, :]
            if best is None:
                best, bestd = e, d
            else:
                take = d < bestd
                best[take], bestd[take] = e[take], d[take]
        xi[o] = best
    xi = np.clip(xi, -1.0, 1.0)
    N, dN = _quad_shape(xi)
    J = np.einsum("mad,mai->mdi", X, dN)
    return np.einsum("ma,mad->md", N, X), N, _surface_gradient(J, dN)


_PROJECT = {"line": _project_line, "triangle": _project_triangle, "quad": _project_quad}


def project(points: np.ndarray, structure: InterfaceMesh, radius: float):
    """Nearest-cell projection of ``points`` onto ``structure``'s cells.

    Returns (x_star (n, dim), nodes (n, 4) padded with 0, N (n, 4) padded with 0,
    grad_s N (n, 4, dim), distance (n,)); points with no cell within ``radius`` get distance inf.
    Ties go to the earlier cell block and the lower cell index (deterministic).

    Candidates in two passes: the cells of the 4 nearest centroids give an upper bound d1 of the
    distance; the nearest cell then has its centroid within min(d1, radius) + (largest cell
    circumradius), and only those cells are projected exactly.
    """
    n, dim = points.shape
    blocks = []
    for order, (ctype, conn) in enumerate(structure.cells.items()):
        if ctype not in _PROJECT or not len(conn):
            continue
        X = structure.points[conn]
        centroid = X.mean(axis=1)
        reach = float(np.linalg.norm(X - centroid[:, None], axis=2).max())
        blocks.append((order, ctype, conn, X, cKDTree(centroid), reach))
    if not blocks:
        raise ValueError(
            "the shape-function mapping needs structure cells (line / triangle / quad); the "
            f"structure interface has {sorted(structure.cells) or 'none'}"
        )

    def candidates(i, c, order, ctype, conn, X):
        x, N, dN = _PROJECT[ctype](points[i], X[c])
        k = conn.shape[1]
        nodes = np.zeros((i.size, 4), dtype=np.int64)
        nodes[:, :k] = conn[c]
        Np = np.zeros((i.size, 4))
        Np[:, :k] = N
        dNp = np.zeros((i.size, 4, dim))
        dNp[:, :k] = dN
        dist = np.linalg.norm(points[i] - x, axis=1)
        return i, np.full(i.size, order), c, x, nodes, Np, dNp, dist

    # pass 1: an upper bound of every point's distance to the mid-surface
    d1 = np.full(n, np.inf)
    for order, ctype, conn, X, tree, _ in blocks:
        k = min(4, conn.shape[0])
        _, c = tree.query(points, k=k)
        c = c.reshape(n, k)
        i = np.repeat(np.arange(n), k)
        dist = candidates(i, c.ravel(), order, ctype, conn, X)[-1]
        d1 = np.minimum(d1, dist.reshape(n, k).min(axis=1))
    # pass 2: every cell that can be nearer
    cand = []
    for order, ctype, conn, X, tree, reach in blocks:
        lists = tree.query_ball_point(points, np.minimum(d1, radius) + reach * (1 + 1e-12))
        counts = np.fromiter((len(x) for x in lists), dtype=np.int64, count=n)
        if counts.sum() == 0:
            continue
        i = np.repeat(np.arange(n), counts)
        c = np.concatenate([np.asarray(x, dtype=np.int64) for x in lists if len(x)])
        cand.append(candidates(i, c, order, ctype, conn, X))
    x_star = np.zeros((n, dim))
    nodes = np.zeros((n, 4), dtype=np.int64)
    N = np.zeros((n, 4))
    dN = np.zeros((n, 4, dim))
    dist = np.full(n, np.inf)
    if cand:
        i, order, c, x, nd, Nn, dNn, d = (np.concatenate(p) for p in zip(*cand, strict=True))
        sel = np.lexsort((c, order, d, i))
        first = np.ones(sel.size, dtype=bool)
        first[1:] = i[sel][1:] != i[sel][:-1]
        w = sel[first]
        ii = i[w]
        x_star[ii], nodes[ii], N[ii], dN[ii], dist[ii] = x[w], nd[w], Nn[w], dNn[w], d[w]
    dist[dist > radius] = np.inf
    return x_star, nodes, N, dN, dist


def _skew(r):
    """Cross-product matrices [r]_x (n, 3, 3): [r]_x v = r x v."""
    z = np.zeros(r.shape[0])
    return np.stack(
        [
            np.stack([z, -r[:, 2], r[:, 1]], axis=1),
            np.stack([r[:, 2], z, -r[:, 0]], axis=1),
            np.stack([-r[:, 1], r[:, 0], z], axis=1),
        ],
        axis=1,
    )


class ShapeFunctionMapping(Mapping):
    kind = "shape-function"
    Params = ShapeFunctionParams
    conservative = True
    #: the large-rotation data (2D line cells), None on the linear path
    _chord: dict | None = None

    def _build(self, fluid: InterfaceMesh, structure: InterfaceMesh):
        radius = self.params.radius
        if radius is None:
            radius = 0.5 * float(structure.thickness.max()) + SEARCH_SPACINGS * point_spacing(
                fluid.points
            )
        self.radius = float(radius)
        P = fluid.points
        n, dim = P.shape
        x, nodes, N, dN, dist = project(P, structure, self.radius)
        lost = np.flatnonzero(~np.isfinite(dist))
        if lost.size:
            raise MappingCoverageError(
                f"mapping 'shape-function': {describe_points(P, lost)} of the fluid interface lie "
                f"farther than radius = {self.radius:.6g} m from every structure cell; set "
                "coupling.mapping.radius larger or check that the fluid and structure interfaces "
                "describe the same member"
            )
        self.distance = dist
        eye = np.eye(dim)
        B = N[:, :, None, None] * eye  # (n, 4, dim, dim)
        if self.params.rotation:
            r = P - x
            if dim == 2:
                # theta about z: (du/ds) . n_e with n_e = z x t; offset theta z x r
                t = dN / np.maximum(np.linalg.norm(dN, axis=2, keepdims=True), 1e-300)
                t = t[:, 0]  # element tangent (same direction for every node of a segment)
                ne = np.stack([-t[:, 1], t[:, 0]], axis=1)
                ds = np.einsum("mad,md->ma", dN, t)  # dN_a/ds
                zr = np.stack([-r[:, 1], r[:, 0]], axis=1)
                B = B + np.einsum("mp,ma,mq->mapq", zr, ds, ne)
            else:
                nrm = self._cell_normals(dN)
                nxg = np.cross(nrm[:, None, :], dN)  # n x grad N_a
                R = -np.einsum("map,mq->mapq", nxg, nrm) + 0.5 * np.einsum("mp,maq->mapq", nrm, nxg)
                B = B - np.einsum("mpk,makq->mapq", _skew(r), R)
        self._chord = None
        if self.params.rotation and self.params.large_rotation and dim == 2:
            self._build_chord(P, x, nodes, N, structure)
        rows = np.arange(n)[:, None, None, None] * dim + np.arange(dim)[None, None, :, None]
        cols = nodes[:, :, None, None] * dim + np.arange(dim)[None, None, None, :]
        rows = np.broadcast_to(rows, B.shape).ravel()
        cols = np.broadcast_to(cols, B.shape).ravel()
        H = sp.csr_matrix((B.ravel(), (rows, cols)), shape=(n * dim, structure.n_points * dim))
        H.eliminate_zeros()
        return H, H.T.tocsr(), False

    # ------------------------------------------------------------ large rotations (2D)
    def _build_chord(self, P, x, nodes, N, structure: InterfaceMesh) -> None:
        """Per fluid point: its segment's nodes, the interpolation N (componentwise, sparse),
        the reference offset r = p - x* and the reference chord e0."""
        n, ns = P.shape[0], structure.n_points
        ia, ib = nodes[:, 0], nodes[:, 1]
        rows = np.repeat(np.arange(n), 2)
        interp = sp.csr_matrix((N[:, :2].ravel(), (rows, nodes[:, :2].ravel())), shape=(n, ns))
        interp.eliminate_zeros()
        X = structure.points
        self._chord = {
            "ia": ia,
            "ib": ib,
            "interp": interp,
            "r": P - x,
            "e0": X[ib] - X[ia],
            "X": X,
        }

    def _current(self, d: np.ndarray):
        """(current chord e (n, 2), rotation theta (n,), R r (n, 2)) for structure
        displacement d."""
        c = self._chord
        d = np.asarray(d, dtype=np.float64)
        e = c["X"][c["ib"]] + d[c["ib"]] - c["X"][c["ia"]] - d[c["ia"]]
        e0, r = c["e0"], c["r"]
        # rotation of the chord from e0 to e (Crisfield 1991, eq. 7.4 in 2D form)
        theta = np.arctan2(e0[:, 0] * e[:, 1] - e0[:, 1] * e[:, 0], np.einsum("nd,nd->n", e0, e))
        cs, sn = np.cos(theta), np.sin(theta)
        Rr = np.stack([cs * r[:, 0] - sn * r[:, 1], sn * r[:, 0] + cs * r[:, 1]], axis=1)
        return e, theta, Rr

    def rotation_angle(self, displacement: np.ndarray) -> np.ndarray:
        """Rotation (rad, in (-pi, pi]) of the segment each fluid point is linked to, for a
        structure displacement (n_s, 2) (large-rotation path only)."""
        if self._chord is None:
            raise RuntimeError("rotation_angle needs rotation = large_rotation = true in 2D")
        return self._current(displacement)[1]

    def displacement_to_fluid(self, displacement: np.ndarray) -> np.ndarray:
        """Structure displacement (n_s, dim) -> fluid points (n_f, dim), m: exact rigid link
        u = sum N_a u_a + (R(theta) - I) r on the large-rotation path, else H u."""
        if self._chord is None:
            return super().displacement_to_fluid(displacement)
        self._check(displacement, self.structure)
        _, _, Rr = self._current(displacement)
        return self._chord["interp"] @ displacement + Rr - self._chord["r"]

    def velocity_to_fluid(self, velocity: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Structure velocity (n_s, dim), m/s, at displacement (n_s, dim) -> fluid points:
        v = sum N_a v_a + omega z x (R r) (time derivative of the rigid link)."""
        if self._chord is None:
            return super().velocity_to_fluid(velocity, displacement)
        self._check(velocity, self.structure)
        self._check(displacement, self.structure)
        return self._tangent_apply(velocity, displacement)

    def forces_to_structure(self, forces: np.ndarray, displacement: np.ndarray) -> np.ndarray:
        """Fluid forces (n_f, dim), N (N/m in 2D) -> structure nodes: the transpose of the
        velocity operator at ``displacement`` (total force and moment about any point of the
        current configuration kept exactly)."""
        if self._chord is None:
            return super().forces_to_structure(forces, displacement)
        self._check(forces, self.fluid)
        self._check(displacement, self.structure)
        c = self._chord
        F = np.asarray(forces, dtype=np.float64)
        e, _, Rr = self._current(displacement)
        out = c["interp"].T @ F
        # moment of each force about its current projection, z . (R r x F)
        m = Rr[:, 0] * F[:, 1] - Rr[:, 1] * F[:, 0]
        # d theta / d(u_b - u_a) = (z x e) / |e|^2, so the moment goes to the nodes as this pair
        q = (m / np.einsum("nd,nd->n", e, e))[:, None] * np.stack([-e[:, 1], e[:, 0]], axis=1)
        np.add.at(out, c["ib"], q)
        np.add.at(out, c["ia"], -q)
        return out

    def _tangent_apply(self, du: np.ndarray, d: np.ndarray) -> np.ndarray:
        """H_t(d) du: the linearised rigid link at configuration d applied to du (n_s, 2)."""
        c = self._chord
        du = np.asarray(du, dtype=np.float64)
        e, _, Rr = self._current(d)
        de = du[c["ib"]] - du[c["ia"]]
        # omega = d theta = (e x de) / |e|^2, the rate of the chord angle
        omega = (e[:, 0] * de[:, 1] - e[:, 1] * de[:, 0]) / np.einsum("nd,nd->n", e, e)
        zRr = np.stack([-Rr[:, 1], Rr[:, 0]], axis=1)
        return c["interp"] @ du + omega[:, None] * zRr

    @staticmethod
    def _check(a: np.ndarray, mesh: InterfaceMesh) -> None:
        if np.shape(a) != mesh.points.shape:
            raise ValueError(f"array of shape {np.shape(a)}, expected {mesh.points.shape}")

    @staticmethod
    def _cell_normals(dN: np.ndarray) -> np.ndarray:
        """Unit normal of the cell at the projection from two independent surface gradients."""
        g = dN
        # the gradients of the shape functions span the tangent plane: pick the pair with the
        # largest cross product for numerical robustness
        best = np.zeros((g.shape[0], 3))
        bestn = np.zeros(g.shape[0])
        for a in range(g.shape[1]):
            for b in range(a + 1, g.shape[1]):
                c = np.cross(g[:, a], g[:, b])
                cn = np.linalg.norm(c, axis=1)
                take = cn > bestn
                best[take], bestn[take] = c[take], cn[take]
        return best / bestn[:, None]
