"""Still water (references.md section 1): gauge pressure, linear profile, no escape, no spurious
free surface. The whole 2 s of scenarios/hydrostatic_2d.toml runs here (about 10 s)."""

import numpy as np
import pytest

from mpsfem.fluid_mps.particle_kinds import FLUID
from mpsfem.fluid_mps.solver import FluidSolver
from mpsfem.scenario.base import ScenarioError
from mpsfem.scenario.loader import load_scenario

RHO, G, H = 1000.0, 9.81, 0.5


@pytest.fixture(scope="module")
def settled(request):
    root = request.config.rootpath
    sc = load_scenario(root / "scenarios" / "hydrostatic_2d.toml").scenario
    solver = FluidSolver(sc.fluid)
    gauge = sc.probes[0]
    times, values, spurious, samples = [], [], [], []
    while solver.t < sc.run.end_time - 1e-12:
        solver.step(solver.dt_towards(sc.run.end_time))
        times.append(solver.t)
        values.append(solver.probe_value(gauge))
        if solver.t > 1.0:
            inner = (solver.kind == FLUID) & (solver.pos[:, 1] < H - 3.0 * solver.l0)
            spurious.append(int(np.count_nonzero(solver.free_surface[inner])))
            if solver.step_count % 25 == 0:  # every 0.05 s: the profile's time mean
                f = (solver.kind == FLUID) & (solver.free_surface == 0)
                samples.append((solver.pos[f, 1].copy(), solver.p[f].copy()))
    return solver, np.array(times), np.array(values), spurious, samples


def test_gauge_pressure_within_2_percent(settled):
    _, t, p = settled[:3]
    expected = RHO * G * (H - 0.05)
    mean = p[t >= 1.0].mean()
    print(f"gauge mean {mean:.1f} Pa vs {expected:.1f} Pa ({(mean / expected - 1) * 100:+.2f} %)")
    assert abs(mean / expected - 1.0) < 0.02


def test_profile_linear_with_slope_rho_g(settled):
    """The time-mean profile over 1-2 s (20 snapshots of every non-surface fluid particle): its
    least-squares slope within 2 % of -rho g, and its mean in layers of one spacing within
    2 % of rho g H of that line (linear). One snapshot alone carries the pressure noise of the
    projection (its rms is reported)."""
    solver, samples = settled[0], settled[4]
    y = np.concatenate([s[0] for s in samples])
    p = np.concatenate([s[1] for s in samples])
    slope, icpt = np.polyfit(y, p, 1)
    resid = p - (slope * y + icpt)
    layer = np.floor(y / solver.l0).astype(int)
    means = np.array([resid[layer == k].mean() for k in np.unique(layer)])
    y_last, p_last = samples[-1]
    s_last = np.polyfit(y_last, p_last, 1)[0]
    print(
        f"time-mean slope {slope:.1f} Pa/m vs {-RHO * G:.1f}; largest layer-mean deviation "
        f"{np.abs(means).max():.1f} Pa; one snapshot: slope {s_last:.1f} Pa/m, rms noise "
        f"{resid.std():.1f} Pa"
    )
    assert len(samples) >= 15
    assert abs(slope / (-RHO * G) - 1.0) < 0.02
    assert np.abs(means).max() < 0.02 * RHO * G * H


def test_no_particle_leaves_the_tank(settled):
    solver = settled[0]
    f = solver.kind == FLUID
    x, y = solver.pos[f, 0], solver.pos[f, 1]
    assert (x > 0).all() and (x < 0.4).all() and (y > 0).all() and (y < H + solver.l0).all()


def test_no_spurious_free_surface_inside(settled):
    spurious = settled[3]
    print(f"max interior surface flags after settling: {max(spurious)}")
    assert max(spurious) == 0


def _still_water_compression(root, kappa: float) -> tuple[float, float, float]:
    """Run still water 1 s with artificial compressibility kappa (1/Pa); over 0.5-1 s return the
    gauge's time mean (Pa), the interior particles' mean n / n0 - 1 and their mean hydrostatic
    pressure rho g (H - y) (Pa)."""
    sc = load_scenario(
        root / "scenarios" / "hydrostatic_2d.toml", [f"fluid.pressure.compressibility={kappa}"]
    ).scenario
    solver = FluidSolver(sc.fluid)
    gauge, strain, p_mean = [], [], []
    while solver.t < 1.0 - 1e-12:
        solver.step(solver.dt_towards(1.0))
        if solver.t >= 0.5:
            inner = (solver.kind == FLUID) & (solver.free_surface == 0)
            gauge.append(solver.probe_value(sc.probes[0]))
            strain.append(solver.number_density[inner].mean() / solver.n0_n - 1.0)
            p_mean.append(RHO * G * np.mean(H - solver.pos[inner, 1]))
    return float(np.mean(gauge)), float(np.mean(strain)), float(np.mean(p_mean))


