"""Structure solver timings: Newmark step and factorisation of the thesis members.

    .venv/bin/python benchmarks/bench_structure.py [--steps N] [--repeats R]

Cases: the green-water vertical plate (50 Hermite beam elements with axial dofs) and the 3D
bottom-slamming plate (800 BFS elements, 40 x 20), from scenarios/structure_*.toml. For each:
model build (assembly with scikit-fem), factorisation of the effective stiffness, and the time per
step of the participant's ``write("forces") + advance(dt)`` path (nodal-force mapping, effective
load, triangular solves, state update) and of the bare Newmark step. Targets (issue 3): at most
0.2 ms per beam step and 2 ms per plate step.

Co-rotational cases (issue 21, target 0.5 ms per step): the same green-water beam with
``kinematics = "corotational"`` under the same small random forces (``corot_beam_50``), and as a
cantilever swinging through large rotations under a harmonic tip force of P L^2 / EI = 1 at
5 Hz (``corot_beam_50_large``, tip rotation about 0.5 rad). For these, "factorisation" is forming
and factorising the Newton Jacobian, the bare step is the integrator's step (Newton included),
and the Newton iterations and Jacobian factorisations per step are reported.

Von Karman plate (issue 21): the 800-element plate with ``kinematics = "von_karman"``
(``vk_plate_800``; 9126 free dofs against the linear plate's 2964: the in-plane Q2 field) under
the same small random forces, at most ``--vk-steps`` steps per repeat; ``vk_plate_800_f64`` is
the same with the double-precision Newton factor (``single_precision_factor = False``, the path
before the single-precision one). Target: a step at most 5x the linear plate's step measured in
the same run. Besides the step, the columns give the cost per Newton iteration (step /
iterations), and the parts of one iteration: the internal force (``force_ms``, the kernel
evaluated afresh), one triangular solve with the kept factor (``solve_ms``), forming the Newton
Jacobian (``jacobian_ms``) and forming + factorising it (``factorisation_ms``); ``other_ms`` is
what the step costs beyond iterations x (force + solve) + factorisations x factorisation_ms.

Prints a table and writes benchmarks/results/structure.csv (median of the repeats), with the
clock used and the 1-minute load average at the start and the end of the run.
"""

from __future__ import annotations

import argparse
import csv
import os
import platform
import statistics
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

#: the timer: wall clock, or this process's CPU time (``--clock cpu``, for a loaded machine)
clock = time.perf_counter

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mpsfem.scenario.structure import StructureSection  # noqa: E402
from mpsfem.structure_fem.participant import StructureParticipant  # noqa: E402

CASES = [
    ("beam_50", "structure_green_water_plate.toml", 0.2),
    ("plate_800", "structure_bottom_slamming_3d.toml", 2.0),
]
COROT_CASES = [
    ("corot_beam_50", "structure_green_water_plate.toml", 0.5, False),
    ("corot_beam_50_large", "structure_green_water_plate.toml", 0.5, True),
]


def section_of(name: str, **member) -> StructureSection:
    data = tomllib.loads((ROOT / "scenarios" / name).read_text())
    for m in data["structure"]["members"]:
        m.update(member)
    return StructureSection.model_validate(data["structure"])


def bench_case(label: str, scenario: str, target_ms: float, steps: int, repeats: int) -> dict:
    sec = section_of(scenario)
    t0 = clock()
    part = StructureParticipant(sec)
    build = clock() - t0
    dt = sec.time.dt
    n_pts = part.interface().n_points
    rng = np.random.default_rng(0)
    forces = 1e-3 * rng.standard_normal((n_pts, part.dim))
    # factorisation of K_eff (a fresh dt forces one)
    fac = []
    for k in range(repeats):
        t0 = clock()
        part.integrator.factor(dt * (1.0 + 1e-6 * (k + 1)))
        fac.append(clock() - t0)
    part.integrator.factor(dt)
    # participant step: write + advance
    per_step = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(steps):
            part.write("forces", forces)
            part.advance(dt)
        per_step.append((clock() - t0) / steps)
    # bare Newmark step
    nm = part.integrator
    F = nm.M @ np.ones(nm.n) * 1e-6
    bare = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(steps):
            nm.step(dt, F)
        bare.append((clock() - t0) / steps)
    step_ms = statistics.median(per_step) * 1e3
    return {
        "case": label,
        "scenario": scenario,
        "elements": sum(
            m.elements if m.type == "beam" else m.divisions[0] * m.divisions[1] for m in sec.members
        ),
        "dofs_free": part.system.n,
        "interface_points": n_pts,
        "solver": "dense Cholesky" if part.integrator.factor(dt)[0].dense else "SuperLU",
        "build_s": round(build, 4),
        "factorisation_ms": round(statistics.median(fac) * 1e3, 3),
        "step_ms": round(step_ms, 4),
        "newmark_step_ms": round(statistics.median(bare) * 1e3, 4),
        "target_ms": target_ms,
        "meets_target": step_ms <= target_ms,
    }


