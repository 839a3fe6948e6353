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
