"""δ-SPH speed: microseconds per particle per right-hand-side evaluation, and steps per
simulated second beside MPS (issue 23; target <= 0.3 us per particle per RHS at 64k particles
on 2 threads).

Part 1: still water in a 2D tank at 4k, 16k and 65k fluid particles (d/l0 = 45, 90, 180; twice
as wide as deep), δ-SPHC, h = 1.3 l0 (and 2.0 with --ratios): after a warm-up, ``--calls``
right-hand sides (neighbour update, EOS, dummy-wall pressure, correction matrix and density
gradient, pair terms) are timed on each thread count of --threads; us per particle counts every
particle (fluid and wall; all have neighbour rows) and, in a second column, fluid only. Each
measurement is the fastest of --repeat runs (our 2 cores are shared with other jobs: the
fastest is the least disturbed). Beside the wall time each row has the CPU time of the process
(``time.process_time``, all threads summed: on one thread it is the measure that a loaded
machine disturbs least; on two it is about twice the wall time where both threads ran) and the
1-minute load average when the row was measured.

Part 2: the dam break of validation/delta_sph_dam_break.py at L/40 (scenarios/dam_break_2d.toml
for MPS) for --sim-time seconds (default 0.1) from the start with each method on 1 thread (after one
untimed step of a second solver, so that compilation is not timed): steps, steps per
simulated second, wall and CPU time per simulated second.

``--profile``: CPU time of each stage of the right-hand side, one thread (:func:`profile_rhs`).

Writes benchmarks/results/delta_sph_rhs.csv and benchmarks/results/delta_sph_vs_mps_steps.csv
(``--tag X``: delta_sph_rhs_X.csv, ..., e.g. to keep a run of another version of the code apart;
``--dim 3``: part 1 in a 3D tank d broad, delta_sph_rhs_3d*.csv; ``--budget``: with the
momentum budget, whose split joins the profile as ``momentum_budget_split``).

    python benchmarks/bench_delta_sph.py [--threads 1,2] [--calls 20] [--repeat 3] [--sim-time 0.1]
                                         [--steps-only] [--rhs-only] [--profile] [--tag X] [--dim 3]
                                         [--budget]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numba
import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
from results_csv import write_csv  # noqa: E402

RESULTS = ROOT / "benchmarks" / "results"


def tank(n_depth: int, ratio: float, dim: int = 2, budget: bool = False):
    """Still water d = 1 m deep at d / l0 = ``n_depth``, 2 d long (and d broad in 3D), in a
    tank 1.5 d high; δ-SPHC, RK4, h = ``ratio`` l0; ``budget``: with the momentum budget
    (``fluid.momentum_budget = true``), whose split then runs in every right-hand side."""
    extra = {"momentum_budget": True} if budget else {}
    from mpsfem.fluid_sph.solver import DeltaSPHSolver
    from mpsfem.scenario.fluid import FluidSection

    d = 1.0
    dx = d / n_depth
    across = [d] * (dim - 2)
    spec = FluidSection(
        method="delta-sph",
        dim=dim,
        spacing=dx,
        gravity=[0.0] * (dim - 1) + [-9.81],
        blocks=[{"lower": [0.0] * dim, "upper": [2 * d, *across, d]}],
        walls=[
            {"shape": "tank", "lower": [0.0] * dim, "upper": [2 * d, *across, 1.5 * d], "name": "t"}
        ],  # fmt: skip
        sph={"smoothing_ratio": ratio},
        **extra,
    )
    return DeltaSPHSolver(spec)


def time_rhs(s, calls: int, repeat: int) -> tuple[float, float]:
    """(wall, CPU) seconds per right-hand side, each the fastest of ``repeat`` runs."""
    best = cpu_best = float("inf")
    for _ in range(repeat):
        cpu = time.process_time()
        tic = time.perf_counter()
        for _ in range(calls):
            s.rhs()
        best = min(best, (time.perf_counter() - tic) / calls)
        cpu_best = min(cpu_best, (time.process_time() - cpu) / calls)
    return best, cpu_best


def profile_rhs(s, calls: int, repeat: int = 1) -> dict[str, float]:
    """CPU seconds per call of each stage of ``DeltaSPHSolver.rhs`` (the same calls in the same
    order, timed one by one: the sum is the right-hand side less the Python glue) and of one
    RK4 step's integrator kernels (``time_stepping``: 4 accumulations, 3 stages, 1 finish); each
    the least of ``repeat`` blocks of ``calls`` calls."""
    from mpsfem.fluid_sph import delta_sph, time_stepping

    nf = s.n_fluid
    nb = s.search.update(s.pos)
    r2 = s.radius * s.radius
    stages = {
        "neighbour_update": lambda: s.search.update(s.pos),
        "equation_of_state": lambda: delta_sph.equation_of_state(s.rho, s.p, nf, s.rho0, s.c0),
        "wall_pressure": lambda: delta_sph.wall_pressure(
            s.pos, s.rho, s.p, s.kind, nb.indptr, nb.indices, r2, nf, s.gravity, s.omega2,
            s.center, s.wall_acc, s.h, s.norm, s.rho0, s.c0),
        "particle_volume": lambda: delta_sph.particle_volume(s.rho, s.mass, s.vol),
        "correction": lambda: delta_sph.correction(
            s.pos, s.rho, s.vol, s.p, nb.indptr, nb.indices, r2, nf, s.inv_h, s.grad_coef, s.M,
            s.pM, s.grad_rho, s.pair_j, s.fv_pair, s.row_end),
        "pair_terms": lambda: delta_sph.pair_terms(
            s.pos, s.vel, s.rho, s.p, nb.indptr, s.row_end, s.pair_j, s.fv_pair, nf, s.h,
            s.rho0, s.c0, s.sph.density_diffusion, s.corrected, s.M, s.pM, s.grad_rho, s.alpha,
            s.gravity, s.omega2, s.center, s.acc, s.drho),
        "wall_reaction": lambda: delta_sph.wall_reaction(
            s.pos, s.rho, s.vol, s.p, nb.indptr, nb.indices, nf, s.inv_h, s.grad_coef,
            s.corrected, s.M, s.ext_slot, s.reaction),
    }  # fmt: skip
    p0, v0, r0 = (a.copy() for a in (s.pos, s.vel, s.rho))
    sp, sv, sr = (np.zeros_like(a) for a in (s.pos, s.vel, s.rho))
    pos, vel, rho = (a.copy() for a in (s.pos, s.vel, s.rho))

    def rk4_kernels():
        for stage in range(4):
            time_stepping.rk_accumulate(sp, sv, sr, vel, s.acc, s.drho, nf, 1.0, stage == 0)
            if stage < 3:
                time_stepping.rk_stage(p0, v0, r0, vel, s.acc, s.drho, nf, 1e-9, pos, vel, rho)
            else:
                time_stepping.rk_finish(p0, v0, r0, sp, sv, sr, nf, 1e-9, pos, vel, rho)

    if s.budget.full:  # the momentum budget's split of the right-hand side (--budget)
        stages["momentum_budget_split"] = lambda: s.budget.evaluate(s, nb)
    stages["rk4_step_integrator"] = rk4_kernels
    stages["rhs_total"] = s.rhs
    out = {}
    for name, fn in stages.items():
        fn()  # compile / warm
        best = float("inf")
        for _ in range(repeat):
            cpu = time.process_time()
            for _ in range(calls):
                fn()
            best = min(best, (time.process_time() - cpu) / calls)
        out[name] = best
    return out


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
    load = os.getloadavg()[0]
    cpu = time.process_time()
    tic = time.perf_counter()
    while s.t < sim_time - 1e-12:
        s.step(s.dt_towards(sim_time))
    wall = time.perf_counter() - tic
    cpu = time.process_time() - cpu
    return {
        "method": method,
        "particles": s.n,
        "fluid_particles": s.n_fluid,
        "sim_time_s": sim_time,
        "steps": s.step_count,
        "steps_per_sim_s": s.step_count / sim_time,
        "wall_s_per_sim_s": wall / sim_time,
        "cpu_s_per_sim_s": cpu / sim_time,
        "load_avg_1min": load,
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
    ap.add_argument("--rhs-only", action="store_true", help="part 1 only")
    ap.add_argument("--dim", type=int, default=2, help="part 1's tank in 2D or 3D (default 2)")
    ap.add_argument(
        "--profile",
        action="store_true",
        help="per-stage CPU time of the right-hand side on 1 thread, then exit",
    )
    ap.add_argument("--tag", default="", help="suffix of the profile CSV's name")
    ap.add_argument(
        "--budget",
        action="store_true",
        help="with the momentum budget (fluid.momentum_budget = true): its split is profiled "
        "and timed in every right-hand side",
    )
    args = ap.parse_args()
    if args.profile:
        numba.set_num_threads(1)
        prof = []
        for n_depth in (int(x) for x in args.depths.split(",")):
            for ratio in (float(r) for r in args.ratios.split(",")):
                s = tank(n_depth, ratio, args.dim, args.budget)
                t = profile_rhs(s, args.calls, args.repeat)
                for name, sec in t.items():
                    prof.append(
                        {
                            "dim": args.dim,
                            "smoothing_ratio": ratio,
                            "particles": s.n,
                            "fluid_particles": s.n_fluid,
                            "stage": name,
                            "ms_per_call": 1e3 * sec,
                            "us_per_particle": 1e6 * sec / s.n,
                        }
                    )
                    print(
                        f"h={ratio} N={s.n:6d} {name:22s} {1e3 * sec:8.3f} ms "
                        f"{1e6 * sec / s.n:7.4f} us/particle",
                        flush=True,
                    )
        tag = ("_3d" if args.dim == 3 else "") + (f"_{args.tag}" if args.tag else "")
        name = f"delta_sph_profile{tag}.csv"
        write_csv(prof, RESULTS / name,
                  comment="δ-SPHC right-hand side, CPU time per stage, 1 thread, still-water tank "
                  "(benchmarks/bench_delta_sph.py --profile)")  # fmt: skip
        return 0
    rows = []
    for ratio in (float(r) for r in args.ratios.split(",")) if not args.steps_only else ():
        for n_depth in (int(x) for x in args.depths.split(",")):
            s = tank(n_depth, ratio, args.dim, args.budget)
            s.rhs()  # compile and warm the neighbour candidates
            for threads in (int(t) for t in args.threads.split(",")):
                numba.set_num_threads(threads)
                load = os.getloadavg()[0]
                sec, cpu = time_rhs(s, args.calls, args.repeat)
                rows.append(
                    {
                        "dim": args.dim,
                        "smoothing_ratio": ratio,
                        "particles": s.n,
                        "fluid_particles": s.n_fluid,
                        "threads": threads,
                        "ms_per_rhs": 1e3 * sec,
                        "us_per_particle_rhs": 1e6 * sec / s.n,
                        "us_per_fluid_particle_rhs": 1e6 * sec / s.n_fluid,
                        "cpu_us_per_particle_rhs": 1e6 * cpu / s.n,
                        "load_avg_1min": load,
                    }
                )
                r = rows[-1]
                print(
                    f"h={ratio} l0 N={s.n:6d} (fluid {s.n_fluid:6d}) threads {threads}: "
                    f"{r['ms_per_rhs']:.2f} ms/RHS, {r['us_per_particle_rhs']:.3f} us/particle "
                    f"(CPU {r['cpu_us_per_particle_rhs']:.3f}), "
                    f"{r['us_per_fluid_particle_rhs']:.3f} us/fluid particle; load {load:.1f}",
                    flush=True,
                )
    tag = ("_3d" if args.dim == 3 else "") + (f"_{args.tag}" if args.tag else "")
    if rows:
        write_csv(rows, RESULTS / f"delta_sph_rhs{tag}.csv",
                  comment="δ-SPHC right-hand side cost, still-water tank (benchmarks/bench_delta_sph.py)")  # fmt: skip
    if args.rhs_only:
        return 0
    numba.set_num_threads(1)
    cmp_rows = [steps_per_second(m, args.sim_time) for m in ("mps", "delta-sph")]
    for r in cmp_rows:
        print(
            f"dam break L/40 {r['method']:10}: {r['steps']} steps in {r['sim_time_s']} s = "
            f"{r['steps_per_sim_s']:.0f} steps/s simulated, {r['wall_s_per_sim_s']:.1f} s wall "
            f"({r['cpu_s_per_sim_s']:.1f} s CPU) per s; load {r['load_avg_1min']:.1f}"
        )
    write_csv(cmp_rows, RESULTS / f"delta_sph_vs_mps_steps{tag}.csv",
              comment="dam break L/40, first sim_time s, 1 thread (benchmarks/bench_delta_sph.py)")  # fmt: skip
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
