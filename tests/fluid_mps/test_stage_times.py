"""The step's stage timers (``StageTimes.timed``, issue 23): every counter the results files and
benchmarks read accrues while a step runs, the counters never claim more than the steps took,
and a timed block that raises still books its time."""

import time

import pytest

from mpsfem.fluid_mps.solver import FluidSolver, StageTimes
from mpsfem.scenario.loader import load_scenario_text

SCENE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.02
[fluid.time_step]
dt_max = 1e-3
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.2, 0.2]
[[fluid.walls]]
shape = "tank"
lower = [0.0, 0.0]
upper = [0.6, 0.3]
"""


def test_each_counter_accrues_and_none_exceeds_the_wall_time():
    s = FluidSolver(load_scenario_text(SCENE).scenario.fluid)
    s.step(s.dt_next)  # compilation outside the measured steps
    s.times = StageTimes()
    tic = time.perf_counter()
    for _ in range(3):
        s.step(s.dt_next)
    wall = time.perf_counter() - tic
    tm = s.times.as_dict()
    assert list(tm) == ["neighbours", "explicit", "assembly", "solve", "other"]
    for name in ("neighbours", "explicit", "assembly", "solve", "other"):
        assert tm[name] > 0.0, name  # neumann walls (default): boundary terms in "other"
    assert sum(tm.values()) <= wall
    assert len(s.times.iterations) == 3 and s.last_iterations == s.times.iterations[-1]


def test_a_block_that_raises_still_books_its_time():
    tm = StageTimes()
    with pytest.raises(RuntimeError), tm.timed("explicit"):
        time.sleep(0.01)
        raise RuntimeError("stop")
    assert tm.explicit >= 0.01 and tm.neighbours == 0.0
