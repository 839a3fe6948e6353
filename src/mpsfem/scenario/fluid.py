"""Schema of the ``[fluid]`` section: the MPS fluid participant."""

from __future__ import annotations

import math
from typing import Annotated, Literal

import numpy as np
from pydantic import Field, field_validator, model_validator

from mpsfem.fluid_methods import FLUID_METHODS, METHOD_TABLES
from mpsfem.scenario.base import COORDINATE_LIMIT, InvalidValue, Point, Section
from mpsfem.scenario.fluid_sph import DeltaSPHSection
from mpsfem.scenario.motion import unit_direction

Vector = list[float]

#: particle spacing bounds, m (a finer or coarser lattice is no MPS scene; 5e-324 overflowed
#: the lattice arithmetic)
MIN_SPACING = 1e-6
MAX_SPACING = 1e3
#: smallest Courant and viscous numbers (smaller ones make dt = 0: a division by zero)
MIN_STEP_NUMBER = 1e-4
#: bounds of the fluid's physics: beyond them a run overflowed or divided by zero at its first
#: step (gravity 1e300, density 1e300, velocity 1e300) instead of being refused
MAX_ACCELERATION = 1e3  # m/s^2 per component (about 100 g)
MAX_SPEED = 1e3  # m/s per component (incompressible flow ends far below)
DENSITY_RANGE = (1e-3, 1e5)  # kg/m^3
MIN_PERIOD = 1e-6  # s

#: a gravity vector, m/s^2
Acceleration = list[Annotated[float, Field(ge=-MAX_ACCELERATION, le=MAX_ACCELERATION)]]
#: a velocity, m/s
Velocity = list[Annotated[float, Field(ge=-MAX_SPEED, le=MAX_SPEED)]]


class KernelSection(Section):
    """Kernel function and radii (in units of the particle spacing l0)."""

    weight: Literal["improved", "original"] = Field(
        "improved",
        description="weight function: 'improved' w = re/(0.85 r + 0.15 re) - 1 (thesis eq. 2-4) "
        "or 'original' w = re/r - 1 (Koshizuka & Oka 1996)",
    )
    re_density: float = Field(
        2.1, gt=1.0, le=6.0, description="radius of particle number density, x l0"
    )
    re_gradient: float = Field(2.1, gt=1.0, le=6.0, description="radius of the gradient, x l0")
    re_laplacian: float = Field(
        4.01, gt=1.0, le=6.0, description="radius of the viscous Laplacian, x l0"
    )
    re_pressure: float = Field(
        4.01,
        gt=1.0,
        le=6.0,
        description="radius of the pressure Poisson equation's Laplacian, x l0",
    )


