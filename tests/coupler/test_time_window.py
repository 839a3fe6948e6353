"""Coupling windows: equal sub-steps landing exactly on window ends, interpolation, and the
convergence measure."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpsfem.coupler.convergence import InstabilityDetector, ResidualCriterion, check_finite, rms
from mpsfem.coupler.errors import CouplingDivergedError, CouplingError
from mpsfem.coupler.time_window import interpolate, plan_substeps, subcycle, window_ends


@pytest.mark.parametrize(
    "window, max_dt, n",
    [(1e-3, 4e-4, 3), (1e-3, 1e-3, 1), (1e-3, 2e-3, 1), (1e-3, 1e-3 / 3, 3), (1e-4, 1e-5, 10)],
)
def test_plan_equal_substeps(window, max_dt, n):
    k, dt = plan_substeps(window, max_dt)
    assert k == n and dt <= max_dt * (1 + 1e-9) and math.isclose(k * dt, window)


def test_plan_never_tiny_last_step():
    """1.01 max_dt is two steps of 0.505, not one full step and a sliver."""
    k, dt = plan_substeps(1.01, 1.0)
    assert k == 2 and dt == 0.505


class Clock:
    """A participant that records its steps; ``limits`` lists successive max_dt values."""

    def __init__(self, limits, short=None):
        self.t, self.steps, self.limits, self.short = 0.0, [], list(limits), short

    def max_dt(self):
        return self.limits[min(len(self.steps), len(self.limits) - 1)]

    def advance(self, dt):
        done = dt if self.short is None or len(self.steps) != self.short else 0.5 * dt
        self.steps.append(done)
        self.t += done
        return done


def test_subcycle_lands_exactly_and_replans_adaptive_dt():
    c = Clock([4e-4, 4e-4, 1e-4])  # the CFL limit drops after two steps
    seen = []
    n = subcycle(c.advance, c.max_dt, 0.0, 1e-3, before=lambda t, dt: seen.append(t))
    assert seen[-1] == 1e-3  # the last sub-step ends on the window end bit for bit
    assert n == len(c.steps)
    assert math.isclose(sum(c.steps), 1e-3, rel_tol=1e-12)
    # first plan: 3 x 3.33e-4; after the limit drops the rest is split equally
    assert math.isclose(c.steps[0], 1e-3 / 3) and math.isclose(c.steps[1], 1e-3 / 3)
    tail = c.steps[2:]
    assert max(tail) <= 1e-4 * (1 + 1e-9) and max(tail) - min(tail) < 1e-15


def test_subcycle_accepts_shorter_step():
    c = Clock([5e-4], short=0)
    subcycle(c.advance, c.max_dt, 0.0, 1e-3)
    assert math.isclose(sum(c.steps), 1e-3) and c.steps[0] == 2.5e-4


def test_subcycle_rejects_bad_advance():
    with pytest.raises(CouplingError, match="advance"):
        subcycle(lambda dt: 2 * dt, lambda: 1.0, 0.0, 1.0, who="fluid")
    with pytest.raises(CouplingError, match="max_dt"):
        subcycle(lambda dt: dt, lambda: 0.0, 0.0, 1.0)


def test_interpolate_exact_ends():
    a, b = np.array([0.1, 0.3]), np.array([0.7, -0.2])
    assert interpolate(a, b, 1.0).tobytes() == b.tobytes()
    assert interpolate(a, b, 0.0).tobytes() == a.tobytes()
    np.testing.assert_allclose(interpolate(a, b, 0.25), a + 0.25 * (b - a))


def test_window_ends():
    e = window_ends(0.0, 0.1, 0.35)
    np.testing.assert_allclose(e, [0.1, 0.2, 0.3, 0.35])
    e = window_ends(0.0, 0.1, 0.3 + 1e-15)
    assert len(e) == 3


def test_residual_relative_with_floor():
    c = ResidualCriterion(relative_tolerance=1e-3, absolute_tolerance=1e-9, min_iterations=2)
    x = np.zeros(10)
    # structure at rest: relative measure uses the floor atol / rtol = 1e-6
    res, r_abs = c.measure(x, np.full(10, 5e-10))
    assert math.isclose(r_abs, 5e-10) and math.isclose(res, 5e-4)
    assert not c.converged(res, 1) and c.converged(res, 2)
    res, _ = c.measure(np.ones(10), np.full(10, 1.01))
    assert math.isclose(res, 0.01 / 1.01) and not c.converged(res, 5)
    assert rms(np.array([3.0, 4.0])) == math.sqrt(12.5)
    with pytest.raises(ValueError):
        ResidualCriterion(min_iterations=3, max_iterations=2)


def test_check_finite():
    check_finite("w", a=np.ones(3))
    with pytest.raises(CouplingDivergedError, match=r"forces holds non-finite values.*\(1, 0\)"):
        check_finite("window 3", forces=np.array([[1.0, 0.0], [np.nan, 0.0]]))


def test_instability_detector():
    rng = np.random.default_rng(0)
    v = rng.standard_normal(20)
    # a sawtooth growing 1.5x per window is caught within 8 windows
    det = InstabilityDetector()
    hits = [det.update(((-1.5) ** k) * 1e-6 * v) for k in range(12)]
    assert any(hits[:9]) and "added-mass instability" in next(h for h in hits if h)
    # a complex pair (rotation 130 deg per window, growth 1.2) is caught within 32 windows
    det = InstabilityDetector()
    w = rng.standard_normal(20)
    hits = [
        det.update(1.2**k * 1e-6 * (np.cos(2.27 * k) * v + np.sin(2.27 * k) * w)) for k in range(40)
    ]
    assert any(hits[:33])
    # smooth physical growth (a ramping load) and stationary noise are not
    det = InstabilityDetector()
    assert not any(det.update(1e-6 * (1.2**k) * v) for k in range(80))
    det = InstabilityDetector()
    assert not any(det.update(1e-6 * rng.standard_normal(20)) for k in range(500))
