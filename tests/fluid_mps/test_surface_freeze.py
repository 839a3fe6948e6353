"""Surface and dry flags frozen across the iterations of an implicit coupling window.

Reference: the contract of fluid_mps.surface_freeze. The first iteration after a checkpoint
records each step's flags; after a restore the same steps get exactly those flags whatever the
structure's motion, and without the freeze the same motion changes them (so the test can fail).
"""

from __future__ import annotations

import numpy as np
import pytest
from test_structure_surface import partition, two_levels  # noqa: F401 (fixture)

from mpsfem.fluid_mps.participant import FluidParticipant
from mpsfem.fluid_mps.surface_freeze import SurfaceFreeze
from mpsfem.scenario.fluid import FluidSection

L0 = 0.01


def test_record_then_replay_per_step():
    fr = SurfaceFreeze()
    a = np.array([0, 1, 0], dtype=np.int8)
    fr.apply(a)  # inactive before the first window: no-op
    assert a.tolist() == [0, 1, 0] and fr.overridden == 0
    fr.start()
    s1, s2 = np.array([1, 0, 0], np.int8), np.array([0, 0, 1], np.int8)
    fr.apply(s1)
    fr.apply(s2)
    fr.rewind()
    x = np.array([0, 0, 0], np.int8)
    fr.apply(x)
    assert x.tolist() == [1, 0, 0] and fr.overridden == 1
    y = np.array([1, 1, 1], np.int8)
    fr.apply(y)
    assert y.tolist() == [0, 0, 1] and fr.overridden == 3
    z = np.array([1, 1, 0], np.int8)  # a step beyond the recorded ones records
    fr.apply(z)
    assert z.tolist() == [1, 1, 0]
    fr.start()  # the next window records afresh
    w = np.array([1, 1, 1], np.int8)
    fr.apply(w)
    assert w.tolist() == [1, 1, 1]


def _flags(fp, d, steps=2, dt=1e-3):
    fp.write("displacement", d)
    fp.write("velocity", d / (steps * dt))
    out = []
    for _ in range(steps):
        fp.advance(dt)
        out.append(fp.solver.free_surface.copy())
    return out


def test_restored_iterations_replay_the_first_iterations_flags(two_levels):  # noqa: F811
    fp = two_levels  # still water 0.2 m / 0.1 m deep on the two sides of a partition
    n = fp.surface.n_interface
    fp.solver.surface_freeze = fp.freeze  # as with fluid.surface.freeze_in_coupling_window
    fp.checkpoint()
    first = _flags(fp, np.zeros((n, 2)))
    moved = np.tile([0.4 * L0, 0.0], (n, 1))  # another iterate of the interface motion
    fp.restore()
    fp.solver.surface_freeze = None  # the same iteration without the freeze ...
    free = _flags(fp, moved)
    assert any(np.any(a != b) for a, b in zip(first, free, strict=True))  # ... flips flags
    fp.restore()
    fp.solver.surface_freeze = fp.freeze
    frozen = _flags(fp, moved)
    for a, b in zip(first, frozen, strict=True):
        assert np.array_equal(a, b)
    # with the first iteration's inputs the replay is bit-identical to the first iteration
    fp.restore()
    again = _flags(fp, np.zeros((n, 2)))
    for a, b in zip(first, again, strict=True):
        assert np.array_equal(a, b)
    fp.restore()


@pytest.mark.parametrize("on", [False, True])
def test_switch(on):
    fluid = FluidSection.model_validate(
        {
            "spacing": 0.02,
            "blocks": [{"lower": [0, 0], "upper": [0.2, 0.2]}],
            "walls": [{"shape": "tank", "lower": [0, 0], "upper": [0.42, 0.4]}],
            "surface": {"freeze_in_coupling_window": on} if on else {},
        }
    )
    fp = FluidParticipant(fluid, partition(0.02, xc=0.31, top=0.2), member_names=["wall"])
    assert (fp.solver.surface_freeze is fp.freeze) == on  # off by default
