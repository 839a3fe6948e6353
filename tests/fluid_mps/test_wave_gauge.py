"""Wave gauge (probe kind "wave_gauge"): the kernel fluid-fraction surface and the top-particle
surface against surfaces whose height is known exactly."""

import numpy as np
import pytest

from mpsfem.fluid_mps.probes import surface_height, surface_height_kernel

L0 = 0.01


def _block(nx: int, ny: int, dim: int = 2, jitter: float = 0.0, seed: int = 3) -> np.ndarray:
    """Lattice particles filling [0, nx l0] x [0, ny l0] (x [0, nx l0] in 3D): cell centres."""
    axes = [(np.arange(nx) + 0.5) * L0] * (dim - 1) + [(np.arange(ny) + 0.5) * L0]
    grid = np.meshgrid(*axes, indexing="ij")
    pos = np.stack([g.ravel() for g in grid], axis=1)
    if jitter:
        pos += np.random.default_rng(seed).uniform(-jitter, jitter, pos.shape) * L0
    return pos


def _gauge(pos, x):
    kind = np.zeros(len(pos), np.int8)
    work = np.empty(len(pos), np.int64)
    return surface_height_kernel(pos, kind, np.atleast_1d(np.asarray(x, float)), 1, L0, work)


# Tolerance of a reading on a regular arrangement: the Wendland sums are 1 to +-0.5 % (h = 1.5 l0)
# and f falls by about 0.45 per l0 through the surface, so the half level is off by <= 0.011 l0.
TOL = 0.011 * L0


def test_still_water_reads_its_depth_anywhere_between_particles():
    """A lattice block 20 l0 deep reads its depth (the half level of the kernel sum lies half a
    spacing above the top centres) wherever the gauge stands between particle columns (measured:
    within 3e-3 l0); the top-particle gauge reads the same depth exactly."""
    pos = _block(60, 20)
    depth = 20 * L0
    readings = [_gauge(pos, x) for x in np.linspace(0.2, 0.21, 11)]
    assert np.max(np.abs(np.array(readings) - depth)) < TOL
    kind = np.zeros(len(pos), np.int8)
    top = surface_height(pos, kind, np.array([0.301]), 0.5 * L0, 1, L0)
    assert top == pytest.approx(depth, abs=1e-12)


def test_three_dimensional_still_water():
    pos = _block(16, 12, dim=3)
    kind = np.zeros(len(pos), np.int8)
    work = np.empty(len(pos), np.int64)
    h = surface_height_kernel(pos, kind, np.array([0.081, 0.077]), 2, L0, work)
    assert h == pytest.approx(12 * L0, abs=TOL)


def test_sloping_surface_is_followed():
    """A sheared lattice (each column shifted up by s x, so its top cell face lies on the line
    y = 0.3 + s x): the gauge follows the line between and across columns (measured: within
    3e-3 l0 for s = 0.1, 0.2, 0.5)."""
    xs = np.linspace(0.15, 0.45, 31)
    for s in (0.1, 0.2, 0.5):
        pos = _block(60, 30)
        pos[:, 1] += s * pos[:, 0]
        err = np.array([_gauge(pos, x) - (0.3 + s * x) for x in xs])
        assert np.max(np.abs(err)) < TOL


def test_reading_is_continuous_when_particles_move():
    """Jittered particles (+-0.1 l0): moving the top layer up by delta moves the reading by a
    fraction of delta, never by a spacing; the top-particle gauge in a column l0 wide can jump
    (it does here, which is why it is not the default)."""
    pos = _block(60, 20, jitter=0.1)
    top_layer = pos[:, 1] > 19 * L0
    base = _gauge(pos, 0.3)
    assert base == pytest.approx(20 * L0, abs=0.05 * L0)
    for delta in (1e-4 * L0, 1e-2 * L0, 0.1 * L0):
        moved = pos.copy()
        moved[top_layer, 1] += delta
        shift = _gauge(moved, 0.3) - base
        assert 0.0 < shift <= delta * 1.01
    kind = np.zeros(len(pos), np.int8)
    xs = np.linspace(0.3, 0.31, 21)
    tops = [surface_height(pos, kind, np.array([x]), 0.5 * L0, 1, L0) for x in xs]
    kern = [_gauge(pos, x) for x in xs]
    assert np.ptp(kern) < 0.1 * L0
    assert np.ptp(tops) > np.ptp(kern)


def test_dry_line_reads_nan():
    pos = _block(10, 10)
    assert np.isnan(_gauge(pos, 0.5))  # 40 l0 beyond the block
    thin = _block(40, 1)  # a single layer: f peaks near 0.5 and a lone one does not reach it
    assert np.isnan(_gauge(thin[::3], 0.2))