class PressureSection(Section):
    """Pressure Poisson equation and its solver."""

    solver: Literal["pcg_amg", "pcg_jacobi", "direct"] = Field(
        "pcg_amg",
        description="linear solver: CG preconditioned by pyamg smoothed aggregation (reused "
        "across steps), CG with a diagonal preconditioner, or a sparse direct solve",
    )
    wall_model: Literal["neumann", "pressure_layer"] = Field(
        "neumann",
        description="'pressure_layer': the first wall layer is an unknown of the pressure "
        "equation and dummy layers are left out (thesis ch. 2.1.3); 'neumann': wall and dummy "
        "particles are ghosts of each fluid particle carrying the projection method's wall "
        "condition (docs/architecture.md), walls are not unknowns",
    )
    gradient: Literal["corrected_pmin", "corrected", "pmin", "tanaka", "cmps"] = Field(
        "corrected_pmin",
        description="pressure gradient: 'corrected_pmin', the p_j - p_min form of eq. 2-11 "
        "multiplied by the inverse moment matrix C_i^-1 (exact for linear fields on any "
        "neighbourhood, so surface and corner particles feel the full hydrostatic gradient; "
        "docs/fluid.md); 'corrected', the same with p_j - p_i (no repulsive part); 'pmin', eq. "
        "2-11 with the neighbourhood minimum (repulsive; half the gradient at a free surface); "
        "'tanaka', the momentum-conserving form of eq. 2-12 (its p_i + p_j repulsion is stiff: "
        "run it with pressure_courant, e.g. 0.25, and with boundary_force = "
        "'momentum_exchange' the momentum budget closes to round-off); 'cmps', Khayyer & "
        "Gotoh's (2008) antisymmetric form sum (p_i + p_j - p_min,i - p_min,j), whose "
        "neighbours' p_min shift cancels the interior hydrostatic gradient (still water falls "
        "and the run stops; docs/fluid.md, momentum budget)",
    )
    gamma: float = Field(
        0.01,
        ge=0.0,
        le=1.0,
        description="weight of the number-density term in the mixed source term (thesis eq. 2-23); "
        "0 = divergence only, 1 = number density only",
    )
    tol: float = Field(1e-6, gt=0.0, lt=1.0, description="relative residual ||r|| <= tol ||b||")
    max_iter: int = Field(2000, ge=1, description="CG iteration limit; exceeded = run stops")
    clamp_negative: bool = Field(True, description="set negative pressures to zero (stability aid)")
    structure_suction: bool = Field(
        False,
        description="let the water pull on a structure member: fluid particles within the "
        "gradient radius of a structure particle, and the structure particles' pressure (the "
        "member's load), keep negative pressures down to suction_floor, while clamp_negative "
        "holds elsewhere (an unclamped free surface is tensile-unstable; docs/fluid.md, "
        "'Suction at structure members')",
    )
    suction_floor: float = Field(
        -98986.0,
        le=0.0,
        description="lowest gauge pressure (Pa) structure_suction keeps: the cavitation limit, "
        "vapour pressure (2339 Pa at 20 C) less the atmosphere's 101325 Pa",
    )
    amg_rebuild_factor: float = Field(
        1.5,
        gt=1.0,
        description="rebuild the AMG hierarchy when CG needs this factor more iterations than "
        "right after the last rebuild",
    )
    compressibility: float = Field(
        0.0,
        ge=0.0,
        description="artificial compressibility kappa (1/Pa): the fluid obeys div u = -kappa "
        "Dp/Dt and still water is compressed by kappa p (sound speed 1 / sqrt(rho kappa): 1e-6 "
        "gives 31.6 m/s; docs/fluid.md); 0 = incompressible",
    )
    compressed_start: bool = Field(
        False,
        description="with compressibility > 0 and hydrostatic_start: still water starts in its "
        "compressed equilibrium, each lattice column's layers moved down (its bottom and mass "
        "kept) so that the layer under pressure p reads the number density n0 (1 + kappa p), "
        "and the pressure that of the compressed column (fluid_mps/geometry.py). Off: the water "
        "starts on the uncompressed lattice, settles by about kappa rho g H^2 / (2 s), s = 1.34 "
        "in 2D, and breathes in its quarter-wave mode, period 4 H / c (docs/fluid.md)",
    )
    source_term: Literal["thesis_mixed", "higher_order"] = Field(
        "thesis_mixed",
        description="velocity part of the source term: 'thesis_mixed', the divergence of u* "
        "(eq. 2-15) in the mixed source term of eq. 2-23; 'higher_order', Khayyer & Gotoh "
        "(2009)'s HS, the number density's time derivative written from the kernel derivative "
        "and the pair velocities, in its place (the gamma part stays; docs/fluid.md)",
    )
    error_compensation: bool = Field(
        False,
        description="add Khayyer & Gotoh (2011)'s error-compensating source term (ECS): the "
        "number density's error and its rate at the start of the step, each with its dynamic "
        "coefficient |error| (docs/fluid.md)",
    )
    source_filter: Literal["none", "kernel_average"] = Field(
        "none",
        description="'kernel_average': the velocity divergence of eq. 2-15 enters the source "
        "term as its Wendland-weighted average over each fluid particle and its non-surface "
        "fluid neighbours within the density radius, so that the source does not ask the "
        "projection for particle-scale divergence its gradient cannot remove; 'none': as is "
        "(docs/fluid.md). Only with source_term = 'thesis_mixed'",
    )
    laplacian: Literal["standard", "higher_order"] = Field(
        "standard",
        description="Laplacian of the pressure equation: 'standard', eq. 2-16; 'higher_order', "
        "Khayyer & Gotoh's HL (2D: 2010, 3D: 2012), pair weight w'' + (d - 3) w'/r normalised "
        "on the initial lattice (docs/fluid.md)",
    )
    wall_acceleration: bool = Field(
        False,
        description="moving walls and members: each wall/dummy ghost of the Neumann wall model "
        "follows dp/dn = rho (g - a_w) . n with a_w the wall particle's acceleration over the "
        "step (its velocity change / dt), and the wall flux of the source term uses the wall's "
        "velocity before the step; false: the hydrostatic ghost and the flux at the new "
        "velocity (the earlier model: a floor oscillating under a 2 m column at 75 Hz gave 0.90 "
        "of the added-mass force, 13 deg late; with it 0.99, 7 deg; validation/"
        "piston_added_mass.py). Neumann wall model only; not with the higher-order source term "
        "or Laplacian, whose ghost parts follow gravity alone",
    )
    buried_walls: Literal["dry", "ghost"] = Field(
        "dry",
        description="Neumann wall model: a wall or member particle that the free-surface "
        "detector leaves unflagged but that has no fluid within the density radius (buried in "
        "the solid, e.g. a side wall's layer below a floor in a corner, a member's foot in the "
        "floor). 'dry' (the earlier model): it and its dummies are p = 0 neighbours of the "
        "pressure equation, which drains a quarter of an accelerating floor's added-mass "
        "pressure through the corners of the 1 m piston column and lets the fluid follow the "
        "floor about a step late; 'ghost': they stay ghosts p_i + D_ij like the wall around "
        "them (with wall_acceleration the piston's force is then in phase to 0.1 deg at the "
        "step's midpoint; validation/piston_added_mass.py, docs/fluid.md)",
    )
    dynamic_stabilization: float = Field(
        0.0,
        ge=0.0,
        lt=1.0,
        description="distance alpha (x l0) of the dynamic stabilisation (after Tsuruta, Khayyer "
        "& Gotoh 2013): every fluid pair closer than alpha l0 after the pressure correction is "
        "pushed back to alpha l0 within the step, shared equally (antisymmetric, so the fluid's "
        "momentum is unchanged; walls keep the collision model; fluid_mps/"
        "dynamic_stabilization.py, docs/fluid.md); 0 = off",
    )
    shifting: float = Field(
        0.0,
        ge=0.0,
        le=1.0,
        description="particle shifting coefficient eps: after the pressure correction every "
        "interior fluid particle (no free-surface or structure particle within re) moves by -eps l0^2 <grad "
        "C> (Lind et al. 2012 with the MPS gradient of the neighbour concentration), at most "
        "0.1 l0; velocities unchanged (fluid_mps/particle_shifting.py, docs/fluid.md); 0 = off",
    )
    pressure_courant: float = Field(
        0.0,
        ge=0.0,
        le=10.0,
        description="time-step limit of the antisymmetric gradients: dt <= C l0 / sqrt(2 "
        "p_max / rho) with p_max the largest fluid pressure, the stiffness of the repulsion "
        "p_i + p_j of the tanaka form (still water at dt = 2e-3 s blew up, 1e-3 s did not; "
        "docs/fluid.md); 0 = no limit",
    )


