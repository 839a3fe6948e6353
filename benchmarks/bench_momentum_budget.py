"""Cost of the fluid's momentum budget (fluid_mps/momentum_budget.py) against the MPS step.

Builds the dam break at about 64.8k fluid particles (l0 = L/180), takes a few steps, then times
each budget stage on the step's own arrays and lists (best of ``--repeat`` calls after a warm-up)
beside the pressure gradient it shadows and a whole step: the budget's share of a step, measured
in one process so that machine load hits both alike. Prints a table and writes
benchmarks/results/momentum_budget.csv.

    python benchmarks/bench_momentum_budget.py [--threads 1] [--spacing-divisor 180]
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

from mpsfem.fluid_mps import wall_boundary  # noqa: E402
from mpsfem.fluid_mps.solver import FluidSolver  # noqa: E402
from mpsfem.scenario.loader import load_scenario  # noqa: E402

L = 0.146  # m, the column width


def best_ms(fn, repeat: int) -> float:
    fn()  # warm-up (compiles on a first call)
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t)
    return 1e3 * best


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--spacing-divisor", type=int, default=180, help="l0 = L / this")
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks/results/momentum_budget.csv")
    args = ap.parse_args(argv)
    numba.set_num_threads(args.threads)
    sc = load_scenario(
        ROOT / "scenarios/dam_break_2d.toml", [f"fluid.spacing={L / args.spacing_divisor:.6g}"]
    )
    s = FluidSolver(sc.scenario.fluid)
    for _ in range(3):
        s.step(s.dt_towards(1.0))
    near = s.search.short if s.search.short is not None else s._last_neighbours
    nb = s._last_neighbours
    b = s.budget
    col = sc.scenario.fluid.collision
    stages = {
        "step (whole)": lambda: s.step(s.dt_towards(1.0)),
        "pressure gradient (for scale)": lambda: wall_boundary.pressure_gradient_ghost(
            s.pos,
            s.p,
            s.kind,
            s.free_surface,
            near.indptr,
            near.indices,
            s.re_grad,
            s.wcode,
            s.n0_grad,
            s.grad_form,
            s.rho,
            s.gravity,
            s.grad_p,
            s.pref_all,
        ),  # fmt: skip
        "budget: pressure split": lambda: b.pressure(
            s._gradient_args(), near, s.vel_before, s.kind
        ),
        "budget: collision exchange": lambda: b.collision(
            s.pos, s.vel, s.kind, near, col.distance * s.l0, col.restitution
        ),
        "budget: viscous exchange": lambda: b.viscous(
            s.pos, s.vel, s.kind, nb, s.re_lap, s.wcode, s.lap_coef
        ),
        "budget: 5 momentum sums": lambda: [b.momentum(s.vel, s.kind) for _ in range(5)],
        "budget: finish (patch sums)": lambda: b.finish(1e-4, s._pressure_integrals()),
    }
    rows = []
    for name, fn in stages.items():
        rows.append({"stage": name, "ms": best_ms(fn, args.repeat)})
    step = rows[0]["ms"]
    budget = sum(r["ms"] for r in rows if r["stage"].startswith("budget"))
    rows.append({"stage": "budget total", "ms": budget})
    for r in rows:
        r["share_of_step"] = r["ms"] / step
        r["particles"] = s.n
        r["fluid_particles"] = s.n_fluid
        r["threads"] = args.threads
    print(f"{s.n_fluid} fluid particles ({s.n} in all), {args.threads} thread(s)")
    for r in rows:
        print(f"  {r['stage']:32s} {r['ms']:8.2f} ms  {100 * r['share_of_step']:5.1f} % of a step")
    write_csv(rows, args.out, comment="benchmarks/bench_momentum_budget.py: best of repeats, ms")
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
