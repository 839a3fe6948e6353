"""Supports of beam ends and plate edges as sets of constrained (zero) degrees of freedom.

All supports are homogeneous, so they are imposed by dropping the constrained rows and columns
(condensation) from M, C and K.

Beam end (Hermite bending dofs w, w'; optional axial dof u):

* ``clamped``: w = w' = 0 and u = 0;
* ``simply_supported`` (pinned): w = 0 and u = 0, the rotation w' is free;
* ``free``: nothing.

Plate edge, Bogner-Fox-Schmit (nodal dofs w, w_x, w_y, w_xy on the edge's nodes):

* ``clamped``: all four vanish along the edge (w = 0 and dw/dn = 0 imply the tangential
  derivatives and the twist vanish too);
* ``simply_supported``: w and its tangential derivative vanish (w_x on an edge along u, w_y on an
  edge along v); the normal slope and the twist stay free;
* ``free``: nothing (the natural boundary conditions hold weakly).

Plate edge, Morley (vertex values w, edge-midpoint normal slopes w_n):

* ``clamped``: w at the edge's vertices and w_n at its midpoints;
* ``simply_supported``: w at the edge's vertices;
* ``free``: nothing.
"""

from __future__ import annotations

import numpy as np

__all__ = ["BOUNDARY_NAMES", "beam_constrained_dofs", "plate_constrained_dofs"]

BOUNDARY_NAMES = ("clamped", "simply_supported", "free")


def _check(name: str) -> None:
    if name not in BOUNDARY_NAMES:
        raise ValueError(f"unknown support {name!r}; allowed: {', '.join(BOUNDARY_NAMES)}")


def beam_constrained_dofs(
    bcs: list[str],
    *,
    w: tuple[int, int],
    slope: tuple[int, int],
    axial: tuple[int, int] | None,
) -> np.ndarray:
    """Constrained dofs of a beam with supports ``bcs = [at start, at end]``.

    `w`, `slope` and `axial` give the (start, end) dof indices of the deflection, the slope and the
    axial displacement (``None`` for an inextensible beam).
    """
    fixed: list[int] = []
    for end, name in enumerate(bcs):
        _check(name)
        if name == "free":
            continue
        fixed.append(w[end])
        if axial is not None:
            fixed.append(axial[end])
        if name == "clamped":
            fixed.append(slope[end])
    return np.unique(np.asarray(fixed, dtype=np.int64))


def plate_constrained_dofs(basis, element: str, edges: list[dict]) -> np.ndarray:
    """Constrained dofs of a plate.

    `basis` is the scikit-fem basis (ElementQuadBFS or ElementTriMorley), `element` ``"bfs"`` or
    ``"morley"``; each entry of `edges` has ``facets`` (facet indices of the edge), ``bc`` (support
    name) and, for BFS, ``direction`` (``"u"`` for an edge along the local u axis, ``"v"``).
    """
    fixed: list[np.ndarray] = []
    for edge in edges:
        name = edge["bc"]
        _check(name)
        if name == "free" or len(edge["facets"]) == 0:
            continue
        dofs = basis.get_dofs(facets=np.asarray(edge["facets"]))
        if element == "bfs":
            if name == "clamped":
                keys = ["u", "u_x", "u_y", "u_xy"]
            else:
                keys = ["u", "u_x" if edge["direction"] == "u" else "u_y"]
        elif element == "morley":
            keys = ["u", "u_n"] if name == "clamped" else ["u"]
        else:
            raise ValueError(f"unknown plate element {element!r}; allowed: 'bfs', 'morley'")
        fixed.append(np.asarray(dofs.all(keys), dtype=np.int64))
    if not fixed:
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.concatenate(fixed))
