"""δ-SPH speed: microseconds per particle per right-hand-side evaluation, and steps per
simulated second beside MPS (issue 23; target <= 0.3 us per particle per RHS at 64k particles
on 2 threads).

Part 1: still water in a 2D tank at 4k, 16k and 65k fluid particles (d/l0 = 45, 90, 180; twice
as wide as deep), δ-SPHC, h = 1.3 l0 (and 2.0 with --ratios): after a warm-up, ``--calls``
right-hand sides (neighbour update, EOS, dummy-wall pressure, correction matrix and density
gradient, pair terms) are timed on each thread count of --threads; us per particle counts every
particle (fluid and wall; all have neighbour rows) and, in a second column, fluid only. Each
measurement is the fastest of --repeat runs (our 2 cores are shared with other jobs: the
fastest is the least disturbed).

Part 2: the dam break of validation/delta_sph_dam_break.py at L/40 (scenarios/dam_break_2d.toml
for MPS) for --sim-time seconds (default 0.1) from the start with each method on 1 thread (after one
untimed step of a second solver, so that compilation is not timed): steps, steps per
simulated second, wall time per simulated second.

Writes benchmarks/results/delta_sph_rhs.csv and benchmarks/results/delta_sph_vs_mps_steps.csv.

    python benchmarks/bench_delta_sph.py [--threads 1,2] [--calls 20] [--repeat 3] [--sim-time 0.1]
                                         [--steps-only]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numba

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
from results_csv import write_csv  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"


def tank(n_depth: int, ratio: float):
    from mpsfem.fluid_sph.solver import DeltaSPHSolver
    from mpsfem.scenario.fluid import FluidSection

    d = 1.0
    dx = d / n_depth
    spec = FluidSection(
        method="delta-sph",
        spacing=dx,
        blocks=[{"lower": [0.0, 0.0], "upper": [2 * d, d]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [2 * d, 1.5 * d], "name": "t"}],
        sph={"smoothing_ratio": ratio},
    )
    return DeltaSPHSolver(spec)


def time_rhs(s, calls: int, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        tic = time.perf_counter()
        for _ in range(calls):
            s.rhs()
        best = min(best, (time.perf_counter() - tic) / calls)
    return best


def steps_per_second(method: str, sim_time: float) -> dict:
    from mpsfem.fluid_methods import create_fluid_solver
    from mpsfem.scenario.loader import load_scenario

    if method == "mps":
        path = ROOT / "scenarios" / "dam_break_2d.toml"
    else:
        path = ROOT / "validation" / "results" / "delta_sph_dam_break.toml"
        if not path.is_file():
            raise SystemExit(f"{path} is missing: run validation/delta_sph_dam_break.py first")
    sc = load_scenario(path).scenario
    s = create_fluid_solver(sc.fluid, path.parent)
    warm = create_fluid_solver(sc.fluid, path.parent)
    warm.step(warm.dt_next)  # compile (or load from the cache) outside the timing
    tic = time.perf_counter()
    while s.t < sim_time - 1e-12:
        s.step(s.dt_towards(sim_time))
    wall = time.perf_counter() - tic
    return {
        "method": method,
        "particles": s.n,
        "fluid_particles": s.n_fluid,
        "sim_time_s": sim_time,
        "steps": s.step_count,
        "steps_per_sim_s": s.step_count / sim_time,
        "wall_s_per_sim_s": wall / sim_time,
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--threads", default="1,2")
    ap.add_argument("--depths", default="45,90,180", help="d / l0 per scene (default 45,90,180)")
    ap.add_argument("--ratios", default="1.3")
    ap.add_argument("--calls", type=int, default=20)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--sim-time", type=float, default=0.1)
    ap.add_argument("--steps-only", action="store_true", help="part 2 only")
    args = ap.parse_args()
    rows = []
    for ratio in (float(r) for r in args.ratios.split(",")) if not args.steps_only else ():
        for n_depth in (int(x) for x in args.depths.split(",")):
            s = tank(n_depth, ratio)
            s.rhs()  # compile and warm the neighbour candidates
            for threads in (int(t) for t in args.threads.split(",")):
                numba.set_num_threads(threads)
                sec = time_rhs(s, args.calls, args.repeat)
                rows.append(
                    {
                        "smoothing_ratio": ratio,
                        "particles": s.n,
                        "fluid_particles": s.n_fluid,
                        "threads": threads,
                        "ms_per_rhs": 1e3 * sec,
                        "us_per_particle_rhs": 1e6 * sec / s.n,
                        "us_per_fluid_particle_rhs": 1e6 * sec / s.n_fluid,
                    }
                )
                r = rows[-1]
                print(
                    f"h={ratio} l0 N={s.n:6d} (fluid {s.n_fluid:6d}) threads {threads}: "
                    f"{r['ms_per_rhs']:.2f} ms/RHS, {r['us_per_particle_rhs']:.3f} us/particle, "
                    f"{r['us_per_fluid_particle_rhs']:.3f} us/fluid particle",
                    flush=True,
                )
    if rows:
        write_csv(rows, RESULTS / "delta_sph_rhs.csv",
                  comment="δ-SPHC right-hand side cost, still-water tank (benchmarks/bench_delta_sph.py)")  # fmt: skip
    numba.set_num_threads(1)
    cmp_rows = [steps_per_second(m, args.sim_time) for m in ("mps", "delta-sph")]
    for r in cmp_rows:
        print(
            f"dam break L/40 {r['method']:10}: {r['steps']} steps in {r['sim_time_s']} s = "
            f"{r['steps_per_sim_s']:.0f} steps/s simulated, {r['wall_s_per_sim_s']:.1f} s wall per s"
        )
    write_csv(cmp_rows, RESULTS / "delta_sph_vs_mps_steps.csv",
              comment="dam break L/40, first sim_time s, 1 thread (benchmarks/bench_delta_sph.py)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