def bench_corotational(
    label: str, scenario: str, target_ms: float, large: bool, steps: int, repeats: int
) -> dict:
    member = {"kinematics": "corotational"}
    if large:
        member["bc"] = ["clamped", "free"]
    sec = section_of(scenario, **member)
    t0 = clock()
    part = StructureParticipant(sec)
    build = clock() - t0
    dt = sec.time.dt
    n_pts = part.interface().n_points
    nm = part.integrator
    m = part.system.models[0]
    if large:  # P L^2 / EI = 1 at the tip, along the member normal, 5 Hz
        P = m.EI / m.length**2 * m.normal
        tip = np.zeros((n_pts, part.dim))

        def forces(k: int) -> np.ndarray:
            tip[-1] = P * np.sin(2 * np.pi * 5.0 * k * dt)
            return tip

        warm = int(round(0.05 / dt))  # a quarter period: under way to the large rotations
    else:
        rng = np.random.default_rng(0)
        f = 1e-3 * rng.standard_normal((n_pts, part.dim))

        def forces(k: int) -> np.ndarray:
            return f

        warm = 5
    k = 0
    for _ in range(warm):
        k += 1
        part.write("forces", forces(k))
        part.advance(dt)
    # forming + factorising the Newton Jacobian at the current state
    fac = []
    u = nm.state.u
    for _ in range(repeats):
        t0 = clock()
        nm.tangent.form(
            lambda x: part.system.effective_tangent(x, 1.0, 1.0 / (0.25 * dt * dt), 0.0), u, -1.0
        )
        fac.append(clock() - t0)
    it0, f0 = nm.iterations, nm.factorizations
    per_step = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(steps):
            k += 1
            part.write("forces", forces(k))
            part.advance(dt)
        per_step.append((clock() - t0) / steps)
    iters = (nm.iterations - it0) / (steps * repeats)
    facs = (nm.factorizations - f0) / (steps * repeats)
    rot = float(np.abs(part.read("rotation")).max())
    F = np.zeros(nm.n)
    bare = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(steps):
            nm.step(dt, F)
        bare.append((clock() - t0) / steps)
    step_ms = statistics.median(per_step) * 1e3
    return {
        "case": label,
        "scenario": scenario,
        "elements": sum(mm.elements for mm in sec.members),
        "dofs_free": part.system.n,
        "interface_points": n_pts,
        "solver": "banded Cholesky (Newton)",
        "build_s": round(build, 4),
        "factorisation_ms": round(statistics.median(fac) * 1e3, 3),
        "step_ms": round(step_ms, 4),
        "newmark_step_ms": round(statistics.median(bare) * 1e3, 4),
        "target_ms": target_ms,
        "meets_target": step_ms <= target_ms,
        "newton_iterations_per_step": round(iters, 3),
        "factorisations_per_step": round(facs, 4),
        "max_rotation_rad": round(rot, 3),
    }


def _median_ms(fn, n: int, repeats: int) -> float:
    times = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(n):
            fn()
        times.append((clock() - t0) / n)
    return statistics.median(times) * 1e3


