"""Prescribed rigid translation of a structure member's supports: schema and motion law.

A member with ``[structure.members.motion]`` moves rigidly along a fixed unit ``direction`` by
s(t) (m) while it deforms; s(0) = 0, so the member starts where the scenario puts it. Kinds:

- ``none``: at rest (the default);
- ``constant_velocity``: s = velocity t (velocity from t = 0 on: a member already moving, e.g.
  a plate falling onto water);
- ``harmonic``: s = amplitude sin(2 pi t / period + phase) - amplitude sin(phase) (the wall
  motion's law, shifted to s(0) = 0 as the walls' ``fluid_mps.wall_motion`` does);
- ``table``: s from a CSV of (t s, s m) rows or an inline ``points`` table, linear interpolation,
  velocity the slope of the segment holding t (at a knot, the segment ending there), 0 before the
  first row and from the last on (the wall's 'table' rule).

The module lives in the scenario package because both solvers may read it; the structure uses
:class:`RigidTranslation` for the frame load and the absolute displacement of the member
(docs/structure.md, "Support motion"). Translation only: a prescribed rotation is not offered.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from .base import COORDINATE_LIMIT, InvalidValue, Section

__all__ = [
    "MemberMotion",
    "RigidTranslation",
    "MOTION_KEYS",
    "unit_direction",
    "harmonic_motion",
    "table_motion",
]

#: the keys each moving kind uses (besides ``kind`` and ``direction``)
MOTION_KEYS: dict[str, set[str]] = {
    "none": set(),
    "constant_velocity": {"velocity"},
    "harmonic": {"amplitude", "period", "phase"},
    "table": {"file", "points"},
}

#: shortest harmonic period, s (as the walls': below it no time step resolves the motion)
MIN_PERIOD = 1e-6
#: largest speed of a prescribed motion, m/s (the fluid's velocity bound, scenario/fluid.py)
MAX_MOTION_SPEED = 1e3


def unit_direction(v: list[float] | None) -> list[float] | None:
    """``v`` normalised without overflow (scaled by its largest entry first: [1e200, 0] is +x);
    raises ValueError for the zero vector. Shared by the walls' and the members' motions."""
    if v is None:
        return v
    big = max((abs(x) for x in v), default=0.0)
    if big == 0.0:
        raise ValueError("must not be the zero vector (the motion needs a direction)")
    scaled = [x / big for x in v]
    norm = math.sqrt(sum(x * x for x in scaled))
    return [x / norm for x in scaled]


def harmonic_motion(amplitude: float, period: float, phase: float, t: float) -> tuple[float, float]:
    """(s m, ds/dt m/s) of s = amplitude sin(2 pi t / period + phase) at time t (s)."""
    w = 2.0 * math.pi / period
    return amplitude * math.sin(w * t + phase), amplitude * w * math.cos(w * t + phase)


def table_motion(
    t_table: np.ndarray, s_table: np.ndarray, v_table: np.ndarray, knot_eps: float, t: float
) -> tuple[float, float]:
    """(s m, ds/dt m/s) of a motion table at time t (s): s interpolated linearly, the velocity
    the slope of the segment holding t - knot_eps (at a knot, the segment ending there), 0
    before the first row and from the last on."""
    x = float(np.interp(t, t_table, s_table))
    k = int(np.searchsorted(t_table, t - knot_eps, side="right")) - 1
    v = float(v_table[k]) if 0 <= k < v_table.size else 0.0
    return x, v


class MemberMotion(Section):
    """Prescribed rigid translation of a member (supports and all): s(t) along `direction`."""

    kind: Literal["none", "constant_velocity", "harmonic", "table"] = Field(
        "none",
        description="'none'; 'constant_velocity': s = velocity t; 'harmonic': s = amplitude "
        "(sin(2 pi t / period + phase) - sin(phase)); 'table': s from `file` or `points` (t, s), "
        "linear interpolation, velocity the slope of the current segment (0 before the first "
        "row and from the last row on). The member moves by s(t) along `direction`; s(0) = 0",
    )
    direction: list[float] | None = Field(
        None,
        min_length=2,
        max_length=3,
        description="direction of the motion (normalised; default +x); 2 components in 2D, 3 in 3D",
    )
    velocity: float = Field(
        0.0,
        ge=-MAX_MOTION_SPEED,
        le=MAX_MOTION_SPEED,
        description="'constant_velocity': speed along `direction`, m/s (|v| <= 1000)",
    )
    amplitude: float = Field(
        0.0,
        ge=-COORDINATE_LIMIT,
        le=COORDINATE_LIMIT,
        description="'harmonic': displacement amplitude, m",
    )
    period: float = Field(1.0, ge=MIN_PERIOD, description="'harmonic': period, s (>= 1e-6)")
    phase: float = Field(0.0, ge=-1e6, le=1e6, description="'harmonic': phase, rad")
    file: str | None = Field(
        None,
        description="'table': CSV file of (time s, displacement m) rows, relative to the "
        "scenario's folder; give this or `points`",
    )
    points: list[list[float]] | None = Field(
        None,
        description="'table': inline [[t0, s0], [t1, s1], ...], times strictly increasing, at "
        "least two rows; give this or `file`",
    )

    @field_validator("direction")
    @classmethod
    def _unit_direction(cls, v: list[float] | None) -> list[float] | None:
        return unit_direction(v)

    @model_validator(mode="after")
    def _check(self) -> MemberMotion:
        # a key of another kind is refused when it differs from its default (a default written
        # out, as model_dump does, is harmless and must validate again)
        defaults = type(self).model_fields
        given = {k for k in self.model_fields_set if getattr(self, k) != defaults[k].default}
        if self.kind == "none":
            unused = sorted(given - {"kind"})
            if unused:
                raise InvalidValue(
                    unused[0],
                    f"motion.{unused[0]} is not used by kind = 'none' (the member rests); give "
                    "a kind: constant_velocity, harmonic or table",
                    getattr(self, unused[0]),
                )
            return self
        allowed = MOTION_KEYS[self.kind] | {"kind", "direction"}
        unused = sorted(given - allowed)
        if unused:
            raise InvalidValue(
                unused[0],
                f"motion.{unused[0]} is not used by kind = {self.kind!r}; its keys are: "
                f"{', '.join(sorted(allowed))}",
                getattr(self, unused[0]),
            )
        if self.kind == "table":
            if (self.file is None) == (self.points is None):
                raise InvalidValue(
                    "points" if self.file is None else "file",
                    "kind = 'table' needs exactly one of motion.file (a CSV of t, s rows) or "
                    "motion.points ([[t, s], ...])",
                )
            if self.points is not None:
                if len(self.points) < 2 or any(len(p) != 2 for p in self.points):
                    raise InvalidValue("points", "needs at least two [t, s] pairs", self.points)
                if not all(math.isfinite(x) for p in self.points for x in p):
                    raise InvalidValue("points", "every t and s must be finite", self.points)
                ts = [p[0] for p in self.points]
                if any(b <= a for a, b in zip(ts, ts[1:], strict=False)):
                    raise InvalidValue(
                        "points", "times must increase strictly from row to row", self.points
                    )
                if any(abs(p[1]) > COORDINATE_LIMIT for p in self.points):
                    raise InvalidValue(
                        "points",
                        f"|s| must be <= {COORDINATE_LIMIT:g} m (the scene's coordinate bound)",
                        self.points,
                    )
        return self

    @property
    def moves(self) -> bool:
        return self.kind != "none"


class RigidTranslation:
    """s(t) (m), ds/dt (m/s) and the frame acceleration (m/s^2) of one member's translation,
    and the vectors along its unit direction."""

    def __init__(
        self,
        spec: MemberMotion,
        dim: int,
        base_dir: Path | str | None = None,
        key: str = "motion",
    ) -> None:
        """``dim``: the scene's dimension; ``base_dir``: where a relative ``file`` is looked up;
        ``key``: the motion's dotted key in the scenario, for error messages."""
        self.spec = spec
        self.kind = spec.kind
        if spec.direction is None:
            d = np.zeros(dim)
            d[0] = 1.0
        else:
            if len(spec.direction) != dim:
                raise ValueError(
                    f"{key}.direction = {spec.direction}: needs {dim} components in a {dim}D scene"
                )
            d = np.asarray(spec.direction, dtype=np.float64)
        self.direction = d / float(np.linalg.norm(d))
        self.t_table = self.s_table = self.v_table = None
        if spec.kind == "table":
            if spec.points is not None:
                data = np.asarray(spec.points, dtype=np.float64)
            else:
                data = read_motion_table(spec.file, base_dir, key)
            self.t_table, self.s_table = data[:, 0].copy(), data[:, 1].copy()
            step = np.diff(self.t_table)
            self.v_table = np.diff(self.s_table) / step
            self._knot_eps = 1e-9 * float(step.min())
            if np.abs(self.v_table).max() > MAX_MOTION_SPEED:
                k = int(np.argmax(np.abs(self.v_table)))
                raise ValueError(
                    f"{key}: the table moves at {self.v_table[k]:.6g} m/s between t = "
                    f"{self.t_table[k]:g} and {self.t_table[k + 1]:g} s; allowed |v| <= "
                    f"{MAX_MOTION_SPEED:g} m/s"
                )
        self._s0 = 0.0
        self._s0 = self.scalar(0.0)[0]

    @property
    def moves(self) -> bool:
        return self.kind != "none"

    def scalar(self, t: float) -> tuple[float, float]:
        """(s m, ds/dt m/s) at time t (s)."""
        s = self.spec
        if self.kind == "constant_velocity":
            return s.velocity * t, s.velocity
        if self.kind == "harmonic":
            x, v = harmonic_motion(s.amplitude, s.period, s.phase, t)
            return x - self._s0, v
        if self.kind == "table":
            x, v = table_motion(self.t_table, self.s_table, self.v_table, self._knot_eps, t)
            return x - self._s0, v
        return 0.0, 0.0

    def step_acceleration(self, t: float, h: float) -> float:
        """Frame acceleration (m/s^2, along `direction`) a time step of length h ending at t
        feels: d2s/dt2 at t for the smooth kinds; for a table, whose velocity jumps at its
        knots, the mean (v(t) - v(t - h)) / h over the step, so that the impulse of each jump
        reaches the member in the step that holds it."""
        s = self.spec
        if self.kind == "harmonic":
            w = 2.0 * math.pi / s.period
            return -s.amplitude * w * w * math.sin(w * t + s.phase)  # d2/dt2 of A sin(wt + phi)
        if self.kind == "table" and h > 0.0:
            return (self.scalar(t)[1] - self.scalar(t - h)[1]) / h
        return 0.0

    def displacement(self, t: float) -> np.ndarray:
        """Displacement vector (m) at t."""
        return self.scalar(t)[0] * self.direction

    def velocity(self, t: float) -> np.ndarray:
        """Velocity vector (m/s) at t."""
        return self.scalar(t)[1] * self.direction

    def acceleration(self, t: float, h: float = 0.0) -> np.ndarray:
        """Frame acceleration vector (m/s^2) of a step of length h ending at t (see
        :meth:`step_acceleration`)."""
        return self.step_acceleration(t, h) * self.direction


