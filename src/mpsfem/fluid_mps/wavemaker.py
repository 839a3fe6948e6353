"""Piston wavemakers: paddle position X(t) (m) and velocity dX/dt (m/s) for a wave tank.

- :class:`SolitaryPaddle`: Goring (1978) paddle for a first-order solitary wave (thesis eqs. 3-1 to
  3-8; references.md section 6).
- :class:`RegularPaddle`: linear piston wavemaker for regular waves (Biesel's transfer function,
  Dean & Dalrymple, *Water Wave Mechanics*, ch. 6), ramped up so the paddle starts at rest.

Both are called once per time step with a scalar time (no particle loop, plain Python floats).
X is measured along the paddle's direction of motion from the middle of its stroke; the caller
(:class:`mpsfem.fluid_mps.wall_motion.MotionLaw`) subtracts X(0) so the wall starts where the
scenario puts it. Formulas and choices: docs/wave_tank.md.
"""

from __future__ import annotations

import math

# Goring (1978): the paddle moves while |k (c t - X)| <= 3.8, tanh(3.8) = 0.9990 of the half-stroke
# (the thesis quotes a truncation of 1e-4 but its eq. 3-8 uses 3.8, i.e. 1e-3; we follow eq. 3-8)
GORING_HALF_SPAN = 3.8
# Miche (1944) steepness limit of a regular wave: H_max = 0.142 L tanh(k d)
MICHE_STEEPNESS = 0.142
_NEWTON_MAX = 50


class SolitaryPaddle:
    """Goring (1978) piston paddle for a solitary wave of amplitude A (m) on depth d (m).

    The paddle rests at X = X(start_time) until ``start_time`` (s), moves for the generation time
    T = 2 (3.8 + A/d) / (k c) (thesis eq. 3-8) with the virtual crest passing the mid-stroke at
    ``start_time + T/2``, and then rests at X(start_time + T). k (X - c t') is 3.8 at the start
    and -3.8 at the end (to 1e-3 A/d), so the paddle starts from X = -tanh(3.8) S/2 = -0.999 S/2
    with the velocity c eta / (d + eta) ~ sech^2(3.8) (1 + A/d) = 2.0e-3 (1 + A/d) of its peak
    c A / (d + A) (a step from rest of that size), covers tanh(3.8) S = 0.999 S and stops with
    the same small step.
    """

    def __init__(
        self, amplitude: float, depth: float, gravity: float, start_time: float = 0.0
    ) -> None:
        """``amplitude`` A (m), ``depth`` d (m), ``gravity`` |g| (m/s^2), ``start_time`` (s)."""
        if not (amplitude > 0.0 and depth > 0.0 and gravity > 0.0):
            raise ValueError(
                f"solitary paddle needs amplitude, depth and gravity > 0, got {amplitude}, "
                f"{depth}, {gravity}"
            )
        self.amplitude = float(amplitude)
        self.depth = float(depth)
        self.gravity = float(gravity)
        self.eps = amplitude / depth
        self.k = math.sqrt(3.0 * amplitude / (4.0 * depth**3))  # thesis eq. 3-2
        self.c = math.sqrt(gravity * (depth + amplitude))  # thesis eq. 3-3
        self.half_stroke = amplitude / (self.k * depth)  # X(+inf), thesis eq. 3-6
        self.stroke = math.sqrt(16.0 * amplitude * depth / 3.0)  # thesis eq. 3-7, = 2 half_stroke
        self.duration = 2.0 * (GORING_HALF_SPAN + self.eps) / (self.k * self.c)  # thesis eq. 3-8
        self.start_time = float(start_time)
        self.end_time = self.start_time + self.duration
        self.crest_time = self.start_time + 0.5 * self.duration

    def surface_elevation(self, x: float, t: float) -> float:
        """eta (m) of the generated wave at the mid-stroke frame's x (m), time t (s) during the
        generation: A sech^2(k (x - c (t - t_crest))) (thesis eq. 3-1)."""
        s = 1.0 / math.cosh(self.k * (x - self.c * (t - self.crest_time)))
        return self.amplitude * s * s

    def _solve(self, t: float) -> tuple[float, float]:
        """X (m) from X = (A / (k d)) tanh(k (c t' - X)) (thesis eq. 3-6) by Newton, and
        tanh(k (c t' - X)) there; t' = t - t_crest."""
        a, k = self.half_stroke, self.k
        ct = self.c * (t - self.crest_time)
        x = a * math.tanh(k * ct)
        th = math.tanh(k * (ct - x))
        for _ in range(_NEWTON_MAX):
            # F(X) = X - a tanh(k (c t' - X)), F' = 1 + a k sech^2 in [1, 1 + A/d]: contracts
            dx = (x - a * th) / (1.0 + a * k * (1.0 - th * th))
            x -= dx
            th = math.tanh(k * (ct - x))
            if abs(dx) <= 1e-15 * a:
                break
        return x, th

    def __call__(self, t: float) -> tuple[float, float]:
        """(X m from mid-stroke, dX/dt m/s) at time t (s)."""
        if t < self.start_time:
            return self._solve(self.start_time)[0], 0.0
        if t > self.end_time:
            return self._solve(self.end_time)[0], 0.0
        x, th = self._solve(t)
        eta = self.amplitude * (1.0 - th * th)  # A sech^2(k (X - c t')), thesis eq. 3-1
        return x, self.c * eta / (self.depth + eta)  # thesis eq. 3-4 (Goring 1978)


