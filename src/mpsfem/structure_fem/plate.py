"""Kirchhoff plate in a 3D scene: ElementQuadBFS (rectangles) or ElementTriMorley (any outline).

The plate lies in the plane through ``origin`` spanned by the unit vectors ``e_u`` and ``e_v``;
its normal is ``n = e_u x e_v``. The unknown is the deflection w(u, v) along n. With the rigidity
``D = E h^3 / (12 (1 - nu^2))``:

* stiffness ``D int [(1 - nu) w_,ij v_,ij + nu (lap w)(lap v)]`` (bending energy);
* consistent mass ``rho h int w v`` (rotary inertia neglected).

Only the normal component of applied forces acts: the plate has no membrane degrees of freedom.
The interface nodes are the mesh vertices (mid-surface nodes).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp
from skfem import Basis, BilinearForm, ElementQuadBFS, ElementTriMorley, LinearForm
from skfem.helpers import dd, ddot, trace

from .boundary_conditions import plate_constrained_dofs
from .meshing import polygon_mesh, rectangle_mesh
from .model import MemberModel

__all__ = ["PlateModel", "plate_bending_form", "area_mass_form", "area_load_form"]


def plate_bending_form(nu: float) -> BilinearForm:
    """Bending bilinear form over D: (1 - nu) w_,ij v_,ij + nu lap w lap v."""

    @BilinearForm
    def form(u, v, w):
        return (1.0 - nu) * ddot(dd(u), dd(v)) + nu * trace(dd(u)) * trace(dd(v))

    return form


@BilinearForm
def area_mass_form(u, v, w):
    """int w v dA (times rho h gives the consistent mass)."""
    return u * v


@LinearForm
def area_load_form(v, w):
    """int v dA (times a uniform pressure gives the consistent load vector)."""
    return v


class PlateModel(MemberModel):
    """Discretised plate; build with :meth:`from_config` or :meth:`create`."""

    origin: np.ndarray
    e_u: np.ndarray
    e_v: np.ndarray
    normal: np.ndarray
    element: str
    D: float
    rho_h: float
    mesh: object
    basis: Basis
    outline: np.ndarray

    @classmethod
    def from_config(cls, cfg) -> PlateModel:
        """From a :class:`~mpsfem.scenario.structure.PlateMember`."""
        if cfg.shape == "rectangle":
            a, b = cfg.size
            if cfg.divisions is not None:
                nx, ny = cfg.divisions
            else:
                nx = max(1, math.ceil(a / cfg.mesh_size - 1e-9))
                ny = max(1, math.ceil(b / cfg.mesh_size - 1e-9))
            planform = {"rectangle": (a, b, nx, ny)}
        else:
            planform = {"polygon": (cfg.outline, cfg.mesh_size)}
        mat = cfg.material
        return cls.create(
            name=cfg.name,
            element=cfg.element,
            origin=cfg.origin,
            axis_u=cfg.axis_u,
            axis_v=cfg.axis_v,
            E=mat.youngs_modulus,
            nu=mat.poisson_ratio,
            density=mat.density,
            thickness=cfg.thickness,
            geometric_thickness=cfg.fluid_thickness,
            bcs=cfg.edge_bcs,
            rayleigh_a1=cfg.rayleigh_a1,
            rayleigh_a2=cfg.rayleigh_a2,
            **planform,
        )

    @classmethod
    def create(
        cls,
        *,
        name: str,
        element: str,
        E: float,
        nu: float,
        density: float,
        thickness: float,
        bcs: list[str],
        rectangle: tuple[float, float, int, int] | None = None,
        polygon: tuple[list, float] | None = None,
        origin=(0.0, 0.0, 0.0),
        axis_u=(1.0, 0.0, 0.0),
        axis_v=(0.0, 1.0, 0.0),
        geometric_thickness: float | None = None,
        rayleigh_a1: float = 0.0,
        rayleigh_a2: float = 0.0,
    ) -> PlateModel:
        e_u = np.asarray(axis_u, dtype=float)
        e_u = e_u / np.linalg.norm(e_u)
        e_v = np.asarray(axis_v, dtype=float)
        e_v = e_v / np.linalg.norm(e_v)
        normal = np.cross(e_u, e_v)
        origin = np.asarray(origin, dtype=float)

        if element == "bfs":
            if rectangle is None:
                raise ValueError('element "bfs" needs a rectangular plate')
            a, b, nx, ny = rectangle
            mesh, edges = rectangle_mesh(a, b, nx, ny, "quad")
            elem = ElementQuadBFS()
            outline = np.array([[0.0, 0.0], [a, 0.0], [a, b], [0.0, b]])
        elif element == "morley":
            if rectangle is not None:
                a, b, nx, ny = rectangle
                mesh, edges = rectangle_mesh(a, b, nx, ny, "tri")
                outline = np.array([[0.0, 0.0], [a, 0.0], [a, b], [0.0, b]])
            elif polygon is not None:
                mesh, edges = polygon_mesh(polygon[0], polygon[1])
                outline = np.asarray(polygon[0], dtype=float)
            else:
                raise ValueError("give a rectangle or a polygon")
            elem = ElementTriMorley()
        else:
            raise ValueError(f"unknown plate element {element!r}; allowed: 'bfs', 'morley'")
        if len(bcs) != len(edges):
            raise ValueError(f"{len(edges)} edges but {len(bcs)} supports given")

        basis = Basis(mesh, elem)
        D = E * thickness**3 / (12.0 * (1.0 - nu**2))
        rho_h = density * thickness
        K = (D * plate_bending_form(nu).assemble(basis)).tocsr()
        M = (rho_h * area_mass_form.assemble(basis)).tocsr()
        ndof = basis.N

        edge_specs = []
        for k, (facets, bc) in enumerate(zip(edges, bcs, strict=True)):
            direction = None
            if element == "bfs":
                direction = "u" if k in (0, 2) else "v"
            edge_specs.append({"facets": facets, "bc": bc, "direction": direction})
        fixed = plate_constrained_dofs(basis, element, edge_specs)

        nn = mesh.p.shape[1]
        w_dofs = basis.nodal_dofs[0].astype(np.int64)
        rows = np.concatenate([3 * np.arange(nn) + c for c in range(3)])
        cols = np.tile(w_dofs, 3)
        vals = np.concatenate([np.full(nn, normal[c]) for c in range(3)])
        T = sp.csr_matrix((vals, (rows, cols)), shape=(3 * nn, ndof))
        rotation = None
        rot_names: tuple[str, ...] = ()
        if element == "bfs":
            wx = basis.nodal_dofs[1].astype(np.int64)
            wy = basis.nodal_dofs[2].astype(np.int64)
            rotation = sp.csr_matrix(
                (
                    np.ones(2 * nn),
                    (
                        np.concatenate([2 * np.arange(nn), 2 * np.arange(nn) + 1]),
                        np.concatenate([wx, wy]),
                    ),
                ),
                shape=(2 * nn, ndof),
            )
            rot_names = ("dw_du", "dw_dv")
        conn = mesh.t.T.astype(np.int64).copy()
        xy = mesh.p.T[conn]  # (ne, k, 2)
        x, y = xy[..., 0], xy[..., 1]
        signed = np.sum(x * np.roll(y, -1, axis=1) - np.roll(x, -1, axis=1) * y, axis=1)
        conn[signed < 0] = conn[signed < 0][:, ::-1]
        nodes = (
            origin[None, :] + mesh.p[0][:, None] * e_u[None, :] + mesh.p[1][:, None] * e_v[None, :]
        )
        model = cls(
            name=name,
            dim=3,
            M=M,
            K=K,
            fixed=fixed,
            nodes=nodes,
            normals=np.tile(normal, (nn, 1)),
            connectivity=conn,
            translation=T,
            thickness=thickness,
            geometric_thickness=thickness if geometric_thickness is None else geometric_thickness,
            rayleigh_a1=rayleigh_a1,
            rayleigh_a2=rayleigh_a2,
            rotation=rotation,
            rotation_components=rot_names,
            dof_kind=np.zeros(ndof, dtype=np.int8),
            dof_kind_names=("bending",),
        )
        model.origin, model.e_u, model.e_v, model.normal = origin, e_u, e_v, normal
        model.element, model.D, model.rho_h = element, D, rho_h
        model.mesh, model.basis, model.outline = mesh, basis, outline
        model.edge_facets = edges
        model.w_dofs = w_dofs
        return model

    # ------------------------------------------------------------------ loads
    def gravity_load(self, g: np.ndarray) -> np.ndarray:
        return self.pressure_load(self.rho_h * float(np.asarray(g, dtype=float) @ self.normal))

    def pressure_load(self, p: float) -> np.ndarray:
        return p * area_load_form.assemble(self.basis)

    def local_coordinates(self, point) -> np.ndarray:
        """(u, v) of the projection of a scene point onto the plate's plane."""
        d = np.asarray(point, dtype=float) - self.origin
        return np.array([d @ self.e_u, d @ self.e_v])

    def nearest_local(self, point) -> np.ndarray:
        """(u, v) of the plate point nearest a scene point (projection, then into the planform)."""
        uv = self.local_coordinates(point)
        poly = self.outline
        if _inside(uv, poly):
            return uv
        best, dist = uv, np.inf
        for p0, p1 in zip(poly, np.roll(poly, -1, axis=0), strict=True):
            e = p1 - p0
            s = float(np.clip((uv - p0) @ e / (e @ e), 0.0, 1.0))
            q = p0 + s * e
            d = float(np.linalg.norm(uv - q))
            if d < dist:
                best, dist = q, d
        return best

    def point_matrix(self, point) -> sp.csr_matrix:
        uv = self.nearest_local(point)
        try:
            P = self.basis.probes(uv[:, None]).tocsr()
        except Exception as exc:  # pragma: no cover - the point is inside by construction
            raise ValueError(f"cannot evaluate plate {self.name!r} at (u, v) = {uv}") from exc
        return sp.kron(sp.csr_matrix(self.normal[:, None]), P, format="csr")


def _inside(uv: np.ndarray, poly: np.ndarray) -> bool:
    x, y = uv
    inside = False
    for (x0, y0), (x1, y1) in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        if (y0 > y) != (y1 > y) and x < x0 + (y - y0) * (x1 - x0) / (y1 - y0):
            inside = not inside
    if inside:
        return True
    # on the outline counts as inside
    for p0, p1 in zip(poly, np.roll(poly, -1, axis=0), strict=True):
        e = p1 - p0
        s = float(np.clip((uv - p0) @ e / (e @ e), 0.0, 1.0))
        if np.linalg.norm(uv - p0 - s * e) <= 1e-12 * max(1.0, float(np.abs(poly).max())):
            return True
    return False
