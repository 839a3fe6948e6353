"""Still water (references.md section 1): gauge pressure, linear profile, no escape, no spurious
free surface. The whole 2 s of scenarios/hydrostatic_2d.toml runs here (about 10 s)."""

import numpy as np
import pytest

from mpsfem.fluid_mps.particle_kinds import FLUID
from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.loader import load_scenario

RHO, G, H = 1000.0, 9.81, 0.5


@pytest.fixture(scope="module")
def settled(request):
    root = request.config.rootpath
    sc = load_scenario(root / "scenarios" / "hydrostatic_2d.toml").scenario
    solver = FluidSolver(sc.fluid)
    gauge = sc.probes[0]
    times, values, spurious = [], [], []
    while solver.t < sc.run.end_time - 1e-12:
        solver.step(solver.dt_towards(sc.run.end_time))
        times.append(solver.t)
        values.append(solver.probe_value(gauge))
        if solver.t > 1.0:
            inner = (solver.kind == FLUID) & (solver.pos[:, 1] < H - 3.0 * solver.l0)
            spurious.append(int(np.count_nonzero(solver.free_surface[inner])))
    return solver, np.array(times), np.array(values), spurious


@pytest.mark.xfail(
    strict=True,
    reason="still water gathers spurious velocities of ~0.1 m/s within 1 s (fluid volume drifts "
    "by ~1.5 %); the gauge mean is ~8 % high and particles splash above the surface "
    "(docs/fluid.md, open in issue 2)",
)
def test_gauge_pressure_within_2_percent(settled):
    _, t, p = settled[:3]
    expected = RHO * G * (H - 0.05)
    mean = p[t >= 1.0].mean()
    print(f"gauge mean {mean:.1f} Pa vs {expected:.1f} Pa ({(mean / expected - 1) * 100:+.2f} %)")
    assert abs(mean / expected - 1.0) < 0.02


@pytest.mark.xfail(
    strict=True,
    reason="still water gathers spurious velocities of ~0.1 m/s within 1 s (fluid volume drifts "
    "by ~1.5 %); the gauge mean is ~8 % high and particles splash above the surface "
    "(docs/fluid.md, open in issue 2)",
)
def test_profile_linear_with_slope_rho_g(settled):
    solver = settled[0]
    f = (solver.kind == FLUID) & (solver.free_surface == 0)
    y, p = solver.pos[f, 1], solver.p[f]
    slope, icpt = np.polyfit(y, p, 1)
    resid = p - (slope * y + icpt)
    print(
        f"slope {slope:.1f} Pa/m vs {-RHO * G:.1f}; rms deviation from the line {resid.std():.1f} Pa"
    )
    assert abs(slope / (-RHO * G) - 1.0) < 0.02
    assert resid.std() < 0.02 * RHO * G * H


@pytest.mark.xfail(
    strict=True,
    reason="still water gathers spurious velocities of ~0.1 m/s within 1 s (fluid volume drifts "
    "by ~1.5 %); the gauge mean is ~8 % high and particles splash above the surface "
    "(docs/fluid.md, open in issue 2)",
)
def test_no_particle_leaves_the_tank(settled):
    solver = settled[0]
    f = solver.kind == FLUID
    x, y = solver.pos[f, 0], solver.pos[f, 1]
    assert (x > 0).all() and (x < 0.4).all() and (y > 0).all() and (y < H + solver.l0).all()


def test_no_spurious_free_surface_inside(settled):
    spurious = settled[3]
    print(f"max interior surface flags after settling: {max(spurious)}")
    assert max(spurious) == 0