def read_motion_table(
    file: str, base_dir: Path | str | None, key: str, body: str = "member", coord: str = "s"
) -> np.ndarray:
    """The (t s, displacement m) rows of a motion table, checked: two finite columns, at least
    two rows, t increasing, |displacement| within the coordinate bound. Errors name ``key``,
    the file, the row and the ``body`` (member or wall) it moves; ``coord`` names the column."""
    path = Path(file)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    if not path.is_file():
        raise ValueError(f"{key}.file = {file!r}: no such file")
    try:
        data = np.loadtxt(path, delimiter=",", comments="#", ndmin=2)
    except ValueError as exc:
        raise ValueError(f"{key}.file = {file!r}: not a table of numbers ({exc})") from None
    if data.shape[0] < 2 or data.shape[1] < 2:
        raise ValueError(
            f"{key}.file = {file!r}: needs two columns (t s, {coord} m) and at least two rows; "
            f"it has {data.shape[0]} rows of {data.shape[1]} columns"
        )
    bad = np.flatnonzero(~np.isfinite(data[:, :2]).all(axis=1))
    if bad.size:
        raise ValueError(
            f"{key}.file = {file!r}: data row {bad[0] + 1} {data[bad[0], :2].tolist()} is not "
            f"finite (nan or inf); every t and {coord} must be a finite number"
        )
    far = np.flatnonzero(np.abs(data[:, 1]) > COORDINATE_LIMIT)
    if far.size:
        raise ValueError(
            f"{key}.file = {file!r}: data row {far[0] + 1} moves the {body} by "
            f"{coord} = {data[far[0], 1]:.6g} m; allowed |{coord}| <= {COORDINATE_LIMIT:g} m "
            "(the scene's coordinate bound)"
        )
    step = np.diff(data[:, 0])
    if np.any(step <= 0):
        r = int(np.flatnonzero(step <= 0)[0]) + 2
        raise ValueError(
            f"{key}.file = {file!r}: t must increase from row to row (data row {r}: "
            f"t = {data[r - 1, 0]} after {data[r - 2, 0]})"
        )
    return data[:, :2]
