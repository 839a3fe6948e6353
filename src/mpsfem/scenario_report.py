"""What ``mpsfem validate`` tells a user before a run: particle counts by kind, memory and run
time estimates, contact problems between members and walls, and a one-line verdict.

Counts are exact for the fluid scene (the particles are built, as a run of the scenario's
``fluid.method`` builds them: δ-SPH lays wall layers for its 2h support; a coupled member's
surface particles are estimated from its length, thickness and the wall layers). Memory is the
per-particle footprint the benchmarks measured for the method (scenario/limits.py; the 3D figures
are guesses). Run time: a rough estimate, steps = end time / dt and the one-thread cost of a
particle-step:

- MPS: dt from the Courant number at the free-fall speed of the highest fluid (or the blocks'
  initial speed) and the viscous limit; the dam-break benchmark's cost per particle-step;
- δ-SPH: explicit, dt from the artificial sound speed c0 (fluid.sph.sound_speed or the default
  10 max(U, sqrt(g H)), seed eq. 1): dt = cfl h / (c0 + u), the force and artificial-viscosity
  limits and dt_max, as the solver takes them (fluid_sph/solver.py ``stable_dt``); each step
  costs 4 right-hand sides with RK4 (1 with the leapfrog) at the cost per particle and right-hand
  side that benchmarks/bench_delta_sph.py measured.

Coupled windows add the structure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mpsfem.fluid_mps.geometry import build_particles, scene_corners
from mpsfem.fluid_mps.particle_kinds import KIND_NAMES
from mpsfem.fluid_sph.solver import DEFAULT_CFL, VISCOUS_LIMIT
from mpsfem.scenario.limits import bytes_per_particle, wall_layers
from mpsfem.scenario.schema import Scenario

#: one-thread cost of an MPS particle-step, s (benchmarks/results/dam_break.md: 3.9 us in 2D
#: at 64.8k; 3D from benchmarks/results/still_water_3d.md, rounded up)
COST_PER_PARTICLE_STEP = {2: 4e-6, 3: 1.5e-5}
#: one-thread cost of a δ-SPH right-hand side per particle (all particles), s: 2D 0.26 us of CPU
#: time at 68k particles, 0.21 us at 5k (benchmarks/results/delta_sph_rhs.csv, δ-SPHC h = 1.3 l0;
#: CPU time, what one thread costs on an idle core); 3D 0.60-0.73 us at 20k-38k particles
#: (delta_sph_rhs_3d.csv), rounded up
COST_PER_PARTICLE_RHS = {2: 0.26e-6, 3: 1.0e-6}
#: right-hand sides per δ-SPH step of each fluid.sph.integrator
RHS_PER_STEP = {"rk4": 4, "symplectic": 1}


@dataclass
class Report:
    """The summary lines and the warnings (contact problems)."""

    lines: list[str]
    warnings: list[str]
    verdict: str


def _fluid_height(scenario: Scenario) -> float:
    """Height of the fluid above the lowest fluid particle along gravity, m."""
    f = scenario.fluid
    up = f.vertical_axis
    lo = min(b.lower[up] for b in f.blocks)
    hi = max(b.upper[up] for b in f.blocks)
    return hi - lo


def _flow_speed(scenario: Scenario) -> float:
    """The free-fall speed from the fluid's height or the blocks' fastest initial speed, m/s."""
    f = scenario.fluid
    g = float(np.linalg.norm(f.gravity))
    speed = math.sqrt(2.0 * g * _fluid_height(scenario))
    for b in f.blocks:
        if b.velocity is not None:
            speed = max(speed, float(np.linalg.norm(b.velocity)))
    return speed


def _delta_sph_time_estimate(scenario: Scenario, n_all: int) -> tuple[int, float, str]:
    """(steps, seconds on one thread, how dt was estimated) of a δ-SPH run: the limits of the
    solver's ``stable_dt`` with u the free-fall speed and a = |g|."""
    f = scenario.fluid
    sph = f.sph
    h = sph.smoothing_ratio * f.spacing
    c0 = f.sph_sound_speed()  # as the solver sets it
    speed = _flow_speed(scenario)
    cfl = sph.cfl if sph.cfl is not None else DEFAULT_CFL[sph.integrator]
    dt = f.time_step.dt_max
    why = "dt_max"
    if c0 > 0.0 and cfl * h / (c0 + speed) < dt:  # acoustic Courant condition
        dt = cfl * h / (c0 + speed)
        why = f"acoustic Courant {cfl:g} h / (c0 + u), c0 = {c0:.3g} m/s, u = {speed:.3g} m/s"
    g = float(np.linalg.norm(f.gravity))
    if g > 0.0 and 0.25 * math.sqrt(h / g) < dt:  # force condition (Monaghan 1992)
        dt = 0.25 * math.sqrt(h / g)
        why = "the force condition 0.25 sqrt(h / g)"
    ramp = f.sponges and sph.damping == "viscosity"  # the seed eq. 4 viscosity ramp
    alpha = max(sph.viscosity_alpha, sph.damping_alpha if ramp else 0.0)
    if sph.viscosity_form == "antuono":  # the kernels read alpha / (2 (n + 2))
        alpha /= 2.0 * (f.dim + 2)
    if alpha > 0.0 and c0 > 0.0:
        limit = VISCOUS_LIMIT[sph.integrator] * h / (alpha * c0)  # artificial viscosity
        if limit < dt:
            dt = limit
            why = f"the artificial viscosity's limit (alpha {alpha:g}, c0 = {c0:.3g} m/s)"
    steps = math.ceil(scenario.run.end_time / dt)
    rhs = RHS_PER_STEP[sph.integrator]
    return steps, steps * rhs * n_all * COST_PER_PARTICLE_RHS[f.dim], why


