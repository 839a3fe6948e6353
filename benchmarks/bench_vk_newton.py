"""Newton settings of the von Karman plate step: cost against the displacement error they imply.

    .venv/bin/python benchmarks/bench_vk_newton.py [--steps N]

The case of bench_structure.py's ``vk_plate_800`` (800 BFS elements, 9126 free dofs, dt = 1e-4
s, the same small random nodal forces, 5 warm-up steps, then N = 100 steps). Each variant runs
the same steps; its displacement history at the interface points is compared with a run at the
round-off floor (tolerance 1e-13: every step iterates until its residual reaches the floor of
:mod:`mpsfem.structure_fem.alpha_method`, ~3e-9 of the forces in balance here), and the time
discretisation error of the same steps is estimated by the run at dt / 2 (Richardson: the
difference of dt and dt / 2 times 4/3 for a second-order scheme). Variants:

* ``default``: tolerance 1e-8, reuse_ratio 0.01 (the scenario defaults), single-precision factor;
* ``f64_factor``: the same with the double-precision factor (``single_precision_factor = False``);
* ``tol_1e-7``, ``tol_1e-6``: looser ``structure.newton.tolerance``;
* ``reuse_0.1``, ``reuse_0.001``: other ``structure.newton.reuse_ratio``;
* ``tol_1e-6_reuse_0.1``: both;
* ``predictor_newmark``: an experiment, not a path of the code: Newton started from the Newmark
  predictor u + dt v + dt^2 (1/2 - beta) a instead of the last displacement u (the start is
  chosen in alpha_method.py; here the call to newton_solve is wrapped).

Columns: Newton iterations, factorisations, internal-force evaluations and solves per step, CPU
time per step (process time: the machine may be shared; compare the counts first), and
``disp_error``: max over steps and points of |d - d_floor| / max |d_floor|. Writes
benchmarks/results/vk_newton.csv.
"""

from __future__ import annotations

import argparse
import csv
import os
import sys
import time
import tomllib
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "src"))

from mpsfem.scenario.structure import StructureSection  # noqa: E402
from mpsfem.structure_fem import alpha_method, newton  # noqa: E402
from mpsfem.structure_fem.participant import StructureParticipant  # noqa: E402

SCENARIO = "structure_bottom_slamming_3d.toml"
VARIANTS = {
    "floor": {"tolerance": 1e-13},
    "default": {},
    "f64_factor": {"single": False},
    "tol_1e-7": {"tolerance": 1e-7},
    "tol_1e-6": {"tolerance": 1e-6},
    "reuse_0.1": {"reuse_ratio": 0.1},
    "reuse_0.001": {"reuse_ratio": 1e-3},
    "tol_1e-6_reuse_0.1": {"tolerance": 1e-6, "reuse_ratio": 0.1},
    "predictor_newmark": {"predictor": True},
    "dt_half": {"dt_div": 2},
}


def section(dt_div: int) -> StructureSection:
    data = tomllib.loads((ROOT / "scenarios" / SCENARIO).read_text())
    for m in data["structure"]["members"]:
        m["kinematics"] = "von_karman"
    data["structure"]["time"]["dt"] /= dt_div
    return StructureSection.model_validate(data["structure"])


def run(steps: int, *, tolerance=None, reuse_ratio=None, single=True, predictor=False, dt_div=1):
    sec = section(dt_div)
    part = StructureParticipant(sec)
    nm = part.integrator
    m = part.system.models[0]
    m.single_precision_factor = single
    if tolerance is not None:
        nm.tolerance = tolerance
    if reuse_ratio is not None:
        nm.reuse_ratio = reuse_ratio
    dt = sec.time.dt * dt_div  # one window of the benchmark's dt, dt_div sub-steps
    counts = {"force": 0, "solve": 0}
    fresh = m.compute_internal_force

    def counted_force(q):
        counts["force"] += 1
        return fresh(q)

    m.compute_internal_force = counted_force
    solve_newton, factorize = alpha_method.newton_solve, newton.factorize_jacobian

    def started(residual, jacobian, x0, **kw):
        if predictor:  # experiment: the Newmark predictor (a1 = 0)
            s, h = nm.state, kw["key"]
            x0 = s.u + h * s.v + h * h * (0.5 - nm.beta) * s.a
        return solve_newton(residual, jacobian, x0, **kw)

    def counted_factor(A):
        f = factorize(A)
        solve = f.solve

        def counted_solve(b):
            counts["solve"] += 1
            return solve(b)

        f.solve = counted_solve
        return f

    n_pts = part.interface().n_points
    forces = 1e-3 * np.random.default_rng(0).standard_normal((n_pts, part.dim))
    alpha_method.newton_solve, newton.factorize_jacobian = started, counted_factor
    try:
        for _ in range(5):
            part.write("forces", forces)
            part.advance(dt)
        it0, f0 = nm.iterations, nm.tangent.count
        counts["force"] = counts["solve"] = 0
        hist = []
        t0 = time.process_time()
        for _ in range(steps):
            part.write("forces", forces)
            part.advance(dt)
            hist.append(part.read("displacement").copy())
        cpu = time.process_time() - t0
    finally:
        alpha_method.newton_solve, newton.factorize_jacobian = solve_newton, factorize
    n = steps * dt_div
    return np.array(hist), {
        "iterations_per_step": (nm.iterations - it0) / n,
        "factorisations_per_step": (nm.tangent.count - f0) / n,
        "force_evaluations_per_step": counts["force"] / n,
        "solves_per_step": counts["solve"] / n,
        "cpu_ms_per_step": 1e3 * cpu / n,
    }


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--out", type=Path, default=ROOT / "benchmarks" / "results" / "vk_newton.csv")
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    hists, rows = {}, []
    for name, kw in VARIANTS.items():
        hists[name], row = run(args.steps, **kw)
        rows.append({"variant": name, **row})
        print(name, {k: round(v, 3) for k, v in row.items()}, flush=True)
    ref = hists["floor"]
    scale = float(np.abs(ref).max())
    for r in rows:
        r["disp_error"] = float(np.abs(hists[r["variant"]] - ref).max() / scale)
    t_err = 4.0 / 3.0 * rows[-1]["disp_error"]  # Richardson, second order
    load1 = os.getloadavg()[0]
    print(f"\nvon Karman plate, {args.steps} steps of dt = 1e-4 s; load average {load0:.2f} -> "
          f"{load1:.2f}; time discretisation error (Richardson from dt / 2) {t_err:.2e}")  # fmt: skip
    cols = ["variant", "iterations_per_step", "factorisations_per_step",
            "force_evaluations_per_step", "solves_per_step", "cpu_ms_per_step", "disp_error"]  # fmt: skip
    print("  ".join(f"{c:>26s}" for c in cols))
    for r in rows:
        print(f"{r['variant']:>26s}  " + "  ".join(f"{r[c]:26.3g}" for c in cols[1:]))
    args.out.parent.mkdir(parents=True, exist_ok=True)
    with args.out.open("w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=[*cols, "time_error_estimate", "load_1min"])
        w.writeheader()
        for r in rows:
            w.writerow({**{c: r[c] for c in cols}, "time_error_estimate": t_err,
                        "load_1min": f"{load0:.2f} -> {load1:.2f}"})  # fmt: skip
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
