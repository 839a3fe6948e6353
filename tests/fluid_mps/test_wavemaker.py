"""Piston wavemakers (Goring solitary paddle, linear regular-wave paddle), table motion, and the
scenario checks of the wavemaker keys. References: thesis eqs. 3-1 to 3-8, references.md section 6,
Dean & Dalrymple (1991) ch. 6."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mpsfem.fluid_mps.wall_motion import MotionLaw
from mpsfem.fluid_mps.wavemaker import (
    GORING_HALF_SPAN,
    RegularPaddle,
    SolitaryPaddle,
    half_cosine_ramp,
    piston_height_to_stroke,
    wave_number,
)
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.fluid import WallMotion
from mpsfem.scenario.loader import load_scenario_text

G = 9.81
DEPTH = 0.114  # thesis ch. 3: every case


def _central_difference(f, t: float, h: float) -> float:
    return (f(t + h)[0] - f(t - h)[0]) / (2.0 * h)


# ---------------------------------------------------------------------------- solitary (Goring)
@pytest.mark.parametrize("ratio", [0.1, 0.3, 0.5, 0.77])
def test_goring_paddle_velocity_is_c_eta_over_d_plus_eta(ratio):
    """dX/dt by central differences of X(t) equals c eta(X, t) / (d + eta(X, t)) (thesis eq. 3-4)
    at the paddle, to 1e-8 m/s; h = 1e-5 s leaves a truncation error h^2 X''' / 6 ~ 1e-9."""
    p = SolitaryPaddle(ratio * DEPTH, DEPTH, G, start_time=0.2)
    h = 1e-5
    for t in np.linspace(p.start_time + 2 * h, p.end_time - 2 * h, 401):
        x, v = p(t)
        eta = p.surface_elevation(x, t)  # A sech^2(k (X - c t')), eq. 3-1 at the paddle
        assert v == pytest.approx(p.c * eta / (DEPTH + eta), abs=1e-14)
        assert abs(_central_difference(p, t, h) - v) < 1e-8


@pytest.mark.parametrize("ratio", [0.2, 0.5])
def test_goring_paddle_solves_the_implicit_position(ratio):
    """X = (A / (k d)) tanh(k (c t' - X)) (thesis eq. 3-6) to rounding."""
    p = SolitaryPaddle(ratio * DEPTH, DEPTH, G)
    for t in np.linspace(0.0, p.duration, 101):
        x, _ = p(t)
        rhs = p.half_stroke * math.tanh(p.k * (p.c * (t - p.crest_time) - x))
        assert abs(x - rhs) < 1e-15


@pytest.mark.parametrize("ratio", [0.2, 0.3, 0.4, 0.5])
def test_goring_stroke_and_generation_time(ratio):
    """The paddle covers S tanh(3.8) with S = sqrt(16 A d / 3) (eq. 3-7): 0.999 S to 1e-6, since
    the end points sit at k (c t' - X) = +-(3.8 + A/d (1 - tanh 3.8)); T = 2 (3.8 + A/d) / (k c)."""
    a = ratio * DEPTH
    p = SolitaryPaddle(a, DEPTH, G, start_time=0.3)
    assert p.stroke == pytest.approx(math.sqrt(16.0 * a * DEPTH / 3.0), rel=1e-15)
    assert 2.0 * p.half_stroke == pytest.approx(p.stroke, rel=1e-14)
    k = math.sqrt(3.0 * a / (4.0 * DEPTH**3))
    c = math.sqrt(G * (DEPTH + a))
    assert p.duration == pytest.approx(2.0 * (3.8 + ratio) / (k * c), rel=1e-15)
    x0, _ = p(0.0)
    x1, _ = p(p.end_time + 1.0)
    assert (x1 - x0) / p.stroke == pytest.approx(math.tanh(GORING_HALF_SPAN), abs=1e-6)
    assert abs((x1 - x0) / p.stroke - 1.0) < 1.01e-3  # the stated stroke tolerance
    assert x0 == pytest.approx(-x1, rel=1e-12)  # symmetric about the mid-stroke


@pytest.mark.parametrize("ratio", [0.1, 0.5])
def test_goring_paddle_starts_at_rest_and_stops(ratio):
    """At rest before start_time and after the generation time (position held); at start the
    velocity is sech^2(3.8) (1 + A/d) = 2.0e-3 (1 + A/d) of the peak c A / (d + A) (Goring's
    truncation), the peak is reached at the crest time, and the paddle never moves backwards."""
    a = ratio * DEPTH
    p = SolitaryPaddle(a, DEPTH, G, start_time=0.4)
    v_peak = p.c * a / (DEPTH + a)
    assert p(0.0)[1] == 0.0 and p(0.39)[1] == 0.0 and p(p.end_time + 0.1)[1] == 0.0
    assert p(0.0)[0] == p(0.39)[0] == p(p.start_time)[0]
    assert p(p.end_time + 0.1)[0] == p(p.end_time)[0]
    s2 = 1.0 / math.cosh(GORING_HALF_SPAN) ** 2
    assert p(p.start_time)[1] / v_peak == pytest.approx(s2 * (1.0 + ratio), rel=0.01)
    assert p(p.crest_time) == pytest.approx((0.0, v_peak), abs=1e-15)
    vs = [p(t)[1] for t in np.linspace(p.start_time, p.end_time, 201)]
    assert min(vs) > 0.0 and max(vs) <= v_peak * (1.0 + 1e-15)


def test_motion_law_solitary_starts_where_the_scenario_puts_the_wall():
    spec = WallMotion(kind="solitary", amplitude=0.3 * DEPTH, depth=DEPTH, start_time=0.1)
    law = MotionLaw(spec, gravity=G)
    assert law(0.0) == (0.0, 0.0)
    s_end, v_end = law(10.0)
    assert v_end == 0.0 and s_end == pytest.approx(law.paddle.stroke * 0.999, rel=1e-4)
    with pytest.raises(ValueError, match="needs gravity"):
        MotionLaw(spec)


# ---------------------------------------------------------------------------- regular (linear)
def test_dispersion_relation_root_and_residual():
    """y tanh y = 1 has the root y = 1.19967864025773 (k d for omega^2 d / g = 1)."""
    omega = math.sqrt(G / DEPTH)
    assert wave_number(omega, DEPTH, G) * DEPTH == pytest.approx(1.19967864025773, rel=1e-13)
    for period in (0.3, 0.7, 1.0, 2.0, 5.0, 30.0):
        for depth in (0.05, 0.266, 3.0):
            om = 2.0 * math.pi / period
            k = wave_number(om, depth, G)
            assert abs(om * om - G * k * math.tanh(k * depth)) < 1e-13 * om * om


def test_dispersion_deep_and_shallow_limits():
    om = 2.0 * math.pi / 0.4  # kd ~ 25 on 1 m: deep water, k = omega^2 / g
    assert wave_number(om, 1.0, G) == pytest.approx(om * om / G, rel=1e-15)
    om = 2.0 * math.pi / 60.0  # kd ~ 0.01 on 0.1 m: shallow water, k = omega / sqrt(g d)
    k = wave_number(om, 0.1, G)
    assert k == pytest.approx(om / math.sqrt(G * 0.1), rel=2e-5)  # 1 + (kd)^2 / 6 correction


def test_piston_transfer_function_matches_the_textbook_form():
    for kd in (0.05, 0.3, 1.0, 2.5, 6.0):
        ref = 2.0 * (math.cosh(2 * kd) - 1.0) / (math.sinh(2 * kd) + 2 * kd)
        assert piston_height_to_stroke(kd) == pytest.approx(ref, rel=1e-14)
    assert piston_height_to_stroke(1.0) == pytest.approx(0.98178930731, rel=1e-10)


def test_piston_transfer_function_limits():
    """Shallow water: H/S = kd (1 - (kd)^4 / 45 + O(kd^6)); deep: 2 - 4 (1 + 2kd) e^{-2kd}."""
    for kd in (1e-4, 1e-3):
        assert piston_height_to_stroke(kd) == pytest.approx(kd, rel=1e-14)
    for kd in (0.01, 0.05, 0.1):
        dev = piston_height_to_stroke(kd) / kd - 1.0
        assert dev == pytest.approx(-(kd**4) / 45.0, rel=0.25 * kd**2 + 1e-4)
    for kd in (8.0, 10.0, 12.0):
        gap = 2.0 - piston_height_to_stroke(kd)
        assert gap == pytest.approx(4.0 * (1.0 + 2.0 * kd) * math.exp(-2.0 * kd), rel=1e-5)
    assert piston_height_to_stroke(1e4) == 2.0


def test_regular_paddle_stroke_from_transfer_function():
    p = RegularPaddle(0.04, 1.0, 0.266, G, ramp_periods=2.0)  # seed paper: T = 1 s, d = 0.266 m
    assert p.stroke == pytest.approx(0.04 / piston_height_to_stroke(p.k * 0.266), rel=1e-15)
    om = 2.0 * math.pi
    assert abs(om * om - G * p.k * math.tanh(p.kd)) < 1e-13 * om * om
    # after the ramp: X = (S/2) sin(omega t)
    for t in (2.0, 2.3, 3.77):
        assert p(t)[0] == pytest.approx(0.5 * p.stroke * math.sin(om * t), abs=1e-15)
        assert p(t)[1] == pytest.approx(0.5 * p.stroke * om * math.cos(om * t), abs=1e-14)


@pytest.mark.parametrize("ramp_periods", [0.0, 1.0, 2.5])
def test_regular_paddle_velocity_is_the_derivative_of_position(ramp_periods):
    """Central differences of X (h = 1e-6 s, truncation h^2 X''' / 6 ~ 1e-12 m/s) match dX/dt,
    ramp included, to 1e-9 m/s."""
    p = RegularPaddle(0.02, 0.8, 0.2, G, ramp_periods=ramp_periods, start_time=0.1)
    h = 1e-6
    for t in np.linspace(0.1 + 2 * h, 0.1 + 4.0 * 0.8, 777):
        assert abs(_central_difference(p, t, h) - p(t)[1]) < 1e-9


def test_regular_paddle_ramp_starts_at_rest():
    p = RegularPaddle(0.02, 0.8, 0.2, G, ramp_periods=2.0, start_time=0.5)
    assert p(0.0) == (0.0, 0.0) and p(0.5) == (0.0, 0.0)
    # X ~ t^3 and dX/dt ~ t^2 right after the start: no jump in position, velocity or acceleration
    tau = 1e-4
    x, v = p(0.5 + tau)
    h = 0.5 * p.stroke
    r2 = 0.25 * (math.pi / 1.6) ** 2  # r = r2 tau^2 + ...
    assert x == pytest.approx(r2 * h * p.omega * tau**3, rel=1e-3)
    assert v == pytest.approx(3.0 * r2 * h * p.omega * tau**2, rel=1e-3)
    r, dr = half_cosine_ramp(1.6, 1.6)
    assert (r, dr) == (1.0, 0.0)
    assert half_cosine_ramp(0.8, 1.6) == pytest.approx((0.5, 0.5 * math.pi / 1.6))


def test_regular_paddle_rejects_waves_beyond_the_miche_limit():
    with pytest.raises(ValueError, match="motion.wave_height = 0.25: must be below the Miche"):
        RegularPaddle(0.25, 1.0, 0.5, G)  # L = 1.51 m: H_max = 0.142 L tanh(kd) = 0.21 m


# ---------------------------------------------------------------------------- table
def test_table_interpolates_and_uses_the_segment_slope(tmp_path):
    f = tmp_path / "paddle.csv"
    f.write_text("# t, x\n0.0, 0.0\n0.5, 0.1\n1.0, 0.1\n2.0, -0.1\n")
    law = MotionLaw(WallMotion(kind="table", file="paddle.csv"), base_dir=tmp_path)
    cases = {  # at a knot: the slope of the segment ending there
        -1.0: (0.0, 0.0),
        0.0: (0.0, 0.0),
        0.25: (0.05, 0.2),
        0.5: (0.1, 0.2),
        0.75: (0.1, 0.0),
        1.5: (0.0, -0.2),
        1.999: (-0.0998, -0.2),
        2.0: (-0.1, -0.2),
        5.0: (-0.1, 0.0),
    }
    for t, (s, v) in cases.items():
        assert law(t) == pytest.approx((s, v), abs=1e-15), t
    # the velocity integrates back to the position (piecewise slope, no offset)
    ts = np.linspace(-0.5, 2.5, 30001)
    vs = np.array([law(t)[1] for t in ts])
    integral = np.concatenate([[0.0], np.cumsum(0.5 * (vs[1:] + vs[:-1]) * np.diff(ts))])
    pos = np.array([law(t)[0] for t in ts])
    assert np.max(np.abs(integral - pos)) < 2e-4  # trapezoid across the 3 slope jumps


def test_table_velocity_agrees_with_the_step_that_ends_at_a_knot(tmp_path):
    """A table sampled at the solver's step (1 ms) and times accumulated step by step, as the
    solver does (t += dt, so t lands a rounding error either side of a knot): at the end of
    each step the velocity is the slope of the segment the step moved along (before: the next
    segment's slope in 1002 of 1500 steps, by rounding alone)."""
    t_knots = np.arange(1501) * 1e-3
    x = 0.05 * np.sin(2 * np.pi * t_knots / 0.7) ** 3  # slopes change at every knot
    f = tmp_path / "signal.csv"
    np.savetxt(f, np.column_stack([t_knots, x]), delimiter=",")
    law = MotionLaw(WallMotion(kind="table", file=str(f)))
    t, wrong = 0.0, 0
    for _ in range(1, 1501):
        s0 = law(t)[0]
        t += 1e-3
        s1, v = law(t)
        wrong += abs(v - (s1 - s0) / 1e-3) > 1e-6
    assert wrong == 0


def test_table_file_errors(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("0.0, 0.0\n0.0, 0.1\n")
    with pytest.raises(ValueError, match="motion.file = .*t must increase.*data row 2"):
        MotionLaw(WallMotion(kind="table", file=str(f)))
    with pytest.raises(ValueError, match="no such file"):
        MotionLaw(WallMotion(kind="table", file=str(tmp_path / "missing.csv")))
    f.write_text("0.0, 0.0\n0.5, nan\n1.0, 0.1\n")
    with pytest.raises(ValueError, match=r"data row 2 \[0.5, nan\] is not finite"):
        MotionLaw(WallMotion(kind="table", file=str(f)), key="fluid.walls[1].motion")
    f.write_text("0.0, 0.0\nnan, 0.1\n1.0, 0.1\n")
    with pytest.raises(ValueError, match=r"^fluid.walls\[1\].motion.file = .* row 2"):
        MotionLaw(WallMotion(kind="table", file=str(f)), key="fluid.walls[1].motion")
    f.write_text("0.0, 0.0\n0.5, abc\n")
    with pytest.raises(ValueError, match="not a table of numbers"):
        MotionLaw(WallMotion(kind="table", file=str(f)))
    f.write_text("0.0, 0.0\n0.5, 1e300\n")  # ran and 'finished' with the paddle far away
    with pytest.raises(ValueError, match=r"data row 2 moves the wall by x = 1e\+300 m"):
        MotionLaw(WallMotion(kind="table", file=str(f)))


# ---------------------------------------------------------------------------- schema
BASE = """
[run]
end_time = 1.0
[fluid]
spacing = 0.01
[[fluid.blocks]]
lower = [0.0, 0.0]
upper = [1.0, 0.114]
[[fluid.walls]]
name = "tank"
shape = "tank"
lower = [0.0, 0.0]
upper = [2.0, 0.3]
[[fluid.walls]]
name = "paddle"
shape = "box"
lower = [-0.1, 0.0]
upper = [-0.05, 0.3]
[fluid.walls.motion]
"""


def _problems(motion: str) -> list[str]:
    with pytest.raises(ScenarioError) as info:
        load_scenario_text(BASE + motion)
    return info.value.problems


def test_schema_accepts_both_wavemakers():
    sc = load_scenario_text(
        BASE + 'kind = "solitary"\namplitude = 0.0342\ndepth = 0.114\nstart_time = 0.1\n'
    ).scenario
    m = sc.fluid.walls[1].motion
    assert (m.kind, m.amplitude, m.depth, m.start_time) == ("solitary", 0.0342, 0.114, 0.1)
    sc = load_scenario_text(
        BASE + 'kind = "regular"\nwave_height = 0.02\nperiod = 1.0\ndepth = 0.114\n'
    ).scenario
    assert sc.fluid.walls[1].motion.ramp_periods == 2.0


@pytest.mark.parametrize(
    ("motion", "expect"),
    [
        (
            'kind = "solitary"\namplitude = 0.1\ndepth = 0.114\n',
            "A/d = 0.8772: must be in (0, 0.78)",
        ),
        ('kind = "solitary"\namplitude = -0.01\ndepth = 0.114\n', "motion.amplitude = -0.01"),
        ('kind = "solitary"\namplitude = 0.03\n', "needs motion.depth"),
        (
            'kind = "solitary"\namplitude = 0.03\ndepth = 0.1\nperiod = 2.0\n',
            "motion.period is not",
        ),
        ('kind = "regular"\ndepth = 0.114\n', "needs motion.wave_height"),
        ('kind = "regular"\nwave_height = 0.1\ndepth = 0.114\n', "H/d = 0.8772: must be below"),
        ('kind = "table"\n', "needs motion.file"),
        ('kind = "wave"\n', "'solitary'"),
    ],
)
def test_schema_errors_name_key_value_and_rule(motion, expect):
    (msg,) = _problems(motion)
    assert msg.startswith("fluid.walls[1].motion")
    assert expect in msg


@pytest.mark.parametrize(
    ("motion", "key"),
    [
        (
            'kind = "solitary"\namplitude = 0.03\ndepth = -0.1\n',
            "fluid.walls[1].motion.depth = -0.1",
        ),
        (
            'kind = "regular"\nwave_height = 0.0\ndepth = 0.1\n',
            "fluid.walls[1].motion.wave_height = 0.0",
        ),
        (
            'kind = "regular"\nwave_height = 0.01\ndepth = 0.1\nramp_periods = -1\n',
            "fluid.walls[1].motion.ramp_periods = -1",
        ),
        (
            'kind = "solitary"\namplitude = 0.03\ndepth = 0.1\nstart_time = -0.5\n',
            "fluid.walls[1].motion.start_time = -0.5",
        ),
    ],
)
def test_schema_range_errors_name_the_dotted_key(motion, key):
    (msg,) = _problems(motion)
    assert msg.startswith(key)
