import numpy as np
import pytest
from conftest import square_lattice, tank

from mpsfem.fluid_mps import operators as ops
from mpsfem.fluid_mps.lattice import lattice_constants
from mpsfem.fluid_mps.neighbours import build_neighbours
from mpsfem.fluid_mps.particle_kinds import DUMMY, FLUID, WALL
from mpsfem.fluid_mps.surface import DETECTORS, flat_surface_asymmetry, make_surface_detector

L0 = 0.01
RE = 2.1 * L0


def detect(name, pos, kind, **kw):
    dim = pos.shape[1]
    nb = build_neighbours(pos, RE)
    n = np.empty(len(pos))
    ops.number_density(pos, nb.indptr, nb.indices, RE, 0, n)
    det = make_surface_detector(name, dim=dim, l0=L0, re=RE, **kw)
    out = np.full(len(pos), 7, np.int8)
    det.detect(pos, kind, n, nb, out)
    return out, n


@pytest.mark.parametrize("name", sorted(DETECTORS))
@pytest.mark.parametrize("dim,n", [(2, 12), (3, 7)])
def test_free_block_outer_layer_only(name, dim, n):
    pos = square_lattice(dim, n, L0)
    kind = np.zeros(len(pos), np.int8)
    flags, _ = detect(name, pos, kind)
    idx = np.rint(pos / L0).astype(int)
    outer = np.any((idx == 0) | (idx == n - 1), axis=1)
    np.testing.assert_array_equal(flags.astype(bool), outer)


@pytest.mark.parametrize("name", sorted(DETECTORS))
@pytest.mark.parametrize("shape", [(16, 10), (6, 5, 4)])
def test_tank_surface_is_the_top_layer(name, shape):
    pos, kind = tank(shape, L0, layers=3, air_rows=3)
    flags, _ = detect(name, pos, kind)
    top = np.rint(pos[:, -1] / L0).astype(int)
    fluid = kind == FLUID
    expect = top == shape[-1] - 1
    if name == "density_asymmetry" and len(shape) == 3:
        # Known limitation of eqs. 2-19/2-20 (all neighbours count in F): at a vertical edge where
        # two walls meet, the walls above the water raise n into the band 0.8-0.97 n0 and shrink
        # |F| below 0.9 |F|^0, so these top-layer particles are missed. Nothing else is.
        ij = np.rint(pos[:, :2] / L0).astype(int)
        edge = np.all((ij == 0) | (ij == np.array(shape[:2]) - 1), axis=1)
        expect &= ~edge
    # fluid: flagged on and only on the top row; next to the walls nothing else is a surface
    np.testing.assert_array_equal(flags[fluid].astype(bool), expect[fluid])
    # walls under the water line are not a surface, dummies never are
    assert not np.any(flags[(kind == WALL) & (top < shape[-1] - 1)])
    assert not np.any(flags[kind == DUMMY])
    # walls standing in the air above the water are (p = 0 there)
    assert np.all(flags[(kind == WALL) & (top >= shape[-1] + 1)] == 1)


def _star(offsets_removed):
    """Lattice around a centre particle at the origin with some neighbours removed."""
    pts = square_lattice(2, 9, L0, origin=-4 * L0)
    keep = np.ones(len(pts), bool)
    for off in offsets_removed:
        keep &= ~np.all(np.isclose(pts, np.array(off) * L0), axis=1)
    pts = pts[keep]
    centre = int(np.flatnonzero(np.all(np.isclose(pts, 0.0), axis=1))[0])
    return pts, centre


def test_asymmetry_spares_a_symmetric_low_density_particle():
    # four neighbours at distance 2 l0 missing: n = 0.966 n0 < 0.97 n0 but F = 0
    pos, c = _star([(2, 0), (-2, 0), (0, 2), (0, -2)])
    kind = np.zeros(len(pos), np.int8)
    n0, _ = lattice_constants(2, L0, RE)
    f_density, n = detect("density", pos, kind)
    f_asym, _ = detect("density_asymmetry", pos, kind)
    assert 0.8 * n0 < n[c] < 0.97 * n0
    assert f_density[c] == 1 and f_asym[c] == 0


def test_asymmetry_flags_a_one_sided_particle_in_the_band():
    # a flat-surface neighbourhood (upper half removed) made denser below so n is in the band
    up = [(a, b) for a in range(-2, 3) for b in range(1, 3)]
    pos, c = _star(up)
    extra = np.array([[-0.5, -1.5], [0.5, -1.5], [0.0, -1.5]]) * L0
    pos = np.vstack([pos, extra])
    kind = np.zeros(len(pos), np.int8)
    n0, _ = lattice_constants(2, L0, RE)
    flags, n = detect("density_asymmetry", pos, kind)
    assert 0.8 * n0 < n[c] < 0.97 * n0
    nb = build_neighbours(pos, RE)
    js = nb.indices[nb.indptr[c] : nb.indptr[c + 1]]
    r = pos[c] - pos[js]
    d = np.linalg.norm(r, axis=1)
    w = RE / (0.85 * d + 0.15 * RE) - 1
    f = 2 / n0 * (r / d[:, None] * w[:, None]).sum(axis=0)
    assert np.linalg.norm(f) > 0.9 * flat_surface_asymmetry(2, L0, RE)
    assert flags[c] == 1
    flags_hi, _ = detect("density_asymmetry", pos, kind, asymmetry=2.0)
    assert flags_hi[c] == 0  # a threshold above |F| spares it


def test_flat_surface_asymmetry_value():
    # improved kernel, re = 2.1 l0, 2D: 2/n0 (w(1) + sqrt2 w(sqrt2) + w(2)) = 0.5648
    w = [2.1 / (0.85 * r + 0.15 * 2.1) - 1 for r in (1.0, np.sqrt(2), 2.0)]
    n0 = 4 * sum(w)
    expect = 2 / n0 * (w[0] + np.sqrt(2) * w[1] + w[2])
    assert flat_surface_asymmetry(2, 1.0, 2.1) == pytest.approx(expect, rel=1e-12)


def test_registry_and_parameters():
    with pytest.raises(ValueError, match="unknown free-surface detector 'foo'.*density, "):
        make_surface_detector("foo", dim=2, l0=1.0, re=2.1)
    with pytest.raises(ValueError, match="beta must be in"):
        make_surface_detector("density", dim=2, l0=1.0, re=2.1, beta=1.5)
    with pytest.raises(ValueError, match="beta_low"):
        make_surface_detector("density_asymmetry", dim=2, l0=1.0, re=2.1, beta_low=0.99)
