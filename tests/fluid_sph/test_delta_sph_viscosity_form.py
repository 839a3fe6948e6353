"""fluid.sph.viscosity_form: 'antuono' is the seed's eq. 3 with alpha / (2 (n + 2)), so a run
with alpha under 'antuono' follows a run with alpha / 8 under 'seed' (2D) to round-off, and the
default leaves today's runs unchanged."""

from __future__ import annotations

import numpy as np
import pytest

from mpsfem.fluid_sph.solver import DeltaSPHSolver
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.fluid import FluidSection


def solver(alpha: float, form: str | None = None) -> DeltaSPHSolver:
    """A 0.2 x 0.1 m column collapsing in a 0.4 m tank (a small dam break: sheared flow)."""
    sph = {"viscosity_alpha": alpha} | ({"viscosity_form": form} if form else {})
    spec = FluidSection(
        method="delta-sph",
        spacing=0.01,
        gravity=[0.0, -9.81],
        blocks=[{"lower": [0.0, 0.0], "upper": [0.2, 0.1]}],
        walls=[{"name": "tank", "shape": "tank", "lower": [0.0, 0.0], "upper": [0.4, 0.2]}],
        sph=sph,
    )
    return DeltaSPHSolver(spec)


def run(s: DeltaSPHSolver, steps: int = 30) -> np.ndarray:
    for _ in range(steps):
        s.step(1e-4)
    return s.vel[: s.n_fluid].copy()


def test_antuono_is_the_seed_form_with_alpha_over_8():
    a = run(solver(0.2, "antuono"))
    b = run(solver(0.025))
    scale = np.abs(b).max()
    assert np.abs(a - b).max() <= 1e-12 * scale


def test_default_is_the_seed_form():
    a = run(solver(0.2, "seed"))
    b = run(solver(0.2))
    assert a.tobytes() == b.tobytes()
    c = run(solver(0.025))
    assert np.abs(a - c).max() > 1e-6 * np.abs(a).max()  # the 8x matters at this alpha


def test_unknown_form_is_refused():
    with pytest.raises((ScenarioError, ValueError), match="viscosity_form"):
        solver(0.02, "monaghan")
