"""3D benchmark: run time against pressure error of still water (scenarios/hydrostatic_3d.toml).

Still water H = 0.15 m in a 0.1 m x 0.1 m tank at l0 = 10, 6.25 and 4 mm (1 500, 6 144 and
23 750 fluid particles; the tank's wall and dummy layers are most of the rest). Prints a table and
writes benchmarks/results/still_water_3d.csv with, per resolution: fluid and all particles, steps,
wall time, microseconds per fluid-particle-step and per particle-step, the stage breakdown
(neighbour search, explicit operators, pressure assembly, pressure solve), pressure-solve
iterations per step, peak memory per particle (slope of peak RSS between the two largest runs, all
particles counted) and the error of the gauge 0.05 m above the floor against rho g (H - 0.05),
time-averaged over the run, H the depth of the lattice's whole layers.

Each resolution runs in its own process so that peak RSS is measured per run.

    python benchmarks/bench_still_water_3d.py [--sizes 1k,6k,23k] [--end-time 0.2] [--threads 1]
"""

from __future__ import annotations

import resource
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from child_runs import benchmark_main, stage_columns, stage_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SCENARIO = ROOT / "scenarios" / "hydrostatic_3d.toml"
RHO, G, Z_GAUGE = 1000.0, 9.81, 0.05
SPACINGS = {"1k": 0.01, "6k": 0.00625, "23k": 0.004}


def one_run(spacing: float, end_time: float, threads: int, overrides: list[str]) -> dict:
    """Run in this process and return the measurements (called in a child process)."""
    import numba

    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    numba.set_num_threads(threads)
    base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    # warm-up on the coarsest scene: numba compiles per argument type, not per size, so the
    # peak memory is the measured solver's alone
    coarse = load_scenario(SCENARIO, [*overrides, f"fluid.spacing={SPACINGS['1k']}"])
    warm = FluidSolver(coarse.scenario.fluid)
    for _ in range(3):
        warm.step(warm.dt_next)
    del warm
    sc = load_scenario(SCENARIO, [*overrides, f"fluid.spacing={spacing}"]).scenario
    gauge = next(p for p in sc.probes if p.name == "gauge")
    solver = FluidSolver(sc.fluid)
    # the water depth the lattice holds: the block's 0.15 m rounded to whole layers (38 layers
    # of 4 mm are 0.152 m)
    depth = float(solver.pos[solver.kind == 0, 2].max()) + 0.5 * spacing
    pressures = []
    t0 = time.perf_counter()
    while solver.t < end_time - 1e-12:
        solver.step(min(solver.dt_next, end_time - solver.t))
        pressures.append(float(solver.probe_value(gauge)))
    wall = time.perf_counter() - t0
    steps = solver.step_count
    exact = RHO * G * (depth - Z_GAUGE)
    return {
        "spacing": spacing,
        "fluid_particles": int(solver.n_fluid),
        "all_particles": int(solver.n),
        "steps": steps,
        "wall_s": wall,
        "us_per_fluid_particle_step": wall / (steps * solver.n_fluid) * 1e6,
        "us_per_particle_step": wall / (steps * solver.n) * 1e6,
        **stage_columns(solver),
        "neighbour_builds": solver.search.builds,
        "peak_rss_kib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss,
        "base_rss_kib": base_rss,
        "depth_m": depth,
        "gauge_mean_pa": float(np.mean(pressures)),
        "gauge_exact_pa": exact,
        "gauge_error": float(np.mean(pressures)) / exact - 1.0,
        "threads": threads,
    }


def describe(row: dict) -> str:
    """One printed line of the table."""
    return (
        f"{row['fluid_particles']:>6d} fluid {row['all_particles']:>6d} all  "
        f"{row['steps']:>4d} steps  {row['wall_s']:7.1f} s  "
        f"{row['us_per_fluid_particle_step']:6.2f} us/fluid-particle-step "
        f"({row['us_per_particle_step']:.2f} per particle)  {stage_text(row)}  "
        f"{row['iterations_per_step']:.1f} it/step  "
        f"gauge {row['gauge_error'] * 100:+.2f} %"
    )


def main() -> None:
    benchmark_main(
        __doc__.splitlines()[0],
        __file__,
        one_run,
        SPACINGS,
        describe,
        end_time=0.2,
        threads=1,
        out=ROOT / "benchmarks" / "results" / "still_water_3d.csv",
    )


if __name__ == "__main__":
    main()
