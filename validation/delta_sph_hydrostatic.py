"""Still water in a tank, δ-SPH beside MPS: the pressure after settling (issue 23).

A 0.4 m wide tank holds water d = 0.2 m deep (l0 = d / --resolution, default 20) from a
hydrostatic start; each method (fluid.method = "mps" with its defaults, "delta-sph" with δ-SPHC
and with the plain gradient at h = 1.3 and 2.0 l0, RK4) runs --end-time seconds (default 1.0). After settling
(t >= end/2) the script averages, per sample, the relative error of the bottom fluid row's mean
pressure against rho g (d - y) (y the row's mean height), and reports the mean and the largest
of these over the settled samples, the largest fluid speed at the end (spurious currents) and the
floor force against the water's weight rho g d W (the pressure integral over the walls' first
layer, which sits half a spacing below the floor in both methods, so it reads rho g (d + l0/2) W
in exact hydrostatics). Criterion (issue 23): the bottom pressure within 1 % after settling.
Writes validation/results/delta_sph_hydrostatic.csv; with ``--wall-pressure wetted``
(fluid.sph.wall_pressure, the δ-SPH cases only) validation/results/delta_sph_hydrostatic_wetted.csv.

    python validation/delta_sph_hydrostatic.py [--resolution 20] [--end-time 1.0]
    python validation/delta_sph_hydrostatic.py --wall-pressure wetted
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from results_csv import write_csv  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
CSV = ROOT / "validation" / "results" / "delta_sph_hydrostatic.csv"
DEPTH, WIDTH, RHO, G = 0.2, 0.4, 1000.0, 9.81


def spec(method: str, dx: float, gradient: str | None, ratio: float = 1.3, wall: str = "adami"):
    from mpsfem.scenario.fluid import FluidSection

    sph = {"gradient": gradient, "smoothing_ratio": ratio, "wall_pressure": wall}
    extra = {"sph": sph} if method == "delta-sph" else {}
    return FluidSection(
        method=method,
        spacing=dx,
        density=RHO,
        gravity=[0.0, -G],
        blocks=[{"lower": [0.0, 0.0], "upper": [WIDTH, DEPTH]}],
        walls=[{"shape": "tank", "lower": [0.0, 0.0], "upper": [WIDTH, 2 * DEPTH], "name": "tank"}],
        **extra,
    )


def run(
    method: str, gradient: str | None, dx: float, t_end: float, ratio: float = 1.3,
    wall_pressure: str = "adami",
) -> dict:  # fmt: skip
    from mpsfem.fluid_methods import create_fluid_solver

    s = create_fluid_solver(spec(method, dx, gradient, ratio, wall_pressure))
    nf = s.n_fluid
    errors = []
    tic = time.perf_counter()
    sample = 0.01
    t_next = sample
    while s.t < t_end - 1e-12:
        s.step(s.dt_towards(min(t_next, t_end)))
        if s.t >= t_next - 1e-12:
            t_next += sample
            if s.t >= 0.5 * t_end - 1e-12:
                y = s.pos[:nf, 1]
                bottom = y < y.min() + 0.5 * dx
                exact = RHO * G * (DEPTH - y[bottom].mean())
                errors.append(s.p[:nf][bottom].mean() / exact - 1.0)
    wall = time.perf_counter() - tic
    errors = np.array(errors)
    floor = s.boundary_force(["tank"])[1] if method == "delta-sph" else None
    if floor is None:  # MPS: the pressure integral of its wall layer, as the force probe reads it
        from mpsfem.fluid_mps import probes

        pt = s.patch("tank")
        floor = probes.patch_force(s.p, s.normal, pt.start, pt.stop, s.kind, dx)[1]
    return {
        "method": method,
        "gradient": gradient or "mps default",
        "smoothing_ratio": ratio if method == "delta-sph" else None,
        "wall_pressure": wall_pressure if method == "delta-sph" else None,
        "d_over_l0": round(DEPTH / dx),
        "t_end": t_end,
        "steps": s.step_count,
        "wall_time_s": wall,
        "bottom_p_rel_error_mean": float(errors.mean()),
        "bottom_p_rel_error_max": float(np.abs(errors).max()),
        "within_1pct": bool(np.abs(errors).max() <= 0.01),
        "max_speed_end": float(np.abs(s.vel[:nf]).max()),
        "floor_force_over_weight": float(-floor / (RHO * G * DEPTH * WIDTH)),
    }


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--resolution", type=int, default=20, help="d / l0 (default 20)")
    ap.add_argument("--end-time", type=float, default=1.0, help="s (default 1.0)")
    ap.add_argument(
        "--wall-pressure",
        choices=("adami", "wetted"),
        default="adami",
        help="fluid.sph.wall_pressure of the δ-SPH cases (wetted: no MPS case, its own CSV)",
    )
    args = ap.parse_args()
    dx = DEPTH / args.resolution
    rows = []
    cases = (
        ("mps", None, 1.3),
        ("delta-sph", "corrected", 1.3),
        ("delta-sph", "plain", 1.3),
        ("delta-sph", "corrected", 2.0),
        ("delta-sph", "plain", 2.0),
    )
    wall = args.wall_pressure
    if wall != "adami":
        cases = cases[1:]  # MPS has no fluid.sph
    for method, gradient, ratio in cases:
        r = run(method, gradient, dx, args.end_time, ratio, wall)
        rows.append(r)
        print(
            f"{method:10} {r['gradient']:12} h/l0 {ratio} bottom p error mean {r['bottom_p_rel_error_mean']:+.4f}"
            f" max {r['bottom_p_rel_error_max']:.4f}  |u|max {r['max_speed_end']:.4f} m/s  floor "
            f"F/W {r['floor_force_over_weight']:.4f}  {r['steps']} steps {r['wall_time_s']:.1f} s"
        )
    out = CSV if wall == "adami" else CSV.with_name(f"{CSV.stem}_{wall}.csv")
    write_csv(
        rows,
        out,
        comment="still water 0.2 m deep, bottom-row pressure vs rho g (d - y) after settling "
        f"(validation/delta_sph_hydrostatic.py, fluid.sph.wall_pressure = {wall})",
    )
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
