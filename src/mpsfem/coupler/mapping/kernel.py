"""Kernel mappings: the thesis's KFBI and its conservative counterpart.

Both weigh a fluid interface point i and a structure node n by the MPS kernel (thesis eq. 2-4,
:func:`mpsfem.fluid_mps.kernels.weight_py`) of their distance r_in, inside a radius r_ei.
The distance is measured to the node's *thickness fibre* {x_n + z n_n : |z| <= t_n / 2}, so the
particles on both faces of a member of geometric thickness t are as close to the node as particles
in its plane (for t = 0 this is the plain Euclidean distance of the thesis).

``"kfbi"`` (thesis ch. 2.3):
    displacement of particle i, eq. 2-53: delta_i = sum_m w_im delta_m / sum_m w_im;
    force on node n, eq. 2-52: F_n = sum_i w_in F_i / sum_i w_in — a kernel-weighted *average*
    of the particle forces F_i = P_i l0^(d-1) n_i. Averaged per face and the faces summed as
    vectors (the face of particle i at node n is the sign of n_i . n_n; particles at an edge,
    |n_i . n_n| < 1/2, form a third group), so a thin member feels the difference of the pressures
    on its two faces. The average is not conservative: F_n ~ P l0^(d-1) while the node's share of
    the load is P h_e^(d-1), so the total force drifts by roughly (l0 / h_e)^(d-1) when the
    element length h_e differs from the particle spacing l0 (the thesis converges its results at
    h_e = l0); ``tests/coupler/test_mapping.py`` prints the table.

``"conservative-kernel"``:
    displacement as eq. 2-53 (normalised weights, operator H with rows summing to one); forces by
    the transpose, F_s = H^T F_f: every particle force is split among nearby nodes with weights
    summing to one, so the total force is kept exactly and the work F_f . (H u) = (H^T F_f) . u
    is the same on both sides.
"""

from __future__ import annotations

from typing import ClassVar, Literal

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

__all__ = ["ConservativeKernelMapping", "KFBIMapping", "kernel_pairs"]

#: default radius in fluid interface spacings (the MPS kernel radius of the thesis, 2.1 l0)
RADIUS_SPACINGS = 2.1


def kernel_pairs(
    fluid: InterfaceMesh, structure: InterfaceMesh, radius: float, kernel: str
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(i_fluid, j_node, weight) of every pair closer than ``radius`` to the node's thickness
    fibre, sorted by (i, j); weights > 0."""
    from mpsfem.fluid_mps.kernels import weight_py

    half = 0.5 * structure.thickness
    reach = radius + (float(half.max()) if half.size else 0.0)
    pairs = cKDTree(fluid.points).sparse_distance_matrix(
        cKDTree(structure.points), reach, output_type="ndarray"
    )
    i = pairs["i"].astype(np.int64)
    j = pairs["j"].astype(np.int64)
    d = fluid.points[i] - structure.points[j]
    n = structure.normals[j]
    z = np.clip(np.einsum("kd,kd->k", d, n), -half[j], half[j])
    r = np.linalg.norm(d - z[:, None] * n, axis=1)
    keep = r < radius
    i, j, r = i[keep], j[keep], r[keep]
    w = weight_py(r, radius, kernel)
    keep = w > 0.0
    i, j, w = i[keep], j[keep], w[keep]
    order = np.lexsort((j, i))
    return i[order], j[order], w[order]


class KernelParams(Section):
    """Common parameters of the kernel mappings."""

    radius: float | None = Field(
        None,
        gt=0,
        description=(
            "Interpolation radius r_ei in m (> 0), measured from a fluid point to a structure "
            "node's thickness fibre. Default: 2.1 x the spacing of the fluid interface points "
            "(median nearest-neighbour distance), the MPS kernel radius of the thesis."
        ),
    )
    kernel: Literal["improved", "original"] = Field(
        "improved",
        description=(
            'Weight function: "improved" (thesis eq. 2-4, r_e/(0.85 r + 0.15 r_e) - 1) or '
            '"original" (Koshizuka-Oka, r_e/r - 1).'
        ),
    )


class KFBIParams(KernelParams):
    """Thesis KFBI (ch. 2.3, eqs. 2-52, 2-53): kernel-weighted averages inside r_ei."""

    kind: Literal["kfbi"] = Field(description='"kfbi".')


class ConservativeKernelParams(KernelParams):
    """Kernel weights for displacement (eq. 2-53), their transpose for forces."""

    kind: Literal["conservative-kernel"] = Field(description='"conservative-kernel".')


class _KernelMapping(Mapping):
    def _pairs(self, fluid: InterfaceMesh, structure: InterfaceMesh):
        radius = self.params.radius
        if radius is None:
            radius = RADIUS_SPACINGS * point_spacing(fluid.points)
        self.radius = float(radius)
        i, j, w = kernel_pairs(fluid, structure, self.radius, self.params.kernel)
        lonely = np.setdiff1d(np.arange(fluid.n_points), i)
        if lonely.size:
            raise MappingCoverageError(
                f"mapping {self.kind!r}: {describe_points(fluid.points, lonely)} of the fluid "
                f"interface have no structure node within radius = {self.radius:.6g} m; set "
                "coupling.mapping.radius larger than half the element length (plus the particle "
                "offset from the member faces)"
            )
        return i, j, w

    def _consistent(self, i, j, w, n_f: int, n_s: int) -> sp.csr_matrix:
        wsum = np.bincount(i, weights=w, minlength=n_f)
        return sp.csr_matrix((w / wsum[i], (i, j)), shape=(n_f, n_s))


class ConservativeKernelMapping(_KernelMapping):
    kind = "conservative-kernel"
    Params = ConservativeKernelParams
    conservative = True

    def _build(self, fluid, structure):
        i, j, w = self._pairs(fluid, structure)
        H = self._consistent(i, j, w, fluid.n_points, structure.n_points)
        return H, H.T.tocsr(), True


class KFBIMapping(_KernelMapping):
    kind = "kfbi"
    Params = KFBIParams
    conservative = False
    #: |n_i . n_n| below this puts particle i in the node's edge group
    EDGE_COSINE: ClassVar[float] = 0.5

    def _build(self, fluid, structure):
        i, j, w = self._pairs(fluid, structure)
        n_f, n_s = fluid.n_points, structure.n_points
        H = self._consistent(i, j, w, n_f, n_s)
        # eq. 2-52 per face: group g in {0: -face, 1: edge, 2: +face} of particle i at node j
        c = np.einsum("kd,kd->k", fluid.normals[i], structure.normals[j])
        g = np.where(c > self.EDGE_COSINE, 2, np.where(c < -self.EDGE_COSINE, 0, 1))
        key = 3 * j + g
        wsum = np.bincount(key, weights=w, minlength=3 * n_s)
        A = sp.csr_matrix((w / wsum[key], (j, i)), shape=(n_s, n_f))
        return H, A, True
