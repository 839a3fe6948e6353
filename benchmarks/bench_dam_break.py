"""Dam-break benchmark: run time against front error at about 4k, 16k and 64k fluid particles.

Prints a table and writes benchmarks/results/dam_break.csv with, per resolution: particles, steps,
wall time, microseconds per particle-step (wall, and the run's own CPU time: on a shared
machine the CPU figure is the one to compare back to back), the stage breakdown (neighbour search, explicit
operators, pressure assembly, pressure solve, I/O), pressure-solve iterations per step, peak
memory per particle (slope of peak RSS between the two largest runs, interpreter baseline
excluded) and the RMS relative front error against Koshizuka & Oka (1996) over 0.5 <= T <= 3.

Each resolution runs in its own process so that peak RSS is measured per run.

    python benchmarks/bench_dam_break.py [--sizes 4k,16k,64k] [--end-time 0.27] [--threads 2]
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
L, G = 0.146, 9.81
# column L x 2L: n = (L / l0) * (2 L / l0) fluid particles
SPACINGS = {"4k": L / 45, "16k": L / 90, "64k": L / 180}


def front_error(times: np.ndarray, front: np.ndarray) -> float:
    ref = np.loadtxt(
        ROOT / "reference_data" / "dam_break_front_koshizuka_oka_1996.csv",
        delimiter=",",
        comments="#",
        skiprows=3,
    )
    T, Z = times * np.sqrt(2 * G / L), front / L
    sel = (ref[:, 0] >= 0.5) & (ref[:, 0] <= 3.0) & (ref[:, 0] <= T[-1])
    z = np.interp(ref[sel, 0], T, Z)
    return float(np.sqrt(np.mean(((z - ref[sel, 1]) / ref[sel, 1]) ** 2)))


def one_run(spacing: float, end_time: float, threads: int, overrides: list[str]) -> dict:
    """Run in this process and return the measurements (called in a child process)."""
    import numba

    from mpsfem.fluid_mps.solver import FluidSolver
    from mpsfem.scenario.loader import load_scenario

    numba.set_num_threads(threads)
    base_rss = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    loaded = load_scenario(
        ROOT / "scenarios" / "dam_break_2d.toml", [*overrides, f"fluid.spacing={spacing}"]
    )
    sc = loaded.scenario
    front = next(p for p in sc.probes if p.kind == "front")
    # warm-up: compile every kernel on a few steps of the same scene at L/10 (numba compiles per
    # argument type, not per size), so the peak memory is the measured solver's alone
    coarse = load_scenario(
        ROOT / "scenarios" / "dam_break_2d.toml", [*overrides, f"fluid.spacing={L / 10}"]
    )
    warm = FluidSolver(coarse.scenario.fluid)
    for _ in range(3):
        warm.step(warm.dt_next)
        warm.probe_value(front)
    del warm
    solver = FluidSolver(sc.fluid)
    times, fronts = [0.0], [solver.probe_value(front)]
    io = 0.0
    t0 = time.perf_counter()
    cpu0 = time.process_time()  # this process's CPU time: less hit by other jobs than the wall
    while solver.t < end_time - 1e-12:
        solver.step(min(solver.dt_next, end_time - solver.t))
        c = time.perf_counter()
        times.append(solver.t)
        fronts.append(solver.probe_value(front))
        io += time.perf_counter() - c
    wall = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    steps = solver.step_count
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    return {
        "spacing": spacing,
        "particles": int(solver.n_fluid),
        "all_particles": int(solver.n),
        "steps": steps,
        "wall_s": wall,
        "us_per_particle_step": wall / (steps * solver.n_fluid) * 1e6,
        "cpu_s": cpu,
        "cpu_us_per_particle_step": cpu / (steps * solver.n_fluid) * 1e6,
        **stage_columns(solver),
        "probes_io_s": io,
        "neighbour_builds": solver.search.builds,
        "peak_rss_kib": peak,
        "base_rss_kib": base_rss,
        "front_rms_error": front_error(np.array(times), np.array(fronts)),
        "threads": threads,
    }


def describe(row: dict) -> str:
    """One printed line of the table."""
    return (
        f"{row['particles']:>7d} fluid  {row['steps']:>5d} steps  {row['wall_s']:8.1f} s  "
        f"{row['us_per_particle_step']:6.2f} us/particle-step (CPU "
        f"{row['cpu_us_per_particle_step']:.2f})  "
        f"{stage_text(row)}  io {row['probes_io_s']:.1f} s  "
        f"{row['iterations_per_step']:.1f} it/step  front error {row['front_rms_error'] * 100:.1f} %"
    )


def main() -> None:
    benchmark_main(
        __doc__.splitlines()[0],
        __file__,
        one_run,
        SPACINGS,
        describe,
        end_time=0.27,
        threads=2,
        out=ROOT / "benchmarks" / "results" / "dam_break.csv",
    )


if __name__ == "__main__":
    main()