class SurfaceSection(Section):
    """Free-surface detection."""

    detector: Literal["density_asymmetry", "density"] = Field(
        "density_asymmetry",
        description="'density': n < beta n0; 'density_asymmetry': the number-density threshold "
        "plus the neighbour-asymmetry test (thesis eqs. 2-18 to 2-20)",
    )
    beta: float = Field(
        0.97, gt=0.0, lt=1.0, description="n >= beta n0 is never surface (thesis eq. 2-18)"
    )
    beta_low: float = Field(
        0.8,
        gt=0.0,
        lt=1.0,
        description="density_asymmetry only: n <= beta_low n0 is always surface; in between the "
        "asymmetry test decides",
    )
    asymmetry: float = Field(
        0.9,
        gt=0.0,
        description="density_asymmetry only: surface when |F_i| > asymmetry |F|0, F the "
        "neighbour-asymmetry vector (thesis eqs. 2-19, 2-20) and |F|0 its value on a flat free "
        "surface of the initial lattice",
    )
    pressure: Literal["half_spacing", "zero"] = Field(
        "half_spacing",
        description="Dirichlet value of a free-surface particle: 'zero', p = 0 at the particle "
        "(thesis); 'half_spacing', p = l0 / 2 |grad p| with the particle's pressure gradient of "
        "the previous step, i.e. p = 0 half a spacing further out, where the fluid a surface "
        "particle represents ends (removes a rho g l0 / 2 bias of the whole pressure field; 0 in "
        "free fall)",
    )

    freeze_in_coupling_window: bool = Field(
        False,
        description="implicit coupling only: the surface and dry-boundary flags of each step of a "
        "coupling window are decided in the window's first iteration and reused by its repeated "
        "iterations, so that no particle flips between surface and interior (or wet and dry) "
        "from one iteration to the next; such flips make the fixed-point map discontinuous and "
        "can stall the iterations at first contact. Off by default: it removed the unconverged "
        "first-contact windows of the elastic obstacle at mass ratio 0.03 but the IQN-ILS run at "
        "0.01 then ended with an escaped particle (docs/coupler.md)",
    )
    freeze_rule: Literal["settled", "first_iterate"] = Field(
        "settled",
        description="with freeze_in_coupling_window: 'first_iterate' keeps the flags of the "
        "window's first iterate for every iteration, the accepted one included (the original "
        "rule); 'settled' also checks, once an iterate has converged, that the flags its own "
        "steps would set are the replayed ones, and if not re-decides them from that iterate and "
        "iterates on (at most 3 times a window), so an accepted window carries its own flags "
        "(fluid_mps/surface_freeze.py)",
    )

    @model_validator(mode="after")
    def _check(self) -> SurfaceSection:
        if self.beta_low >= self.beta:
            raise InvalidValue("beta_low", f"must be below beta = {self.beta}", self.beta_low)
        return self


class TimeStepSection(Section):
    """Adaptive time step of the fluid."""

    courant: float = Field(
        0.2, ge=MIN_STEP_NUMBER, le=1.0, description="Courant number u_max dt / l0"
    )
    viscous_number: float = Field(
        0.2, ge=MIN_STEP_NUMBER, le=0.5, description="viscous limit nu dt / l0^2 <= value"
    )
    dt_max: float = Field(1e-3, gt=0.0, description="largest time step, s")
    dt_min: float = Field(
        1e-8, gt=0.0, description="smallest allowed time step, s; needing less stops the run"
    )
    dt_initial: float | None = Field(
        None,
        gt=0.0,
        description="first time step, s (default: dt_max), lowered to the Courant and "
        "viscous limits of the initial velocities; dt_min <= it <= dt_max",
    )

    @model_validator(mode="after")
    def _check(self) -> TimeStepSection:
        if self.dt_min > self.dt_max:
            raise InvalidValue("dt_min", f"must be <= dt_max = {self.dt_max}", self.dt_min)
        if self.dt_initial is not None and not self.dt_min <= self.dt_initial <= self.dt_max:
            raise InvalidValue(
                "dt_initial",
                f"must lie in [dt_min, dt_max] = [{self.dt_min}, {self.dt_max}]",
                self.dt_initial,
            )
        return self


class NeighbourSection(Section):
    """Neighbour search (cell-linked list, fluid_mps/neighbours.py)."""

    skin: float = Field(
        0.3,
        ge=0.0,
        le=2.0,
        description="Verlet skin, x l0: a candidate list at the search radius + skin is reused "
        "while no particle has moved more than skin / 2 (0 = build every step). Changes the "
        "run time, never a result; rebuilt every step where particles move more than skin / 4 "
        "per step (Courant-limited flows)",
    )


class CollisionSection(Section):
    """Particle collision (anti-penetration) model."""

    enabled: bool = Field(True, description="switch the collision model on")
    distance: float = Field(
        0.8,
        gt=0.0,
        lt=1.0,
        description="pairs closer than distance x l0 collide (0.8: below it our dam break at "
        "L/40 grows voids and stops; docs/validation.md)",
    )
    restitution: float = Field(0.2, ge=0.0, le=1.0, description="restitution coefficient")
    ramp: float = Field(
        0.0,
        ge=0.0,
        lt=1.0,
        description="share of distance over which a pair's impulse fades out, in [0, 1): full "
        "below (1 - ramp) distance, none at distance; 0 (default): the hard threshold, whose "
        "jump makes a member's contact load discontinuous in its displacement (an implicit "
        'window then may have no fixed point; docs/coupler.md, "Contact that fades in")',
    )


def _check_box(lower: Vector, upper: Vector) -> None:
    """``upper`` has as many entries as ``lower`` and exceeds it in every axis."""
    if len(lower) != len(upper):
        raise InvalidValue(
            "upper", f"must have as many entries as lower = {lower} ({len(lower)})", upper
        )
    if any(u <= lo for lo, u in zip(lower, upper, strict=True)):
        raise InvalidValue("upper", f"must exceed lower = {lower} in every axis", upper)