def _time_estimate(scenario: Scenario, n_all: int) -> tuple[int, float, str]:
    """(steps, seconds on one thread, how dt was estimated) of an MPS run."""
    f = scenario.fluid
    ts = f.time_step
    speed = _flow_speed(scenario)
    dt = ts.dt_max
    why = "dt_max"
    if speed > 0.0 and ts.courant * f.spacing / speed < dt:
        dt = ts.courant * f.spacing / speed
        why = f"Courant {ts.courant:g} at {speed:.3g} m/s (free fall from the fluid's height)"
    if f.viscosity > 0.0 and ts.viscous_number * f.spacing**2 / f.viscosity < dt:
        dt = ts.viscous_number * f.spacing**2 / f.viscosity
        why = "the viscous limit"
    steps = math.ceil(scenario.run.end_time / dt)
    return steps, steps * n_all * COST_PER_PARTICLE_STEP[f.dim], why


def _member_particles(scenario: Scenario, layers: int) -> int:
    """Surface particles the fluid lays for the coupled members (both faces, all layers)."""
    if scenario.structure is None or scenario.fluid is None:
        return 0
    l0 = scenario.fluid.spacing
    n = 0
    for m in scenario.structure.members:
        if getattr(m, "type", "") == "beam":
            length = float(np.linalg.norm(np.subtract(m.end, m.start)))
            n += 2 * layers * max(1, round(length / l0))
        else:
            n += 2 * layers * max(1, round(m.extent / l0)) ** 2
    return n


def _box_distance(p: np.ndarray, lo: np.ndarray, hi: np.ndarray, tank: bool) -> float:
    """Distance (m) from point ``p`` to the solid of a wall: a tank's solid is outside its box
    (negative: p is in the solid), a box's solid its inside."""
    if tank:
        return float(min(np.min(p - lo), np.min(hi - p)))
    outside = np.maximum(np.maximum(lo - p, p - hi), 0.0)
    dist = float(np.linalg.norm(outside))
    return dist if dist > 0.0 else -float(np.min(np.minimum(p - lo, hi - p)))


