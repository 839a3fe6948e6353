"""Prescribed rigid motion of wall patches: displacement s(t) along a fixed direction.

Kinds (schema: ``mpsfem.scenario.fluid.WallMotion``; formulas: docs/wave_tank.md):

- ``harmonic``: s = amplitude sin(2 pi t / period + phase);
- ``table``: s from a CSV of (t, s) rows, linear interpolation; the velocity is the slope of the
  segment containing t (at a knot, within 1e-9 of the shortest row interval, the segment that
  ends there: the one a time step ending at the knot moved along, however t was rounded), 0 up
  to the first row and after the last, where the position is held;
- ``solitary``: Goring (1978) piston paddle (:class:`~mpsfem.fluid_mps.wavemaker.SolitaryPaddle`);
- ``regular``: linear piston paddle (:class:`~mpsfem.fluid_mps.wavemaker.RegularPaddle`).

Every law is shifted so that s(0) = 0: the wall starts where the scenario puts it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from mpsfem.fluid_mps.wavemaker import RegularPaddle, SolitaryPaddle
from mpsfem.scenario.fluid import WallMotion
from mpsfem.scenario.motion import harmonic_motion, read_motion_table, table_motion


class MotionLaw:
    """s(t) (m) and ds/dt (m/s) of one wall patch along its unit direction."""

    def __init__(
        self,
        spec: WallMotion,
        base_dir: Path | None = None,
        gravity: float | None = None,
        dim: int = 2,
        key: str = "motion",
    ) -> None:
        """``base_dir``: where a relative ``motion.file`` is looked up; ``gravity``: |g| (m/s^2)
        of the fluid section, needed by the wavemakers ('solitary', 'regular'); ``dim``: the
        scene's dimension (the default direction is +x); ``key``: the motion's dotted key in the
        scenario, for error messages (``fluid.walls[1].motion``)."""
        self.kind = spec.kind
        if spec.direction is None:
            d = np.zeros(dim)
            d[0] = 1.0
        else:
            d = np.asarray(spec.direction, dtype=np.float64)
        norm = float(np.linalg.norm(d))
        if norm == 0.0:
            raise ValueError(f"{key}.direction = [0, ...]: must be a non-zero vector")
        self.direction = d / norm
        self.spec = spec
        self.paddle: SolitaryPaddle | RegularPaddle | None = None
        if spec.kind == "table":
            data = read_motion_table(spec.file, base_dir, key, body="wall", coord="x")
            step = np.diff(data[:, 0])
            self.t_table, self.s_table = data[:, 0].copy(), data[:, 1].copy()
            self.v_table = np.diff(self.s_table) / step
            self._knot_eps = 1e-9 * float(step.min())
        elif spec.kind in ("solitary", "regular"):
            if gravity is None or not gravity > 0.0:
                raise ValueError(
                    f"{key}.kind = {spec.kind!r} needs gravity: the magnitude of fluid.gravity "
                    f"(got {gravity}); it must be > 0"
                )
            if spec.kind == "solitary":
                self.paddle = SolitaryPaddle(
                    spec.amplitude, spec.depth, gravity, start_time=spec.start_time
                )
            else:
                self.paddle = RegularPaddle(
                    spec.wave_height,
                    spec.period,
                    spec.depth,
                    gravity,
                    ramp_periods=spec.ramp_periods,
                    start_time=spec.start_time,
                )
        self._s0 = 0.0
        self._s0 = self(0.0)[0]  # the wall starts where the scenario puts it

    @property
    def moves(self) -> bool:
        return self.kind != "none"

    def __call__(self, t: float) -> tuple[float, float]:
        """(displacement from the initial position m, velocity m/s) at time t (s)."""
        s = self.spec
        if self.paddle is not None:
            x, v = self.paddle(t)
            return x - self._s0, v
        if self.kind == "harmonic":
            x, v = harmonic_motion(s.amplitude, s.period, s.phase, t)
            return x - self._s0, v
        if self.kind == "table":
            x, v = table_motion(self.t_table, self.s_table, self.v_table, self._knot_eps, t)
            return x - self._s0, v
        return 0.0, 0.0


def place_moving_walls(moving, origin: dict, t: float, pos: np.ndarray, vel: np.ndarray) -> None:
    """Put each moving wall patch at its prescribed position (m) and velocity (m/s) at time
    ``t`` (s): ``moving`` holds (patch, MotionLaw) pairs, ``origin`` each patch's particle
    positions at s = 0; rows ``patch.start:patch.stop`` of ``pos`` / ``vel`` are written."""
    for pt, law in moving:
        s, v = law(t)
        sl = slice(pt.start, pt.stop)
        pos[sl] = origin[pt.name] + s * law.direction
        vel[sl] = v * law.direction