def test_artificial_compressibility_compresses_still_water_by_kappa_p(request):
    """With kappa = 1e-6 1/Pa (sound speed 31.6 m/s) still water keeps its hydrostatic pressure
    (gauge within 2 %) and is compressed by kappa p: the interior's mean n / n0 rises by kappa
    times its mean pressure, 0.25 %, over the incompressible run's (whose lattice disorder alone
    reads -0.2 %). Measured: +0.06 % at the gauge, a rise of 0.23 %. 25 % is allowed on the rise
    (the two runs' disorders differ). The diagonal term alone would compress it by kappa p /
    gamma, 25 % (pressure_poisson.py)."""
    root = request.config.rootpath
    kappa = 1e-6
    gauge, strain, p_mean = _still_water_compression(root, kappa)
    _, strain0, _ = _still_water_compression(root, 0.0)
    expected = RHO * G * (H - 0.05)
    rise = strain - strain0
    print(f"gauge {gauge:.1f} Pa vs {expected:.1f}; n/n0 rise {rise:.5f} vs {kappa * p_mean:.5f}")
    assert abs(gauge / expected - 1.0) < 0.02
    assert rise == pytest.approx(kappa * p_mean, rel=0.25)


def _column_breathing(root, compressed_start: bool) -> tuple[float, float, float]:
    """Still water with kappa = 1e-5 1/Pa (c = 10 m/s, quarter-wave period 4 H / c = 0.2 s)
    over 0.5 s: the range (m) of the fluid's centre-of-mass height, the gauge's standard
    deviation (Pa) over 0.25-0.5 s, and how far the compressed start lowered the top (m)."""
    sets = [
        "fluid.pressure.compressibility=1e-5",
        f"fluid.pressure.compressed_start={str(compressed_start).lower()}",
    ]
    sc = load_scenario(root / "scenarios" / "hydrostatic_2d.toml", sets).scenario
    solver = FluidSolver(sc.fluid)
    fluid = solver.kind == FLUID
    height, gauge = [solver.pos[fluid, 1].mean()], []
    while solver.t < 0.5 - 1e-12:
        solver.step(solver.dt_towards(0.5))
        height.append(solver.pos[fluid, 1].mean())
        if solver.t >= 0.25:
            gauge.append(solver.probe_value(sc.probes[0]))
    return float(np.ptp(height)), float(np.std(gauge)), solver.compressed_drop


def test_compressed_start_keeps_weakly_compressible_still_water_still(request):
    """From the uncompressed lattice the column settles by about kappa rho g H^2 / (2 s) (8.8 mm
    here, s = 1.34 the lattice's uniaxial response) and breathes in its quarter-wave mode;
    started compressed it stays within the lattice disorder's own settling (the incompressible
    run's centre of mass moves 0.2 mm). Measured: 0.58 mm against 6.6 mm, gauge standard
    deviation 77 Pa against 337 Pa (the incompressible run's: 198 Pa). Allowed: 15 % of the
    settling for the compressed start, and at least half of it without (so the test fails if
    the start did nothing); the gauge's deviation at most half the uncompressed start's."""
    root = request.config.rootpath
    moved, noise, drop = _column_breathing(root, True)
    moved0, noise0, drop0 = _column_breathing(root, False)
    print(
        f"centre of mass range {moved:.2e} / {moved0:.2e} m, gauge std {noise:.0f} / {noise0:.0f} Pa"
    )
    assert drop0 == 0.0 and drop == pytest.approx(8.84e-3, rel=0.01)
    assert moved < 0.15 * drop
    assert moved0 > 0.5 * drop
    assert noise < 0.5 * noise0


def test_compressed_start_refused_without_compressibility(request):
    scene = request.config.rootpath / "scenarios" / "hydrostatic_2d.toml"
    with pytest.raises(ScenarioError, match=r"fluid\.pressure\.compressed_start.*compressibility"):
        load_scenario(scene, ["fluid.pressure.compressed_start=true"])
    with pytest.raises(ScenarioError, match=r"compressed_start.*hydrostatic_start = false"):
        load_scenario(
            scene,
            [
                "fluid.pressure.compressed_start=true",
                "fluid.pressure.compressibility=1e-6",
                "fluid.hydrostatic_start=false",
            ],
        )