def wave_number(omega: float, depth: float, gravity: float) -> float:
    """k (1/m) of the linear dispersion relation omega^2 = g k tanh(k d), by Newton on kd."""
    if not (omega > 0.0 and depth > 0.0 and gravity > 0.0):
        raise ValueError(
            f"wave_number needs omega, depth, gravity > 0, got {omega}, {depth}, {gravity}"
        )
    x = omega * omega * depth / gravity  # y tanh(y) = x, y = k d
    y = x / math.sqrt(math.tanh(x))  # within ~5 % of the root for every x
    for _ in range(_NEWTON_MAX):
        th = math.tanh(y)
        dy = (y * th - x) / (th + y * (1.0 - th * th))
        y -= dy
        if abs(dy) <= 1e-15 * y:
            return y / depth
    raise RuntimeError(f"dispersion relation did not converge (omega {omega}, depth {depth})")


def piston_height_to_stroke(kd: float) -> float:
    """H/S of a linear piston wavemaker: 2 (cosh 2kd - 1) / (sinh 2kd + 2kd) (Biesel & Suquet
    1951; Dean & Dalrymple 1991, ch. 6), evaluated as 2 tanh^2(kd) / (tanh(kd) + kd sech^2(kd))
    (no cancellation as kd -> 0, no overflow as kd -> inf). Shallow water: kd (1 - (kd)^4 / 45);
    deep water: 2 - 4 (1 + 2 kd) exp(-2 kd)."""
    th = math.tanh(kd)
    sech2 = 1.0 / math.cosh(kd) ** 2 if kd < 350.0 else 0.0
    return 2.0 * th * th / (th + kd * sech2)


def half_cosine_ramp(tau: float, duration: float) -> tuple[float, float]:
    """(r, dr/dt) of r = (1 - cos(pi tau / duration)) / 2 on [0, duration], 0 before, 1 after:
    r, r' continuous, r(0) = r'(0) = 0."""
    if tau <= 0.0:
        return 0.0, 0.0
    if tau >= duration:
        return 1.0, 0.0
    w = math.pi / duration
    return 0.5 * (1.0 - math.cos(w * tau)), 0.5 * w * math.sin(w * tau)


class RegularPaddle:
    """Linear piston wavemaker: X(t) = r(t') (S/2) sin(omega t'), t' = t - start_time, with the
    half-cosine ramp r over ``ramp_periods`` periods, so that X = dX/dt = 0 at t' = 0; the stroke
    S = H / (H/S)(kd) from the linear transfer function (:func:`piston_height_to_stroke`)."""

    def __init__(
        self,
        wave_height: float,
        period: float,
        depth: float,
        gravity: float,
        ramp_periods: float = 2.0,
        start_time: float = 0.0,
    ) -> None:
        """``wave_height`` H (m), ``period`` T (s), ``depth`` d (m), ``gravity`` |g| (m/s^2),
        ``ramp_periods`` (-), ``start_time`` (s)."""
        if not (wave_height > 0.0 and period > 0.0 and depth > 0.0 and gravity > 0.0):
            raise ValueError(
                f"regular paddle needs wave_height, period, depth and gravity > 0, got "
                f"{wave_height}, {period}, {depth}, {gravity}"
            )
        if ramp_periods < 0.0:
            raise ValueError(f"motion.ramp_periods = {ramp_periods}: must be >= 0")
        self.wave_height = float(wave_height)
        self.period = float(period)
        self.depth = float(depth)
        self.omega = 2.0 * math.pi / period
        self.k = wave_number(self.omega, depth, gravity)
        self.kd = self.k * depth
        self.wavelength = 2.0 * math.pi / self.k
        h_max = MICHE_STEEPNESS * self.wavelength * math.tanh(self.kd)
        if wave_height >= h_max:
            raise ValueError(
                f"motion.wave_height = {wave_height}: must be below the Miche breaking height "
                f"0.142 L tanh(kd) = {h_max:.4g} m for motion.period = {period} s on motion.depth "
                f"= {depth} m (wavelength L = {self.wavelength:.4g} m)"
            )
        self.height_to_stroke = piston_height_to_stroke(self.kd)
        self.stroke = wave_height / self.height_to_stroke
        self.ramp_time = ramp_periods * period
        self.start_time = float(start_time)

    def __call__(self, t: float) -> tuple[float, float]:
        """(X m from mid-stroke, dX/dt m/s) at time t (s)."""
        tau = t - self.start_time
        if tau <= 0.0:
            return 0.0, 0.0
        if self.ramp_time > 0.0:
            r, dr = half_cosine_ramp(tau, self.ramp_time)
        else:
            r, dr = 1.0, 0.0
        h = 0.5 * self.stroke
        s, c = math.sin(self.omega * tau), math.cos(self.omega * tau)
        return r * h * s, h * (dr * s + r * self.omega * c)
