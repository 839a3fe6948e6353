import numpy as np
import pytest
from conftest import brute_force_neighbours, square_lattice

from mpsfem.fluid_mps.neighbours import (
    NeighbourSearch,
    NeighbourSearchError,
    build_neighbours,
    radix_sort,
)


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("cells", [1, 2, 3])
def test_matches_brute_force_random(dim, cells, rng):
    n = 400 if dim == 2 else 600
    pos = rng.uniform(0.0, 10.0, size=(n, dim))
    radius = 1.7
    nl = NeighbourSearch(dim, radius, cells_per_radius=cells).build(pos)
    ref = brute_force_neighbours(pos, radius)
    assert nl.indptr.shape == (n + 1,)
    assert nl.indices.dtype == np.int32
    for i in range(n):
        got = nl.indices[nl.indptr[i] : nl.indptr[i + 1]]
        np.testing.assert_array_equal(got, ref[i])  # ascending, self excluded


def test_lattice_counts_and_smaller_radius():
    pos = square_lattice(2, 20, l0=0.1)
    search = NeighbourSearch(2, 0.401)
    nl = search.build(pos)
    counts = np.diff(nl.indptr)
    assert counts.max() == 48  # |(a, b)| < 4.01 on the integer lattice, self excluded
    nl2 = search.build(pos, radius=0.21)
    assert np.diff(nl2.indptr).max() == 12
    ref = brute_force_neighbours(pos, 0.21)
    for i in range(len(pos)):
        np.testing.assert_array_equal(nl2.indices[nl2.indptr[i] : nl2.indptr[i + 1]], ref[i])


def test_buffers_reused_and_grow(rng):
    search = NeighbourSearch(2, 1.0)
    pos = rng.uniform(0, 5, size=(100, 2))
    nl = search.build(pos)
    buf = search._indices
    nl = search.build(pos + 0.01)
    assert search._indices is buf
    big = rng.uniform(0, 5, size=(1000, 2))
    nl = search.build(big)
    ref = brute_force_neighbours(big, 1.0)
    assert nl.nnz == sum(len(r) for r in ref)


def test_domain_clipping_is_exact(rng):
    pos = rng.uniform(0, 4, size=(300, 2))
    pos[:20] += 7.0  # outside the domain, some close to each other
    search = NeighbourSearch(2, 1.0, domain=([0, 0], [4, 4]))
    nl = search.build(pos)
    ref = brute_force_neighbours(pos, 1.0)
    for i in range(len(pos)):
        np.testing.assert_array_equal(nl.indices[nl.indptr[i] : nl.indptr[i + 1]], ref[i])


def test_escape_raise_names_particle(rng):
    pos = rng.uniform(0, 4, size=(50, 2))
    pos[17] = [9.0, 2.0]
    search = NeighbourSearch(2, 1.0, domain=([0, 0], [4, 4]), escape="raise")
    with pytest.raises(NeighbourSearchError, match="particle 17"):
        search.build(pos)


def test_far_particle_without_domain_raises(rng):
    pos = rng.uniform(0, 4, size=(50, 2))
    pos[33] = [1e9, 2.0]
    with pytest.raises(NeighbourSearchError, match="particle 33"):
        build_neighbours(pos, 0.5)


def test_nan_raises(rng):
    pos = rng.uniform(0, 4, size=(50, 3))
    pos[5, 2] = np.nan
    with pytest.raises(NeighbourSearchError, match="particle 5 has a non-finite"):
        build_neighbours(pos, 0.5)


def test_within_filters_the_last_build(rng):
    pos = rng.uniform(0.0, 6.0, size=(500, 2))
    search = NeighbourSearch(2, 1.5)
    search.build(pos)
    small = search.within(pos, 0.7)
    ref = brute_force_neighbours(pos, 0.7)
    for i in range(len(pos)):
        np.testing.assert_array_equal(small.indices[small.indptr[i] : small.indptr[i + 1]], ref[i])
    with pytest.raises(ValueError, match="exceeds"):
        search.within(pos, 2.0)


def test_long_rows_match_brute_force(rng):
    """3D rows at the Laplacian radius 4.01 l0 hold ~270 neighbours, above LONG_ROW: they take
    the radix-sort branch and must still be the brute-force rows, ascending."""
    from mpsfem.fluid_mps.neighbours import LONG_ROW

    g = np.arange(12, dtype=np.float64)
    pos = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    pos += rng.uniform(-0.2, 0.2, size=pos.shape)
    pos = pos[rng.permutation(len(pos))]  # indices unrelated to the cell order
    nl = NeighbourSearch(3, 4.01).build(pos)
    ref = brute_force_neighbours(pos, 4.01)
    lengths = np.diff(nl.indptr)
    assert lengths.max() > LONG_ROW and lengths.min() < LONG_ROW  # both branches run
    for i in range(len(pos)):
        np.testing.assert_array_equal(nl.indices[nl.indptr[i] : nl.indptr[i + 1]], ref[i])


@pytest.mark.parametrize(
    ("size", "span"),
    [(0, 1), (1, 9), (2, 2), (300, 1), (300, 256), (300, 257), (300, 70_000), (300, 2**31 - 1)],
)
def test_radix_sort_sorts_any_span(size, span, rng):
    """The long-row sort against numpy's: spans needing no digit pass (all equal), one, two,
    three and four 8-bit passes (an odd count leaves the keys in the scratch array), with
    repeated keys and an offset minimum."""
    keys = (rng.integers(0, span, size) + (7 if span < 2**31 - 8 else 0)).astype(np.int32)
    got = keys.copy()
    radix_sort(got)
    np.testing.assert_array_equal(got, np.sort(keys))


@pytest.mark.parametrize("dim", [2, 3])
def test_rows_mask_leaves_rows_empty_and_keeps_the_others(dim, rng):
    """``build(rows=mask)``: masked rows are empty, the others are exactly the full list's rows
    (masked particles still appear in them), and ``within`` works on the result."""
    pos = rng.uniform(0.0, 1.0, size=(600, dim))
    s = NeighbourSearch(dim, 0.2)
    full = s.build(pos)
    full_rows = [full.indices[full.indptr[i] : full.indptr[i + 1]].copy() for i in range(600)]
    mask = (rng.uniform(size=600) < 0.7).astype(np.int8)
    part = s.build(pos, rows=mask)
    for i in range(600):
        row = part.indices[part.indptr[i] : part.indptr[i + 1]]
        if mask[i]:
            np.testing.assert_array_equal(row, full_rows[i])
        else:
            assert row.size == 0
    assert np.any(~mask.astype(bool)[part.indices])  # masked particles are still neighbours
    small = s.within(pos, 0.1)
    assert all(small.indptr[i] == small.indptr[i + 1] for i in np.flatnonzero(mask == 0))
    with pytest.raises(ValueError, match="rows must be an int8 array"):
        s.build(pos, rows=mask.astype(bool))
