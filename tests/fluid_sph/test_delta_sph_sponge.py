"""``fluid.sph.damping = "sponge"``: MPS's sponge (thesis eq. 3-9, ``fluid_mps.sponge``) under
δ-SPH, once per step at the step's end; the default "viscosity" keeps the seed's eq. 4 ramp."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpsfem.fluid_sph.solver import DeltaSPHSolver
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.fluid import FluidSection
from mpsfem.scenario.loader import load_scenario_text

U0 = 0.3  # m/s, the block's speed along x
ALPHA_S = 40.0  # 1/s, the sponge's rate at its outer edge


def _block(damping: str | None, budget: bool = False) -> DeltaSPHSolver:
    """Two 10 x 6 blocks of still-density water (p = 0) sliding at U0 along x without gravity or
    walls: the lower one inside two overlapping sponges across y (axis 1), one rising from y = 0
    to 0.1 m and one from 0.1 m down to 0, whose rates add to alpha_s everywhere between
    (fluid_mps.sponge: overlapping zones add); the upper one (y = 0.15-0.21 m, 9 spacings from
    the lower) outside both. Each block's velocity stays uniform, so every pair term (pressure,
    viscosity, density) vanishes and the sponge alone changes the velocity."""
    sph = {"sound_speed": 10.0} | ({"damping": damping} if damping else {})
    extra = {"momentum_budget": True} if budget else {}
    spec = FluidSection(
        method="delta-sph",
        spacing=0.01,
        gravity=[0.0, 0.0],
        blocks=[
            {"lower": [0.0, 0.0], "upper": [0.1, 0.06], "velocity": [U0, 0.0]},
            {"lower": [0.0, 0.15], "upper": [0.1, 0.21], "velocity": [U0, 0.0]},
        ],
        sponges=[
            {"axis": 1, "start": 0.0, "end": 0.1, "coefficient": ALPHA_S},
            {"axis": 1, "start": 0.1, "end": 0.0, "coefficient": ALPHA_S},
        ],
        sph=sph,
        **extra,
    )
    return DeltaSPHSolver(spec)


@pytest.mark.parametrize("integrator", ["rk4", "symplectic"])
def test_sponge_damps_a_sliding_block_at_its_rate(integrator):
    """u after n steps = U0 (1 - dt alpha_s)^n in the zone (the explicit factor of thesis eq.
    3-9) to round-off, U0 outside it; and U0 exp(-alpha_s t) within the explicit Euler's own
    error n (dt alpha_s)^2 / 2 (leading order), which the test checks is not round-off."""
    s = _block("sponge")
    s.sph = s.sph.model_copy(update={"integrator": integrator})
    s.integrator = integrator
    inside = s.pos[: s.n_fluid, 1] < 0.1
    assert inside.sum() == 60 and (~inside).sum() == 60
    dt = 2e-3
    n = 25
    for _ in range(n):
        s.step(dt)
    u = s.vel[: s.n_fluid]
    discrete = U0 * (1.0 - dt * ALPHA_S) ** n
    assert np.max(np.abs(u[inside, 0] - discrete)) < 1e-13 * U0
    assert np.all(u[~inside, 0] == U0)
    assert np.max(np.abs(u[:, 1])) < 1e-13 * U0
    t = n * dt
    exact = U0 * math.exp(-ALPHA_S * t)
    bound = exact * n * (dt * ALPHA_S) ** 2 / 2.0 * 1.1
    err = np.abs(u[inside, 0] - exact)
    assert err.max() <= bound
    assert err.min() > 0.5 * bound  # the explicit factor's error is there, not round-off
    # the positions follow the damped velocity: x moved by less inside than outside
    moved = s.pos[: s.n_fluid, 0] - _block("sponge").pos[: s.n_fluid, 0]
    assert np.allclose(moved[~inside], U0 * t, rtol=1e-12)
    assert np.all(moved[inside] < 0.8 * U0 * t)


def test_sponge_books_its_impulse_and_leaves_the_viscosity_alone():
    """With the momentum budget on, the ``sponge`` entry is the momentum the sponge took, and
    the budget closes to round-off; the artificial viscosity is not ramped in the zone and does
    not limit the time step (alpha_max = viscosity_alpha)."""
    s = _block("sponge", budget=True)
    p0 = s.budget.take(s.vel, s.kind)["fluid_momentum"]
    for _ in range(10):
        s.step(2e-3)
    b = s.budget.take(s.vel, s.kind)
    assert b["momentum_change"][0] < -1e-3 * abs(p0[0])  # the sponge took momentum
    assert np.allclose(b["sponge"], b["momentum_change"], rtol=1e-12, atol=0.0)
    assert np.abs(b["residual"]).max() < 1e-12 * abs(p0[0])
    assert np.all(s.alpha == s.sph.viscosity_alpha)
    assert s.alpha_max == s.sph.viscosity_alpha
    ramped = _block(None)
    assert ramped.sph.damping == "viscosity"  # the default: seed eq. 4
    assert ramped.alpha.max() > 10 * ramped.sph.viscosity_alpha
    assert ramped.alpha_max == ramped.sph.damping_alpha
    # the default damps through viscosity only: the uniformly sliding blocks keep their speed
    ramped.step(2e-3)
    assert np.all(ramped.vel[: ramped.n_fluid, 0] == U0)


def test_sponge_restart_is_bit_identical():
    """The sponge has no state: 3 + 3 steps through state()/restore() equal 6 steps."""
    a = _block("sponge")
    for _ in range(6):
        a.step(2e-3)
    b = _block("sponge")
    for _ in range(3):
        b.step(2e-3)
    arrays = {k: v.copy() for k, v in b.state().items()}
    meta = b.meta()
    c = _block("sponge")
    c.restore(arrays, meta)
    for _ in range(3):
        c.step(2e-3)
    assert np.array_equal(a.vel, c.vel) and np.array_equal(a.pos, c.pos)


def test_damping_key_is_validated():
    """A damping other than viscosity / sponge is refused with the key and what is allowed."""
    text = """
[run]
end_time = 0.01
[fluid]
method = "delta-sph"
spacing = 0.01
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [0.1, 0.1]
[fluid.sph]
damping = "%s"
"""
    assert load_scenario_text(text % "sponge").scenario.fluid.sph.damping == "sponge"
    with pytest.raises(ScenarioError) as err:
        load_scenario_text(text % "sponges")
    msg = str(err.value)
    assert "damping" in msg and "sponges" in msg
    assert "viscosity" in msg and "'sponge'" in msg
