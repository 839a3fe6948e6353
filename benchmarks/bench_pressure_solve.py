"""Pressure Poisson equation: assembly and solve cost per step, by PPE radius and solver.

A small inviscid MPS dam break (Koshizuka-Oka proportions: water column 1 x 2 in a tank 4 wide,
one pressure wall layer and dummy layers, gravity, mixed source term gamma = 0.01, collision
model) is run with the library's own kernels to produce a realistic sequence of particle states.
Each state's predicted positions and velocities are recorded; then every (radius, solver) pair
replays the same sequence, warm-starting each solve from its own previous pressure, as the time
loop does. Reported per step (medians over the steps, robust to other load on the machine):
assembly time (divergence, source, CSR matrix/matrices), solve time (including AMG rebuilds),
their sum in wall-clock and in process CPU time, CG iterations (mean, max), rebuilds; and the
first (cold: hierarchy built) solve separately. ``pcg_amg_same`` is pcg_amg with its V-cycle
built on the PPE matrix itself (precond_re = re) instead of the density-radius matrix;
``scipy_cg_pyamg`` is the textbook baseline (scipy CG, pyamg's own V-cycle), defined here only.
The slow solvers (direct, pcg_jacobi) replay a quarter of the steps; direct only up to
--direct-max.

    python benchmarks/bench_pressure_solve.py [--sizes 4k,16k,64k] [--steps 20] [--threads 2]

Prints a table and writes benchmarks/results/pressure_solve.csv.
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import time
from pathlib import Path


def parse():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--sizes", default="4k,16k,64k", help="fluid particle counts (k = 1000)")
    ap.add_argument("--radii", default="2.1,3.1,4.01", help="PPE kernel radii, x l0")
    ap.add_argument("--solvers", default="pcg_amg,pcg_amg_same,scipy_cg_pyamg,pcg_jacobi,direct")
    ap.add_argument("--steps", type=int, default=20, help="measured steps per replay")
    ap.add_argument("--warmup", type=int, default=30, help="steps before the recorded sequence")
    ap.add_argument("--threads", type=int, default=2, help="numba threads")
    ap.add_argument("--direct-max", type=int, default=20000, help="largest size for 'direct'")
    ap.add_argument("--out", default=str(Path(__file__).parent / "results" / "pressure_solve.csv"))
    return ap.parse_args()


ARGS = parse()
os.environ.setdefault("NUMBA_NUM_THREADS", str(max(ARGS.threads, 1)))

import numba  # noqa: E402
import numpy as np  # noqa: E402

from mpsfem.fluid_mps import operators as ops  # noqa: E402
from mpsfem.fluid_mps.collision import collide  # noqa: E402
from mpsfem.fluid_mps.lattice import lattice_constants  # noqa: E402
from mpsfem.fluid_mps.neighbours import NeighbourSearch  # noqa: E402
from mpsfem.fluid_mps.pressure_poisson import (  # noqa: E402
    SOLVERS,
    PressureSolver,
    make_pressure_solver,
)
from mpsfem.fluid_mps.surface import make_surface_detector  # noqa: E402

RHO, G = 1000.0, 9.81
LAYERS = 5  # 1 pressure wall + 4 dummy layers: fills 4.01 l0


class ScipyCGPyamg(PressureSolver):
    """Baseline, not in the library: scipy's CG with pyamg's own V-cycle as preconditioner
    (``ml.aspreconditioner()``, symmetric Gauss-Seidel, hierarchy of the 're' matrix reused and
    its finest level swapped for the current matrix), as one would write it first."""

    name = "scipy_cg_pyamg"

    def __init__(self, **kw):
        super().__init__(**kw)
        self.ml = None

    def _solve(self, A, b, x, info):
        import pyamg
        from scipy.sparse.linalg import cg

        if self.ml is None or self.ml.levels[0].A.shape != A.shape:
            state = np.random.get_state()  # noqa: NPY002
            np.random.seed(0)  # noqa: NPY002
            self.ml = pyamg.smoothed_aggregation_solver(
                A.copy(),
                presmoother=("gauss_seidel", {"sweep": "symmetric"}),
                postsmoother=("gauss_seidel", {"sweep": "symmetric"}),
                max_coarse=500,
            )
            np.random.set_state(state)  # noqa: NPY002
            info.rebuilt = True
        self.ml.levels[0].A = A
        count = [0]

        def cb(_):
            count[0] += 1

        info.initial_residual = float(np.linalg.norm(b - A @ x) / np.linalg.norm(b))
        x[:], _ = cg(
            A,
            b,
            x0=x.copy(),
            rtol=self.tol,
            atol=0.0,
            maxiter=self.max_iter,
            M=self.ml.aspreconditioner(cycle="V"),
            callback=cb,
        )
        info.iterations = count[0]
        info.residual = float(np.linalg.norm(b - A @ x) / np.linalg.norm(b))


SOLVERS.setdefault("scipy_cg_pyamg", ScipyCGPyamg)  # benchmark-only baseline


def dam_break(n_fluid: int):
    """Particles of a 2D dam break with about n_fluid fluid particles, l0 = 0.146 / nx."""
    nx = max(8, int(round(np.sqrt(n_fluid / 2.0))))
    ny = 2 * nx
    l0 = 0.146 / nx
    tank_w, tank_h = 4 * nx, ny + 10
    pts, kinds = [], []
    for j in range(-LAYERS, tank_h):
        for i in range(-LAYERS, tank_w + LAYERS):
            if 0 <= i < tank_w and j >= 0:
                if i < nx and j < ny:
                    pts.append((i, j))
                    kinds.append(0)
                continue
            d = max(-j if j < 0 else 0, -i if i < 0 else 0, i - tank_w + 1 if i >= tank_w else 0)
            pts.append((i, j))
            kinds.append(1 if d == 1 else 2)
    pos = (np.array(pts, float) + 0.5) * l0
    return pos, np.array(kinds, np.int8), l0


def record_states(n_fluid, steps, warmup):
    """Run the dam break; return l0, kind and the recorded (pos, vel*, dt) of each step."""
    pos, kind, l0 = dam_break(n_fluid)
    dim = 2
    fl = kind == 0
    vel = np.zeros_like(pos)
    re_n, re_lap = 2.1 * l0, 4.01 * l0
    n0n, _ = lattice_constants(dim, l0, re_n)
    search = NeighbourSearch(dim, re_lap)
    det = make_surface_detector("density_asymmetry", dim=dim, l0=l0, re=re_n)
    ppe = make_pressure_solver(
        "pcg_amg", dim=dim, l0=l0, re=re_lap, re_density=re_n, rho=RHO, gamma=0.01
    )
    H = fl.sum() and pos[fl, 1].max()
    p = np.where(kind != 2, RHO * G * np.maximum(H - pos[:, 1], 0.0), 0.0)
    n = np.empty(len(pos))
    fs = np.empty(len(pos), np.int8)
    grad = np.empty_like(pos)
    states = []
    for step in range(warmup + steps):
        umax = np.sqrt((vel[fl] ** 2).sum(axis=1).max())
        dt = min(2e-3 * l0 / 0.002, 0.2 * l0 / max(umax, 1e-9))
        vel[fl, 1] -= G * dt
        pos[fl] += vel[fl] * dt
        nb = search.build(pos)
        before = vel.copy()
        collide(pos, vel, kind, nb.indptr, nb.indices, 0.5 * l0, 0.2)
        pos[fl] += (vel[fl] - before[fl]) * dt
        if step >= warmup:
            states.append((pos.copy(), vel.copy(), dt))
        ops.number_density(pos, nb.indptr, nb.indices, re_n, 0, n)
        det.detect(pos, kind, n, nb, fs)
        ppe.solve(pos, vel, kind, n, fs, nb, dt, p)
        np.maximum(p, 0.0, out=p)
        ops.pressure_gradient(pos, p, kind, nb.indptr, nb.indices, re_n, 0, n0n, 1, True, grad)
        dv = -dt / RHO * grad[fl]
        vel[fl] += dv
        pos[fl] += dv * dt
    return l0, kind, states, int(fl.sum())


def replay(l0, kind, states, radius, solver):
    dim = 2
    re_n = 2.1 * l0
    re = radius * l0
    name, extra = solver, {}
    if solver == "pcg_amg_same":
        name, extra = "pcg_amg", {"precond_re": re}
    search = NeighbourSearch(dim, max(re, re_n))
    det = make_surface_detector("density_asymmetry", dim=dim, l0=l0, re=re_n)
    ppe = make_pressure_solver(
        name, dim=dim, l0=l0, re=re, re_density=re_n, rho=RHO, gamma=0.01, max_iter=5000, **extra
    )
    p = np.zeros(len(kind))
    n = np.empty(len(kind))
    fs = np.empty(len(kind), np.int8)
    rows = []
    for pos, vel, dt in states:
        nb = search.build(pos)
        ops.number_density(pos, nb.indptr, nb.indices, re_n, 0, n)
        det.detect(pos, kind, n, nb, fs)
        c0, w0 = time.process_time(), time.perf_counter()
        info = ppe.solve(pos, vel, kind, n, fs, nb, dt, p)
        info.cpu_time = time.process_time() - c0
        info.wall_time = time.perf_counter() - w0
        rows.append(info)
    return rows, ppe


def main():
    ops.number_density(
        np.zeros((2, 2)), np.zeros(3, np.int64), np.zeros(0, np.int32), 1.0, 0, np.zeros(2)
    )  # starts the threading layer
    numba.set_num_threads(max(1, min(ARGS.threads, numba.config.NUMBA_NUM_THREADS)))
    sizes = [
        int(float(s.lower().rstrip("k")) * (1000 if s.lower().endswith("k") else 1))
        for s in ARGS.sizes.split(",")
    ]
    radii = [float(r) for r in ARGS.radii.split(",")]
    solvers = ARGS.solvers.split(",")
    print(
        f"# numba threads {numba.get_num_threads()} ({numba.threading_layer()}) on "
        f"{os.cpu_count()} CPUs "
        f"({platform.machine()}), {ARGS.steps} measured steps"
    )
    hdr = (
        f"{'fluid':>6} {'unknowns':>8} {'re/l0':>5} {'solver':>14} {'nnz/row':>7} "
        f"{'asm ms':>7} {'solve ms':>8} {'step ms':>8} {'cpu ms':>8} {'it':>5} {'it max':>6} "
        f"{'rebuilds':>8} {'first ms':>8} {'us/unk':>7}"
    )
    print(hdr)
    out_rows = []
    for size in sizes:
        t = time.perf_counter()
        l0, kind, states, nfl = record_states(size, ARGS.steps + 1, ARGS.warmup)
        print(
            f"# {nfl} fluid particles, {len(kind)} in all: states recorded in "
            f"{time.perf_counter() - t:.1f} s"
        )
        for radius in radii:
            for solver in solvers:
                if solver == "direct" and nfl > ARGS.direct_max:
                    continue
                if solver == "pcg_amg_same" and radius <= 2.1:
                    continue  # same as pcg_amg
                slow = solver in ("direct", "pcg_jacobi")
                steps = states[: max(4, len(states) // 4)] if slow else states
                rows, ppe = replay(l0, kind, steps, radius, solver)
                first, rest = rows[0], rows[1:]
                asm, sol, wall, cpu = (
                    float(np.median([getattr(r, key) for r in rest])) * 1e3
                    for key in ("assembly_time", "solve_time", "wall_time", "cpu_time")
                )
                its = [r.iterations for r in rest]
                rebuilds = sum(r.rebuilt for r in rest)
                unk = int(np.mean([r.n_unknowns for r in rest]))
                rec = dict(
                    fluid_particles=nfl,
                    particles=len(kind),
                    unknowns=unk,
                    re_over_l0=radius,
                    solver=solver,
                    nnz_per_row=round(first.nnz / first.n_rows, 1),
                    assembly_ms=round(asm, 2),
                    solve_ms=round(sol, 2),
                    step_wall_ms=round(wall, 2),
                    step_cpu_ms=round(cpu, 2),
                    iterations_mean=round(float(np.mean(its)), 2),
                    iterations_max=int(max(its)),
                    rebuilds=rebuilds,
                    steps=len(rest),
                    first_solve_ms=round(first.solve_time * 1e3, 1),
                    us_per_unknown=round(wall * 1e3 / unk, 3),
                    threads=numba.get_num_threads(),
                    threading_layer=numba.threading_layer(),
                )
                out_rows.append(rec)
                print(
                    f"{nfl:>6} {unk:>8} {radius:>5} {solver:>14} {rec['nnz_per_row']:>7} "
                    f"{asm:>7.1f} {sol:>8.1f} {wall:>8.1f} {cpu:>8.1f} {rec['iterations_mean']:>5} "
                    f"{max(its):>6} "
                    f"{rebuilds:>8} {rec['first_solve_ms']:>8} {rec['us_per_unknown']:>7}",
                    flush=True,
                )
    out = Path(ARGS.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(out_rows[0]))
        w.writeheader()
        w.writerows(out_rows)
    print(f"# wrote {out}")


if __name__ == "__main__":
    main()
