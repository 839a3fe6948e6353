"""Sponge layer (thesis eq. 3-9): f_s = -rho alpha_s (x - x_s) / L_s u inside the zone, 0 outside,
applied as the explicit factor 1 - dt alpha_s r per step."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpsfem.fluid_mps.sponge import SpongeLayer
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.fluid import SpongeZone
from mpsfem.scenario.loader import load_scenario_text

ALPHA = 50.0  # thesis ch. 3.2


def _line(xs, y=0.05):
    pos = np.zeros((len(xs), 2))
    pos[:, 0] = xs
    pos[:, 1] = y
    return pos


def test_one_step_factor_inside_and_no_effect_outside(rng):
    """Thesis 2D tank: sponge over the last 0.5 m of 2.5 m."""
    xs = np.linspace(1.7, 2.7, 1001)
    pos = _line(xs)
    vel0 = rng.normal(size=(len(xs), 2))
    vel = vel0.copy()
    dt = 1e-3
    SpongeLayer(SpongeZone(start=2.0, end=2.5, coefficient=ALPHA), 2).apply(pos, vel, len(xs), dt)
    inside = (xs >= 2.0) & (xs <= 2.5)
    expect = 1.0 - dt * ALPHA * (xs - 2.0) / 0.5  # explicit Euler of du/dt = -alpha (x-x_s)/L_s u
    np.testing.assert_allclose(vel[inside], vel0[inside] * expect[inside, None], rtol=1e-14)
    assert np.array_equal(vel[~inside], vel0[~inside])  # bit-identical outside (and past the end)
    assert inside.sum() == 501 and vel[inside][-1] / vel0[inside][-1] == pytest.approx(0.95)


def test_only_fluid_particles_are_damped(rng):
    pos = _line(np.full(10, 2.3))
    vel0 = rng.normal(size=(10, 2))
    vel = vel0.copy()
    SpongeLayer([SpongeZone(start=2.0, end=2.5)], 2).apply(pos, vel, 6, 1e-3)
    assert np.all(vel[:6] != vel0[:6])
    assert np.array_equal(vel[6:], vel0[6:])  # wall / structure particles after n_fluid


def test_zone_at_the_low_end_and_on_another_axis(rng):
    """end < start: the zone grows towards the low end; axis = 1 in 3D."""
    pos = rng.uniform(-0.2, 1.0, size=(500, 3))
    vel0 = rng.normal(size=(500, 3))
    vel = vel0.copy()
    dt = 2e-4
    SpongeLayer(SpongeZone(axis=1, start=0.6, end=0.1, coefficient=30.0), 3).apply(
        pos, vel, 500, dt
    )
    y = pos[:, 1]
    r = np.where((y <= 0.6) & (y >= 0.1), (0.6 - y) / 0.5, 0.0)
    np.testing.assert_allclose(vel, vel0 * (1.0 - dt * 30.0 * r)[:, None], rtol=1e-14)
    assert np.array_equal(vel[r == 0.0], vel0[r == 0.0])


def test_overlapping_zones_add():
    pos = _line([0.3])
    vel = np.array([[1.0, -2.0]])
    zones = [SpongeZone(start=0.0, end=1.0, coefficient=10.0), SpongeZone(start=0.5, end=0.1)]
    SpongeLayer(zones, 2).apply(pos, vel, 1, 1e-3)
    rate = 10.0 * 0.3 + 50.0 * 0.5  # r = 0.3 and r = (0.5 - 0.3) / 0.4
    np.testing.assert_allclose(vel, [[1.0 - 1e-3 * rate, -2.0 * (1.0 - 1e-3 * rate)]], rtol=1e-14)


@pytest.mark.parametrize("r", [0.2, 0.6, 1.0])
def test_uniform_field_decays_by_the_analytic_factor(r):
    """n steps of a uniform field at fixed x: exactly (1 - dt alpha r)^n, and exp(-alpha r t) of
    du/dt = -alpha r u (eq. 3-9) within the explicit-Euler error n (alpha r dt)^2 / 2, which halves
    with dt (first order)."""
    x = 2.0 + 0.5 * r
    t_end = 0.1
    errors = []
    for n in (100, 200, 400):
        dt = t_end / n
        pos = _line(np.full(64, x))
        vel = np.tile([0.3, -0.1], (64, 1))
        sponge = SpongeLayer(SpongeZone(start=2.0, end=2.5, coefficient=ALPHA), 2)
        for _ in range(n):
            sponge.apply(pos, vel, 64, dt)
        h = ALPHA * r * dt
        np.testing.assert_allclose(vel, np.tile([0.3, -0.1], (64, 1)) * (1.0 - h) ** n, rtol=1e-12)
        exact = math.exp(-ALPHA * r * t_end)
        err = vel[0, 0] / 0.3 / exact - 1.0
        assert -0.6 * n * h * h < err < -0.4 * n * h * h  # exp(n (log(1 - h) + h)) - 1
        errors.append(err)
    assert errors[0] / errors[1] == pytest.approx(2.0, rel=0.02)
    assert errors[1] / errors[2] == pytest.approx(2.0, rel=0.02)


def test_too_large_step_is_refused():
    sponge = SpongeLayer(SpongeZone(start=0.0, end=1.0, coefficient=ALPHA), 2)
    with pytest.raises(ValueError, match="exceeds 1"):
        sponge.apply(_line([0.5]), np.zeros((1, 2)), 1, 0.03)


def test_no_zones_is_a_no_op(rng):
    vel0 = rng.normal(size=(5, 2))
    vel = vel0.copy()
    sponge = SpongeLayer([], 2)
    sponge.apply(_line(np.zeros(5)), vel, 5, 1e-3)
    assert not sponge.active and np.array_equal(vel, vel0)


def test_axis_beyond_dimension_refused():
    with pytest.raises(ValueError, match=r"fluid.sponges\[0\].axis = 2: must be below dim = 2"):
        SpongeLayer([SpongeZone(axis=2, start=0.0, end=1.0)], 2)


# ---------------------------------------------------------------------------- schema
BASE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.01
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [2.5, 0.114]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [2.5, 0.3]
[[fluid.sponges]]
"""


def _problems(zone: str) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(BASE + zone)
    return info.value.problems


def test_schema_thesis_tank_sponge():
    sc = load_scenario_text(BASE + "start = 2.0\nend = 2.5\n").scenario
    (z,) = sc.fluid.sponges
    assert (z.axis, z.start, z.end, z.coefficient) == (0, 2.0, 2.5, 50.0)


@pytest.mark.parametrize(
    ("zone", "expect"),
    [
        ("start = 2.0\nend = 2.0\n", "fluid.sponges[0].end = 2.0"),
        ("start = 2.0\nend = 2.5\ncoefficient = -5.0\n", "fluid.sponges[0].coefficient = -5.0"),
        ("start = 2.0\nend = 2.5\naxis = 3\n", "fluid.sponges[0].axis = 3"),
        ("end = 2.5\n", "fluid.sponges[0].start: required key is missing"),
        ("start = 2.0\nend = 2.5\nlength = 0.5\n", "fluid.sponges[0].length: unknown key"),
    ],
)
def test_schema_errors(zone, expect):
    (msg,) = _problems(zone)
    assert msg.startswith(expect)


def test_schema_axis_against_dimension():
    (msg,) = _problems("start = 2.0\nend = 2.5\naxis = 2\n")
    assert "fluid.sponges[0].axis = 2: must be below dim = 2" in msg