class FluidBlock(Section):
    """A region filled with fluid particles on the square lattice of spacing l0."""

    shape: Literal["box"] = Field("box", description="geometry primitive")
    lower: Point = Field(description="lower corner, m")
    upper: Point = Field(description="upper corner, m")
    velocity: Velocity | None = Field(
        None, description=f"initial velocity, m/s (default 0; components within +-{MAX_SPEED:g})"
    )

    @model_validator(mode="after")
    def _check(self) -> FluidBlock:
        _check_box(self.lower, self.upper)
        return self


# keys each moving wall kind reads (besides kind and direction)
_MOTION_KEYS = {
    "harmonic": {"amplitude", "period", "phase"},
    "table": {"file"},
    "solitary": {"amplitude", "depth", "start_time"},
    "regular": {"wave_height", "period", "depth", "ramp_periods", "start_time"},
}
BREAKING_RATIO = 0.78  # depth-limited breaking, wave height / depth (McCowan 1894)


class WallMotion(Section):
    """Prescribed rigid motion of a wall (displacement added to its initial position).

    Piston wavemakers (docs/wave_tank.md): 'solitary' (Goring 1978) and 'regular' (linear piston
    theory). A moving kind accepts only its own keys (listed in the error otherwise)."""

    kind: Literal["none", "harmonic", "table", "solitary", "regular"] = Field(
        "none",
        description="'none'; 'harmonic': x(t) = amplitude sin(2 pi t / period + phase) along "
        "direction; 'table': displacement along direction from a CSV (t, x), linear "
        "interpolation, velocity = the slope of the current segment (0 before the first row "
        "and from the last row on, where the position is held); "
        "'solitary': Goring piston paddle for a solitary wave of amplitude A on depth d; "
        "'regular': linear piston paddle for waves of height wave_height and period on depth d",
    )
    direction: Vector | None = Field(
        None, description="direction of the motion (normalised; default: +x, [1, 0] or [1, 0, 0])"
    )
    amplitude: float = Field(
        0.0,
        ge=-COORDINATE_LIMIT,
        le=COORDINATE_LIMIT,
        description="'harmonic': displacement amplitude, m; 'solitary': wave amplitude A (crest "
        "above still water), m, with 0 < A/depth < 0.78",
    )
    period: float = Field(1.0, ge=MIN_PERIOD, description="'harmonic', 'regular': period, s")
    phase: float = Field(0.0, ge=-1e6, le=1e6, description="'harmonic': phase, rad")
    file: str | None = Field(None, description="'table': CSV file of (time s, displacement m) rows")
    depth: float | None = Field(
        None, gt=0.0, description="'solitary', 'regular': still-water depth d at the paddle, m"
    )
    wave_height: float | None = Field(
        None,
        gt=0.0,
        description="'regular': wave height H (crest to trough), m, with H/depth < 0.78 (the "
        "paddle stroke follows from the linear piston transfer function)",
    )
    ramp_periods: float = Field(
        2.0,
        ge=0.0,
        description="'regular': the stroke grows over this many periods by a half-cosine ramp, "
        "so the paddle starts at rest (0 = no ramp: the paddle starts at full speed)",
    )
    start_time: float = Field(
        0.0,
        ge=0.0,
        description="'solitary', 'regular': the paddle rests until this time, s. 'solitary' "
        "then moves through its stroke S = sqrt(16 A d / 3) in T = 2 (3.8 + A/d) / (k c) "
        "(crest at the paddle's mid-stroke at start_time + T/2) and stops",
    )

    @field_validator("direction")
    @classmethod
    def _unit_direction(cls, v: Vector | None) -> Vector | None:
        return unit_direction(v)

    @model_validator(mode="after")
    def _check(self) -> WallMotion:
        if self.kind == "none":
            return self
        allowed = _MOTION_KEYS[self.kind] | {"kind", "direction"}
        unused = sorted(self.model_fields_set - allowed)
        if unused:
            raise InvalidValue(
                unused[0],
                f"motion.{unused[0]} is not used by kind = {self.kind!r}; its keys are: "
                f"{', '.join(sorted(allowed))}",
                getattr(self, unused[0]),
            )
        if self.kind == "table" and not self.file:
            raise InvalidValue("file", "kind = 'table' needs motion.file (a CSV of t, x rows)")
        if self.kind in ("solitary", "regular") and self.depth is None:
            raise InvalidValue(
                "depth", f"kind = {self.kind!r} needs motion.depth (still-water depth, m)"
            )
        if self.kind == "solitary":
            ratio = self.amplitude / self.depth
            if not 0.0 < ratio < BREAKING_RATIO:
                raise InvalidValue(
                    "amplitude",
                    f"on motion.depth = {self.depth} gives A/d = {ratio:.4g}: must be in "
                    f"(0, {BREAKING_RATIO}) (a solitary wave breaks beyond A/d ~ 0.78)",
                    self.amplitude,
                )
        if self.kind == "regular":
            if self.wave_height is None:
                raise InvalidValue(
                    "wave_height", "kind = 'regular' needs motion.wave_height (crest to trough, m)"
                )
            ratio = self.wave_height / self.depth
            if not ratio < BREAKING_RATIO:
                raise InvalidValue(
                    "wave_height",
                    f"on motion.depth = {self.depth} gives H/d = {ratio:.4g}: must be below "
                    f"{BREAKING_RATIO} (depth-limited breaking)",
                    self.wave_height,
                )
        return self


#: fewest vertices of a polygon wall
MIN_POLYGON_VERTICES = 3


