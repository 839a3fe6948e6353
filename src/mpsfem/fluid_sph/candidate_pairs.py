"""Verlet candidate pairs for the δ-SPH right-hand side, filtered inside the kernels.

``fluid_mps.neighbours.NeighbourSearch.update`` keeps a candidate list at ``radius + skin`` and
filters it to the exact list at ``radius`` on every call (a count pass and a fill pass over the
candidates: 0.07 us per particle at 68k particles in 2D, a quarter of a δ-SPH right-hand side
after its kernels were sped up). The δ-SPH kernels compute every pair's distance anyway, so
here the candidates go to the kernels as they are: ``delta_sph.wall_pressure`` and
``delta_sph.correction`` skip the pairs with ``r^2 >= radius^2`` (the test the search's filter
applies, on the same r^2 bits), and ``correction`` writes the pairs it kept, in their order,
into the candidates' slots of each row for ``delta_sph.pair_terms``. Every kernel thus sums the
exact list's pairs in the exact list's (ascending) order: the results are those of the exact
list, bit for bit. Coupled runs take them too (since 2026-11-27): a thin-member filter drops
its pairs from a copy (``DeltaSPHSolver.neighbour_rows``), and the wall reaction, patch
exchange and momentum budget skip the pairs beyond the kernel's support (F = 0) or read the
correction pass's pairs.

The rebuild rule is the search's (``NeighbourSearch.update``): the candidates are kept while no
particle has moved more than ``skin / 2`` since they were built (a pair closer than ``radius``
now was closer than ``radius + skin`` then); where particles move more than ``skin / 4`` per
call the candidates would last under two calls, so the list is built at ``radius`` (exact)
until the measured displacement per call falls below that again. Either list is a valid input
of the kernels.
"""

from __future__ import annotations

import numpy as np

from mpsfem.fluid_mps.neighbours import NeighbourList, NeighbourSearch, max_displacement


class CandidatePairs:
    """Candidate neighbour rows (ascending, self excluded) that hold every pair closer than
    ``radius`` (m): a cell-list build at ``radius + skin`` reused while it stays valid (module
    docstring). ``domain``/``escape`` as :class:`NeighbourSearch`."""

    def __init__(self, dim: int, radius: float, skin: float, domain=None, escape: str = "clip"):
        if not (np.isfinite(skin) and skin >= 0.0):
            raise ValueError(f"skin must be a finite length >= 0, got {skin!r}")
        self.radius = float(radius)
        self.skin = float(skin)
        self.search = NeighbourSearch(dim, self.radius + self.skin, domain=domain, escape=escape)
        self._ref = np.empty((0, dim))
        self._valid = False
        self._calls = 0
        self._last: NeighbourList | None = None
        #: update() calls that built a list (``builds``) and that reused the candidates
        self.builds = 0
        self.reuses = 0

    def update(self, pos: np.ndarray) -> NeighbourList:
        """Candidate rows for ``pos`` (N, dim), m: a superset of the pairs closer than
        :attr:`radius`, each row ascending. Views into the search's buffers, valid until the
        next call that rebuilds."""
        known = self._ref.shape == pos.shape
        moved = max_displacement(pos, self._ref) if known else np.inf
        if self._valid and known and 2.0 * moved <= self.skin * (1 - 1e-9):
            self._calls += 1
            self.reuses += 1
            return self._last
        # per-call displacement since the last build: candidates pay when they last >= 2 calls
        rate = moved / (self._calls + 1) if known else 0.0
        skin = self.skin if 4.0 * rate <= self.skin else 0.0
        self._calls = 0
        self._valid = False
        self.builds += 1
        self._last = self.search.build(pos, radius=self.radius + skin)  # raises on a NaN
        if not known:
            self._ref = np.empty_like(pos)
        self._ref[:] = pos
        self._valid = skin > 0.0
        return self._last
