import numpy as np
import pytest
from conftest import brute_force_neighbours, square_lattice

from mpsfem.fluid_mps.neighbours import (
    NeighbourSearch,
    NeighbourSearchError,
    build_neighbours,
    merge_runs,
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
    radix_sort(got, np.empty(size, np.int32), np.empty(257, np.int64))
    np.testing.assert_array_equal(got, np.sort(keys))


@pytest.mark.parametrize("runs", [0, 1, 2, 5, 40])
@pytest.mark.parametrize("size", [0, 1, 2, 41, 300])
def test_merge_runs_sorts_rows_of_ascending_runs(size, runs, rng):
    """The short-row sort against numpy's: rows made of ``runs`` ascending runs (0: sorted
    already; 40: nearly random), with repeated keys; the scratch is left longer than needed."""
    keys = rng.integers(0, 50, size).astype(np.int32)
    if runs:
        cuts = np.sort(rng.integers(0, size + 1, runs - 1))
        keys = np.concatenate([np.sort(part) for part in np.split(keys, cuts)])
    else:
        keys = np.sort(keys)
    got = keys.copy()
    merge_runs(got, np.full(size + 3, -1, np.int32))
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


def _random_walk(dim, n, steps, step_size, rng):
    """Positions of ``n`` particles in a unit box over ``steps`` calls, each particle moving by
    up to ``step_size`` per call (some more, to cross skin / 2 now and then)."""
    pos = rng.uniform(0.0, 1.0, size=(n, dim))
    for _ in range(steps):
        pos = pos + rng.uniform(-step_size, step_size, size=pos.shape)
        yield pos


@pytest.mark.parametrize("dim", [2, 3])
def test_update_is_the_exact_list_whichever_path_it_takes(dim, rng):
    """Verlet candidates (``update`` with a skin): every call returns exactly the list a fresh
    ``build`` gives (same rows, same order), both while the candidates are reused and when they
    are rebuilt; rows masked out stay empty."""
    n, radius, skin = 700 if dim == 2 else 900, 0.12, 0.04
    mask = (rng.uniform(size=n) < 0.8).astype(np.int8)
    search = NeighbourSearch(dim, radius, domain=([0.0] * dim, [1.0] * dim), skin=skin)
    fresh = NeighbourSearch(dim, radius, domain=([0.0] * dim, [1.0] * dim))
    for pos in _random_walk(dim, n, 40, 0.004, rng):
        got = search.update(pos, rows=mask)
        want = fresh.build(pos, rows=mask)
        np.testing.assert_array_equal(got.indptr, want.indptr)
        np.testing.assert_array_equal(got.indices, want.indices)
        assert got.radius == radius
    assert search.reuses > 20 and search.builds >= 3  # both paths ran


def test_update_finds_a_pair_that_closed_in_by_just_under_the_skin():
    """The validity bound at its edge: two particles a hair inside radius + skin apart each
    move just under skin / 2 towards each other; the candidates are reused and the pair, now
    just inside radius, is in the list."""
    radius, skin = 1.0, 0.2
    pos = np.array([[0.0, 0.0], [radius + skin * (1 - 1e-6), 0.0], [5.0, 5.0]])
    search = NeighbourSearch(2, radius, skin=skin)
    assert search.update(pos).nnz == 0
    step = 0.5 * skin * (1 - 2e-9)
    moved = pos + np.array([[step, 0.0], [-step, 0.0], [0.0, 0.0]])
    assert np.linalg.norm(moved[1] - moved[0]) < radius
    nb = search.update(moved)
    assert search.reuses == 1
    np.testing.assert_array_equal(nb.indices, [1, 0])


def test_update_builds_exact_lists_while_particles_move_fast_and_returns_to_candidates(rng):
    """Moving more than skin / 4 per call, candidates would not outlive a call: ``update``
    builds the exact list every call (no reuse); once the motion slows down it reuses again."""
    radius, skin = 0.1, 0.02
    search = NeighbourSearch(2, radius, domain=([0.0, 0.0], [1.0, 1.0]), skin=skin)
    fresh = NeighbourSearch(2, radius, domain=([0.0, 0.0], [1.0, 1.0]))
    pos = rng.uniform(0.0, 1.0, size=(400, 2))
    drift = np.zeros_like(pos)
    drift[0, 0] = 0.6 * skin  # one fast particle is enough
    for _ in range(10):
        pos = pos + drift
        np.testing.assert_array_equal(search.update(pos).indices, fresh.build(pos).indices)
    assert search.reuses == 0 and search.builds == 10
    for _ in range(10):
        pos = pos + 0.1 * drift
        np.testing.assert_array_equal(search.update(pos).indices, fresh.build(pos).indices)
    assert search.reuses >= 5


def test_update_raises_on_nan_and_escape_while_reusing(rng):
    """The reuse path keeps the build's guards: a particle that leaves the domain by less than
    skin / 2 (no rebuild) and a non-finite position both raise, naming the particle."""
    pos = rng.uniform(1.0, 3.0, size=(200, 2))
    pos[7] = [3.95, 2.0]
    search = NeighbourSearch(2, 0.5, domain=([0, 0], [4, 4]), escape="raise", skin=0.2)
    search.update(pos)
    search.update(pos)
    assert search.reuses == 1
    out = pos.copy()
    out[7] = [4.001, 2.0]  # moved 0.051 < skin / 2: reused, and outside the domain
    with pytest.raises(NeighbourSearchError, match="particle 7 .* left the domain"):
        search.update(out)
    bad = pos.copy()
    bad[3, 1] = np.nan
    with pytest.raises(NeighbourSearchError, match="particle 3 has a non-finite"):
        search.update(bad)


def test_update_rebuilds_for_new_rows_mask(rng):
    pos = rng.uniform(0.0, 1.0, size=(300, 2))
    search = NeighbourSearch(2, 0.15, skin=0.05)
    fresh = NeighbourSearch(2, 0.15)
    search.update(pos)
    mask = (rng.uniform(size=300) < 0.5).astype(np.int8)
    got = search.update(pos, rows=mask)
    assert search.reuses == 0
    np.testing.assert_array_equal(got.indices, fresh.build(pos, rows=mask).indices)


def test_negative_skin_is_refused():
    with pytest.raises(ValueError, match="skin"):
        NeighbourSearch(2, 1.0, skin=-0.1)


@pytest.mark.parametrize("box", [8.0, 14.0])
@pytest.mark.parametrize("dim", [2, 3])
def test_short_list_is_the_brute_force_list_at_its_radius(dim, box, rng):
    """With ``short_radius`` every build and update also leaves the pairs closer than it in
    ``search.short``: the brute-force rows, ascending, on the cell-list path (skin 0) and on
    the Verlet path (candidates built, then filtered after a small move), next to rows both
    longer (box 8: short rows picked from the sorted row) and shorter (box 14: short rows
    sorted on their own) than LONG_ROW; a build at a radius below ``short_radius`` leaves
    none."""
    from mpsfem.fluid_mps.neighbours import LONG_ROW

    n = 500 if dim == 2 else 700
    pos = rng.uniform(0.0, box, size=(n, dim))
    for skin in (0.0, 0.4):
        search = NeighbourSearch(dim, 3.0, skin=skin, short_radius=1.6)
        for step in range(3):
            if step:
                pos += rng.uniform(-0.05, 0.05, size=pos.shape)  # within skin / 2
            nb = search.update(pos)
            short = search.short
            assert short is not None and short.radius == 1.6
            ref_long = brute_force_neighbours(pos, 3.0)
            ref = brute_force_neighbours(pos, 1.6)
            for i in range(n):
                row = nb.indices[nb.indptr[i] : nb.indptr[i + 1]]
                np.testing.assert_array_equal(row, ref_long[i])
                row = short.indices[short.indptr[i] : short.indptr[i + 1]]
                np.testing.assert_array_equal(row, ref[i])
        if skin:
            assert search.reuses == 2
    lengths = np.diff(nb.indptr)
    assert (np.median(lengths) > LONG_ROW) == (box == 8.0)
    search.build(pos, radius=1.5)
    assert search.short is None


def test_short_radius_outside_the_search_radius_is_refused():
    with pytest.raises(ValueError, match="short_radius"):
        NeighbourSearch(2, 1.0, short_radius=1.5)
