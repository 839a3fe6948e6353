"""The Verlet skin of the fluid's neighbour list changes the run time, never a result."""

from pathlib import Path

import numpy as np

from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario

ROOT = Path(__file__).resolve().parents[2]


def _run(skin: float, steps: int) -> FluidSolver:
    sc = load_scenario(
        ROOT / "scenarios" / "solitary_wave_2d.toml",
        ["fluid.spacing=0.0122", f"fluid.neighbours.skin={skin}"],
    ).scenario
    solver = FluidSolver(sc.fluid)
    for _ in range(steps):
        solver.step(solver.dt_next)
    return solver


def test_skin_leaves_the_wave_tank_bit_identical():
    """A coarse solitary-wave tank (moving paddle, sponge, free surface), 40 steps: with a
    skin (0.05 l0 here, so that it rebuilds a few times in 40 steps) the candidates are reused
    on most steps, and every state array equals the run that builds the list every step, bit
    for bit. So a result does not depend on when the candidates were built (a restart builds
    them afresh)."""
    exact = _run(0.0, 40)
    verlet = _run(0.05, 40)
    assert exact.search.reuses == 0
    assert verlet.search.reuses > 20 and verlet.search.builds >= 2
    a, b = exact.state(), verlet.state()
    for key, value in a.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(b[key], value, err_msg=key)
    assert verlet.t == exact.t


def _dam_break(steps: int, short: str, collision: bool = True) -> FluidSolver:
    sc = load_scenario(
        ROOT / "scenarios" / "dam_break_2d.toml",
        ["fluid.spacing=0.0073", f"fluid.collision.enabled={str(collision).lower()}"],
    ).scenario
    solver = FluidSolver(sc.fluid)
    if short == "off":  # every operator on the shared 4.01 l0 list
        solver.short_radius = None
    elif short == "refilter":  # a margin below any shift: the short list is filtered every step
        solver.short_margin = -1.0
    for _ in range(steps):
        solver.step(solver.dt_next)
    return solver


def _assert_same_state(run: FluidSolver, ref: FluidSolver) -> None:
    a, b = ref.state(), run.state()
    for key, value in a.items():
        if isinstance(value, np.ndarray):
            np.testing.assert_array_equal(b[key], value, err_msg=key)
    assert run.t == ref.t


def test_short_list_leaves_the_dam_break_bit_identical():
    """The small-kernel operators (collision, number density, free surface, divergence,
    gradient) read the search's 2.2 l0 list: 60 steps of a coarse dam break (collisions, walls,
    free surface) end bit-identical to the run where they read the shared 4.01 l0 list, and so
    does the run that filters the short list anew every step (the path taken after a large
    collision shift)."""
    ref = _dam_break(60, "off")
    fast = _dam_break(60, "on")
    refilter = _dam_break(60, "refilter")
    assert fast.short_radius is not None and fast.search.short is not None
    assert fast.short_refilters < 30 and refilter.short_refilters == 60
    _assert_same_state(fast, ref)
    _assert_same_state(refilter, ref)


def test_short_list_without_collisions_has_no_margin_and_changes_nothing():
    """Without the collision model nothing moves between the search and the operators: the
    short list is exactly 2.1 l0 (no margin), never filtered anew, and 40 steps end
    bit-identical to the run on the shared list."""
    ref = _dam_break(40, "off", collision=False)
    fast = _dam_break(40, "on", collision=False)
    assert fast.short_margin == 0.0 and fast.short_refilters == 0
    assert fast.search.short.radius == fast.short_radius
    _assert_same_state(fast, ref)