def _segments_cross(a, b, c, d) -> bool:
    """Whether the closed segments a-b and c-d (2D points) share a point."""

    def orient(p, q, r) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    def on(p, q, r) -> bool:  # r on segment p-q, given the three are collinear
        return min(p[0], q[0]) <= r[0] <= max(p[0], q[0]) and min(p[1], q[1]) <= r[1] <= max(
            p[1], q[1]
        )

    o1, o2, o3, o4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
    if ((o1 > 0) != (o2 > 0)) and ((o3 > 0) != (o4 > 0)) and o1 and o2 and o3 and o4:
        return True
    return (
        (o1 == 0 and on(a, b, c))
        or (o2 == 0 and on(a, b, d))
        or (o3 == 0 and on(c, d, a))
        or (o4 == 0 and on(c, d, b))
    )


def check_polygon(vertices: list[list[float]], key: str = "vertices") -> None:
    """Refuse an outline that is no simple 2D polygon: fewer than 3 vertices, a vertex with other
    than 2 coordinates, a zero-length edge (a repeated vertex, the first repeated at the end
    included), zero area or two edges that cross or touch (self-intersection)."""
    n = len(vertices)
    if n < MIN_POLYGON_VERTICES:
        raise InvalidValue(
            key, f"a polygon needs at least {MIN_POLYGON_VERTICES} vertices, got {n}", vertices
        )
    for i, v in enumerate(vertices):
        if len(v) != 2:
            raise InvalidValue(
                f"{key}[{i}]", "polygon walls are 2D: each vertex is [x, y] (2 entries)", v
            )
    for i in range(n):
        a, b = vertices[i], vertices[(i + 1) % n]
        if a[0] == b[0] and a[1] == b[1]:
            raise InvalidValue(
                f"{key}[{(i + 1) % n}]",
                f"repeats vertex {i} ({a}): edges need a length (list the outline once; the "
                "last vertex joins the first by itself)",
                b,
            )
    # shoelace formula: twice the signed area
    area2 = sum(
        vertices[i][0] * vertices[(i + 1) % n][1] - vertices[(i + 1) % n][0] * vertices[i][1]
        for i in range(n)
    )
    if area2 == 0.0:
        raise InvalidValue(key, "the polygon has zero area (collinear vertices)", vertices)
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (i == 0 and j == n - 1):
                continue  # neighbouring edges share a vertex
            a, b = vertices[i], vertices[(i + 1) % n]
            c, d = vertices[j], vertices[(j + 1) % n]
            if _segments_cross(a, b, c, d):
                raise InvalidValue(
                    key,
                    f"edge {i} ({a} .. {b}) meets edge {j} ({c} .. {d}): the outline must not "
                    "intersect itself (a simple polygon)",
                    vertices,
                )


class Wall(Section):
    """Rigid wall particles: one pressure layer plus dummy layers that fill the kernel."""

    shape: Literal["tank", "box", "polygon"] = Field(
        description="'tank': walls on the floor and both sides (and the ends in 3D) of the "
        "box lower..upper, fluid inside, top open; 'box': a solid obstacle, fluid outside; "
        "'polygon' (2D only): a solid obstacle of any simple polygonal outline ``vertices``, "
        "fluid outside, its particles laid along the faces (docs/fluid.md, polygon walls)"
    )
    lower: Point | None = Field(
        None,
        description="lower corner of the fluid-side face box, m ('tank', 'box'; required); "
        "'polygon': leave out, it is the vertices' bounding box",
    )
    upper: Point | None = Field(
        None,
        description="upper corner of the fluid-side face box, m ('tank', 'box'; required); "
        "'polygon': leave out, it is the vertices' bounding box",
    )
    vertices: list[Point] | None = Field(
        None,
        description="'polygon' only: the outline's corners [[x, y], ...], m, in order around it "
        "(either sense), at least 3, each listed once (the last joins the first), no edge "
        "crossing another",
    )
    name: str | None = Field(None, description="patch name, for force probes")
    motion: WallMotion = Field(default_factory=WallMotion, description="prescribed motion")

    @model_validator(mode="before")
    @classmethod
    def _polygon_bounds(cls, data):
        """A polygon's lower/upper are its vertices' bounding box (filled in here, so that the
        domain, the size estimate and the reports treat it as the box it spans)."""
        if not isinstance(data, dict) or data.get("shape") != "polygon":
            return data
        for key in ("lower", "upper"):
            if key in data:
                raise InvalidValue(
                    key,
                    "is not used by shape = 'polygon' (its bounding box follows from vertices); "
                    "leave it out",
                    data[key],
                )
        verts = data.get("vertices")
        numbers = (int, float)
        if (
            isinstance(verts, list)
            and verts
            and all(
                isinstance(v, list)
                and v
                and all(
                    isinstance(x, numbers) and not isinstance(x, bool) and math.isfinite(x)
                    for x in v
                )
                and len(v) == len(verts[0])
                for v in verts
            )
        ):
            dim = len(verts[0])
            data = {
                **data,
                "lower": [float(min(v[a] for v in verts)) for a in range(dim)],
                "upper": [float(max(v[a] for v in verts)) for a in range(dim)],
            }
        return data

    @model_validator(mode="after")
    def _check(self) -> Wall:
        if self.shape == "polygon":
            if self.vertices is None:
                raise InvalidValue("vertices", "shape = 'polygon' needs vertices [[x, y], ...]")
            check_polygon(self.vertices)
            return self
        if self.vertices is not None:
            raise InvalidValue(
                "vertices",
                f"is only used by shape = 'polygon', not {self.shape!r} (which takes lower and "
                "upper)",
                self.vertices,
            )
        for key in ("lower", "upper"):
            if getattr(self, key) is None:
                raise InvalidValue(key, f"shape = {self.shape!r} needs {key} (a corner, m)")
        _check_box(self.lower, self.upper)
        return self