def bench_von_karman(
    linear_step_ms: float, steps: int, repeats: int, *, single: bool = True
) -> dict:
    scenario = "structure_bottom_slamming_3d.toml"
    sec = section_of(scenario, kinematics="von_karman")
    t0 = clock()
    part = StructureParticipant(sec)
    build = clock() - t0
    dt = sec.time.dt
    n_pts = part.interface().n_points
    nm = part.integrator
    m = part.system.models[0]
    m.single_precision_factor = single
    free = part.system.frees[0]
    rng = np.random.default_rng(0)
    forces = 1e-3 * rng.standard_normal((n_pts, part.dim))
    for _ in range(5):  # compiles the kernels, forms the first Jacobian
        part.write("forces", forces)
        part.advance(dt)
    q = part.system.expand(nm.state.u, m.name)
    c0 = 1.0 / (0.25 * dt * dt)
    jac = _median_ms(lambda: m.reduced_effective(q, free, 1.0, c0, 0.0), 5, repeats)
    fac = _median_ms(
        lambda: nm.tangent.form(
            lambda x: part.system.effective_tangent(x, 1.0, c0, 0.0), nm.state.u, -1.0
        ),
        1,
        repeats,
    )
    force = _median_ms(lambda: m.compute_internal_force(q), 20, repeats)
    nm.tangent.form(lambda x: part.system.effective_tangent(x, 1.0, c0, 0.0), nm.state.u, dt)
    b = rng.standard_normal(part.system.n)
    solve = _median_ms(lambda: nm.tangent.factor.solve(b), 20, repeats)
    factor_kind = type(nm.tangent.factor).__name__
    it0, f0 = nm.iterations, nm.tangent.count
    per_step = []
    for _ in range(repeats):
        t0 = clock()
        for _ in range(steps):
            part.write("forces", forces)
            part.advance(dt)
        per_step.append((clock() - t0) / steps)
    iters = (nm.iterations - it0) / (steps * repeats)
    facs = (nm.tangent.count - f0) / (steps * repeats)
    step_ms = statistics.median(per_step) * 1e3
    target = 5.0 * linear_step_ms
    return {
        "case": "vk_plate_800" if single else "vk_plate_800_f64",
        "scenario": scenario,
        "elements": 800,
        "dofs_free": part.system.n,
        "interface_points": n_pts,
        "solver": f"SuperLU {'float32' if single else 'float64'} (modified Newton)",
        "build_s": round(build, 4),
        "factorisation_ms": round(fac, 3),
        "step_ms": round(step_ms, 4),
        "newmark_step_ms": "",
        "target_ms": round(target, 4),
        "meets_target": step_ms <= target,
        "newton_iterations_per_step": round(iters, 3),
        "factorisations_per_step": round(facs, 4),
        "max_rotation_rad": "",
        "ms_per_newton_iteration": round(step_ms / max(iters, 1e-12), 4),
        "force_ms": round(force, 4),
        "solve_ms": round(solve, 4),
        "jacobian_ms": round(jac, 3),
        "other_ms": round(step_ms - iters * (force + solve) - facs * fac, 4),
        "factor": factor_kind,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=2000)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--vk-steps", type=int, default=100, help="steps per repeat, vK plate")
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "structure.csv")
    ap.add_argument(
        "--clock", choices=("wall", "cpu"), default="wall", help="cpu: process CPU time"
    )
    args = ap.parse_args(argv)
    global clock
    clock = time.process_time if args.clock == "cpu" else time.perf_counter
    load0 = os.getloadavg()[0]
    rows = [bench_case(*c, steps=args.steps, repeats=args.repeats) for c in CASES]
    rows += [bench_corotational(*c, steps=args.steps, repeats=args.repeats) for c in COROT_CASES]
    linear_plate = next(r for r in rows if r["case"] == "plate_800")
    vk_steps = min(args.steps, args.vk_steps)
    rows.append(bench_von_karman(linear_plate["step_ms"], vk_steps, args.repeats))
    rows.append(bench_von_karman(linear_plate["step_ms"], vk_steps, args.repeats, single=False))
    load1 = os.getloadavg()[0]
    extra = ("newton_iterations_per_step", "factorisations_per_step", "max_rotation_rad",
             "ms_per_newton_iteration", "force_ms", "solve_ms", "jacobian_ms", "other_ms",
             "factor")  # fmt: skip
    for r in rows:
        for key in extra:
            r.setdefault(key, "")
        r["clock"] = args.clock
        r["load_1min"] = f"{load0:.2f} -> {load1:.2f}"
    host = f"{platform.node()} {platform.processor() or platform.machine()}, {os.cpu_count()} cpus"
    print(f"structure solver, {host}, python {platform.python_version()}, {args.clock} clock, "
          f"load average (1 min) {load0:.2f} at the start, {load1:.2f} at the end")  # fmt: skip
    cols = ["case", "elements", "dofs_free", "solver", "build_s", "factorisation_ms", "step_ms",
            "newmark_step_ms", "target_ms", "meets_target", "newton_iterations_per_step",
            "factorisations_per_step", "max_rotation_rad", "ms_per_newton_iteration",
            "force_ms", "solve_ms", "jacobian_ms", "other_ms"]  # fmt: skip
    widths = [max(len(c), *(len(str(r[c])) for r in rows)) for c in cols]
    print("  ".join(c.ljust(w) for c, w in zip(cols, widths, strict=True)))
    for r in rows:
        print("  ".join(str(r[c]).ljust(w) for c, w in zip(cols, widths, strict=True)))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=[*rows[-1].keys(), "host"])
        w.writeheader()
        for r in rows:
            w.writerow({**r, "host": host})
    print(f"wrote {args.out}")
    return 0 if all(r["meets_target"] for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
