"""Shared helpers for the MPS kernel tests: small lattices."""

from __future__ import annotations

import numpy as np
import pytest


def square_lattice(dim: int, n: int, l0: float = 1.0, origin=0.0) -> np.ndarray:
    """n**dim lattice points of spacing l0 (x fastest) as (N, dim) float64."""
    idx = np.indices((n,) * dim).reshape(dim, -1).T[:, ::-1]
    return idx.astype(np.float64) * l0 + origin


def interior_mask(pos: np.ndarray, lo, hi, margin: float) -> np.ndarray:
    """Particles at least ``margin`` inside the box [lo, hi] on every axis."""
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    return np.all((pos >= lo + margin - 1e-12) & (pos <= hi - margin + 1e-12), axis=1)


def brute_force_neighbours(pos: np.ndarray, radius: float) -> list[np.ndarray]:
    d2 = ((pos[:, None, :] - pos[None, :, :]) ** 2).sum(axis=2)
    np.fill_diagonal(d2, np.inf)
    return [np.flatnonzero(row < radius * radius) for row in d2]


@pytest.fixture
def rng():
    return np.random.default_rng(12345)


def tank(shape, l0=1.0, layers=3, air_rows=3, closed=False):
    """Fluid block of ``shape`` lattice sites (last axis vertical) in an open tank.

    Walls on the floor and on every side: the layer touching the fluid is WALL (1), the
    ``layers - 1`` behind it DUMMY (2). The walls rise ``air_rows`` rows above the water; with
    ``closed`` a lid closes the box right above the fluid instead (no free surface). Returns
    (pos, kind) with the fluid first, in lattice order (x fastest).
    """
    dim = len(shape)
    lo = [-layers] * dim
    hi = [s + layers for s in shape[:-1]] + [shape[-1] + (layers if closed else air_rows)]
    extent = [h - l for l, h in zip(lo, hi, strict=True)]
    idx = np.indices(extent[::-1]).reshape(dim, -1).T[:, ::-1] + np.array(lo)  # x fastest
    out = np.zeros(len(idx), dtype=np.int64)  # layers outside the fluid block
    for d in range(dim):
        below = -idx[:, d]
        above = idx[:, d] - (shape[d] - 1)
        if d == dim - 1 and not closed:
            above = np.zeros_like(above)  # open top
        out = np.maximum(out, np.maximum(below, above))
    inside = np.all(idx >= 0, axis=1) & np.all(idx < np.array(shape), axis=1)
    fluid = inside
    wall = (out >= 1) & (out <= layers)
    kind = np.full(len(idx), -1, dtype=np.int8)
    kind[fluid] = 0
    kind[wall & (out == 1)] = 1
    kind[wall & (out > 1)] = 2
    keep = kind >= 0
    pos, kind = idx[keep].astype(np.float64) * l0, kind[keep]
    order = np.argsort(kind, kind="stable")
    return pos[order], kind[order]