def contact_problems(scenario: Scenario) -> list[str]:
    """2D beams against the rigid walls: a free end closer to a wall than two spacings (flow
    through such a gap needs 2-3 particle rows; docs/fluid.md, "Narrow gaps"), or a member's
    body inside a wall away from its supported ends."""
    f, st = scenario.fluid, scenario.structure
    if f is None or st is None or f.dim != 2:
        return []
    l0 = f.spacing
    walls = [
        (key, np.asarray(lo), np.asarray(hi), w.shape == "tank")
        for (key, lo, hi), w in zip(scene_corners(f)[len(f.blocks) :], f.walls, strict=True)
    ]
    out = []
    for i, m in enumerate(st.members):
        if getattr(m, "type", "") != "beam":
            continue
        a, b = np.asarray(m.start, float), np.asarray(m.end, float)
        length = float(np.linalg.norm(b - a))
        t = (b - a) / length
        n = np.array([-t[1], t[0]])
        half = 0.5 * m.fluid_thickness
        bc = [m.bc, m.bc] if isinstance(m.bc, str) else list(m.bc)
        name = f"structure.members[{i}] ({m.name})"
        for end, point, sign in ((0, a, -1.0), (1, b, 1.0)):
            if bc[end] != "free":
                continue
            face = [point + sign * 0.5 * l0 * t + s * half * n for s in (-1.0, 0.0, 1.0)]
            for key, lo, hi, tank in walls:
                gap = min(_box_distance(p, lo, hi, tank) for p in face)
                if 0.0 < gap < 2.0 * l0:
                    out.append(
                        f"{name}: its free {'start' if end == 0 else 'end'} is {gap:.3g} m "
                        f"({gap / l0:.2f} spacings) from {key}: fluid passes a gap only with 2-3 "
                        "particle rows; widen the gap or refine fluid.spacing"
                    )
        inner = [a + s * (b - a) for s in np.linspace(0.0, 1.0, 21)]
        inner = [p for p in inner if min(np.linalg.norm(p - a), np.linalg.norm(p - b)) > l0]
        for key, lo, hi, tank in walls:
            if any(_box_distance(p, lo, hi, tank) < 0.0 for p in inner):
                out.append(f"{name} meets {key}: part of its mid-line lies inside the wall")
    return out


def report(scenario: Scenario, title: str = "") -> Report:
    """The summary of a validated scenario (see the module docstring)."""
    lines: list[str] = []
    warnings = contact_problems(scenario)
    n_all = 0
    time_text = ""
    if scenario.fluid is not None:
        f = scenario.fluid
        layers = wall_layers(f)
        delta = f.method == "delta-sph"
        # the δ-SPH solver fills its 2h support with dummy layers (fluid_sph/solver.py)
        ps = build_particles(f.model_copy(update={"dummy_layers": layers - 1}) if delta else f)
        kinds, counts = np.unique(ps.kind, return_counts=True)
        by_kind = {KIND_NAMES[int(k)]: int(c) for k, c in zip(kinds, counts, strict=True)}
        members = _member_particles(scenario, layers)
        if members:
            by_kind["structure surfaces (estimate)"] = members
        n_all = int(sum(by_kind.values()))
        lines.append(
            "particles: " + ", ".join(f"{v} {k}" for k, v in by_kind.items()) + f" ({n_all} in all)"
        )
        each = bytes_per_particle(f)
        method = "δ-SPH" if delta else "MPS"
        lines.append(
            f"memory: about {n_all * each / 2**20:.0f} MiB ({each} B per particle, {method})"
        )
        if delta:
            steps, seconds, why = _delta_sph_time_estimate(scenario, n_all)
            rhs = RHS_PER_STEP[f.sph.integrator]
            cost = (
                f"δ-SPH, explicit: {rhs} right-hand side(s) a step ({f.sph.integrator}) at "
                f"{COST_PER_PARTICLE_RHS[f.dim] * 1e6:g} us per particle each "
                "(benchmarks/bench_delta_sph.py)"
            )
        else:
            steps, seconds, why = _time_estimate(scenario, n_all)
            cost = "MPS, the dam-break benchmark's cost per particle-step"
        time_text = f"{seconds / 60:.1f} min" if seconds >= 60 else f"{seconds:.0f} s"
        lines.append(
            f"run time: about {steps} fluid steps (dt from {why}), roughly {time_text} on one "
            f"thread ({cost}; splashing flows take more)"
        )
    if scenario.structure is not None:
        text = f"structure: {len(scenario.structure.members)} member(s)"
        ratios = scenario.mass_ratios()  # docs/coupler.md, "Light members"
        if ratios:
            each = ", ".join(f"{name} {r:.3g}" for name, r in ratios.items())
            H = scenario.fluid.water_height
            text += f"; mass ratio (rho_s h) / (rho_w H), H = {H:.3g} m: {each}"
        lines.append(text)
    lines.extend(f"warning: {w}" for w in warnings)
    what = title or "scenario"
    verdict = f"valid: {what}" + (
        f"; {n_all} particles, about {time_text} on one thread" if n_all else ""
    )
    verdict += f"; {len(warnings)} warning(s)" if warnings else "; no contact problems"
    return Report(lines, warnings, verdict)