class SpongeZone(Section):
    """A wave-absorbing sponge layer (thesis eq. 3-9): inside the zone the momentum equation gets
    the source f_s = -rho alpha_s (x - x_s) / L_s u, growing linearly from 0 at the inner edge
    ``start`` to alpha_s at the outer edge ``end`` (docs/wave_tank.md)."""

    axis: int = Field(0, ge=0, le=2, description="axis across the zone: 0 = x, 1 = y, 2 = z")
    start: float = Field(description="inner edge x_s (no damping there), m along axis")
    end: float = Field(
        description="outer edge (full damping), m along axis; below start for a zone at the "
        "low end of the axis; the zone length is L_s = abs(end - start)"
    )
    coefficient: float = Field(
        50.0,
        gt=0.0,
        description="alpha_s, 1/s: damping rate at the outer edge (thesis: 50); overlapping "
        "zones add",
    )

    @model_validator(mode="after")
    def _check(self) -> SpongeZone:
        if self.end == self.start:
            raise InvalidValue(
                "end",
                f"equals start = {self.start}: the zone needs a length, end != start (end is "
                "the outer edge)",
                self.end,
            )
        return self


class FluidSection(Section):
    """The particle fluid: material, numerics and initial geometry."""

    method: Literal[FLUID_METHODS.names()] = Field(
        "mps",
        description="particle method (fluid_methods.py): 'mps', semi-implicit MPS (numerical "
        "keys in kernel, pressure, surface, collision); 'delta-sph', weakly compressible "
        "δ-SPH / δ-SPHC (numerical keys in [fluid.sph], docs/fluid_sph.md)",
    )
    dim: Literal[2, 3] = Field(2, description="space dimension")
    spacing: Annotated[float, Field(ge=MIN_SPACING, le=MAX_SPACING)] = Field(
        description=f"initial particle spacing l0, m ({MIN_SPACING:g} .. {MAX_SPACING:g})"
    )
    density: float = Field(
        1000.0,
        ge=DENSITY_RANGE[0],
        le=DENSITY_RANGE[1],
        description=f"density rho, kg/m^3 ({DENSITY_RANGE[0]:g} .. {DENSITY_RANGE[1]:g})",
    )
    viscosity: float = Field(1e-6, ge=0.0, description="kinematic viscosity nu, m^2/s (0 = off)")
    gravity: Acceleration = Field(
        [0.0, -9.81],
        description=(
            "gravitational acceleration, m/s^2 (default [0, -9.81] in 2D, [0, 0, -9.81] in 3D)"
        ),
    )
    hydrostatic_start: bool = Field(True, description="start still water from hydrostatic pressure")
    boundary_force: Literal["pressure_and_contact", "pressure_integral", "momentum_exchange"] = (
        Field(
            "pressure_and_contact",
            description="force of the fluid on walls and structure members (force probes, "
            "coupling loads): 'pressure_integral', the sum of -p_i l0^(d-1) n_i over the "
            "pressure layer (thesis eq. 2-51; the earlier default); 'pressure_and_contact', that "
            "plus the reaction to the step's viscous and collision pair interactions with the "
            "boundary's particles (dummies booked on their pressure particle): the momentum the "
            "collision model takes from fluid near a member reaches the member; "
            "'momentum_exchange', the reaction to every pair interaction, pressure included, so "
            "the impulse a boundary receives is exactly the momentum the fluid loses at it "
            "(MPS: needs an antisymmetric fluid.pressure.gradient, docs/fluid.md, momentum "
            "budget; δ-SPH: the walls' pressure pair exchange averaged over the step with the "
            "integrator's weights, docs/fluid_sph.md)",
        )
    )
    momentum_budget: bool = Field(
        True,
        description="record the fluid's momentum budget in the results file (/momentum_budget: "
        "each stage's momentum change, the internal imbalance of the pair terms, the impulse "
        "exchanged with and reported on each boundary patch, the residual). Under fluid.method = "
        "'delta-sph' only when given explicitly (its default there stays off: the split costs a "
        "serial pair pass per right-hand side; docs/fluid_sph.md)",
    )
    dummy_layers: int | None = Field(
        None,
        ge=1,
        le=8,
        description="dummy wall layers behind the pressure layer (default: enough to fill the "
        "largest kernel radius)",
    )
    domain_lower: Point | None = Field(
        None,
        description="lower corner of the domain, m; a fluid particle leaving it stops the run "
        "(default: the walls' bounding box grown by 10 l0 sideways and 1 m upwards)",
    )
    domain_upper: Point | None = Field(None, description="upper corner of the domain, m")
    kernel: KernelSection = Field(default_factory=KernelSection, description="kernel")
    pressure: PressureSection = Field(default_factory=PressureSection, description="pressure")
    surface: SurfaceSection = Field(default_factory=SurfaceSection, description="free surface")
    time_step: TimeStepSection = Field(default_factory=TimeStepSection, description="time step")
    collision: CollisionSection = Field(default_factory=CollisionSection, description="collision")
    neighbours: NeighbourSection = Field(
        default_factory=NeighbourSection, description="neighbour search"
    )
    sph: DeltaSPHSection | None = Field(
        None, description="δ-SPH numerics (fluid.method = 'delta-sph' only; default table)"
    )
    blocks: list[FluidBlock] = Field(min_length=1, description="fluid regions")
    walls: list[Wall] = Field(default_factory=list, description="rigid walls and obstacles")
    sponges: list[SpongeZone] = Field(
        default_factory=list, description="wave-absorbing sponge layers (thesis eq. 3-9)"
    )

    @property
    def vertical_axis(self) -> int:
        """The axis gravity acts along most (the last axis without gravity)."""
        g = [abs(x) for x in self.gravity]
        return g.index(max(g)) if any(g) else self.dim - 1

    @property
    def water_height(self) -> float:
        """Extent of the fluid blocks along :attr:`vertical_axis`, m: the initial water depth
        or column height."""
        up = self.vertical_axis
        return max(b.upper[up] for b in self.blocks) - min(b.lower[up] for b in self.blocks)

    def sph_sound_speed(self) -> float:
        """δ-SPH's artificial sound speed c0, m/s, as its solver sets it: fluid.sph.sound_speed,
        else 10 max(U, U_block, sqrt(g H)) (seed eq. 1) with H the tallest block, U_block the
        blocks' fastest initial speed and U fluid.sph.reference_speed (default 2 sqrt(g H),
        Ritter's dam-break front); 0 without gravity and speeds (the solver refuses that)."""
        sph = self.sph if self.sph is not None else DeltaSPHSection()
        if sph.sound_speed is not None:
            return float(sph.sound_speed)
        g = float(np.linalg.norm(np.asarray(self.gravity, dtype=np.float64)))
        up = self.vertical_axis
        height = max(b.upper[up] - b.lower[up] for b in self.blocks)
        u_block = max(
            (float(np.linalg.norm(b.velocity)) for b in self.blocks if b.velocity), default=0.0
        )
        u_ref = (
            sph.reference_speed if sph.reference_speed is not None else 2.0 * math.sqrt(g * height)
        )
        return 10.0 * max(u_ref, u_block, math.sqrt(g * height))  # seed eq. 1

    def domain_box(self, extra: list[list[float]] = ()) -> tuple[list[float], list[float]]:
        """The domain (lower, upper corner, m) a fluid particle may not leave: ``domain_lower`` /
        ``domain_upper`` where given, else the bounding box of the blocks, the walls and the
        ``extra`` points (structure members) grown by 10 l0 on every side and by 1 m more along
        the gravity axis (as the solver does with its particles, which lie within l0 of it)."""
        corners = [c for b in self.blocks for c in (b.lower, b.upper)]
        corners += [c for w in self.walls for c in (w.lower, w.upper)]
        corners += [list(p) for p in extra]
        d, pad = self.dim, 10.0 * self.spacing
        lo = [min(c[k] for c in corners) - pad for k in range(d)]
        hi = [max(c[k] for c in corners) + pad for k in range(d)]
        hi[self.vertical_axis] += 1.0
        return (
            list(self.domain_lower) if self.domain_lower is not None else lo,
            list(self.domain_upper) if self.domain_upper is not None else hi,
        )

    @model_validator(mode="before")
    @classmethod
    def _gravity_along_the_last_axis(cls, data):
        """Gravity left out: -9.81 m/s^2 along the last axis (y in 2D, z in 3D)."""
        if isinstance(data, dict) and "gravity" not in data and data.get("dim") == 3:
            data = {**data, "gravity": [0.0, 0.0, -9.81]}
        return data

    @model_validator(mode="after")
    def _method_tables(self) -> FluidSection:
        """A numerical table of another method is refused; δ-SPH gets its default table."""
        for method, tables in METHOD_TABLES.items():
            if method == self.method:
                continue
            for key in tables:
                if key in self.model_fields_set and getattr(self, key) is not None:
                    raise InvalidValue(
                        key,
                        f"belongs to fluid.method = {method!r}, but fluid.method = "
                        f"{self.method!r} (whose numerical keys are "
                        f"{', '.join('fluid.' + k for k in METHOD_TABLES[self.method])}); remove it",
                        getattr(self, key).model_dump(exclude_unset=True),
                    )
        if self.method == "delta-sph":
            if self.sph is None:
                object.__setattr__(self, "sph", DeltaSPHSection())
            c = self.sph.central_field_center
            if c is not None and len(c) != self.dim:
                raise InvalidValue(
                    "sph.central_field_center",
                    f"must have {self.dim} components (dim = {self.dim})",
                    c,
                )
        return self

    @model_validator(mode="after")
    def _check(self) -> FluidSection:
        d = self.dim
        pr = self.pressure
        if pr.wall_acceleration and (
            pr.wall_model != "neumann"
            or pr.source_term != "thesis_mixed"
            or pr.laplacian != "standard"
        ):
            raise InvalidValue(
                "pressure.wall_acceleration",
                "needs wall_model = 'neumann', source_term = 'thesis_mixed' and laplacian = "
                f"'standard' (given {pr.wall_model!r}, {pr.source_term!r}, {pr.laplacian!r}): the "
                "other models' wall terms do not carry the walls' acceleration",
                True,
            )
        if pr.source_filter != "none" and pr.source_term != "thesis_mixed":
            raise InvalidValue(
                "pressure.source_filter",
                f"filters the divergence of eq. 2-15 and needs source_term = 'thesis_mixed' "
                f"(given {pr.source_term!r}, whose higher-order source has no such divergence)",
                pr.source_filter,
            )
        if pr.compressed_start and (pr.compressibility == 0.0 or not self.hydrostatic_start):
            raise InvalidValue(
                "pressure.compressed_start",
                "needs fluid.pressure.compressibility > 0 and fluid.hydrostatic_start = true "
                f"(given compressibility = {pr.compressibility:g}, hydrostatic_start = "
                f"{str(self.hydrostatic_start).lower()}): only weakly compressible still water "
                "has a compressed equilibrium to start from",
                True,
            )
        if pr.buried_walls != "dry" and pr.wall_model != "neumann":
            raise InvalidValue(
                "pressure.buried_walls",
                f"needs wall_model = 'neumann' (given {pr.wall_model!r}): the pressure-layer "
                "model's walls are unknowns, not ghosts",
                pr.buried_walls,
            )
        if (  # MPS only: δ-SPH's pressure pairs are antisymmetric (seed eqs. 6, 12)
            self.method == "mps"
            and self.boundary_force == "momentum_exchange"
            and self.pressure.gradient not in ("tanaka", "cmps")
        ):
            raise InvalidValue(
                "boundary_force",
                f"'momentum_exchange' needs an antisymmetric pressure gradient "
                f"(fluid.pressure.gradient = 'tanaka' or 'cmps'), not "
                f"{self.pressure.gradient!r}: with it the fluid-fluid pairs do not cancel and "
                "the pair exchange with walls misses most of their push (docs/fluid.md, "
                "momentum budget); use 'pressure_and_contact' or 'pressure_integral'",
                self.boundary_force,
            )
        if len(self.gravity) != d:
            raise InvalidValue("gravity", f"must have {d} components (dim = {d})", self.gravity)
        for key in ("domain_lower", "domain_upper"):
            corner = getattr(self, key)
            if corner is not None and len(corner) != d:
                raise InvalidValue(key, f"must have {d} components (dim = {d})", corner)
        lo, hi = self.domain_lower, self.domain_upper
        if lo is not None and hi is not None:
            for a in range(d):
                if not lo[a] < hi[a]:
                    raise InvalidValue(
                        "domain_upper",
                        f"must exceed domain_lower = {lo} in every axis (axis {a})",
                        hi,
                    )
        for i, b in enumerate(self.blocks):
            if len(b.lower) != d:
                raise InvalidValue(
                    f"blocks[{i}].lower", f"must have {d} components (dim = {d})", b.lower
                )
            if b.velocity is not None and len(b.velocity) != d:
                raise InvalidValue(
                    f"blocks[{i}].velocity", f"must have {d} components (dim = {d})", b.velocity
                )
            if any(u - lo < self.spacing for lo, u in zip(b.lower, b.upper, strict=True)):
                raise InvalidValue(
                    f"blocks[{i}].upper",
                    f"the block from lower = {b.lower} is thinner than one spacing "
                    f"{self.spacing} in some axis",
                    b.upper,
                )
        for i, w in enumerate(self.walls):
            if w.shape == "polygon" and d != 2:
                raise InvalidValue(
                    f"walls[{i}].shape",
                    f"'polygon' walls are 2D only (dim = {d}); use 'box' in 3D",
                    w.shape,
                )
            if len(w.lower) != d:
                raise InvalidValue(
                    f"walls[{i}].lower", f"must have {d} components (dim = {d})", w.lower
                )
            if w.motion.direction is not None and len(w.motion.direction) != d:
                raise InvalidValue(
                    f"walls[{i}].motion.direction",
                    f"must have {d} components (dim = {d})",
                    w.motion.direction,
                )
            if w.shape == "box":
                for a, (lo, u) in enumerate(zip(w.lower, w.upper, strict=True)):
                    if round((u - lo) / self.spacing) < 2:
                        raise InvalidValue(
                            f"walls[{i}].upper",
                            f"the box from lower = {w.lower} is {u - lo:g} m thick along axis "
                            f"{a}: a solid box needs at least 2 spacings (2 l0 = "
                            f"{2 * self.spacing:g} m), else its opposite faces share particles "
                            "whose normals cancel (force probes read 0); a thinner member belongs "
                            "in [structure] (both faces, thin-member handling)",
                            w.upper,
                        )
        for i, z in enumerate(self.sponges):
            if z.axis >= d:
                raise InvalidValue(f"sponges[{i}].axis", f"must be below dim = {d}", z.axis)
        ts = self.time_step
        if self.viscosity > 0.0:
            viscous_dt = ts.viscous_number * self.spacing**2 / self.viscosity
            if not viscous_dt >= ts.dt_min:
                raise InvalidValue(
                    "viscosity",
                    f"limits the time step to time_step.viscous_number x spacing^2 / viscosity "
                    f"= {viscous_dt:.3g} s, below time_step.dt_min = {ts.dt_min} s: the run "
                    "could not take a step (lower the viscosity or dt_min, or coarsen spacing)",
                    self.viscosity,
                )
        rate = sum(z.coefficient for z in self.sponges)
        if rate * self.time_step.dt_max > 1.0:
            raise InvalidValue(
                "time_step.dt_max",
                f"times the summed sponge coefficients {rate:g} 1/s is "
                f"{rate * self.time_step.dt_max:.3g}: the explicit sponge factor 1 - dt alpha_s r "
                f"(thesis eq. 3-9) needs dt_max <= {1.0 / rate:.3g} s (or smaller "
                "fluid.sponges[*].coefficient)",
                self.time_step.dt_max,
            )
        dom_lo, dom_hi = self.domain_lower, self.domain_upper
        for i, b in enumerate(self.blocks):
            below = dom_lo is not None and any(b.lower[a] < dom_lo[a] for a in range(d))
            above = dom_hi is not None and any(b.upper[a] > dom_hi[a] for a in range(d))
            if below or above:
                raise InvalidValue(
                    "domain_lower" if below else "domain_upper",
                    f"leaves fluid.blocks[{i}] ({b.lower} .. {b.upper}) partly outside the "
                    "domain; a fluid particle outside it stops the run: the domain must contain "
                    "every block",
                    dom_lo if below else dom_hi,
                )
        eps = 1e-9
        for i, b in enumerate(self.blocks):
            for j, t in enumerate(self.walls):
                if t.shape != "tank":
                    continue
                inside = (
                    all(
                        t.lower[k] - eps <= b.lower[k] and b.upper[k] <= t.upper[k] + eps
                        for k in range(d - 1)
                    )
                    and b.lower[d - 1] >= t.lower[d - 1] - eps
                )
                if not inside:
                    raise InvalidValue(
                        f"blocks[{i}]",
                        f"({b.lower} .. {b.upper}) lies outside the tank walls[{j}] "
                        f"({t.lower} .. {t.upper})",
                    )
        return self
